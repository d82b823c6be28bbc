"""Converters and Add Shader against Cycles, each fed by a texture so its input
varies over the plane, wired into an Emission shader (relMSE <= 1e-3, `test_nodes.py`'s
criterion for a node's value itself):

- Clamp of a Noise texture's Fac: Min Max, Range with Min above Max (Blender swaps them),
  and Min Max with Min above Max (Max everywhere);
- Invert (factor 0.7) and Gamma (2.2, and 0.45) of a Noise texture's Color;
- Separate Color into Combine Color, RGB (channels permuted) and HSV (hue moved by Math);
- Add Shader of two Emissions (a noise-driven one and a constant one);

and Add Shader of a Diffuse and a Glossy BSDF under a sun (the lit criterion: mean within 2 %,
relMSE <= 0.01), whose sum Cycles renders.
"""

import pytest

from cycles_compare import compare
from test_nodes import emission_matches, lit_scene, node_material, plane_scene

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def noise(tree, scale=3.0):
    """A Noise texture on Generated coordinates (its default), values varying over the plane."""
    node = tree.nodes.new("ShaderNodeTexNoise")
    node.inputs["Scale"].default_value = scale
    node.inputs["Detail"].default_value = 2.0
    return node


@pytest.mark.parametrize("clamp_type", ["MINMAX", "RANGE"])
def test_clamp_of_noise_into_emission(tmp_path, clamp_type):
    mat, tree = node_material(f"Clamp {clamp_type}")
    source = noise(tree)
    clamp = tree.nodes.new("ShaderNodeClamp")
    clamp.clamp_type = clamp_type
    # Min above Max: Range swaps them, Min Max gives Max wherever the value is below Min.
    lo, hi = (0.42, 0.58) if clamp_type == "MINMAX" else (0.58, 0.42)
    clamp.inputs["Min"].default_value = lo
    clamp.inputs["Max"].default_value = hi
    tree.links.new(source.outputs["Fac"], clamp.inputs["Value"])
    emission_matches(f"clamp {clamp_type.lower()} emission", mat, tree,
                     clamp.outputs["Result"], tmp_path, strength=2.0)


def test_clamp_min_above_max_into_emission(tmp_path):
    """Min Max with Min above Max is Blender's min(max(v, Min), Max): Max everywhere (unlike
    Range, which swaps them), here the factor of a Mix."""
    mat, tree = node_material("Clamp crossed")
    source = noise(tree)
    clamp = tree.nodes.new("ShaderNodeClamp")
    clamp.inputs["Min"].default_value = 0.6
    clamp.inputs["Max"].default_value = 0.3
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.inputs["A"].default_value = (0.9, 0.2, 0.1, 1.0)
    mix.inputs["B"].default_value = (0.1, 0.3, 0.9, 1.0)
    tree.links.new(source.outputs["Fac"], clamp.inputs["Value"])
    tree.links.new(clamp.outputs["Result"], mix.inputs["Factor"])
    emission_matches("clamp crossed emission", mat, tree, mix.outputs["Result"], tmp_path)


def test_invert_of_noise_into_emission(tmp_path):
    mat, tree = node_material("Invert")
    source = noise(tree)
    invert = tree.nodes.new("ShaderNodeInvert")
    invert.inputs["Fac"].default_value = 0.7
    tree.links.new(source.outputs["Color"], invert.inputs["Color"])
    emission_matches("invert emission", mat, tree, invert.outputs["Color"], tmp_path)


@pytest.mark.parametrize("gamma", [2.2, 0.45])
def test_gamma_of_noise_into_emission(tmp_path, gamma):
    mat, tree = node_material(f"Gamma {gamma}")
    source = noise(tree)
    node = tree.nodes.new("ShaderNodeGamma")
    node.inputs["Gamma"].default_value = gamma
    tree.links.new(source.outputs["Color"], node.inputs["Color"])
    emission_matches(f"gamma {gamma} emission", mat, tree, node.outputs["Color"], tmp_path,
                     strength=1.5)


