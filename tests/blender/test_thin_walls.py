"""The photon method on rooms built as Blender users build them (scenes/blender/window_room.py):
a room of zero-thickness planes, and the same room with thick walls, lit only by a sun through a
small window, black world. Nearly all the light inside is indirect, from a small sunlit patch
of floor, so any light carried through a wall or across a plane's two faces shows at once.

Photon's default render (`auto`: photon mapping with the irradiance cache) must agree with the
8192-spp Cycles reference (64 bounces): mean within 2 % and relMSE <= 0.01.
"""

import pytest

from helpers import assert_matches_reference

SPP = 64
RELMSE_MAX = 0.01
MEAN_TOL = 0.02


@pytest.mark.parametrize("name", ["room_thin", "room_thick"])
def test_window_lit_room_matches_cycles(name):
    assert_matches_reference(name, SPP, RELMSE_MAX, MEAN_TOL)
