"""The Attribute node reading Geometry Nodes named attributes against Cycles through the add-on
(Blender's glTF exporter writes them as `_NAME` vertex attributes, export.py keeps the ones
node trees read).

A 2 m grid made by Geometry Nodes, seen from 3 m above, 32x32, emission only (a black world):
Store Named Attribute writes a float on the points (linear in the position, so any
triangulation interpolates it alike), a colour on the faces and a float on the face corners;
the material reads them by name (Fac through a Color Ramp, times the colour, the corners'
float as the strength). Mean within 1 % of Cycles', relMSE over 4x4-pixel blocks <= 1e-3.
Attribute nodes of the other types (Object, Instancer, View Layer):
test_nodes_object_attributes.py.
"""

import bpy
import pytest

import common
from test_nodes import node_material
from test_nodes_object import geometry_nodes, matches_cycles, top_camera



@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def stored(nodes, links, geometry, name, data_type, domain, value):
    """A Store Named Attribute node writing `value` (an output socket) to `geometry`."""
    store = nodes.new("GeometryNodeStoreNamedAttribute")
    store.data_type = data_type
    store.domain = domain
    store.inputs["Name"].default_value = name
    links.new(geometry, store.inputs["Geometry"])
    links.new(value, store.inputs["Value"])
    return store.outputs["Geometry"]


def vector_math(nodes, links, operation, vector, *operands):
    node = nodes.new("ShaderNodeVectorMath")
    node.operation = operation
    links.new(vector, node.inputs[0])
    for k, operand in enumerate(operands, start=1):
        node.inputs[k].default_value = operand
    return node.outputs[0]


def attributed_grid(material):
    """A mesh object whose Geometry Nodes make a 2 m grid of 8x8 vertices with the named
    attributes "height" (points), "tint" (faces) and "gain" (face corners), and `material`."""
    group, output = geometry_nodes("Attributes")
    nodes, links = group.nodes, group.links
    grid = nodes.new("GeometryNodeMeshGrid")
    for key, value in (("Size X", 2.0), ("Size Y", 2.0), ("Vertices X", 8), ("Vertices Y", 8)):
        grid.inputs[key].default_value = value
    position = nodes.new("GeometryNodeInputPosition").outputs["Position"]
    # height = 0.3 x + 0.2 y + 0.5, as the dot product with (0.3, 0.2, 0) plus 0.5.
    dot = vector_math(nodes, links, "DOT_PRODUCT", position, (0.3, 0.2, 0.0))
    height = nodes.new("ShaderNodeMath")
    height.operation = "ADD"
    height.inputs[1].default_value = 0.5
    links.new(dot, height.inputs[0])
    tint = vector_math(nodes, links, "MULTIPLY_ADD", position, (0.5, 0.5, 0.0), (0.5, 0.5, 0.3))
    gain = nodes.new("ShaderNodeMath")
    gain.operation = "MULTIPLY_ADD"
    gain.inputs[1].default_value = 0.8
    gain.inputs[2].default_value = 1.2
    separate = nodes.new("ShaderNodeSeparateXYZ")
    links.new(position, separate.inputs["Vector"])
    links.new(separate.outputs["Y"], gain.inputs[0])
    geometry = grid.outputs["Mesh"]
    geometry = stored(nodes, links, geometry, "height", "FLOAT", "POINT", height.outputs[0])
    geometry = stored(nodes, links, geometry, "tint", "FLOAT_COLOR", "FACE", tint)
    geometry = stored(nodes, links, geometry, "gain", "FLOAT", "CORNER", gain.outputs[0])
    set_material = nodes.new("GeometryNodeSetMaterial")
    set_material.inputs["Material"].default_value = material
    links.new(geometry, set_material.inputs["Geometry"])
    links.new(set_material.outputs["Geometry"], output.inputs["Geometry"])
    mesh = bpy.data.meshes.new("Grid")
    mesh.materials.append(material)
    obj = common.link(bpy.data.objects.new("Grid", mesh))
    obj.modifiers.new("Attributes", "NODES").node_group = group
    return obj


@pytest.mark.slow  # renders Cycles
def test_named_attributes_of_geometry_nodes_into_emission(tmp_path):
    mat, tree = node_material("Attributes")
    nodes, links = tree.nodes, tree.links

    def attribute(name):
        node = nodes.new("ShaderNodeAttribute")
        node.attribute_name = name
        return node

    ramp = nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.1, 0.2, 0.9, 1.0)
    ramp.color_ramp.elements[1].color = (1.0, 0.7, 0.1, 1.0)
    links.new(attribute("height").outputs["Fac"], ramp.inputs["Fac"])
    mix = nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.blend_type = "MULTIPLY"
    mix.inputs["Factor"].default_value = 1.0
    links.new(ramp.outputs["Color"], mix.inputs["A"])
    links.new(attribute("tint").outputs["Color"], mix.inputs["B"])
    emission = nodes.new("ShaderNodeEmission")
    links.new(mix.outputs["Result"], emission.inputs["Color"])
    links.new(attribute("gain").outputs["Fac"], emission.inputs["Strength"])
    links.new(emission.outputs["Emission"], nodes["Material Output"].inputs["Surface"])
    attributed_grid(mat)
    top_camera()
    matches_cycles("named attributes", bpy.context.scene, tmp_path)
