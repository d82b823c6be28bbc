"""Blender's Light Paths › Caustics settings against Cycles through the add-on: Reflective
Caustics, Refractive Caustics and Filter Glossy.

Cycles builds a shading point's closures for the path that reached it: with a caustics switch
off, a surface met straight after a diffuse bounce has no glossy reflection (or transmission)
lobes, so the light a diffuse floor receives through a mirror (or through glass) is gone; with
Filter Glossy F, every glossy lobe is at least as rough as α = ½ √(1 − p / F), p the smallest
density of the path's bounces so far, which spreads a sharp glossy caustic.

Two 64x64 scenes over a grey diffuse floor: an open ring of Glossy BSDF (roughness 0.1) lit
by a small lamp, whose inside throws a bright caustic on the floor, and test_clamp's Glass BSDF
sphere in sunlight. Photon must match Cycles with the same settings (mean within 1 %, relMSE
of 4x4-pixel block means at most BLOCK_RELMSE_MAX) and must not without them (rendered with
the switches on, Filter Glossy 0: what Photon rendered before it read them).
"""

import bpy
import pytest

import common
import scenes_bpy
import test_clamp
from test_clamp import assert_matches_only_with

SIZE = 64
CYCLES_SPP = 1024
PHOTON_SPP = 512
PHOTON_METHOD_SPP = 64

# Cycles' defaults are caustics on and Filter Glossy 1; the references of the other tests turn
# it to 0 (common.configure_cycles).
TODAY = {"caustics_reflective": True, "caustics_refractive": True, "blur_glossy": 0.0}


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def glossy_ring_scene(roughness=0.1):
    """An open ring of Glossy BSDF on the floor, a small lamp beside it above its rim: the
    ring's inside reflects the lamp onto the floor within it."""
    scene = common.reset_scene(SIZE, SIZE)
    floor = common.principled("Floor", (0.8, 0.8, 0.8), roughness=1.0)
    common.quad("Floor", [(-4, -4, 0), (4, -4, 0), (4, 4, 0), (-4, 4, 0)], floor)
    mat, tree = test_clamp.node_material("Ring")
    glossy = tree.nodes.new("ShaderNodeBsdfAnisotropic")  # Glossy BSDF
    glossy.inputs["Color"].default_value = (0.9, 0.8, 0.6, 1.0)
    glossy.inputs["Roughness"].default_value = roughness
    tree.links.new(glossy.outputs["BSDF"], tree.nodes["Material Output"].inputs["Surface"])
    bpy.ops.mesh.primitive_cylinder_add(vertices=96, radius=0.8, depth=0.5,
                                        end_fill_type="NOTHING", location=(0.0, 0.0, 0.25))
    ring = bpy.context.active_object
    ring.name = "Ring"
    bpy.ops.object.shade_smooth()
    ring.data.materials.append(mat)
    common.light("Lamp", "POINT", (1.5, 0.3, 1.1), energy=200.0, shadow_soft_size=0.05)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.05, 0.05, 0.05, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    common.camera("Camera", (0.0, -2.4, 2.6), (42.0, 0.0, 0.0), 45.0)
    return scene


def render(scene, engine, path, samples, light_paths):
    """`scenes_bpy.render` with Cycles' caustics settings and Filter Glossy `light_paths`."""
    configure = common.configure_cycles

    def configure_light_paths(scene, samples, seed, threads):
        settings = configure(scene, samples, seed, threads)
        for key, value in light_paths.items():
            setattr(scene.cycles, key, value)
        return settings

    common.configure_cycles = configure_light_paths
    try:
        return scenes_bpy.render(scene, engine, path, samples, reference_scope=__name__)
    finally:
        common.configure_cycles = configure


def check(tmp_path, name, scene, method, light_paths, feature):
    ref = render(scene, "CYCLES", tmp_path / "cycles.exr", CYCLES_SPP, {**TODAY, **light_paths})
    scene.photon.method = method
    spp = PHOTON_SPP if method == "PATH" else PHOTON_METHOD_SPP
    img = render(scene, "PHOTON", tmp_path / "photon.exr", spp, {**TODAY, **light_paths})
    without = render(scene, "PHOTON", tmp_path / "today.exr", spp, TODAY)
    assert_matches_only_with(f"{name}, {method.lower()}", img, ref, without, feature)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_reflective_caustics_off_matches_cycles(tmp_path, method):
    check(tmp_path, "glossy ring", glossy_ring_scene(), method,
          {"caustics_reflective": False}, "the switch")


@pytest.mark.slow
@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_refractive_caustics_off_matches_cycles(tmp_path, method):
    check(tmp_path, "glass sphere", test_clamp.glass_sphere_scene(), method,
          {"caustics_refractive": False}, "the switch")


@pytest.mark.slow
@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_filter_glossy_matches_cycles(tmp_path, method):
    check(tmp_path, "glossy ring", glossy_ring_scene(), method, {"blur_glossy": 1.0},
          "Filter Glossy")
