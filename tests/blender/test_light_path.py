"""Light Path's outputs as Cycles defines them, against Cycles through the add-on.

Every scene is 32x32, a 2 m floor seen from 3 m above (test_nodes.py's `plane_scene`), lit
criterion (mean within 2 %, relMSE <= 0.01, `cycles_compare.compare`):

- the classic tricks: a lamp the camera sees through (Mix Shader of an Emission and a
  Transparent BSDF by Is Camera Ray), which still lights the floor; a box that casts no shadow
  (Mix Shader of a red Principled BSDF and a Transparent BSDF by Is Shadow Ray), by the path
  tracer and by photon mapping (both light the floor with the same light sampler and shadow
  rays); a lamp whose emission stops after one bounce (Ray Depth < 1.5: the camera sees it and
  it lights the floor and a box directly, but no bounce carries its light further);
- each of the other outputs (Is Diffuse / Glossy / Singular / Reflection / Transmission Ray,
  Ray Depth, Diffuse / Glossy / Transparent / Transmission Depth) choosing the floor's colour,
  seen straight, through a Transparent quad, a smooth and a rough Glass quad, and bounced onto
  a white box, under a white world; the floor is not emissive, so each output is read only
  where a ray meets it.

A tree reading those outputs makes `auto` choose the path tracer, and an explicit photon method
warns that it renders them differently (checked here on the command line's output).
"""

import math

import bpy
import pytest

import common
from cycles_compare import compare
from test_nodes import emission_into_output, lamp_over_floor, node_material, plane_scene

SIZE = 32


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def shader_mix(tree, fac_output, first, second):
    """A Mix Shader of `first` (factor 0) and `second` (factor 1) by Light Path's `fac_output`,
    into the Material Output."""
    light_path = tree.nodes.new("ShaderNodeLightPath")
    mix = tree.nodes.new("ShaderNodeMixShader")
    tree.links.new(light_path.outputs[fac_output], mix.inputs["Fac"])
    tree.links.new(first, mix.inputs[1])
    tree.links.new(second, mix.inputs[2])
    tree.links.new(mix.outputs["Shader"], tree.nodes["Material Output"].inputs["Surface"])


def white_box():
    """A white diffuse box on the floor, turned 30 degrees."""
    mat = common.principled("Box", (0.8, 0.8, 0.8), roughness=1.0)
    return common.box("Box", (0.4, 0.4, 0.4), mat, (0.55, -0.5, 0.0), 30.0)


@pytest.mark.slow
def test_lamp_seen_through_by_the_camera(tmp_path):
    """A lamp whose camera rays pass (Transparent) and whose other rays see its emission: the
    camera sees the floor under it, lit by it."""
    mat, tree = node_material("Invisible lamp")
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (1.0, 0.6, 0.3, 1.0)
    emission.inputs["Strength"].default_value = 6.0
    transparent = tree.nodes.new("ShaderNodeBsdfTransparent")
    shader_mix(tree, "Is Camera Ray", emission.outputs["Emission"],
               transparent.outputs["BSDF"])
    scene = lamp_over_floor(mat, 0.3, 0.6)
    compare("lamp seen through", scene, tmp_path, photon_spp=256, cycles_spp=512)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_box_without_a_shadow(tmp_path, method):
    """A red box that shadow rays pass (Is Shadow Ray -> Transparent BSDF) on a floor under a
    sun: no shadow, as in Cycles; without transparent shadows the floor beside it is dark."""
    mat, tree = node_material("Shadowless")
    red = tree.nodes.new("ShaderNodeBsdfPrincipled")
    red.inputs["Base Color"].default_value = (0.8, 0.1, 0.05, 1.0)
    transparent = tree.nodes.new("ShaderNodeBsdfTransparent")
    shader_mix(tree, "Is Shadow Ray", red.outputs["BSDF"], transparent.outputs["BSDF"])
    floor = common.principled("Floor", (0.7, 0.7, 0.7), roughness=1.0)
    scene, _ = plane_scene(floor)
    common.box("Box", (0.6, 0.6, 0.6), mat, (0.2, 0.1, 0.0), 20.0)
    common.light("Sun", "SUN", (0, 0, 5), (40.0, 10.0, 0.0), energy=3.0, angle=0.05)
    compare(f"box without shadow {method.lower()}", scene, tmp_path, photon_spp=256,
            cycles_spp=512, method=method)


@pytest.mark.slow
def test_emission_only_up_to_one_bounce(tmp_path):
    """A lamp emitting for Ray Depth < 1.5 over a floor beside a white wall: the camera sees it
    (depth 0) and it lights what it sees (light samples and bounce rays both read depth 1),
    but light bounced once more reads depth 2 and is dark. Cycles and Photon render direct
    light only; counting every ray as depth 0 adds the indirect light."""
    mat, tree = node_material("One bounce")
    light_path = tree.nodes.new("ShaderNodeLightPath")
    below = tree.nodes.new("ShaderNodeMath")
    below.operation = "LESS_THAN"
    below.inputs[1].default_value = 1.5
    tree.links.new(light_path.outputs["Ray Depth"], below.inputs[0])
    emission = emission_into_output(tree, below.outputs["Value"], strength=8.0)
    emission.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    scene = lamp_over_floor(mat, 0.3, 0.5)
    wall = common.principled("Wall", (0.9, 0.9, 0.9), roughness=1.0)
    common.quad("Wall", [(0.5, -1, 0), (0.5, 1, 0), (0.5, 1, 1.2), (0.5, -1, 1.2)], wall)
    compare("emission up to one bounce", scene, tmp_path, photon_spp=512, cycles_spp=1024)


