"""Blender 5's Multiple Scattering sky against Cycles 5.0 (the Sky Texture's default type from
Blender 5.0; Blender 4.5 has no such sky, so the scenes and references were made under bpy 5.0.1
by scenes/blender/multiple_scattering_sky.py and are committed): a box on a grey ground under the
sky with the sun at 12 and at 50 degrees, exported through the add-on. Photon renders each .glb
(path tracer, 1024 spp, 48 x 32) and must match Cycles' converged render: mean within 1 % and
4x4-block relMSE at most 0.001. The .glb must carry the sky as the add-on writes it.
"""

import json
import struct

import pytest

from helpers import SCENES, block_means, reference, rel_mse, render_photon

NAMES = {"sky_ms_12": 12.0, "sky_ms_50": 50.0}


def world_extension(name):
    data = (SCENES / f"{name}.glb").read_bytes()
    (length,) = struct.unpack_from("<I", data, 12)
    doc = json.loads(data[20:20 + length])
    return doc["scenes"][0]["extensions"]["PHOTON_world"]


@pytest.mark.parametrize("name", NAMES)
def test_reference_is_blender_5_and_converged(name):
    ref, info = reference(name)
    assert info["blender"].startswith("5."), info["blender"]
    assert info["sky"]["sky_type"] == "MULTIPLE_SCATTERING"
    assert ref.shape == (info["height"], info["width"], 3) and max(ref.shape) <= 64
    assert info["relmse_between_seeds"] < 1e-4, info["relmse_between_seeds"]
    sky = world_extension(name)["sky"]
    assert sky["type"] == "MULTIPLE_SCATTERING"
    assert sky["sun_elevation"] == pytest.approx(NAMES[name] * 3.14159265 / 180, rel=1e-6)
    assert sky["altitude"] == pytest.approx(info["sky"]["altitude"])


@pytest.mark.parametrize("name", NAMES)
def test_photon_matches_cycles_5(name):
    ref, info = reference(name)
    img = render_photon(name, info["width"], info["height"], 1024, extra=["--method", "path"])
    diff = float(img.mean() / ref.mean()) - 1.0
    err = rel_mse(block_means(img), block_means(ref))
    print(f"{name}: mean photon {img.mean():.4f} vs cycles {ref.mean():.4f} "
          f"({100 * diff:+.2f} %), 4x4-block relMSE {err:.6f}, pixel relMSE "
          f"{rel_mse(img, ref):.6f}")
    assert abs(diff) <= 0.01
    assert err <= 0.001
