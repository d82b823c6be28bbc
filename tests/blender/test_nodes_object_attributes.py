"""The Attribute node of type Object, Instancer and View Layer against Cycles through the add-on
(object_attributes.py finds the values at export; PHOTON_object "info" "attributes" carries the
per-object ones, the node's `value` the view layer's).

Each scene, 32x32 seen from 3 m above, is emission only (a black world): the image is the
attributes' values themselves, so the engines differ only in anti-aliasing noise. The criterion
(test_nodes_object.matches_cycles): mean within 1 % of Cycles', relMSE over 4x4-pixel blocks
<= 1e-3.

- one material on six quads, each with other custom properties: a colour ("tint", a float
  array), a float ("gain"), an int on the mesh data ("level"), none at all (zero), and the
  Object Color read by its RNA path ("color");
- a Geometry Nodes scatter of a hidden tile on a 4x4 grid, each instance with its own colour
  on the instance domain (Store Named Attribute), read as Instancer attributes, times a custom
  property of the instancer object ("boost") also read through Instancer, and the tile mesh's
  custom property read as an Object attribute;
- a view layer property, a scene property and a world property read as View Layer attributes,
  over a gradient;
- particles rendering an object, with custom properties on the particle settings and the
  emitter read through Instancer.
"""

import bpy
import pytest

from test_nodes import bare_material, node_material
from test_nodes_object import emission_of, instances_on_a_grid, matches_cycles, square, top_camera


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def attribute(tree, kind, name):
    node = tree.nodes.new("ShaderNodeAttribute")
    node.attribute_type = kind
    node.attribute_name = name
    return node


def multiply(tree, a, b):
    """A Mix node multiplying colours `a` and `b` (output sockets)."""
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.blend_type = "MULTIPLY"
    mix.inputs["Factor"].default_value = 1.0
    tree.links.new(a, mix.inputs["A"])
    tree.links.new(b, mix.inputs["B"])
    return mix.outputs["Result"]


def add_value(tree, a, b):
    node = tree.nodes.new("ShaderNodeMath")
    node.operation = "ADD"
    tree.links.new(a, node.inputs[0])
    if isinstance(b, float):
        node.inputs[1].default_value = b
    else:
        tree.links.new(b, node.inputs[1])
    return node.outputs["Value"]


def object_attribute_material():
    """Colour: "tint" (grey 0.5 plus) times the Object Color; strength: "gain" + "level"/4 +
    0.3 (Fac outputs)."""
    mat, tree = node_material("Shared")
    tint = attribute(tree, "OBJECT", "tint").outputs["Color"]
    lifted = tree.nodes.new("ShaderNodeMix")
    lifted.data_type = "RGBA"
    lifted.blend_type = "ADD"
    lifted.inputs["Factor"].default_value = 1.0
    lifted.inputs["B"].default_value = (0.2, 0.2, 0.2, 1.0)
    tree.links.new(tint, lifted.inputs["A"])
    colour = multiply(tree, lifted.outputs["Result"], attribute(tree, "OBJECT", "color")
                      .outputs["Color"])
    level = tree.nodes.new("ShaderNodeMath")
    level.operation = "MULTIPLY_ADD"
    level.inputs[1].default_value = 0.25
    level.inputs[2].default_value = 0.3
    tree.links.new(attribute(tree, "OBJECT", "level").outputs["Fac"], level.inputs[0])
    strength = add_value(tree, attribute(tree, "OBJECT", "gain").outputs["Fac"],
                         level.outputs["Value"])
    emission_of(tree, colour, strength)
    return mat


