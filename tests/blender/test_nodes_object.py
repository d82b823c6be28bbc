"""Object Info against Cycles through the add-on: what the node reads of each object and of
each instance (PHOTON_object "info", written by export.py's `object_infos`).

Each scene, 32x32 seen from 3 m above, is emission only (a black world): the image is the
node's values themselves, so the engines differ only in anti-aliasing noise. The criterion:
mean within 1 % of Cycles', relMSE over 4x4-pixel blocks <= 1e-3.

- Random through a Color Ramp on three plain quads (Cycles' hash of each object's name) and on
  a 4x4 grid of Geometry Nodes instances of a hidden tile (each instance's random id);
- Object Color times Alpha on quads of different colours, and Location, Object Index and
  Material Index combined into a colour on quads at different places with different pass
  indices.
"""

import bpy
import numpy as np
import pytest

import common
import scenes_bpy
from helpers import rel_mse
from test_nodes import SIZE, node_material
from test_volumes import block_means

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s

BLOCK_RELMSE_MAX = 1e-3
MEAN_TOL = 0.01


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def matches_cycles(name, scene, tmp_path, *, spp=256):
    """Render `scene` with both engines: mean within MEAN_TOL, 4x4-block relMSE within
    BLOCK_RELMSE_MAX."""
    ref = scenes_bpy.render(scene, "CYCLES", tmp_path / f"{name}_cycles.exr", spp)
    scene.photon.method = "PATH"
    img = scenes_bpy.render(scene, "PHOTON", tmp_path / f"{name}_photon.exr", spp)
    diff = float(img.mean() / ref.mean()) - 1.0
    blocks = rel_mse(block_means(img), block_means(ref))
    msg = (f"{name}: mean photon {img.mean():.5f} vs cycles {ref.mean():.5f} "
           f"({100 * diff:+.2f} %), 4x4-block relMSE {blocks:.6f}, pixel relMSE "
           f"{rel_mse(img, ref):.5f}")
    print(msg)
    assert np.isfinite(img).all()
    assert abs(diff) <= MEAN_TOL, msg
    assert blocks <= BLOCK_RELMSE_MAX, msg


def emission_of(tree, color_socket, strength_socket=None):
    emission = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(color_socket, emission.inputs["Color"])
    if strength_socket is not None:
        tree.links.new(strength_socket, emission.inputs["Strength"])
    tree.links.new(emission.outputs["Emission"], tree.nodes["Material Output"].inputs["Surface"])


def square(name, material, centre, half):
    """A square of half size `half` around `centre` (its object's location), facing up."""
    corners = [(-half, -half, 0), (half, -half, 0), (half, half, 0), (-half, half, 0)]
    return common.mesh_object(name, corners, [(0, 1, 2, 3)], material, centre)


def top_camera():
    common.camera("Camera", (0.0, 0.0, 3.0), (0.0, 0.0, 0.0), 36.0)


def geometry_nodes(name):
    """A Geometry Nodes group taking and giving a geometry, and its Group Output node."""
    group = bpy.data.node_groups.new(name, "GeometryNodeTree")
    group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    group.nodes.new("NodeGroupInput")
    return group, group.nodes.new("NodeGroupOutput")


def instances_on_a_grid(name, tile, centre, size, count):
    """An object whose Geometry Nodes put an instance of `tile` on each point of a
    count x count grid of `size` around `centre`."""
    group, output = geometry_nodes(name)
    nodes, links = group.nodes, group.links
    grid = nodes.new("GeometryNodeMeshGrid")
    grid.inputs["Size X"].default_value = size
    grid.inputs["Size Y"].default_value = size
    grid.inputs["Vertices X"].default_value = count
    grid.inputs["Vertices Y"].default_value = count
    info = nodes.new("GeometryNodeObjectInfo")
    info.inputs["Object"].default_value = tile
    on_points = nodes.new("GeometryNodeInstanceOnPoints")
    links.new(grid.outputs["Mesh"], on_points.inputs["Points"])
    links.new(info.outputs["Geometry"], on_points.inputs["Instance"])
    links.new(on_points.outputs["Instances"], output.inputs["Geometry"])
    mesh = bpy.data.meshes.new(name)
    holder = bpy.data.objects.new(name, mesh)
    holder.location = centre
    bpy.context.scene.collection.objects.link(holder)
    holder.modifiers.new("Scatter", "NODES").node_group = group
    return holder


def test_object_info_random_through_a_color_ramp(tmp_path):
    mat, tree = node_material("Random")
    info = tree.nodes.new("ShaderNodeObjectInfo")
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.9, 0.1, 0.05, 1.0)
    ramp.color_ramp.elements[1].color = (0.05, 0.3, 1.0, 1.0)
    ramp.color_ramp.elements.new(0.5).color = (0.1, 0.9, 0.2, 1.0)
    tree.links.new(info.outputs["Random"], ramp.inputs["Fac"])
    emission_of(tree, ramp.outputs["Color"])
    scene = bpy.context.scene
    for k, x in enumerate((-0.75, 0.0, 0.75)):
        square(f"Plain {k}", mat, (x, 0.6, 0.0), 0.3)
    tile = square("Tile", mat, (0.0, 0.0, -5.0), 0.12)
    tile.hide_render = True
    instances_on_a_grid("Scattered", tile, (0.0, -0.45, 0.0), 1.6, 4)
    top_camera()
    matches_cycles("object info random", scene, tmp_path)


def test_object_color_alpha_location_and_indices(tmp_path):
    coloured, tree = node_material("Coloured")
    info = tree.nodes.new("ShaderNodeObjectInfo")
    emission_of(tree, info.outputs["Color"], info.outputs["Alpha"])
    placed = bpy.data.materials.new("Placed")
    if bpy.app.version < (5, 0, 0):
        placed.use_nodes = True
    placed.pass_index = 3
    nodes, links = placed.node_tree.nodes, placed.node_tree.links
    nodes.remove(nodes["Principled BSDF"])
    info = nodes.new("ShaderNodeObjectInfo")
    separate = nodes.new("ShaderNodeSeparateXYZ")
    links.new(info.outputs["Location"], separate.inputs["Vector"])

    def scaled(socket, factor, offset):
        node = nodes.new("ShaderNodeMath")
        node.operation = "MULTIPLY_ADD"
        node.inputs[1].default_value = factor
        node.inputs[2].default_value = offset
        links.new(socket, node.inputs[0])
        return node.outputs["Value"]

    combine = nodes.new("ShaderNodeCombineXYZ")
    links.new(scaled(separate.outputs["X"], 0.4, 0.5), combine.inputs["X"])
    links.new(scaled(info.outputs["Object Index"], 0.2, 0.1), combine.inputs["Y"])
    links.new(scaled(info.outputs["Material Index"], 0.25, 0.0), combine.inputs["Z"])
    emission_of(placed.node_tree, combine.outputs["Vector"])
    scene = bpy.context.scene
    colours = [(1.0, 0.2, 0.1, 1.0), (0.1, 0.8, 0.3, 0.5), (0.2, 0.3, 1.0, 0.8)]
    for k, colour in enumerate(colours):
        obj = square(f"Coloured {k}", coloured, (-0.75 + 0.75 * k, 0.5, 0.0), 0.3)
        obj.color = colour
    for k in range(3):
        obj = square(f"Placed {k}", placed, (-0.75 + 0.75 * k, -0.5, 0.0), 0.3)
        obj.pass_index = 1 + 2 * k
    top_camera()
    matches_cycles("object info colour location indices", scene, tmp_path)
