"""Blender's light and shadow linking (Object › Shading › Light Linking) against Cycles through
the add-on.

Two diffuse spheres on a floor, 64x64, path tracer 512 spp against Cycles 1024 spp (mean within
1 %, relMSE of 4x4-pixel block means at most BLOCK_RELMSE_MAX), each failing without the
linking (the export's light_linking removed):
- light linking: a point light whose receiver collection includes the left sphere lights only
  it (not the right sphere, not the floor); a dim sun lights everything;
- shadow linking: a sun whose blocker collection includes only the right sphere: the left
  sphere casts no shadow from it.
"""

import bpy
import pytest

import common
import scenes_bpy
from test_clamp import SIZE, assert_matches_only_with, sphere


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def two_spheres():
    scene = common.reset_scene(SIZE, SIZE)
    floor = common.principled("Floor", (0.8, 0.8, 0.8), roughness=1.0)
    common.quad("Floor", [(-4, -4, 0), (4, -4, 0), (4, 4, 0), (-4, 4, 0)], floor)
    white = common.principled("White", (0.8, 0.8, 0.8), roughness=1.0)
    left = sphere("Left", white, (-0.7, 0.0, 0.5))
    right = sphere("Right", white, (0.7, 0.0, 0.5))
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.05, 0.05, 0.05, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    common.camera("Camera", (0.0, -4.0, 2.6), (58.0, 0.0, 0.0), 40.0)
    return scene, left, right


def linking_collection(name, included):
    coll = bpy.data.collections.new(name)
    for obj in included:
        coll.objects.link(obj)
    for entry in coll.collection_objects:
        entry.light_linking.link_state = "INCLUDE"
    return coll


def receiver_scene():
    scene, left, right = two_spheres()
    lamp = common.light("Lamp", "POINT", (0.0, -0.6, 2.0), energy=300.0, shadow_soft_size=0.1)
    lamp.light_linking.receiver_collection = linking_collection("Lit by lamp", [left])
    common.light("Sun", "SUN", (0, 0, 5), (30.0, 0.0, 20.0), energy=0.5, angle=0.1)
    return scene


def blocker_scene():
    scene, left, right = two_spheres()
    sun = common.light("Sun", "SUN", (0, 0, 5), (45.0, 0.0, -30.0), energy=3.0, angle=0.1)
    sun.light_linking.blocker_collection = linking_collection("Shadows", [right])
    return scene


def render_photon_unlinked(scene, path, samples):
    """Photon's render with the export's light linking left out."""
    from blender_addon import lights

    linking = lights.light_linking
    lights.light_linking = lambda objects: ({}, {}, [])
    try:
        return scenes_bpy.render(scene, "PHOTON", path, samples)
    finally:
        lights.light_linking = linking


@pytest.mark.slow
@pytest.mark.parametrize("name,build,method", [
    ("receiver collection", receiver_scene, "PATH"),
    ("receiver collection", receiver_scene, "PHOTON"),
    ("blocker collection", blocker_scene, "PATH"),
    ("blocker collection", blocker_scene, "PHOTON")])
def test_light_linking_matches_cycles(tmp_path, name, build, method):
    scene = build()
    ref = scenes_bpy.render(scene, "CYCLES", tmp_path / "cycles.exr", 1024)
    scene.photon.method = method
    spp = 512 if method == "PATH" else 128
    img = scenes_bpy.render(scene, "PHOTON", tmp_path / "photon.exr", spp)
    unlinked = render_photon_unlinked(scene, tmp_path / "unlinked.exr", spp)
    name = f"{name} ({method.lower()})"
    assert_matches_only_with(name, img, ref, unlinked, "linking")