@pytest.mark.slow  # renders Cycles
def test_object_attributes_of_objects_sharing_a_material(tmp_path):
    mat = object_attribute_material()
    settings = [  # (tint, gain, level on the mesh, Object Color)
        ((0.9, 0.2, 0.1), 0.5, None, (1.0, 1.0, 1.0, 1.0)),
        ((0.1, 0.7, 0.2), None, 2, (1.0, 0.8, 0.6, 1.0)),
        ((0.2, 0.3, 0.9), 1.2, 1, (0.5, 1.0, 1.0, 1.0)),
        (None, 0.8, None, (1.0, 1.0, 1.0, 1.0)),  # no tint: (0, 0, 0) plus the grey
        (None, None, None, (0.3, 0.6, 1.0, 1.0)),
        ((1.0, 1.0, 0.0), 0.1, 3, (1.0, 0.5, 1.0, 1.0)),
    ]
    for k, (tint, gain, level, colour) in enumerate(settings):
        obj = square(f"Quad {k}", mat, (-0.75 + 0.75 * (k % 3), 0.45 - 0.9 * (k // 3), 0.0),
                     0.3)
        obj.color = colour
        if tint is not None:
            obj["tint"] = tint
        if gain is not None:
            obj["gain"] = gain
        if level is not None:
            obj.data["level"] = level
    top_camera()
    matches_cycles("object attributes", bpy.context.scene, tmp_path)


def store_instance_colour(holder, name):
    """Add to `holder`'s Geometry Nodes a colour per instance (instance domain attribute
    `name`): a random colour seeded by the instance's index."""
    group = holder.modifiers["Scatter"].node_group
    nodes, links = group.nodes, group.links
    output = next(n for n in nodes if n.bl_idname == "NodeGroupOutput")
    instances = output.inputs["Geometry"].links[0].from_socket
    random = nodes.new("FunctionNodeRandomValue")
    random.data_type = "FLOAT_VECTOR"
    random.inputs["Seed"].default_value = 7
    store = nodes.new("GeometryNodeStoreNamedAttribute")
    store.data_type = "FLOAT_COLOR"
    store.domain = "INSTANCE"
    store.inputs["Name"].default_value = name
    links.new(instances, store.inputs["Geometry"])
    links.new(random.outputs["Value"], store.inputs["Value"])
    links.new(store.outputs["Geometry"], output.inputs["Geometry"])


@pytest.mark.slow  # renders Cycles
def test_instancer_attributes_of_a_geometry_nodes_scatter(tmp_path):
    mat, tree = node_material("Scattered")
    colour = multiply(tree, attribute(tree, "INSTANCER", "speckle").outputs["Color"],
                      attribute(tree, "OBJECT", "base").outputs["Color"])
    strength = add_value(tree, attribute(tree, "INSTANCER", "boost").outputs["Fac"], 0.5)
    emission_of(tree, colour, strength)
    tile = square("Tile", mat, (0.0, 0.0, -5.0), 0.15)
    tile.hide_render = True
    # Geometry Nodes instance the tile's mesh, not the object: on the mesh the Object
    # attribute finds it.
    tile.data["base"] = (1.0, 0.8, 0.9)
    holder = instances_on_a_grid("Scatter", tile, (0.0, 0.0, 0.0), 1.8, 4)
    holder["boost"] = 0.75
    store_instance_colour(holder, "speckle")
    top_camera()
    matches_cycles("instancer attributes", bpy.context.scene, tmp_path)


@pytest.mark.slow  # renders Cycles
def test_view_layer_scene_and_world_attributes(tmp_path):
    mat, tree = node_material("Layered")
    scene = bpy.context.scene
    bpy.context.view_layer["grade"] = (0.9, 0.6, 0.3, 1.0)
    scene["grade"] = (0.1, 0.1, 0.1, 1.0)  # the view layer's comes first
    scene["exposure"] = 1.5
    scene.world["tone"] = (0.4, 0.8, 1.0)
    coordinates = tree.nodes.new("ShaderNodeTexCoord")
    gradient = tree.nodes.new("ShaderNodeTexGradient")
    tree.links.new(coordinates.outputs["Generated"], gradient.inputs["Vector"])
    lit = multiply(tree, attribute(tree, "VIEW_LAYER", "grade").outputs["Color"],
                   gradient.outputs["Color"])
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.blend_type = "MIX"
    tree.links.new(gradient.outputs["Fac"], mix.inputs["Factor"])
    tree.links.new(lit, mix.inputs["A"])
    tree.links.new(attribute(tree, "VIEW_LAYER", "tone").outputs["Color"], mix.inputs["B"])
    strength = add_value(tree, attribute(tree, "VIEW_LAYER", "exposure").outputs["Fac"],
                         attribute(tree, "VIEW_LAYER", "missing").outputs["Alpha"])
    emission_of(tree, mix.outputs["Result"], strength)
    square("Plane", mat, (0.0, 0.0, 0.0), 0.9)
    top_camera()
    matches_cycles("view layer attributes", scene, tmp_path)


@pytest.mark.parametrize("kind", ["INSTANCER", "OBJECT", "VIEW_LAYER"])
def test_scene_attributes_are_evaluated_and_named_past_the_slots(kind):
    from blender_addon import node_tree, preflight
    mat, tree = node_material(f"Attribute {kind}")
    emission_of(tree, attribute(tree, kind, "tint").outputs["Color"])
    assert preflight.material_features(mat) == []
    extension, problems = node_tree.material_nodes(mat)
    assert problems == [] and extension is not None
    node = next(n for n in extension["nodes"] if n["type"] == "ShaderNodeAttribute")
    if kind == "VIEW_LAYER":
        assert node["value"] == [0.0, 0.0, 0.0, 0.0]  # found nowhere
    else:
        assert node["object_slot"] == 0
    if kind != "VIEW_LAYER":
        # Past the slots a scene carries, the material falls back and says why.
        many, tree = bare_material("Many")
        colour = attribute(tree, kind, "a0").outputs["Color"]
        for k in range(1, 9):
            colour = multiply(tree, colour, attribute(tree, kind, f"a{k}").outputs["Color"])
        emission_of(tree, colour)
        extension, problems = node_tree.material_nodes(many)
        assert extension is None
        assert any("carries 8 object and instancer attributes" in p for p in problems), problems


@pytest.mark.slow  # renders Cycles
def test_instancer_attributes_of_particles(tmp_path):
    """Particles rendering an object: Instancer reads the particle settings' custom property
    ("boost"), then the emitter's ("tint"); Object reads the instance's Object Color, which is
    the emitter's (white), not the tile's (Blender's depsgraph gives each instance its
    instancer's colour; read as the tile's: -32 %)."""
    mat, tree = node_material("Particles")
    colour = multiply(tree, attribute(tree, "INSTANCER", "tint").outputs["Color"],
                      attribute(tree, "OBJECT", "color").outputs["Color"])
    strength = add_value(tree, attribute(tree, "INSTANCER", "boost").outputs["Fac"], 0.3)
    emission_of(tree, colour, strength)
    tile = square("Tile", mat, (40.0, 0.0, 0.0), 0.12)
    tile.color = (0.5, 1.0, 0.8, 1.0)
    emitter = square("Emitter", mat, (0.0, 0.0, 0.0), 0.8)
    emitter.show_instancer_for_render = False
    emitter["tint"] = (0.9, 0.4, 0.2)
    emitter.modifiers.new("Scatter", "PARTICLE_SYSTEM")
    settings = emitter.particle_systems[0].settings
    settings.count = 12
    settings.frame_start = settings.frame_end = 1
    settings.lifetime = 1000
    settings.physics_type = "NO"
    settings.render_type = "OBJECT"
    settings.instance_object = tile
    settings.particle_size = 1.0
    settings["boost"] = 0.8
    top_camera()
    matches_cycles("particle instancer attributes", bpy.context.scene, tmp_path)
