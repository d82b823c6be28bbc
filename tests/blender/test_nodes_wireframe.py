"""The Wireframe node against Cycles through the add-on: a 2 m grid of 4x4 quads (drawn as
Cycles draws them: each triangle's edges, the quads' diagonals too), turned 30° away from a
camera 3 m above (so the pixels' footprint varies), its Fac mixing two emission colours, Size
in scene units and in pixels. 32x32, a black world; mean within 1 % of Cycles', relMSE over
4x4-pixel blocks <= 1e-3.
"""

import math

import bpy
import pytest

from test_nodes import node_material
from test_nodes_object import matches_cycles, top_camera

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


@pytest.mark.parametrize("pixel_size, size", [(False, 0.06), (True, 1.5)])
def test_wireframe_of_a_tilted_grid_into_emission(tmp_path, pixel_size, size):
    mat, tree = node_material("Wireframe")
    nodes, links = tree.nodes, tree.links
    wire = nodes.new("ShaderNodeWireframe")
    wire.use_pixel_size = pixel_size
    wire.inputs["Size"].default_value = size
    mix = nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.inputs["A"].default_value = (0.05, 0.1, 0.3, 1.0)
    mix.inputs["B"].default_value = (1.0, 0.8, 0.2, 1.0)
    links.new(wire.outputs["Fac"], mix.inputs["Factor"])
    emission = nodes.new("ShaderNodeEmission")
    links.new(mix.outputs["Result"], emission.inputs["Color"])
    links.new(emission.outputs["Emission"], nodes["Material Output"].inputs["Surface"])
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=5, y_subdivisions=5, size=2.0,
                                    rotation=(math.radians(30.0), 0.0, 0.0))
    grid = bpy.context.active_object
    grid.data.materials.append(mat)
    top_camera()
    unit = "pixels" if pixel_size else "m"
    matches_cycles(f"wireframe {size} {unit}", bpy.context.scene, tmp_path)
