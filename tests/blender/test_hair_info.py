"""The Hair Info node (Blender's Curves Info) against Cycles through the add-on: the hair tubes
carry the intercept, length, thickness and curve index as vertex attributes
(blender_addon/points_curves.py) that the renderer's Hair Info reads.

Each scene, 48x48, is emission only (a black world), seen from the front by a camera 6 m away:
a curtain of upright strands (Curves objects, evenly spaced points, so a Catmull-Rom curve's
values between them are the linear ones Cycles interpolates), three staggered rows deep so that
which strand is in front matters little. The image is the node's values themselves: mean within
1 % of Cycles', relMSE over 4x4-pixel blocks <= 1e-3.

- Intercept through a Color Ramp, with a quad behind the strands of the same material (no
  hair: Intercept reads 0 there, the ramp's first colour);
- Random through a Color Ramp (Cycles' hash of each curve's index);
- Length and Thickness (strands of random lengths and radii) as the colour's red and green,
  Is Strand as its blue (the quad behind: black).
- Random on the strands of two hair particle systems of one emitter (numbered over both);
- Tangent Normal (the direction to the viewer made perpendicular to the strand) as a colour.
"""

import random

import bpy
import numpy as np
import pytest

import common
from cycles_compare import compare
from helpers import rel_mse
from test_nodes import node_material
from test_volumes import block_means

pytestmark = pytest.mark.slow  # renders Cycles

SIZE = 48
MEAN_TOL = 0.01
BLOCK_RELMSE_MAX = 1e-3


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def curtain(material, *, lengths=(1.6, 1.6), radii=(0.03, 0.03), seed=7, rows=3,
            per_row=40, segments=6):
    """A Curves object: `rows` rows of `per_row` upright strands over x in [-1.2, 1.2] (the
    rows staggered, 0.1 m apart in depth), each of `segments` + 1 evenly spaced points, its
    length and radius drawn from `lengths` and `radii`, thinning to 60 % at the tip."""
    rng = random.Random(seed)
    curves = bpy.data.hair_curves.new("Curtain")
    curves.add_curves([segments + 1] * (rows * per_row))
    positions, point_radii = [], []
    spacing = 2.4 / per_row
    for row in range(rows):
        for k in range(per_row):
            x = -1.2 + (k + 0.5 + row / rows) * spacing
            length, radius = rng.uniform(*lengths), rng.uniform(*radii)
            lean = rng.uniform(-0.05, 0.05)
            for s in range(segments + 1):
                t = s / segments
                positions += [x + lean * t, 0.1 * row, -0.9 + length * t]
                point_radii.append(radius * (1.0 - 0.4 * t))
    curves.position_data.foreach_set("vector", positions)
    curves.attributes.new("radius", "FLOAT", "POINT").data.foreach_set("value", point_radii)
    curves.materials.append(material)
    return common.link(bpy.data.objects.new("Curtain", curves))


def backdrop(material):
    """A quad of `material` behind the strands (a mesh: no hair)."""
    common.quad("Backdrop", [(-1.5, 0.6, -1.2), (1.5, 0.6, -1.2), (1.5, 0.6, 1.2),
                             (-1.5, 0.6, 1.2)], material)


def front_camera():
    common.camera("Camera", (0.0, -6.0, 0.0), (90.0, 0.0, 0.0), 26.0)


def ramp(tree, socket, colors):
    node = tree.nodes.new("ShaderNodeValToRGB")
    elements = node.color_ramp.elements
    elements[0].color, elements[1].color = colors[0], colors[-1]
    for position, color in zip((0.5,), colors[1:-1]):
        elements.new(position).color = color
    tree.links.new(socket, node.inputs["Fac"])
    return node.outputs["Color"]


def emission(tree, color):
    node = tree.nodes.new("ShaderNodeEmission")
    tree.links.new(color, node.inputs["Color"])
    tree.links.new(node.outputs["Emission"], tree.nodes["Material Output"].inputs["Surface"])


def matches_cycles(name, tmp_path):
    scene = bpy.context.scene
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.cycles_curves.shape = "THICK"
    img, ref = compare(name, scene, tmp_path, photon_spp=256, cycles_spp=256,
                       mean_tol=MEAN_TOL, relmse_max=1.0)
    blocks = rel_mse(block_means(img), block_means(ref))
    print(f"{name}: 4x4-block relMSE {blocks:.6f}")
    assert np.isfinite(img).all()
    assert blocks <= BLOCK_RELMSE_MAX, f"{name}: 4x4-block relMSE {blocks:.6f}"


