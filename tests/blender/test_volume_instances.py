"""Volumes that particle systems and Geometry Nodes instance or make, against Cycles through the
add-on, 40x40, Photon 256 spp, Cycles 512 (mean within 2 % and relMSE <= 0.01,
`cycles_compare.compare`).

- one hair particle instancing a Volume object of constant density, seen straight down: the
  light through its middle against the closed form too, in volume space Object and World;
- a hair particle system scattering five instances of a Volume object (a soft ball of smoke
  Blender baked to OpenVDB) over a quad, each at its own turn and size;
- a Geometry Nodes Instance on Points of a Volume object (Object Info), the points on a line,
  each instance turned and scaled by the node;
- a Volume Cube made inside a Geometry Nodes tree on a mesh object (a soft ball of density from
  the position), with a Set Material;
- a Mesh to Volume of a cube inside a Geometry Nodes tree (uniform density inside the mesh),
  instanced twice by Instance on Points;
- a Volume Displace modifier on a Volume object (its evaluated grids, not its file's; relMSE
  over 4x4 blocks);
- the pre-flight report: silent about what these render (and the export too), still naming a
  Volume object whose OpenVDB file is missing when particles instance it.
"""

import math

import bpy
import pytest

import common
from cycles_compare import compare
from helpers import rel_mse
from test_volumes import block_means
import volume_scenes
from volume_scenes import baked_smoke_vdb, sun, volume_material, volume_object

SIZE = 40

pytestmark = pytest.mark.slow


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def floor_scene(world=0.05):
    """A fresh scene of this file's size (`volume_scenes.floor_scene`)."""
    return volume_scenes.floor_scene(SIZE, world)


def smoke_material(density=6.0):
    mat, node = volume_material("Smoke", "ShaderNodeVolumePrincipled")
    node.inputs["Color"].default_value = (0.9, 0.5, 0.2, 1.0)
    node.inputs["Density"].default_value = density
    return mat


def hidden_smoke(path, material):
    """A Volume object of the OpenVDB file at `path`, out of the camera's view and hidden, only
    there to be instanced (Cycles renders instances of an object hidden from renders)."""
    smoke = volume_object("Smoke", path, material, (0.0, 0.0, 0.0))
    smoke.hide_render = True
    return smoke


def nodes_modifier(obj, name):
    """A new Geometry Nodes group `name` on `obj` (a modifier), with a Geometry input and
    output; returns the group."""
    group = bpy.data.node_groups.new(name, "GeometryNodeTree")
    group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    group.nodes.new("NodeGroupInput")
    group.nodes.new("NodeGroupOutput")
    obj.modifiers.new(name, "NODES").node_group = group
    return group


def points_on_a_line(group, count, start, end):
    """A Mesh Line of `count` points from `start` to `end` in `group`; returns its output."""
    line = group.nodes.new("GeometryNodeMeshLine")
    line.mode = "END_POINTS"
    line.inputs["Count"].default_value = count
    line.inputs["Start Location"].default_value = start
    line.inputs["Offset"].default_value = end
    return line.outputs["Mesh"]


def particles_of(volume, count, half_x, half_y, height):
    """A quad (2 `half_x` by 2 `half_y` at `height`, not rendered itself) whose hair particle
    system renders `volume` (an object) at `count` hairs one metre long (a hair's instance is
    scaled by its length as well as by the particle size). Returns the particle settings."""
    x, y = half_x, half_y
    emitter = common.quad("Emitter", [(-x, -y, height), (x, -y, height), (x, y, height),
                                      (-x, y, height)], None)
    emitter.show_instancer_for_render = False
    emitter.modifiers.new("Particles", "PARTICLE_SYSTEM")
    settings = emitter.particle_systems[0].settings
    settings.type = "HAIR"
    settings.hair_length = 1.0
    settings.count = count
    settings.render_type = "OBJECT"
    settings.instance_object = volume
    return settings


def constant_vdb(path, n=4):
    """Writes an OpenVDB file of one "density" grid of value 1 to `path`: `n`³ voxels 1/`n`
    apart over [−½, ½]³. Along a line through its middle third, parallel to an axis, the
    density interpolated between voxel centres integrates to 1 (object units)."""
    vdb = volume_scenes.openvdb_module()
    import numpy as np
    grid = vdb.FloatGrid()
    grid.copyFromArray(np.ones((n, n, n), np.float32))
    grid.name = "density"
    grid.transform = vdb.createLinearTransform(
        [[1 / n, 0, 0, 0], [0, 1 / n, 0, 0], [0, 0, 1 / n, 0], [-0.5, -0.5, -0.5, 1]])
    vdb.write(str(path), grids=[grid])
    return path


