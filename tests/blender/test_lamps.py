"""Lamps (point and spot lights with a radius) as rays meet them, against Cycles: a mirror
sphere shows the lamp it reflects, a glossy floor's highlight, a spot lamp seen in a mirror (its
cone evaluated along the reflected ray), and the open ring's mirror caustic of its lamp, which
the path tracer now finds. Each Blender scene is rendered by Cycles and by Photon through the
add-on at 48x32: mean within 2 % and relMSE <= 0.01. The add-on exports the lamp's Soft Falloff
and ray visibility (PHOTON_light) and names in the pre-flight report what it cannot carry.
"""

import math
import os

import bpy
import numpy as np
import pytest

import common
from cycles_compare import compare
from helpers import reference, render_photon


@pytest.fixture
def _addon(photon_addon, binary_env):
    return photon_addon


def mirror_scene(floor=0.0):
    """A mirror sphere on a floor of albedo `floor` under a grey world (radiance 1), the
    camera looking down at 32 degrees; the lamps stand out of the camera's view (and Blender
    hides lights from camera rays), so only their reflections show. On a black floor nothing
    makes a caustic: with a lit one, Cycles' own reference at 1024 spp is speckled by the
    sphere's caustic of the lamp (relMSE 0.04-0.17 between the engines, all of it from single
    samples on the floor)."""
    scene = common.reset_scene(48, 32)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    grey = common.principled("Grey", (floor, floor, floor))
    common.quad("Floor", [(-5, -5, 0), (5, -5, 0), (5, 5, 0), (-5, 5, 0)], grey)
    mirror = common.principled("Mirror", (0.9, 0.9, 0.9), roughness=0.0)
    mirror.node_tree.nodes["Principled BSDF"].inputs["Metallic"].default_value = 1.0
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=0.8,
                                         location=(0.0, 0.0, 0.8))
    sphere = bpy.context.object
    bpy.ops.object.shade_smooth()
    sphere.data.materials.append(mirror)
    common.camera("Camera", (0.0, -4.0, 2.6), (58.0, 0.0, 0.0), 45.0)
    return scene


@pytest.mark.slow
@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_mirror_sphere_reflects_a_point_lamp(_addon, tmp_path, method):
    scene = mirror_scene()
    common.light("Lamp", "POINT", (-1.2, -2.5, 2.5), energy=300.0, shadow_soft_size=0.2)
    # The reflection covers a few pixels: their share of the mean needs the samples (the
    # photon method's final gathers make its samples dearer; it converges faster here).
    img, ref = compare(f"mirror lamp r=0.2 ({method.lower()})", scene, tmp_path,
                       photon_spp=1024 if method == "PATH" else 256, method=method)
    # The reflection: a few pixels at the lamp's radiance, far above the rest.
    assert ref.max() > 20.0 * np.median(ref), "Cycles shows the reflection"
    assert img.max() > 0.5 * ref.max(), (img.max(), ref.max())


@pytest.mark.slow
def test_photon_method_counts_the_lamp_once_beside_its_caustic(_addon, tmp_path):
    """On a lit floor the sphere throws a caustic of the lamp (the caustic map's photons) and
    the camera sees the lamp in the sphere (the camera path): each counted once, the mean
    agrees with Cycles'."""
    scene = mirror_scene(floor=0.5)
    common.light("Lamp", "POINT", (-1.2, -2.5, 2.5), energy=300.0, shadow_soft_size=0.2)
    compare("mirror lamp on a lit floor (photon)", scene, tmp_path, photon_spp=256,
            cycles_spp=2048, method="PHOTON")


@pytest.mark.slow
def test_glossy_floor_lit_by_a_small_lamp(_addon, tmp_path):
    """A glossy floor (roughness 0.1) under a point lamp of radius 0.1: the highlight is the
    lamp's blurred reflection, found by BSDF rays and light samples together (MIS)."""
    scene = common.reset_scene(48, 32)
    glossy = common.principled("Glossy", (0.3, 0.3, 0.3), roughness=0.1)
    common.quad("Floor", [(-5, -5, 0), (5, -5, 0), (5, 5, 0), (-5, 5, 0)], glossy)
    common.camera("Camera", (0.0, -4.0, 2.0), (65.0, 0.0, 0.0), 50.0)
    common.light("Lamp", "POINT", (0.3, 2.0, 1.2), energy=200.0, shadow_soft_size=0.1)
    compare("glossy floor lamp r=0.1", scene, tmp_path, photon_spp=256)


@pytest.mark.slow
def test_spot_lamp_seen_in_a_mirror(_addon, tmp_path):
    """A spot lamp of radius 0.25 aimed at the mirror sphere: its reflection is its disc, dimmed
    by the cone evaluated along each reflected ray."""
    scene = mirror_scene()
    common.light("Spot", "SPOT", (1.0, -2.5, 2.2), (55.0, 0.0, 20.0), energy=600.0,
                 spot_size=math.radians(60.0), spot_blend=0.5, shadow_soft_size=0.25)
    img, ref = compare("spot lamp r=0.25 in a mirror", scene, tmp_path, photon_spp=256)
    assert ref.max() > 20.0 * np.median(ref), "Cycles shows the reflection"


def test_lamp_flags_exported_and_partial_visibility_named(photon_addon, tmp_path):
    from blender_addon import lights, preflight
    scene = mirror_scene()
    lamp = common.light("Lamp", "POINT", (-1.2, -2.5, 2.5), energy=300.0, shadow_soft_size=0.2)
    lamp.visible_camera = True
    lamp.data.use_soft_falloff = False
    spot = common.light("Spot", "SPOT", (1.0, -2.5, 2.2), energy=600.0, shadow_soft_size=0.1)
    spot.visible_glossy = False
    data = lights.light_extension(lamp)
    assert (data["soft_falloff"], data["visible_camera"], data["visible_bounces"]) == (
        False, True, True)
    data = lights.light_extension(spot)
    assert (data["soft_falloff"], data["visible_camera"], data["visible_bounces"]) == (
        True, False, False)
    messages = preflight.unsupported_features(scene, list(scene.objects))
    named = [m for m in messages if "ray visibility" in m]
    assert len(named) == 1 and "'Spot'" in named[0] and "glossy" in named[0], messages


@pytest.mark.slow
def test_path_tracer_finds_the_open_rings_lamp_caustic():
    """The ring's outside reflects its lamp onto the floor next to the wall: the path tracer now
    meets the lamp through the mirror (before, it saw none of that light: -18 % in the band
    next to the wall at 2048 spp) and agrees there with Cycles and with the photon method."""
    if not os.environ.get("PHOTON_BINARY"):
        pytest.fail("PHOTON_BINARY is not set", pytrace=False)
    from test_open_ring import floor_radius
    ref, info = reference("ring_open")
    r = floor_radius(info)
    band = (r > info["ring"]["radius"]) & (r < 1.3 * info["ring"]["radius"])
    size = (info["width"], info["height"])
    path = render_photon("ring_open", *size, 4096, extra=["--method", "path"])
    photon = render_photon("ring_open", *size, 256, extra=["--method", "photon"])
    cycles = float(ref[band].mean())
    msg = (f"band next to the ring: cycles {cycles:.4f}, path {path[band].mean():.4f}, "
           f"photon {photon[band].mean():.4f}")
    print(msg)
    assert abs(path[band].mean() / cycles - 1.0) < 0.08, msg
    assert abs(path[band].mean() / photon[band].mean() - 1.0) < 0.08, msg
