"""Checks of the committed Cycles references and of the comparison helpers (no Photon needed).

Each reference in scenes/blender/ must come with its .glb and JSON sidecar, be small, finite,
at the recorded resolution and converged (the noise recorded in its sidecar), and the light-plane
references must agree with the analytic radiance. The relMSE helper must be 0 for an image
against itself and positive for a 10 % brighter copy.
"""

import json
import struct

import numpy as np
import pytest

from helpers import SCENES, lit_mask, read_exr, reference, rel_mse

NAMES = ["cornell", "cornell_lambert", "point_plane", "sun_plane", "spot_plane", "principled_r05",
         "principled_r10"]


@pytest.mark.parametrize("name", NAMES)
def test_reference_is_complete_and_converged(name):
    ref, info = reference(name)
    assert ref.shape == (info["height"], info["width"], 3)
    assert ref.shape[0] <= 128 and ref.shape[1] <= 128
    assert np.isfinite(ref).all() and (ref >= 0).all()
    assert (SCENES / f"{name}.exr").stat().st_size < 300 * 1024
    assert ref.mean() > 0.01, f"{name} reference is black"
    limit = 5e-4 if name.startswith("cornell") else 1e-3
    assert info["relmse_between_seeds"] < limit, info["relmse_between_seeds"]


@pytest.mark.parametrize("name", NAMES)
def test_glb_has_camera_and_light(name):
    data = (SCENES / f"{name}.glb").read_bytes()
    magic, version, _ = struct.unpack("<4sII", data[:12])
    assert magic == b"glTF" and version == 2
    length, kind = struct.unpack("<I4s", data[12:20])
    assert kind == b"JSON"
    doc = json.loads(data[20:20 + length])
    assert len(doc["cameras"]) == 1
    if name.startswith("cornell"):
        assert any(m.get("extensions", {}).get("KHR_materials_emissive_strength")
                   for m in doc["materials"]), "no emissive material"
    else:
        assert len(doc["extensions"]["KHR_lights_punctual"]["lights"]) == 1


@pytest.mark.parametrize("name", ["point_plane", "sun_plane", "spot_plane"])
def test_light_reference_matches_analytic(name):
    _, info = reference(name)
    assert abs(info["analytic_check"]["ratio"] - 1.0) < 0.005, info["analytic_check"]


def test_rel_mse_helper():
    ref = read_exr(SCENES / "cornell.exr")
    assert rel_mse(ref, ref) == 0.0
    brighter = rel_mse(ref * 1.1, ref)
    assert brighter > 0.0
    # For bright pixels relMSE of a 10 % error tends to 0.01; dark pixels weigh less.
    assert 0.001 < brighter < 0.0101
    with pytest.raises(ValueError):
        rel_mse(ref[:-1], ref)


def test_lit_mask_helper():
    ref = read_exr(SCENES / "spot_plane.exr")
    mask = lit_mask(ref)
    assert 0 < mask.sum() < mask.size
    assert ref[mask].min() > 0.05 * ref.max()