@pytest.mark.parametrize("space", ["OBJECT", "WORLD"])
def test_one_particle_instance_transmittance(tmp_path, space):
    """One particle (a hair from a tiny quad at the origin, size 0.5) instancing a Volume
    object of constant density (absorption only, 1.5 per unit) seen straight down by an
    orthographic camera against a white world: in the middle of the instance, the light that
    gets through is exp(−1.5) in volume space Object (the density per unit of the instance's own
    length) and exp(−1.5 × 0.5) in World, in Photon as in Cycles."""
    scene, mat = volume_scenes.absorber_from_above(SIZE, 1.0)
    box = volume_object("Box", constant_vdb(tmp_path / "constant.vdb"), mat, (0.0, 0.0, 5.0))
    box.data.render.space = space
    box.hide_render = True
    settings = particles_of(box, 1, 0.01, 0.01, 0.0)
    settings.particle_size = 0.5
    photon, cycles = compare(f"one particle instance {space}", scene, tmp_path, photon_spp=256,
                             cycles_spp=256)
    middle = slice(SIZE // 2 - 6, SIZE // 2 + 6)
    expected = math.exp(-1.5 * (1.0 if space == "OBJECT" else 0.5))
    got = [float(image[middle, middle, :3].mean()) for image in (photon, cycles)]
    print(f"{space}: transmittance in the middle: photon {got[0]:.4f}, cycles {got[1]:.4f}, "
          f"expected {expected:.4f}")
    assert all(abs(g / expected - 1.0) < 0.02 for g in got)


def test_particles_scatter_a_volume_object(tmp_path):
    """A hair particle system (five hairs, rendered as Object) scattering a Volume object of
    baked smoke over a quad (not rendered itself), each instance at a random turn and size."""
    path = baked_smoke_vdb(tmp_path / "bake")
    scene = floor_scene()
    smoke = hidden_smoke(path, smoke_material())
    settings = particles_of(smoke, 5, 1.6, 1.2, 0.6)
    settings.particle_size = 0.6
    settings.size_random = 0.5
    settings.use_rotations = True
    settings.rotation_mode = "GLOB_Z"
    settings.phase_factor_random = 2.0
    settings.use_rotation_instance = True
    sun()
    compare("particle volumes", scene, tmp_path, photon_spp=256, cycles_spp=512)


def test_instance_on_points_of_a_volume_object(tmp_path):
    """Geometry Nodes' Instance on Points placing a Volume object (Object Info, As Instance)
    on three points of a line, turned about z by 40° per instance and scaled 0.4 to 0.7."""
    path = baked_smoke_vdb(tmp_path / "bake")
    scene = floor_scene()
    smoke = hidden_smoke(path, smoke_material())
    holder = common.mesh_object("Holder", [(0, 0, 0)], [], None, (0.0, 0.0, 0.9))
    group = nodes_modifier(holder, "Scatter")
    nodes, links = group.nodes, group.links
    info = nodes.new("GeometryNodeObjectInfo")
    info.inputs["Object"].default_value = smoke
    info.inputs["As Instance"].default_value = True
    index = nodes.new("GeometryNodeInputIndex")
    turn = nodes.new("ShaderNodeMath")
    turn.operation = "MULTIPLY"
    turn.inputs[1].default_value = math.radians(40.0)
    links.new(index.outputs[0], turn.inputs[0])
    rotation = nodes.new("ShaderNodeCombineXYZ")
    links.new(turn.outputs[0], rotation.inputs["Z"])
    size = nodes.new("ShaderNodeMath")
    size.operation = "MULTIPLY_ADD"
    size.inputs[1].default_value = 0.15
    size.inputs[2].default_value = 0.4
    links.new(index.outputs[0], size.inputs[0])
    place = nodes.new("GeometryNodeInstanceOnPoints")
    links.new(points_on_a_line(group, 3, (-1.2, -0.2, 0.0), (1.2, 0.3, 0.2)),
              place.inputs["Points"])
    links.new(info.outputs["Geometry"], place.inputs["Instance"])
    links.new(rotation.outputs[0], place.inputs["Rotation"])
    links.new(size.outputs[0], place.inputs["Scale"])
    links.new(place.outputs[0], nodes["Group Output"].inputs[0])
    sun()
    compare("instance on points volumes", scene, tmp_path, photon_spp=256, cycles_spp=512)


def test_volume_cube_made_by_geometry_nodes(tmp_path):
    """A Volume Cube (24 voxels a side over [-0.8, 0.8]³) inside a Geometry Nodes tree on a
    mesh object, its density a soft ball from the position, with a Set Material of smoke; the
    object moved, turned and scaled."""
    scene = floor_scene()
    holder = common.mesh_object("Holder", [(0, 0, 0)], [], None, (0.2, 0.0, 1.0))
    holder.rotation_euler = (0.3, 0.0, 0.5)
    holder.scale = (1.2, 1.0, 0.9)
    group = nodes_modifier(holder, "Cloud")
    nodes, links = group.nodes, group.links
    cube = nodes.new("GeometryNodeVolumeCube")
    for axis in "XYZ":
        cube.inputs[f"Resolution {axis}"].default_value = 24
    cube.inputs["Min"].default_value = (-0.8, -0.8, -0.8)
    cube.inputs["Max"].default_value = (0.8, 0.8, 0.8)
    links.new(volume_scenes.soft_ball(group, 0.8), cube.inputs["Density"])
    material = nodes.new("GeometryNodeSetMaterial")
    material.inputs["Material"].default_value = smoke_material(4.0)
    links.new(cube.outputs[0], material.inputs["Geometry"])
    links.new(material.outputs[0], nodes["Group Output"].inputs[0])
    sun()
    compare("geometry nodes volume cube", scene, tmp_path, photon_spp=256, cycles_spp=512)


def test_mesh_to_volume_instanced_by_geometry_nodes(tmp_path):
    """A cube mesh turned into a volume of density 1 inside it (Mesh to Volume), with a Set
    Material, placed twice by Instance on Points at different turns."""
    scene = floor_scene()
    holder = common.mesh_object("Holder", [(0, 0, 0)], [], None, (0.0, 0.0, 0.7))
    group = nodes_modifier(holder, "Fog")
    nodes, links = group.nodes, group.links
    mesh = nodes.new("GeometryNodeMeshCube")
    mesh.inputs["Size"].default_value = (0.9, 0.9, 0.9)
    to_volume = nodes.new("GeometryNodeMeshToVolume")
    to_volume.inputs["Voxel Amount"].default_value = 24
    links.new(mesh.outputs["Mesh"], to_volume.inputs["Mesh"])
    material = nodes.new("GeometryNodeSetMaterial")
    material.inputs["Material"].default_value = smoke_material(1.5)
    links.new(to_volume.outputs[0], material.inputs["Geometry"])
    place = nodes.new("GeometryNodeInstanceOnPoints")
    links.new(points_on_a_line(group, 2, (-0.8, 0.0, 0.0), (1.6, 0.4, 0.0)),
              place.inputs["Points"])
    links.new(material.outputs[0], place.inputs["Instance"])
    place.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(30.0))
    links.new(place.outputs[0], nodes["Group Output"].inputs[0])
    sun()
    compare("mesh to volume instances", scene, tmp_path, photon_spp=256, cycles_spp=512)


