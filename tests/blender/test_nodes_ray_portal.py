"""The Ray Portal BSDF against Cycles through the add-on: a ray that meets it goes on from the
node's Position along its Direction (unlinked: the hit point and the ray's own direction),
weighted by its Color (src/integrator/walk.rs, `through_portal`).

32x32, seen from 3 m above, a black world, path tracer, 256 spp; mean within 1 % of Cycles',
relMSE over 4x4-pixel blocks <= 1e-3 (test_nodes_object.matches_cycles):

- a tinted portal whose Position is the hit point moved 5 m along x: through it the camera sees
  an emitting checker board and a grey diffuse plane lit by a point lamp, both out of its view,
  around it an emitting floor seen directly;
- a portal with its Position unlinked and its Direction the view turned upside down (Incoming
  times (1, 1, -1)): the floor under it seen mirrored, through a second, default portal
  (straight on) beside it;
- the world's camera background (Light Path "Is Camera Ray") seen through a tinted portal and a
  tinted Transparent BSDF: still camera rays, weighted by the tints.
"""

import bpy
import pytest

import common
from test_nodes import bare_material, node_material
from test_nodes_object import emission_of, matches_cycles, square, top_camera
from test_world import mix_into_output, world_nodes

pytestmark = pytest.mark.slow  # renders Cycles


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def floor(name, centre, half, z):
    """An emitting floor: a checker on its Generated coordinates, of its own material."""
    mat, tree = bare_material(name)
    coordinates = tree.nodes.new("ShaderNodeTexCoord")
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = 3.0
    checker.inputs["Color1"].default_value = (0.9, 0.5, 0.1, 1.0)
    checker.inputs["Color2"].default_value = (0.1, 0.3, 0.8, 1.0)
    tree.links.new(coordinates.outputs["Generated"], checker.inputs["Vector"])
    emission_of(tree, checker.outputs["Color"])
    return square(name, mat, (centre[0], centre[1], z), half)


def portal_material(name, *, offset=None, flip=False, color=(1.0, 1.0, 1.0, 1.0)):
    mat, tree = bare_material(name)
    portal = tree.nodes.new("ShaderNodeBsdfRayPortal")
    portal.inputs["Color"].default_value = color
    geometry = tree.nodes.new("ShaderNodeNewGeometry")
    if offset is not None:
        moved = tree.nodes.new("ShaderNodeVectorMath")
        moved.operation = "ADD"
        moved.inputs[1].default_value = offset
        tree.links.new(geometry.outputs["Position"], moved.inputs[0])
        tree.links.new(moved.outputs["Vector"], portal.inputs["Position"])
    if flip:
        turned = tree.nodes.new("ShaderNodeVectorMath")
        turned.operation = "MULTIPLY"
        turned.inputs[1].default_value = (1.0, 1.0, -1.0)
        tree.links.new(geometry.outputs["Incoming"], turned.inputs[0])
        tree.links.new(turned.outputs["Vector"], portal.inputs["Direction"])
    tree.links.new(portal.outputs["BSDF"], tree.nodes["Material Output"].inputs["Surface"])
    return mat


def test_portal_shows_a_view_from_elsewhere(tmp_path):
    node_material("Unused")  # a fresh scene
    scene = bpy.context.scene
    floor("Floor", (0.0, 0.0), 2.5, -0.5)
    floor("Elsewhere", (5.0, 0.3), 0.6, -0.8)
    grey = common.principled("Grey", (0.6, 0.6, 0.6), roughness=1.0)
    square("Lit", grey, (5.0, -0.9, -0.8), 0.6)
    lamp = bpy.data.lights.new("Lamp", "POINT")
    lamp.energy = 60.0
    lamp.shadow_soft_size = 0.0
    lamp_object = bpy.data.objects.new("Lamp", lamp)
    lamp_object.location = (5.0, -0.9, 0.5)
    scene.collection.objects.link(lamp_object)
    square("Portal", portal_material("Portal", offset=(5.0, 0.0, 0.0),
                                     color=(0.8, 0.9, 1.0, 1.0)), (0.0, 0.0, 0.0), 0.6)
    top_camera()
    matches_cycles("ray portal elsewhere", scene, tmp_path)


def test_portal_turns_the_view_by_its_direction(tmp_path):
    node_material("Unused")
    scene = bpy.context.scene
    floor("Floor", (0.0, 0.0), 2.5, -0.5)
    square("Flipping", portal_material("Flipping", flip=True), (-0.6, 0.0, 0.0), 0.45)
    square("Straight", portal_material("Straight"), (0.6, 0.0, 0.0), 0.45)
    top_camera()
    matches_cycles("ray portal direction", scene, tmp_path)


def test_camera_background_through_a_portal_and_a_transparent_surface(tmp_path):
    node_material("Unused")
    scene = bpy.context.scene
    tree, dark = world_nodes(scene)
    seen = tree.nodes.new("ShaderNodeBackground")
    seen.inputs["Color"].default_value = (0.3, 0.6, 0.9, 1.0)
    light_path = tree.nodes.new("ShaderNodeLightPath")
    mix = mix_into_output(tree, dark, seen)
    tree.links.new(light_path.outputs["Is Camera Ray"], mix.inputs["Fac"])
    square("Portal", portal_material("Portal", color=(0.5, 1.0, 1.0, 1.0)), (-0.6, 0.0, 0.0),
           0.45)
    clear, clear_tree = bare_material("Clear")
    transparent = clear_tree.nodes.new("ShaderNodeBsdfTransparent")
    transparent.inputs["Color"].default_value = (1.0, 0.5, 0.25, 1.0)
    clear_tree.links.new(transparent.outputs["BSDF"],
                         clear_tree.nodes["Material Output"].inputs["Surface"])
    square("Clear", clear, (0.6, 0.0, 0.0), 0.45)
    top_camera()
    matches_cycles("camera background through a portal", scene, tmp_path)
