"""An open, zero-thickness mirror ring on a diffuse floor, lit by a small spherical lamp below
its rim (scenes/blender/open_ring.py), against Cycles (2 x 8192 spp, 64 bounces).

The caustic the ring's outside throws on the floor lies right next to its wall, and the floor
inside the ring receives no light at all: Cycles renders it exactly black. Photon-map estimates
that gather across the wall put light there.
  - the default render and the photon method agree with Cycles in 8 x 8-pixel blocks
    (relMSE <= 0.01; blocks average away the reference's own caustic noise);
  - inside the ring the photon method stays dark: its mean is below 1/1000 of the lit floor's
    just outside the ring.
"""

import numpy as np
import pytest

from helpers import reference, rel_mse, render_photon

SPP = 64
BLOCK = 8
BLOCK_RELMSE_MAX = 0.01
LEAK_MAX = 1e-3


def blocks(img):
    h, w, c = img.shape
    return img.reshape(h // BLOCK, BLOCK, w // BLOCK, BLOCK, c).mean(axis=(1, 3))


def floor_radius(info):
    """Distance from the ring's axis of the floor point each pixel centre sees (camera looking
    straight down from its height, field of view along the image's side)."""
    w, h = info["width"], info["height"]
    half = info["camera"]["height"] * np.tan(np.radians(info["camera"]["fov_deg"]) / 2)
    yy, xx = np.mgrid[0:h, 0:w]
    x = (xx + 0.5) / w * 2 * half - half
    y = half - (yy + 0.5) / h * 2 * half
    return np.hypot(x, y)


@pytest.mark.parametrize("method", ["auto", "photon"])
def test_open_ring_matches_cycles_in_blocks(method):
    ref, info = reference("ring_open")
    img = render_photon("ring_open", info["width"], info["height"], SPP,
                        extra=["--method", method])
    err = rel_mse(blocks(img), blocks(ref))
    msg = f"ring_open {method}: 8x8-block relMSE {err:.5f} (max {BLOCK_RELMSE_MAX})"
    print(msg)
    assert err <= BLOCK_RELMSE_MAX, msg


def test_no_light_reaches_inside_the_ring():
    ref, info = reference("ring_open")
    img = render_photon("ring_open", info["width"], info["height"], SPP,
                        extra=["--method", "photon"])
    r = floor_radius(info)
    ring = info["ring"]["radius"]
    inside = r < 0.9 * ring
    # The lit floor just outside the wall, without the lamp's own pixels.
    outside = (r > 1.1 * ring) & (r < 1.6 * ring) & (ref.max(axis=2) < 5.0)
    assert ref[inside].max() == 0.0, "the reference must be black inside the ring"
    lit = float(ref[outside].mean())
    leak = float(img[inside].mean())
    msg = f"inside the ring: mean {leak:.3g}, lit floor outside {lit:.3g} (ratio {leak / lit:.2g})"
    print(msg)
    assert leak <= LEAK_MAX * lit, msg