def test_volume_displace_modifier(tmp_path):
    """A Volume object of baked smoke whose Volume Displace modifier (a Clouds texture, strength
    0.8) moves its voxels: the grids Blender evaluates render, not the file's."""
    path = baked_smoke_vdb(tmp_path / "bake")
    scene = floor_scene()
    smoke = volume_object("Smoke", path, smoke_material(), (0.0, 0.0, 0.9), rotation_z=20.0)
    displace = smoke.modifiers.new("Displace", "VOLUME_DISPLACE")
    displace.texture = bpy.data.textures.new("Clouds", "CLOUDS")
    displace.texture.noise_scale = 0.3
    displace.strength = 0.8
    sun()
    # Photon's image has a few fireflies where the displaced smoke is thin (Cycles' has none):
    # relMSE over 4x4 blocks is the criterion (the undisplaced grids of the file: 0.28 per pixel).
    img, ref = compare("displaced volume", scene, tmp_path, photon_spp=256, cycles_spp=512,
                       relmse_max=0.05)
    blocks = rel_mse(block_means(img), block_means(ref))
    print(f"displaced volume: relMSE of 4x4 blocks {blocks:.5f}")
    assert blocks <= 0.01


def volume_messages(scene):
    from blender_addon import preflight
    return [m for m in preflight.unsupported_features(scene, list(scene.objects))
            if "olume" in m or "particle" in m]


def test_preflight_silent_on_volumes_it_renders(tmp_path):
    """Particles of a Volume object, a Volume object with a modifier and a Volume Cube made by
    Geometry Nodes: the pre-flight report names none of them, and the export warns of none."""
    path = baked_smoke_vdb(tmp_path / "bake")
    scene = floor_scene()
    smoke = hidden_smoke(path, smoke_material())
    particles_of(smoke, 3, 1.0, 1.0, 0.5)
    displaced = volume_object("Displaced", path, smoke_material(), (0.0, 0.0, 1.0))
    displaced.modifiers.new("Displace", "VOLUME_DISPLACE")
    holder = common.mesh_object("Holder", [(0, 0, 0)], [], None)
    group = nodes_modifier(holder, "Cloud")
    cube = group.nodes.new("GeometryNodeVolumeCube")
    group.links.new(cube.outputs[0], group.nodes["Group Output"].inputs[0])
    bpy.context.view_layer.update()
    assert volume_messages(scene) == []
    # Nor does the export warn (the glTF exporter's "no primitives" of the Volume Cube's mesh).
    from blender_addon import export
    assert export.export_in_process(tmp_path / "scene.glb", "blender_addon") == []


def test_preflight_names_an_instanced_volume_object_it_cannot_read(tmp_path):
    """A hidden Volume object whose OpenVDB file is missing, instanced by particles: one message
    naming it as not rendered."""
    scene = floor_scene()
    smoke = hidden_smoke(tmp_path / "missing.vdb", smoke_material())
    particles_of(smoke, 3, 1.0, 1.0, 0.5)
    bpy.context.view_layer.update()
    messages = volume_messages(scene)
    assert len(messages) == 1 and messages[0].startswith(
        "Volume object 'Smoke' is not rendered: its OpenVDB file cannot be read"), messages
