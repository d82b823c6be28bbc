"""The Gabor Texture (Blender 4.3+) against Cycles through the add-on: its Value, Phase and
Intensity, 2D and 3D, partly anisotropic, on a plane's Generated coordinates (the texture's
implicit Vector), wired into an Emission shader (32x32, a black world: the image is the
texture's values). Mean within 1 % of Cycles', relMSE over 4x4-pixel blocks <= 1e-3.
"""

import math

import pytest

from test_nodes import node_material, plane_scene
from test_nodes_object import matches_cycles

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


@pytest.mark.parametrize("kind", ["2D", "3D"])
def test_gabor_value_phase_intensity_into_emission(tmp_path, kind):
    mat, tree = node_material(f"Gabor {kind}")
    nodes, links = tree.nodes, tree.links
    gabor = nodes.new("ShaderNodeTexGabor")
    gabor.gabor_type = kind
    gabor.inputs["Scale"].default_value = 3.0
    gabor.inputs["Frequency"].default_value = 2.5
    gabor.inputs["Anisotropy"].default_value = 0.6
    by_id = {s.identifier: s for s in gabor.inputs}  # both are named "Orientation"
    by_id["Orientation 2D"].default_value = math.radians(30.0)
    by_id["Orientation 3D"].default_value = (0.3, 0.8, 0.5)
    combine = nodes.new("ShaderNodeCombineXYZ")
    for output, axis in (("Value", "X"), ("Phase", "Y"), ("Intensity", "Z")):
        links.new(gabor.outputs[output], combine.inputs[axis])
    emission = nodes.new("ShaderNodeEmission")
    links.new(combine.outputs["Vector"], emission.inputs["Color"])
    links.new(emission.outputs["Emission"], nodes["Material Output"].inputs["Surface"])
    scene, _ = plane_scene(mat)
    matches_cycles(f"gabor {kind}", scene, tmp_path)
