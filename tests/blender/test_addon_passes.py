"""Render passes through the add-on: with Depth, Normal and Denoising Data enabled on the view
layer, Photon's EXR fills them through `load_from_file` (they reach a multilayer EXR written by
Blender), and at the cube's centre pixel they agree with Cycles'.
"""

import bpy
import numpy as np
import pytest

import common
import scenes_bpy
from helpers import photon_binary

PASSES = ["Combined.R", "Combined.A", "Depth.Z", "Normal.X", "Normal.Y", "Normal.Z",
          "Denoising Normal.X", "Denoising Albedo.R"]


def render_multilayer(scene, engine, path):
    return scenes_bpy.render_layers(scene, engine, path, 32)


@pytest.mark.slow
def test_passes_are_loaded(photon_addon, tmp_path):
    photon_binary()
    scene = scenes_bpy.default_scene()
    layer = scene.view_layers[0]
    layer.use_pass_z = layer.use_pass_normal = True
    layer.cycles.denoising_store_passes = True  # for Cycles
    layer.photon.use_pass_denoising_data = True  # for Photon (View Layer > Passes > Data)
    cycles = render_multilayer(scene, "CYCLES", tmp_path / "cycles.exr")
    photon = render_multilayer(scene, "PHOTON", tmp_path / "photon.exr")
    for name in PASSES:
        assert f"{layer.name}.{name}" in photon, sorted(photon)
    centre = (18, 32)
    get = lambda img, name: float(img[f"{layer.name}.{name}"][centre])  # noqa: E731
    assert get(photon, "Depth.Z") == pytest.approx(get(cycles, "Depth.Z"), rel=1e-3)
    assert get(photon, "Normal.X") == pytest.approx(get(cycles, "Normal.X"), abs=0.05)
    assert get(photon, "Denoising Albedo.R") == pytest.approx(get(cycles, "Denoising Albedo.R"),
                                                              rel=0.03)
    assert get(photon, "Combined.A") == pytest.approx(1.0)


LIGHT_PASSES = ["Emit", "DiffDir", "DiffInd", "Caustic", "Subsurface"]


@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_light_passes_add_up_to_combined(photon_addon, tmp_path, method):
    """With Emission, Diffuse Direct/Indirect and Photon's Caustic and Subsurface enabled, the
    passes reach the render result and add up to Combined."""
    photon_binary()
    scene = scenes_bpy.default_scene()
    layer = scene.view_layers[0]
    layer.use_pass_emit = layer.use_pass_diffuse_direct = layer.use_pass_diffuse_indirect = True
    layer.photon.use_pass_caustic = layer.photon.use_pass_subsurface = True
    scene.photon.method = method
    common.set_multilayer_exr(scene.render.image_settings)
    scene.render.image_settings.color_depth = "32"  # full float, for the sum
    photon = render_multilayer(scene, "PHOTON", tmp_path / "photon.exr")
    for name in LIGHT_PASSES:
        for chan in "RGB":
            assert f"{layer.name}.{name}.{chan}" in photon, sorted(photon)
    for chan in "RGB":
        combined = photon[f"{layer.name}.Combined.{chan}"]
        total = sum(photon[f"{layer.name}.{name}.{chan}"] for name in LIGHT_PASSES)
        assert combined.mean() > 0.01
        np.testing.assert_allclose(total, combined, rtol=1e-4, atol=1e-6)
        for name in LIGHT_PASSES:
            assert photon[f"{layer.name}.{name}.{chan}"].min() >= 0.0
    # The point light lights the cube directly.
    assert photon[f"{layer.name}.DiffDir.R"].mean() > 0.0
