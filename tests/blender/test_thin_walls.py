"""The photon method on rooms built as Blender users build them (scenes/blender/window_room.py):
a room of zero-thickness planes, and the same room with thick walls, lit only by a sun through a
small window, black world. Nearly all the light inside is indirect, from a small sunlit patch
of floor, so any light carried through a wall or across a plane's two faces shows at once.

Photon's default render (`auto`: photon mapping with the irradiance cache) must agree with the
8192-spp Cycles reference (64 bounces) to relMSE <= 0.01, and its mean must be free of bias: at
256 spp (four generations of photon maps and cache) within 2 %. A single generation (the default
64 spp) carries frozen photon-map and cache noise that moves the whole room's mean from one seed
to the next: seeds 1-6 gave +2.1, -0.1, -0.3, -1.1, -4.9 and -0.1 % on the thick-walled room
(docs/bench/measurements.md), so at 64 spp the mean is held to 5 %.
"""

import pytest

from helpers import assert_matches_reference

RELMSE_MAX = 0.01


@pytest.mark.parametrize("name", ["room_thin", "room_thick"])
def test_window_lit_room_default_render_matches_cycles(name):
    assert_matches_reference(name, 64, RELMSE_MAX, 0.05)


@pytest.mark.parametrize("name", ["room_thin", "room_thick"])
def test_window_lit_room_mean_is_unbiased(name):
    assert_matches_reference(name, 256, RELMSE_MAX, 0.02)
