"""Smoke and fire of baked fluid domains (Mantaflow gas) against Cycles through the add-on.

Each test bakes a small gas domain (16 cells along its 2 m side, 8 frames, OpenVDB cache in a
temporary folder: scenes/blender/fluid_scenes.py), renders its last frame with Cycles and with
Photon, and compares: mean within 2 % and relMSE <= 0.01 (`cycles_compare.compare`).

- smoke (Quick Smoke's material: Principled Volume, density 5 from the "density" grid) over a
  sunlit floor, the domain scaled by 0.8 (its density stays per metre, as Cycles keeps a
  domain's);
- smoke with noise (2x upres: the noise file's density, as Cycles renders it);
- fire (Quick Fire's: Blackbody Intensity 1 from the "temperature" Cycles makes from the
  flame), lighting the floor, under a dim world;
- a domain at a frame it has no baked data for: nothing, in both engines; nor for a domain
  whose material reads none of its grids;
- the pre-flight report on a baked domain: silent for Quick Smoke's material, one message when
  the material reads the "color" attribute.

Blender 5 (bpy 5.0): smoke and the unbaked frame match; the fire does not (marked below).

The Cycles references are rendered without reference_cache.py's sharing: its walk over every
property reads the fluid domain's grids from the original object, where bpy (as a module)
holds none, and crashes. Each test ends on an empty scene: a fluid domain still loaded when
the process ends makes bpy's Mantaflow abort it.
"""

import bpy
import numpy as np
import pytest

import reference_cache
import scenes_bpy
from cycles_compare import compare
import volume_scenes
from fluid_scenes import bake_gas, fire_material, principled_volume_material, smoke_material

SIZE = 40

pytestmark = pytest.mark.slow


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env, monkeypatch):
    monkeypatch.setattr(reference_cache, "cached_render",
                        lambda render, path, scope=None, read=None: (render(), False))
    yield photon_addon
    # A domain still loaded when the process ends makes bpy's Mantaflow abort it (exit 134).
    bpy.ops.wm.read_factory_settings(use_empty=True)


def floor_scene(world=0.05):
    """A fresh scene of this file's size (`volume_scenes.floor_scene`), the camera lower."""
    return volume_scenes.floor_scene(SIZE, world, ((0.0, -5.0, 2.5), (75.0, 0.0, 0.0)))


def test_baked_smoke(tmp_path):
    scene = floor_scene()
    bake_gas(tmp_path / "cache", "SMOKE", scale=0.8, material=smoke_material())
    volume_scenes.sun()
    compare("fluid smoke", scene, tmp_path, photon_spp=256, cycles_spp=1024)


def test_baked_smoke_with_noise(tmp_path):
    """Noise (2x upres): Cycles renders the noise file's density, 32 cells a side."""
    scene = floor_scene()
    bake_gas(tmp_path / "cache", "SMOKE", material=smoke_material(), noise=True)
    volume_scenes.sun()
    compare("fluid smoke with noise", scene, tmp_path, photon_spp=256, cycles_spp=1024)


# The domain's temperature jumps from 0 to the Ignition temperature at the flame's edge, where
# Blender 5's stochastic interpolation (one voxel per lookup) and Blender 4.5's trilinear one
# differ most through Blackbody: Cycles 5 renders this fire 14 % brighter than 4.5, and the
# add-on has Photon read grids as each does.
def test_baked_fire(tmp_path):
    scene = floor_scene(world=0.02)
    bake_gas(tmp_path / "cache", "FIRE", material=fire_material())
    compare("fluid fire", scene, tmp_path, photon_spp=512, cycles_spp=1024)


def assert_renders_nothing(name, scene, domain, tmp_path):
    """Cycles renders the scene as it does without `domain`, and so does Photon."""
    ref = scenes_bpy.render(scene, "CYCLES", tmp_path / f"{name}_cycles.exr", 16)
    domain.hide_render = True
    empty = scenes_bpy.render(scene, "CYCLES", tmp_path / "empty_cycles.exr", 16)
    domain.hide_render = False
    img = scenes_bpy.render(scene, "PHOTON", tmp_path / f"{name}_photon.exr", 16)
    print(f"{name}: mean cycles {ref.mean():.5f} (without the domain {empty.mean():.5f}), "
          f"photon {img.mean():.5f}")
    assert abs(ref.mean() / empty.mean() - 1.0) < 0.01, "Cycles renders nothing for it"
    assert abs(img.mean() / empty.mean() - 1.0) < 0.02
    assert np.isfinite(img).all()


def test_unbaked_frame_renders_nothing(tmp_path):
    scene = floor_scene(world=1.0)
    domain = bake_gas(tmp_path / "cache", "SMOKE", frames=4, material=smoke_material())
    domain.modifiers["Fluid"].domain_settings.cache_frame_end = 8
    scene.frame_set(6)  # inside the cache's frames, never baked
    assert_renders_nothing("unbaked", scene, domain, tmp_path)


def test_domain_whose_material_reads_no_grid_renders_nothing(tmp_path):
    """A baked domain whose Principled Volume reads no grid (Density Attribute cleared): Cycles
    renders nothing for it (it builds a domain's volume from the grids read), nor does Photon,
    where the box would otherwise be filled."""
    scene = floor_scene(world=1.0)
    material, node = principled_volume_material("Constant", Density=1.0)
    node.inputs["Density Attribute"].default_value = ""
    domain = bake_gas(tmp_path / "cache", "SMOKE", frames=4, material=material)
    assert_renders_nothing("no grid read", scene, domain, tmp_path)


def test_preflight_names_what_of_a_baked_domain_is_not_rendered(tmp_path):
    """A baked domain whose material reads the "color" attribute: one message (the flows'
    colours are not read); Quick Smoke's material (density only): none."""
    from blender_addon import preflight
    scene = floor_scene()
    domain = bake_gas(tmp_path / "cache", "SMOKE", frames=3, material=smoke_material())
    assert not [m for m in preflight.unsupported_features(scene, list(scene.objects))
                if "Domain" in m]
    principled = domain.data.materials[0].node_tree.nodes["Principled Volume"]
    principled.inputs["Color Attribute"].default_value = "color"
    messages = [m for m in preflight.unsupported_features(scene, list(scene.objects))
                if "Domain" in m]
    assert len(messages) == 1 and messages[0].startswith(
        "fluid domain 'Domain': its \"color\" attribute"), messages
