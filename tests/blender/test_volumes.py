"""Volumes (Blender's Volume sockets) against Cycles through the add-on, 32x32.

Each scene is built with bpy, rendered by Cycles (1024 spp) and by Photon through the add-on,
and compared: mean within 2 % and relMSE <= 0.01 (`cycles_compare.compare`) unless a test says
otherwise. Volume bounces stay at Blender's default, 0 (single scattering), but where a test
sets them.

- a cube of Principled Volume (density 2) over a sunlit floor, Surface unlinked (the cube's
  surface is only the medium's boundary);
- a cube of Volume Absorption in front of an emitting wall (Beer–Lambert through the cube);
- a cube of smoke whose density is a Noise Texture × 6 (heterogeneous, the node program
  evaluated at points in the medium);
- an emitting Principled Volume sphere (emission strength 2, orange), which lights the floor
  (both methods: the photon method emits photons from the medium);
- a World with a Principled Volume and a sun: black, as Cycles renders it (the sun is
  attenuated over an infinite medium);
- a spot light in a fog box (Volume Scatter) over a sphere: the light cone (the path tracer and
  the photon method, whose volume photon map holds the light scattered more than once);
- a Volume Scatter cube with two volume bounces;
- a glass sphere in a fog box under an area light (its caustic on the floor and its shadow in
  the fog; relMSE over 4x4 blocks <= 0.01, both engines' per-pixel noise being large there);
- a window-lit room of thin walls filled with haze, the sun through the window (god rays; both
  methods, and auto, which takes the photon method there);
- three linked duplicates of one smoke cube (instances of one prototype), each reading its own
  object space through a Noise Texture on Object coordinates;
- three overlapping Volume objects of one OpenVDB file at different scales (their media add);
- a scaled Volume object in volume space World (its density per metre);
- a Volume object emitting a constant colour: only where its voxels are (the leaves Cycles
  builds its volume mesh from), not in the whole box;
- a Volume object in a collection outside the scene, instanced twice by Empties: each instance
  at its transform.
"""

import math

import bpy
import pytest

import common
from cycles_compare import compare
from helpers import rel_mse
import volume_scenes
from volume_scenes import (baked_smoke_vdb, checker_vdb, cube, fire_vdb, glass_fog, god_rays, shader_material, sphere, sun,
                           volume_material, volume_object)

SIZE = 32

