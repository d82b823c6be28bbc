"""Volume Direct and Volume Indirect passes, and the Fournier-Forand phase function, through the
add-on against Cycles.

- A fog cube (Volume Scatter, one volume bounce) over a floor, lit by a point light: with
  every light pass Photon writes enabled (Cycles' Volume Direct / Indirect toggles on
  `view_layer.cycles` included), the passes reach the render result and add up to Combined,
  for the path tracer and the photon method; the path tracer's Volume Direct and Volume
  Indirect agree with Cycles' (no specular surface in the scene, so Photon's count of
  non-specular vertices and Cycles' count of bounces classify the same paths).
- A fog cube whose Volume Scatter uses the Fournier-Forand phase function, under a sun, against
  Cycles (`cycles_compare.compare`).
"""

import bpy
import numpy as np
import pytest

import common
import scenes_bpy
from cycles_compare import compare
from volume_scenes import cube, volume_material

SIZE = 24

pytestmark = pytest.mark.slow

LIGHT_PASSES = ["Emit", "DiffDir", "DiffInd", "VolumeDir", "VolumeInd", "Caustic", "Subsurface"]


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def fog_scene():
    """A diffuse floor, a 2 m fog cube standing on it beside the view's centre and a point
    light over the cube, the world black; one volume bounce."""
    scene = common.reset_scene(SIZE, SIZE)
    scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    floor = common.principled("Floor", (0.8, 0.8, 0.8), roughness=1.0)
    common.quad("Floor", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], floor)
    common.camera("Camera", (0.0, -4.0, 3.0), (53.0, 0.0, 0.0), 45.0)
    mat, _ = volume_material("Fog", "ShaderNodeVolumeScatter", Density=0.6)
    cube("Fog", mat, 2.0, (-0.6, 0.0, 1.0))
    light = common.light("Lamp", "POINT", (0.2, -0.3, 2.4), (0.0, 0.0, 0.0), energy=300.0)
    light.data.shadow_soft_size = 0.05
    scene.cycles.volume_bounces = 1
    layer = scene.view_layers[0]
    layer.use_pass_emit = layer.use_pass_diffuse_direct = layer.use_pass_diffuse_indirect = True
    layer.cycles.use_pass_volume_direct = layer.cycles.use_pass_volume_indirect = True
    layer.photon.use_pass_caustic = layer.photon.use_pass_subsurface = True
    common.set_multilayer_exr(scene.render.image_settings)
    scene.render.image_settings.color_depth = "32"  # full float, for the sums
    return scene


def render_layers(scene, engine, path, samples, method="PATH"):
    """Render with `engine` (Photon by `method`) and return the passes by channel name."""
    scene.photon.method = method
    return scenes_bpy.render_layers(scene, engine, path, samples)


# Blender 5 writes Cycles' passes under their full names.
FULL_NAMES = {"VolumeDir": "Volume Direct", "VolumeInd": "Volume Indirect"}


def rgb(image, layer, name):
    if f"{layer}.{name}.R" not in image:
        name = FULL_NAMES.get(name, name)
    return np.stack([image[f"{layer}.{name}.{c}"] for c in "RGB"], axis=-1)


@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_volume_passes_add_up_to_combined(tmp_path, method):
    scene = fog_scene()
    layer = scene.view_layers[0].name
    photon = render_layers(scene, "PHOTON", tmp_path / "photon.exr", 64, method)
    for name in LIGHT_PASSES:
        for chan in "RGB":
            assert f"{layer}.{name}.{chan}" in photon, sorted(photon)
    combined = np.stack([photon[f"{layer}.Combined.{c}"] for c in "RGB"], axis=-1)
    total = sum(rgb(photon, layer, name) for name in LIGHT_PASSES)
    assert combined.mean() > 0.01
    np.testing.assert_allclose(total, combined, rtol=1e-4, atol=1e-6)
    means = {name: float(rgb(photon, layer, name).mean()) for name in LIGHT_PASSES}
    print(f"volume passes {method.lower()}: " +
          ", ".join(f"{k} {v:.4f}" for k, v in means.items()))
    for name in LIGHT_PASSES:
        assert rgb(photon, layer, name).min() >= 0.0, name
    for name in ["DiffDir", "DiffInd", "VolumeDir", "VolumeInd"]:
        assert means[name] > 0.0, name


def test_volume_passes_match_cycles(tmp_path):
    """The path tracer's volume passes against Cycles' (1024 spp): means within 3 %."""
    scene = fog_scene()
    layer = scene.view_layers[0].name
    cycles = render_layers(scene, "CYCLES", tmp_path / "cycles.exr", 1024)
    photon = render_layers(scene, "PHOTON", tmp_path / "photon.exr", 512)
    for name, tol in [("Combined", 0.02), ("VolumeDir", 0.03), ("VolumeInd", 0.05)]:
        ours, ref = rgb(photon, layer, name).mean(), rgb(cycles, layer, name).mean()
        diff = float(ours / ref) - 1.0
        print(f"{name}: photon {ours:.5f} vs cycles {ref:.5f} ({100 * diff:+.2f} %)")
        assert abs(diff) <= tol, name


@pytest.mark.parametrize("backscatter, ior, sun_tilt", [(0.1, 1.33, 30.0), (0.3, 1.1, -75.0)])
def test_fournier_forand_fog_cube(tmp_path, backscatter, ior, sun_tilt):
    """A fog cube with the Fournier-Forand phase function over a nearly black floor (the image
    is the fog's single scattering), lit by a sun from the camera's side (light scattered back
    by about 120 degrees) or from behind the cube (forward, by about 50 degrees). An isotropic
    fog in its place gives Cycles' means +53 % and -11 %."""
    scene = common.reset_scene(32, 32)
    scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    floor = common.principled("Floor", (0.02, 0.02, 0.02), roughness=1.0)
    common.quad("Floor", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], floor)
    common.camera("Camera", (0.0, -4.0, 3.0), (53.0, 0.0, 0.0), 45.0)
    mat, node = volume_material("Fog", "ShaderNodeVolumeScatter", Density=2.0)
    node.phase = "FOURNIER_FORAND"  # IOR and Backscatter are found once they show
    node.inputs["IOR"].default_value = ior
    node.inputs["Backscatter"].default_value = backscatter
    cube("Fog", mat, 1.2, (0.0, 0.0, 0.8))
    common.light("Sun", "SUN", (0, 0, 5), (sun_tilt, 0.0, 10.0), energy=3.0)
    compare(f"fournier-forand B {backscatter} n {ior} sun {sun_tilt}", scene, tmp_path,
            photon_spp=256)


def test_volume_passes_without_media_are_black(tmp_path):
    """A scene without media: the renderer writes no volume passes (the image has no volume
    light) and Blender's render result keeps the enabled ones black."""
    scene = fog_scene()
    bpy.data.objects.remove(bpy.data.objects["Fog"])
    layer = scene.view_layers[0].name
    photon = render_layers(scene, "PHOTON", tmp_path / "photon.exr", 16)
    assert rgb(photon, layer, "DiffDir").mean() > 0.0
    for name in ["VolumeDir", "VolumeInd"]:
        assert not rgb(photon, layer, name).any(), name