def test_separate_combine_rgb_permuted_into_emission(tmp_path):
    mat, tree = node_material("Separate RGB")
    source = noise(tree)
    separate = tree.nodes.new("ShaderNodeSeparateColor")
    combine = tree.nodes.new("ShaderNodeCombineColor")
    tree.links.new(source.outputs["Color"], separate.inputs["Color"])
    tree.links.new(separate.outputs["Blue"], combine.inputs["Red"])
    tree.links.new(separate.outputs["Red"], combine.inputs["Green"])
    tree.links.new(separate.outputs["Green"], combine.inputs["Blue"])
    emission_matches("separate combine rgb emission", mat, tree, combine.outputs["Color"],
                     tmp_path)


def test_separate_combine_hsv_hue_moved_into_emission(tmp_path):
    """Hue x 0.5 + 0.3 (staying in [0.3, 0.8]), saturation squared, value kept."""
    mat, tree = node_material("Separate HSV")
    source = noise(tree)
    separate = tree.nodes.new("ShaderNodeSeparateColor")
    separate.mode = "HSV"
    combine = tree.nodes.new("ShaderNodeCombineColor")
    combine.mode = "HSV"
    hue = tree.nodes.new("ShaderNodeMath")
    hue.operation = "MULTIPLY_ADD"
    hue.inputs[1].default_value = 0.5
    hue.inputs[2].default_value = 0.3
    sat = tree.nodes.new("ShaderNodeMath")
    sat.operation = "POWER"
    sat.inputs[1].default_value = 0.5
    tree.links.new(source.outputs["Color"], separate.inputs["Color"])
    tree.links.new(separate.outputs["Red"], hue.inputs[0])
    tree.links.new(separate.outputs["Green"], sat.inputs[0])
    tree.links.new(hue.outputs["Value"], combine.inputs["Red"])
    tree.links.new(sat.outputs["Value"], combine.inputs["Green"])
    tree.links.new(separate.outputs["Blue"], combine.inputs["Blue"])
    emission_matches("separate combine hsv emission", mat, tree, combine.outputs["Color"],
                     tmp_path, strength=1.5)


def test_add_shader_of_two_emissions(tmp_path):
    mat, tree = node_material("Add emissions")
    source = noise(tree)
    first = tree.nodes.new("ShaderNodeEmission")
    second = tree.nodes.new("ShaderNodeEmission")
    second.inputs["Color"].default_value = (0.1, 0.2, 0.6, 1.0)
    second.inputs["Strength"].default_value = 0.5
    add = tree.nodes.new("ShaderNodeAddShader")
    tree.links.new(source.outputs["Color"], first.inputs["Color"])
    tree.links.new(first.outputs["Emission"], add.inputs[0])
    tree.links.new(second.outputs["Emission"], add.inputs[1])
    tree.links.new(add.outputs["Shader"], tree.nodes["Material Output"].inputs["Surface"])
    scene, _ = plane_scene(mat)
    compare("add shader emissions", scene, tmp_path, photon_spp=512, cycles_spp=512,
            relmse_max=1e-3)


@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_add_shader_of_diffuse_and_glossy_lit(tmp_path, method):
    """Add Shader sums its BSDFs: a dim red Diffuse plus a grey Glossy (their sum reflects
    less than all the light), textured by a Noise into the Diffuse colour; by the path tracer
    and by photon mapping (photons scatter through the same doubled pick)."""
    mat, tree = node_material("Add lit")
    source = noise(tree)
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.05, 0.02, 0.01, 1.0)
    ramp.color_ramp.elements[1].color = (0.5, 0.15, 0.1, 1.0)
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    glossy = tree.nodes.new("ShaderNodeBsdfGlossy")
    glossy.inputs["Color"].default_value = (0.35, 0.35, 0.35, 1.0)
    glossy.inputs["Roughness"].default_value = 0.4
    add = tree.nodes.new("ShaderNodeAddShader")
    tree.links.new(source.outputs["Fac"], ramp.inputs["Fac"])
    tree.links.new(ramp.outputs["Color"], diffuse.inputs["Color"])
    tree.links.new(diffuse.outputs["BSDF"], add.inputs[0])
    tree.links.new(glossy.outputs["BSDF"], add.inputs[1])
    tree.links.new(add.outputs["Shader"], tree.nodes["Material Output"].inputs["Surface"])
    compare(f"add shader diffuse glossy {method.lower()}", lit_scene(mat), tmp_path,
            photon_spp=256, cycles_spp=256, method=method)