pytestmark = pytest.mark.slow


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def block_means(image, k=4):
    """The image's mean over k x k blocks."""
    h, w = image.shape[0] // k * k, image.shape[1] // k * k
    return image[:h, :w].reshape(h // k, k, w // k, k, -1).mean(axis=(1, 3))


def floor_scene(world=0.05):
    """A fresh scene of this file's size (`volume_scenes.floor_scene`)."""
    return volume_scenes.floor_scene(SIZE, world)


@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_principled_volume_cube_over_a_sunlit_floor(tmp_path, method):
    scene = floor_scene()
    mat, _ = volume_material("Smoke", "ShaderNodeVolumePrincipled", Density=2.0)
    cube("Smoke", mat, 1.2, (0.0, 0.0, 0.8))
    sun()
    compare(f"principled volume {method.lower()}", scene, tmp_path, photon_spp=256,
            method=method)


def test_absorption_cube_before_an_emitting_wall(tmp_path):
    scene = floor_scene(world=0.0)
    wall, _ = shader_material("Wall", "ShaderNodeEmission", "Surface", Strength=1.0)
    common.quad("Wall", [(-3, 2, 0), (3, 2, 0), (3, 2, 4), (-3, 2, 4)], wall)
    mat, _ = volume_material("Ink", "ShaderNodeVolumeAbsorption",
                             Color=(0.8, 0.4, 0.2, 1.0), Density=1.5)
    cube("Ink", mat, 1.5, (0.0, 0.0, 1.0))
    compare("absorption", scene, tmp_path, photon_spp=64)


def test_noise_density_smoke(tmp_path):
    scene = floor_scene()
    mat, node = volume_material("Noise smoke", "ShaderNodeVolumePrincipled")
    tree = mat.node_tree
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 3.0
    times = tree.nodes.new("ShaderNodeMath")
    times.operation = "MULTIPLY"
    times.inputs[1].default_value = 6.0
    tree.links.new(noise.outputs["Fac"], times.inputs[0])
    tree.links.new(times.outputs[0], node.inputs["Density"])
    cube("Noise smoke", mat, 1.2, (0.0, 0.0, 0.8))
    sun()
    compare("noise density", scene, tmp_path, photon_spp=256)


@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_emitting_principled_volume_sphere(tmp_path, method):
    scene = floor_scene(world=0.0)
    mat, _ = volume_material("Glow", "ShaderNodeVolumePrincipled", Density=0.5,
                             **{"Emission Strength": 2.0,
                                "Emission Color": (1.0, 0.4, 0.1, 1.0)})
    sphere("Glow", mat, 0.8, (0.0, 0.0, 1.0))
    compare(f"emitting volume {method}", scene, tmp_path, photon_spp=256 if method == "PATH" else 64,
            method=method)


def test_world_volume_stops_the_sun(tmp_path):
    scene = floor_scene(world=0.0)
    world = scene.world.node_tree
    fog = world.nodes.new("ShaderNodeVolumePrincipled")
    fog.inputs["Density"].default_value = 0.04
    world.links.new(fog.outputs[0], world.nodes["World Output"].inputs["Volume"])
    sun()
    import scenes_bpy
    ref = scenes_bpy.render(scene, "CYCLES", tmp_path / "world_cycles.exr", 16)
    img = scenes_bpy.render(scene, "PHOTON", tmp_path / "world_photon.exr", 16)
    print(f"world volume: max photon {img.max():.3g}, cycles {ref.max():.3g}")
    assert ref.max() < 1e-4, "Cycles renders a world volume under a sun black"
    assert img.max() < 1e-4


@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_spot_light_in_a_fog_box(tmp_path, method):
    scene = floor_scene(world=0.0)
    mat, _ = volume_material("Fog", "ShaderNodeVolumeScatter", Density=0.15)
    cube("Fog", mat, 5.0, (0.0, 0.0, 2.49))
    ball = common.principled("Ball", (0.8, 0.3, 0.2), roughness=0.5)
    sphere("Ball", ball, 0.5, (0.0, 0.0, 0.5))
    spot = bpy.data.lights.new("Spot", "SPOT")
    spot.energy = 400.0
    spot.spot_size = math.radians(35.0)
    spot.spot_blend = 0.2
    spot.shadow_soft_size = 0.05
    obj = common.link(bpy.data.objects.new("Spot", spot))
    obj.location = (0.8, 0.5, 3.5)
    obj.rotation_euler = (math.radians(12.0), math.radians(10.0), 0.0)
    # The photon method's radii shrink every 64 spp: at 128 its map still blurs the cone's
    # edge (+2.4 %), at 512 it is within 1 %.
    compare(f"spot in fog {method.lower()}", scene, tmp_path, photon_spp=512, method=method)


def test_scatter_cube_with_two_volume_bounces(tmp_path):
    scene = floor_scene()
    mat, _ = volume_material("Cloud", "ShaderNodeVolumeScatter",
                             Color=(0.9, 0.9, 0.9, 1.0), Density=3.0, Anisotropy=0.3)
    cube("Cloud", mat, 1.2, (0.0, 0.0, 0.8))
    sun()
    scene.cycles.volume_bounces = 2
    compare("two volume bounces", scene, tmp_path, photon_spp=512)


def test_glass_sphere_in_fog(tmp_path):
    """A glass sphere inside a fog box under a small area light: the glass's caustic on the
    floor (found by BSDF-sampled rays through the glass in both engines) and its shadow in the
    fog; the fog continues inside the glass (it has no volume of its own). At Blender's default
    of 0 Volume bounces a camera path does not go on from a scattering in the fog, so neither
    engine shows the caustic in the fog itself."""
    scene = glass_fog(SIZE)
    # Per pixel both engines are noisy (the caustic is found by BSDF-sampled rays alone):
    # relMSE over 4x4 blocks, where that noise averages out, is the criterion.
    img, ref = compare("glass in fog", scene, tmp_path, photon_spp=1024, cycles_spp=2048,
                       relmse_max=0.05)
    blocks = rel_mse(block_means(img), block_means(ref))
    print(f"glass in fog: relMSE of 4x4 blocks {blocks:.5f}")
    assert blocks <= 0.01


@pytest.mark.parametrize("method", ["PATH", "PHOTON", "AUTO"])
def test_window_lit_room_with_haze(tmp_path, method):
    """God rays: a room of one-sided thin walls with a window, a sun through it, and haze
    (Volume Scatter) filling the room; the camera inside sees the shaft of light. Auto (the
    add-on's default) takes the photon method here (its pilot counts the haze's direct light
    with the noise the photon method's segment light samples leave)."""
    scene = god_rays(SIZE)
    compare(f"god rays {method.lower()}", scene, tmp_path,
            photon_spp=1024 if method == "PATH" else 128, cycles_spp=2048, relmse_max=0.02,
            method=method)


def test_instanced_smoke_cubes(tmp_path):
    """Three linked duplicates of one smoke cube (one mesh, three objects: instances of one
    prototype), its density a Noise Texture on Object coordinates, so each instance reads its
    own object space; turned and scaled differently, over a sunlit floor."""
    scene = floor_scene()
    mat, node = volume_material("Instanced smoke", "ShaderNodeVolumePrincipled")
    tree = mat.node_tree
    coords = tree.nodes.new("ShaderNodeTexCoord")
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 2.5
    times = tree.nodes.new("ShaderNodeMath")
    times.operation = "MULTIPLY"
    times.inputs[1].default_value = 5.0
    tree.links.new(coords.outputs["Object"], noise.inputs["Vector"])
    tree.links.new(noise.outputs["Fac"], times.inputs[0])
    tree.links.new(times.outputs[0], node.inputs["Density"])
    first = cube("Smoke", mat, 0.8, (-1.2, 0.0, 0.5))
    for k, (x, turn, scale) in enumerate([(0.0, 30.0, 1.2), (1.2, 60.0, 0.8)]):
        twin = bpy.data.objects.new(f"Smoke {k}", first.data)
        twin.location = (x, 0.3 * k, 0.5)
        twin.rotation_euler = (0.0, 0.0, math.radians(turn))
        twin.scale = (scale, scale, scale)
        common.link(twin)
    sun()
    compare("instanced smoke", scene, tmp_path, photon_spp=256)


def test_openvdb_smoke_volume_objects(tmp_path):
    """Two Volume objects showing one OpenVDB file that Blender baked (a 12³ "density" grid: a
    noisy soft ball), over a sunlit floor: one with a Principled Volume (orange, Density 6,
    reading the grid by its Density Attribute), turned and moved; one without a material, which
    Cycles renders with its default volume shader. The coarse grid shows where voxels sit."""
    path = baked_smoke_vdb(tmp_path / "bake")
    scene = floor_scene()
    mat, node = volume_material("Smoke", "ShaderNodeVolumePrincipled")
    node.inputs["Color"].default_value = (0.9, 0.5, 0.2, 1.0)
    node.inputs["Density"].default_value = 6.0
    volume_object("Smoke", path, mat, (-0.9, 0.2, 1.0), scale=0.9, rotation_z=30.0)
    volume_object("Plain", path, None, (1.0, -0.2, 1.0), scale=0.8)
    sun()
    compare("openvdb smoke", scene, tmp_path, photon_spp=256)


@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_openvdb_fire_with_temperature_and_color_grids(tmp_path, method):
    """A Volume object of a small fire written with bpy's openvdb module: Principled Volume
    reading its "density", "color" (a vec3 grid) and "temperature" grids (Blackbody Intensity
    1: emission from the temperature grid × 1500 K), beside a diffuse sphere it lights, under
    a dim world."""
    path = fire_vdb(tmp_path / "fire.vdb")
    scene = floor_scene(world=0.02)
    mat, node = volume_material("Fire", "ShaderNodeVolumePrincipled")
    node.inputs["Density"].default_value = 2.0
    node.inputs["Blackbody Intensity"].default_value = 1.0
    node.inputs["Temperature"].default_value = 1500.0
    node.inputs["Color Attribute"].default_value = "color"
    node.inputs["Temperature Attribute"].default_value = "temperature"
    volume_object("Fire", path, mat, (-0.3, 0.0, 0.6), scale=1.2)
    sphere("Ball", common.principled("Ball", (0.8, 0.8, 0.8), roughness=1.0), 0.4,
           (0.8, 0.2, 0.4))
    compare(f"openvdb fire {method}", scene, tmp_path, photon_spp=256 if method == "PATH" else 64,
            method=method)


def test_openvdb_voxels_sit_where_blender_puts_them(tmp_path):
    """A 4³ grid of columns of density 0, 1 or 2 (absorption only) seen straight down by an
    orthographic camera against a white world: Blender places voxel i's value at index i + ½
    of the grid's transform, so the columns' shadows must fall where Cycles draws them (with
    values at whole indices instead, relMSE is 1.75)."""
    path = checker_vdb(tmp_path / "checker.vdb")
    scene, mat = volume_scenes.absorber_from_above(48, 3.0)
    volume_object("Checker", path, mat, (0.0, 0.0, 0.0))
    compare("openvdb voxels", scene, tmp_path, photon_spp=64, cycles_spp=256)


def test_overlapping_volume_objects(tmp_path):
    """Three Volume objects of one OpenVDB file, at scales 0.7, 0.9 and 0.6, overlapping (their
    media add where they meet, as Cycles' volume stack adds them), over a sunlit floor."""
    path = baked_smoke_vdb(tmp_path / "bake")
    scene = floor_scene()
    mat, node = volume_material("Smoke", "ShaderNodeVolumePrincipled")
    node.inputs["Color"].default_value = (0.9, 0.5, 0.2, 1.0)
    node.inputs["Density"].default_value = 4.0
    for k, (x, scale, turn) in enumerate([(-0.6, 0.7, 0.0), (0.1, 0.9, 30.0), (0.7, 0.6, 60.0)]):
        volume_object(f"Smoke {k}", path, mat, (x, 0.1 * k, 0.9), scale=scale, rotation_z=turn)
    sun()
    compare("overlapping volume objects", scene, tmp_path, photon_spp=256)


def test_world_space_volume_object(tmp_path):
    """A Volume object at scale 0.6 whose volume space is World: its density per metre, not
    per unit of the object's own length (Object space would make it 1/0.6 times denser)."""
    path = baked_smoke_vdb(tmp_path / "bake")
    scene = floor_scene()
    mat, node = volume_material("Smoke", "ShaderNodeVolumePrincipled")
    node.inputs["Density"].default_value = 6.0
    obj = volume_object("Smoke", path, mat, (0.0, 0.0, 0.8), scale=0.6, rotation_z=20.0)
    obj.data.render.space = "WORLD"
    sun()
    # Read in Object space it is -1.5 %, relMSE 0.0066: bounds tight enough to tell.
    compare("world-space volume object", scene, tmp_path, photon_spp=256, mean_tol=0.005,
            relmse_max=0.002)


def test_constant_emission_only_where_the_voxels_are(tmp_path):
    """A Volume object whose Principled Volume emits a constant colour (Emission Strength, not
    driven by a grid) glows only where its grids have voxels above the Clipping value (the
    OpenVDB leaves Cycles builds its volume mesh from), not through the whole box around them."""
    path = baked_smoke_vdb(tmp_path / "bake")
    scene = floor_scene(world=0.02)
    mat, node = volume_material("Glowing smoke", "ShaderNodeVolumePrincipled")
    node.inputs["Color"].default_value = (0.2, 0.2, 0.2, 1.0)
    node.inputs["Density"].default_value = 3.0
    node.inputs["Emission Strength"].default_value = 1.5
    node.inputs["Emission Color"].default_value = (1.0, 0.5, 0.2, 1.0)
    volume_object("Glowing smoke", path, mat, (0.0, 0.0, 1.0), scale=0.9, rotation_z=15.0)
    compare("constant emission in smoke", scene, tmp_path, photon_spp=256)


def test_instanced_openvdb_volume_objects(tmp_path):
    """A Volume object of one OpenVDB file in a collection that is not in the scene, instanced
    twice by Empties (collection instances) at different places, turns and scales: each
    instance renders at its transform, as Cycles renders it."""
    path = baked_smoke_vdb(tmp_path / "bake")
    scene = floor_scene()
    mat, node = volume_material("Smoke", "ShaderNodeVolumePrincipled")
    node.inputs["Color"].default_value = (0.9, 0.5, 0.2, 1.0)
    node.inputs["Density"].default_value = 6.0
    smoke = volume_object("Smoke", path, mat, (0.0, 0.0, 0.0), scale=0.7)
    scene.collection.objects.unlink(smoke)
    group = bpy.data.collections.new("Smoke set")
    group.objects.link(smoke)
    for k, (x, turn, scale) in enumerate([(-0.9, 20.0, 1.0), (0.9, 70.0, 1.3)]):
        empty = bpy.data.objects.new(f"Smoke instance {k}", None)
        empty.instance_type = "COLLECTION"
        empty.instance_collection = group
        empty.location = (x, 0.2 * k, 0.9)
        empty.rotation_euler = (0.0, 0.0, math.radians(turn))
        empty.scale = (scale, scale, scale)
        common.link(empty)
    sun()
    compare("instanced openvdb smoke", scene, tmp_path, photon_spp=256)
