"""The photon method on rooms built as Blender users build them (scenes/blender/window_room.py):
a room of zero-thickness planes, and the same room with thick walls, lit only by a sun through a
small window, black world. Nearly all the light inside is indirect, from a small sunlit patch
of floor, so any light carried through a wall or across a plane's two faces shows at once.

Photon's default render (`auto`: photon mapping with the irradiance cache) must agree with the
8192-spp Cycles reference (64 bounces) to relMSE <= 0.01, and its mean within 2 % at 256 spp and
3 % at the default 64 spp, where a single render's mean is as noisy as the path tracer's. The
sun's photons are guided through the window (integrator/photon/guide.rs): emitted uniformly,
most landed on the walls' outsides, and the room's mean moved from one seed to the next by
-3.8..+2.9 % at 64 spp. Now seeds 0-6 give -1.6..+2.2 % (thick walls) and -1.2..+1.5 % (thin),
the spread of the camera samples themselves (the path tracer at 64 spp: -1.2..+1.8 %); this
test's seed 1 is the thick room's highest, +2.2 %. Over 8 seeds at 256 spp the mean is +0.40 %
where the path tracer's is +0.4..+0.5 % at 1024-2048 spp (docs/bench/photon_method.md,
"Guided photons").
"""

import pytest

from helpers import assert_matches_reference

RELMSE_MAX = 0.01


@pytest.mark.parametrize("name", ["room_thin", "room_thick"])
def test_window_lit_room_default_render_matches_cycles(name):
    assert_matches_reference(name, 64, RELMSE_MAX, 0.03)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["room_thin", "room_thick"])
def test_window_lit_room_mean_is_unbiased(name):
    assert_matches_reference(name, 256, RELMSE_MAX, 0.02)