OUTPUTS = ["Is Diffuse Ray", "Is Glossy Ray", "Is Singular Ray", "Is Reflection Ray",
           "Is Transmission Ray", "Ray Depth", "Diffuse Depth", "Glossy Depth",
           "Transparent Depth", "Transmission Depth"]


def see_through(name, corners, shader, **inputs):
    """A quad of a lone BSDF node of type `shader` with `inputs`."""
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    bsdf = tree.nodes.new(shader)
    for key, value in inputs.items():
        bsdf.inputs[key].default_value = value
    tree.links.new(bsdf.outputs["BSDF"], tree.nodes["Material Output"].inputs["Surface"])
    return common.quad(name, corners, mat)


@pytest.mark.slow
@pytest.mark.parametrize("output", OUTPUTS)
def test_output_chooses_the_floor_colour(tmp_path, output):
    """The floor's base colour is Mix(orange, blue) by `output` / 2, seen directly, through a
    Transparent quad (left), a smooth Glass quad (top right) and a rough one (bottom right), and
    bounced onto a white box; a white world lights it."""
    scene = floor_scene(output)
    compare(f"floor by {output.lower()}", scene, tmp_path, photon_spp=512, cycles_spp=1024)


def floor_scene(output):
    """The scene of `test_output_chooses_the_floor_colour`."""
    common.reset_scene(SIZE, SIZE)
    floor = bpy.data.materials.new("Floor by " + output)
    if bpy.app.version < (5, 0, 0):
        floor.use_nodes = True
    tree = floor.node_tree
    bsdf = tree.nodes["Principled BSDF"]
    bsdf.inputs["Roughness"].default_value = 0.6
    light_path = tree.nodes.new("ShaderNodeLightPath")
    half = tree.nodes.new("ShaderNodeMath")
    half.operation = "MULTIPLY"
    half.use_clamp = True
    half.inputs[1].default_value = 0.5
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.inputs["A"].default_value = (0.9, 0.4, 0.1, 1.0)
    mix.inputs["B"].default_value = (0.1, 0.3, 0.9, 1.0)
    tree.links.new(light_path.outputs[output], half.inputs[0])
    tree.links.new(half.outputs["Value"], mix.inputs["Factor"])
    tree.links.new(mix.outputs["Result"], bsdf.inputs["Base Color"])
    scene, _ = plane_scene(floor)
    see_through("Transparent", [(-1, -1, 0.5), (0, -1, 0.5), (0, 1, 0.5), (-1, 1, 0.5)],
                "ShaderNodeBsdfTransparent", Color=(0.9, 0.9, 0.9, 1.0))
    see_through("Smooth glass", [(0, 0, 0.5), (1, 0, 0.5), (1, 1, 0.5), (0, 1, 0.5)],
                "ShaderNodeBsdfGlass", Roughness=0.0, IOR=1.45)
    see_through("Rough glass", [(0, -1, 0.5), (1, -1, 0.5), (1, 0, 0.5), (0, 0, 0.5)],
                "ShaderNodeBsdfGlass", Roughness=0.3, IOR=1.45)
    white_box()
    # A sun's disc seen through the smooth glass would be a caustic of rare, bright paths.
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    return scene


def test_photon_method_warns_and_auto_picks_the_path_tracer(tmp_path):
    """A tree reading Diffuse Depth: `auto` renders it with the path tracer (the plan says
    why), and `--method photon` warns that it differs."""
    import subprocess

    from helpers import photon_binary

    mat, tree = node_material("Depth colour")
    light_path = tree.nodes.new("ShaderNodeLightPath")
    emission_into_output(tree, light_path.outputs["Diffuse Depth"])
    scene, _ = plane_scene(mat)
    common.light("Sun", "SUN", (0, 0, 5), energy=3.0)
    from blender_addon import export
    glb = tmp_path / "depth.glb"
    export.export_in_process(glb, "blender_addon")
    info = subprocess.run([str(photon_binary()), "info", str(glb)], capture_output=True,
                          text=True, check=True).stdout
    assert "auto method: path tracer (node trees read Light Path" in info, info
    run = subprocess.run([str(photon_binary()), "render", str(glb), "-o",
                          str(tmp_path / "out.exr"), "--spp", "1", "--width", "8",
                          "--height", "8", "--method", "photon", "--progress", "none"],
                         capture_output=True, text=True, check=True)
    assert "read Light Path's ray kind or depths" in run.stderr, run.stderr
    assert "Depth colour" in run.stderr, run.stderr
