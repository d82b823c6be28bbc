"""Point clouds and hair curves as Cycles renders them: a Point Cloud object's points as spheres
of their radius (exported as instances of one sphere) and a Curves object's hair as round
tubes of its radius (blender_addon/points_curves.py). Each scene is rendered by Cycles and by
Photon through the add-on at 48x32: mean within 2 % and relMSE <= 0.01.
"""

import math
import random

import bpy
import pytest

import common
from cycles_compare import compare

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def lit_floor():
    """A grey floor under a sun and a dim grey world, the camera looking down at it."""
    scene = common.reset_scene(48, 32)
    background = scene.world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    background.inputs["Strength"].default_value = 0.3
    grey = common.principled("Grey", (0.5, 0.5, 0.5))
    common.quad("Floor", [(-4, -4, 0), (4, -4, 0), (4, 4, 0), (-4, 4, 0)], grey)
    common.light("Sun", "SUN", (0, 0, 5), (35.0, 0.0, 30.0), energy=3.0)
    common.camera("Camera", (0.0, -3.2, 2.4), (55.0, 0.0, 0.0), 50.0)
    return scene


def point_cloud(name, count, material, seed=3):
    """A Point Cloud object whose points (made by a Geometry Nodes Points node) lie at random
    in a box over the floor, with random radii from 0.06 to 0.16."""
    obj = bpy.data.objects.new(name, bpy.data.pointclouds.new(name))
    bpy.context.scene.collection.objects.link(obj)
    tree = bpy.data.node_groups.new(f"{name} points", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    points = tree.nodes.new("GeometryNodePoints")
    points.inputs["Count"].default_value = count
    position = tree.nodes.new("FunctionNodeRandomValue")
    position.data_type = "FLOAT_VECTOR"
    position.inputs["Min"].default_value = (-1.0, -0.8, 0.2)
    position.inputs["Max"].default_value = (1.0, 0.8, 1.0)
    position.inputs["Seed"].default_value = seed
    radius = tree.nodes.new("FunctionNodeRandomValue")
    radius.data_type = "FLOAT"
    radius.inputs[2].default_value = 0.06  # Min (float)
    radius.inputs[3].default_value = 0.16  # Max (float)
    tree.links.new(position.outputs["Value"], points.inputs["Position"])
    tree.links.new(radius.outputs[1], points.inputs["Radius"])
    # Geometry made by nodes has only the materials its nodes give it.
    set_material = tree.nodes.new("GeometryNodeSetMaterial")
    set_material.inputs["Material"].default_value = material
    tree.links.new(points.outputs["Points"], set_material.inputs["Geometry"])
    tree.links.new(set_material.outputs["Geometry"],
                   tree.nodes.new("NodeGroupOutput").inputs[0])
    obj.modifiers.new("points", "NODES").node_group = tree
    return obj


def hair(name, material, strands=120, segments=6, radius=0.02, seed=5):
    """A Curves object: `strands` curved hairs rising from a 1.6 m patch of the floor, each of
    `segments` + 1 points, radius `radius` at the root thinning to half at the tip."""
    curves = bpy.data.hair_curves.new(name)
    curves.add_curves([segments + 1] * strands)
    rng = random.Random(seed)
    positions, radii = [], []
    for _ in range(strands):
        x, y = rng.uniform(-0.8, 0.8), rng.uniform(-0.8, 0.8)
        lean = rng.uniform(0.0, 2.0 * math.pi)
        for k in range(segments + 1):
            t = k / segments
            bend = 0.35 * t * t
            positions.append((x + bend * math.cos(lean), y + bend * math.sin(lean), 0.9 * t))
            radii.append(radius * (1.0 - 0.5 * t))
    curves.position_data.foreach_set("vector", [c for p in positions for c in p])
    attribute = curves.attributes.new("radius", "FLOAT", "POINT")
    attribute.data.foreach_set("value", radii)
    curves.materials.append(material)
    obj = bpy.data.objects.new(name, curves)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def test_point_cloud_as_spheres(tmp_path):
    scene = lit_floor()
    point_cloud("Cloud", 40, common.principled("Orange", (0.8, 0.4, 0.1)))
    compare("point cloud", scene, tmp_path)


@pytest.mark.parametrize("shape", ["RIBBONS", "THICK"])
def test_hair_curves_as_tubes(tmp_path, shape):
    """Against Cycles' two curve shapes: rounded ribbons (the default) and 3D curves."""
    scene = lit_floor()
    scene.cycles_curves.shape = shape
    hair("Fur", common.principled("Brown", (0.5, 0.3, 0.15), roughness=0.6))
    compare(f"hair curves ({shape.lower()})", scene, tmp_path)


@pytest.mark.parametrize("show_emitter", [True, False])
def test_hair_particles_as_tubes(tmp_path, show_emitter):
    """A hair particle system on a raised patch (parents and interpolated children, a
    root-to-tip taper with a strand shape), read as Cycles reads it; with Show Emitter off the
    patch is not rendered."""
    scene = lit_floor()
    blue = common.principled("Patch", (0.05, 0.1, 0.5))
    patch = common.quad("Patch", [(-0.8, -0.8, 0.1), (0.8, -0.8, 0.1), (0.8, 0.8, 0.1),
                                  (-0.8, 0.8, 0.1)], blue)
    patch.show_instancer_for_render = show_emitter
    patch.data.materials.append(common.principled("Fur", (0.6, 0.25, 0.1), roughness=0.6))
    patch.modifiers.new("Fur", "PARTICLE_SYSTEM")
    settings = patch.particle_systems[0].settings
    settings.type = "HAIR"
    settings.count = 60
    settings.hair_length = 0.7
    settings.material = 2
    settings.child_type = "INTERPOLATED"
    settings.rendered_child_count = 3
    settings.radius_scale = 0.04
    settings.root_radius = 1.0
    settings.tip_radius = 0.3
    settings.shape = -0.3
    settings.use_close_tip = False
    patch.particle_systems[0].seed = 4
    compare(f"hair particles (emitter {'shown' if show_emitter else 'hidden'})", scene,
            tmp_path)