def test_intercept_through_a_color_ramp(tmp_path):
    mat, tree = node_material("Intercept")
    info = tree.nodes.new("ShaderNodeHairInfo")
    emission(tree, ramp(tree, info.outputs["Intercept"],
                        [(0.1, 0.2, 0.9, 1.0), (0.9, 0.2, 0.3, 1.0), (1.0, 0.9, 0.2, 1.0)]))
    curtain(mat)
    backdrop(mat)
    front_camera()
    matches_cycles("hair intercept", tmp_path)


def test_random_through_a_color_ramp(tmp_path):
    mat, tree = node_material("Random")
    info = tree.nodes.new("ShaderNodeHairInfo")
    emission(tree, ramp(tree, info.outputs["Random"],
                        [(0.05, 0.1, 0.8, 1.0), (0.2, 0.9, 0.3, 1.0), (1.0, 0.5, 0.1, 1.0)]))
    curtain(mat, rows=2, per_row=24, radii=(0.045, 0.045))
    front_camera()
    matches_cycles("hair random", tmp_path)


def test_length_thickness_and_is_strand(tmp_path):
    mat, tree = node_material("Length")
    info = tree.nodes.new("ShaderNodeHairInfo")
    combine = tree.nodes.new("ShaderNodeCombineColor")
    half = tree.nodes.new("ShaderNodeMath")
    half.operation = "MULTIPLY"
    half.inputs[1].default_value = 0.5
    tree.links.new(info.outputs["Length"], half.inputs[0])
    tree.links.new(half.outputs[0], combine.inputs["Red"])
    wide = tree.nodes.new("ShaderNodeMath")
    wide.operation = "MULTIPLY"
    wide.inputs[1].default_value = 10.0
    tree.links.new(info.outputs["Thickness"], wide.inputs[0])
    tree.links.new(wide.outputs[0], combine.inputs["Green"])
    tree.links.new(info.outputs["Is Strand"], combine.inputs["Blue"])
    emission(tree, combine.outputs["Color"])
    curtain(mat, lengths=(0.6, 1.9), radii=(0.02, 0.05))
    backdrop(mat)
    front_camera()
    matches_cycles("hair length", tmp_path)


def test_tangent_normal_against_cycles(tmp_path):
    """Tangent Normal (the view made perpendicular to the fibre) as a colour, 0.5 + v/2, on
    the curtain and on the quad behind it (no hair: zero, grey)."""
    from blender_addon import preflight
    mat, tree = node_material("Tangent normal")
    info = tree.nodes.new("ShaderNodeHairInfo")
    mapped = tree.nodes.new("ShaderNodeVectorMath")
    mapped.operation = "MULTIPLY_ADD"
    mapped.inputs[1].default_value = (0.5, 0.5, 0.5)
    mapped.inputs[2].default_value = (0.5, 0.5, 0.5)
    tree.links.new(info.outputs["Tangent Normal"], mapped.inputs[0])
    emission(tree, mapped.outputs["Vector"])
    assert preflight.material_features(mat) == []
    curtain(mat, lengths=(0.6, 1.9))
    backdrop(mat)
    front_camera()
    matches_cycles("hair tangent normal", tmp_path)


def test_random_on_particle_hair_of_two_systems(tmp_path):
    """Random on the strands of two hair particle systems of one emitter (hidden): Cycles
    numbers the curves over both systems."""
    mat, tree = node_material("Particle random")
    info = tree.nodes.new("ShaderNodeHairInfo")
    emission(tree, ramp(tree, info.outputs["Random"],
                        [(0.05, 0.1, 0.8, 1.0), (0.2, 0.9, 0.3, 1.0), (1.0, 0.5, 0.1, 1.0)]))
    patch = common.quad("Patch", [(-1.2, -0.3, -0.9), (1.2, -0.3, -0.9), (1.2, 0.3, -0.9),
                                  (-1.2, 0.3, -0.9)], mat)
    patch.show_instancer_for_render = False
    for k, count in enumerate((150, 90)):
        patch.modifiers.new(f"Fur {k}", "PARTICLE_SYSTEM")
        system = patch.particle_systems[k]
        system.seed = 3 + k
        settings = system.settings
        settings.type = "HAIR"
        settings.count = count
        settings.hair_length = 1.2 + 0.4 * k
        settings.radius_scale = 0.08
        settings.root_radius = 1.0
        settings.tip_radius = 0.6
        settings.use_close_tip = False
    front_camera()
    matches_cycles("particle hair random", tmp_path)
