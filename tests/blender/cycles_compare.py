"""Render one bpy scene with Cycles and with Photon through the add-on (F12,
`bpy.ops.render.render()`) and compare: the mean of Photon's image within MEAN_TOL of Cycles'
and relMSE at most RELMSE_MAX. Used by the per-feature tests (test_camera.py, test_lights.py,
test_depsgraph.py); each prints its measured numbers.
"""

from __future__ import annotations

import time

import numpy as np

import scenes_bpy
from helpers import rel_mse

MEAN_TOL = 0.02
RELMSE_MAX = 0.01


def compare(name, scene, tmp_path, *, photon_spp=256, cycles_spp=1024, method="PATH",
            mean_tol=MEAN_TOL, relmse_max=RELMSE_MAX, glint=None):
    """Render `scene` with both engines and assert that they agree; returns (photon, cycles).
    With `glint`, the pixels where either image has a channel above it are left out: set to 0
    in both before they are compared (and as returned)."""
    t0 = time.perf_counter()
    ref = scenes_bpy.render(scene, "CYCLES", tmp_path / f"{name}_cycles.exr", cycles_spp)
    t1 = time.perf_counter()
    scene.photon.method = method
    img = scenes_bpy.render(scene, "PHOTON", tmp_path / f"{name}_photon.exr", photon_spp)
    t2 = time.perf_counter()
    assert img.shape == ref.shape, (img.shape, ref.shape)
    if glint is not None:
        bright = (img.max(axis=-1) > glint) | (ref.max(axis=-1) > glint)
        img, ref = img.copy(), ref.copy()
        img[bright] = ref[bright] = 0.0
    assert np.isfinite(img).all()
    err = rel_mse(img, ref)
    diff = float(img.mean() / ref.mean()) - 1.0
    msg = (f"{name}: mean photon {img.mean():.5f} vs cycles {ref.mean():.5f} "
           f"({100 * diff:+.2f} %), relMSE {err:.5f}; cycles {cycles_spp} spp {t1 - t0:.1f} s, "
           f"photon {method.lower()} {photon_spp} spp {t2 - t1:.1f} s")
    print(msg)
    assert abs(diff) <= mean_tol, msg
    assert err <= relmse_max, msg
    return img, ref
