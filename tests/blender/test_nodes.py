"""Shader node trees evaluated by Photon (PHOTON_material_nodes), against Cycles.

Each scene is built with bpy and rendered by Cycles and by Photon through the add-on at 32x32:

- a texture wired into an Emission shader on a plane seen straight on (the image is the
  texture's values themselves): Checker on Generated coordinates; Noise (fBm) on Object
  coordinates through a Mapping and a Color Ramp; a Gradient on UV coordinates through Math,
  Map Range and a Mix (Multiply) with vertex colours. relMSE <= 1e-3;
- lit materials under a sun: a Checker into a Principled BSDF's Base Color; a Mix Shader of a
  Diffuse and a Glossy BSDF driven by a Noise texture; a Noise through a Bump into the Normal;
  one tree mixing many (Noise, Color Ramp, vertex colours, Bump, Voronoi, Mix Shader): mean
  within 2 %, relMSE <= 0.01.

Also: Voronoi with Hue/Saturation and an Overlay Mix, Wave rings into Bright/Contrast, an 8x8
PNG through the Image Texture node, and Layer Weight, Fresnel and Reflection coordinates on a
smooth sphere, wired into Emission (relMSE <= 1e-3); White Noise (1D to 4D) on floored
coordinates, Magic, Brick and Blackbody, and the Normal Map node (tangent, object and
Blender world spaces) as 0.5 N + 0.5, and a Noise into the Material Output's Displacement
(object and world space, as bump) seen through Geometry Normal, each wired into Emission
(relMSE <= 1e-3); Light Path's Is Camera Ray choosing a lamp's colour (lit criterion, path
tracer and photon mapping); three UV maps read by name and by default (the render map); a
16-bit PNG and an OpenEXR image; a Principled BSDF's Alpha from a gradient over an emitting
plane; a lamp whose emission depends on the view (Layer Weight) lighting a floor; Light Path's
Ray Length into a lamp's emission.
"""

import math

import bpy
import pytest

import common
from cycles_compare import compare

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s

EMISSION_RELMSE_MAX = 1e-3
SIZE = 32


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def bare_material(name):
    """A node material without its Principled BSDF (its Material Output alone)."""
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    return mat, mat.node_tree


def node_material(name):
    """A fresh scene (black world) and a node material without its Principled BSDF."""
    common.reset_scene(SIZE, SIZE)
    return bare_material(name)


def emission_into_output(tree, socket, strength=1.0):
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = strength
    tree.links.new(socket, emission.inputs["Color"])
    tree.links.new(emission.outputs["Emission"], tree.nodes["Material Output"].inputs["Surface"])
    return emission


def emission_matches(name, mat, tree, socket, tmp_path, *, strength=1.0, photon_spp=512,
                     cycles_spp=512, **plane):
    """Wire `socket` into an Emission shader of `mat`, and compare the plane with Cycles:
    relMSE <= EMISSION_RELMSE_MAX."""
    emission_into_output(tree, socket, strength)
    scene, _ = plane_scene(mat, **plane)
    compare(name, scene, tmp_path, photon_spp=photon_spp, cycles_spp=cycles_spp,
            relmse_max=EMISSION_RELMSE_MAX)


def plane_scene(material, *, uv=False, colors=False, camera=True):
    """A 2 m plane facing a camera 3 m above it (the plane fills the view), in the scene
    `node_material` reset."""
    scene = bpy.context.scene
    plane = common.quad("Plane", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], material)
    mesh = plane.data
    if uv:
        layer = mesh.uv_layers.new(name="UVMap")
        for loop, (u, v) in zip(mesh.loops, [(0, 0), (1, 0), (1, 1), (0, 1)]):
            layer.data[loop.index].uv = (u, v)
    if colors:
        attribute = mesh.color_attributes.new("Col", "FLOAT_COLOR", "POINT")
        corners = [(1.0, 0.2, 0.1, 1.0), (0.1, 1.0, 0.2, 1.0), (0.2, 0.1, 1.0, 1.0),
                   (1.0, 1.0, 1.0, 1.0)]
        for i, c in enumerate(corners):
            attribute.data[i].color = c
        mesh.color_attributes.active_color = attribute
        mesh.color_attributes.render_color_index = 0
    if camera:
        common.camera("Camera", (0.0, 0.0, 3.0), (0.0, 0.0, 0.0), 36.0)
    return scene, plane


def test_checker_on_generated_into_emission(tmp_path):
    mat, tree = node_material("Checker")
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = 3.0
    checker.inputs["Color1"].default_value = (0.9, 0.3, 0.1, 1.0)
    checker.inputs["Color2"].default_value = (0.05, 0.2, 0.6, 1.0)
    emission_matches("checker emission", mat, tree, checker.outputs["Color"], tmp_path,
                     strength=2.0)


def test_noise_mapping_color_ramp_into_emission(tmp_path):
    mat, tree = node_material("Noise")
    coords = tree.nodes.new("ShaderNodeTexCoord")
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Location"].default_value = (0.3, -0.2, 0.1)
    mapping.inputs["Rotation"].default_value = (0.2, 0.1, math.radians(30.0))
    mapping.inputs["Scale"].default_value = (1.5, 1.0, 1.0)
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 2.5
    noise.inputs["Detail"].default_value = 3.5
    noise.inputs["Roughness"].default_value = 0.6
    noise.inputs["Distortion"].default_value = 0.3
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].position = 0.35
    ramp.color_ramp.elements[0].color = (0.05, 0.1, 0.4, 1.0)
    ramp.color_ramp.elements[1].position = 0.7
    ramp.color_ramp.elements[1].color = (1.0, 0.8, 0.2, 1.0)
    middle = ramp.color_ramp.elements.new(0.5)
    middle.color = (0.8, 0.1, 0.1, 1.0)
    tree.links.new(coords.outputs["Object"], mapping.inputs["Vector"])
    tree.links.new(mapping.outputs["Vector"], noise.inputs["Vector"])
    tree.links.new(noise.outputs["Fac"], ramp.inputs["Fac"])
    emission_matches("noise ramp emission", mat, tree, ramp.outputs["Color"], tmp_path,
                     strength=1.5)


def test_gradient_math_mix_vertex_colours_into_emission(tmp_path):
    mat, tree = node_material("Gradient")
    uv = tree.nodes.new("ShaderNodeUVMap")
    gradient = tree.nodes.new("ShaderNodeTexGradient")
    gradient.gradient_type = "EASING"
    power = tree.nodes.new("ShaderNodeMath")
    power.operation = "POWER"
    power.inputs[1].default_value = 0.5
    map_range = tree.nodes.new("ShaderNodeMapRange")
    map_range.inputs["To Min"].default_value = 0.2
    map_range.inputs["To Max"].default_value = 0.9
    colors = tree.nodes.new("ShaderNodeVertexColor")
    colors.layer_name = "Col"
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.blend_type = "MULTIPLY"
    mix.inputs["Factor"].default_value = 1.0
    group = bpy.data.node_groups.new("Scale", "ShaderNodeTree")
    group.interface.new_socket("Value", in_out="INPUT", socket_type="NodeSocketFloat")
    group.interface.new_socket("Value", in_out="OUTPUT", socket_type="NodeSocketFloat")
    g_in = group.nodes.new("NodeGroupInput")
    g_out = group.nodes.new("NodeGroupOutput")
    g_mul = group.nodes.new("ShaderNodeMath")
    g_mul.operation = "MULTIPLY"
    g_mul.inputs[1].default_value = 1.25
    group.links.new(g_in.outputs[0], g_mul.inputs[0])
    group.links.new(g_mul.outputs[0], g_out.inputs[0])
    grouped = tree.nodes.new("ShaderNodeGroup")
    grouped.node_tree = group
    reroute = tree.nodes.new("NodeReroute")
    tree.links.new(uv.outputs["UV"], gradient.inputs["Vector"])
    tree.links.new(gradient.outputs["Fac"], power.inputs[0])
    tree.links.new(power.outputs["Value"], grouped.inputs[0])
    tree.links.new(grouped.outputs[0], map_range.inputs["Value"])
    tree.links.new(map_range.outputs["Result"], reroute.inputs[0])
    tree.links.new(reroute.outputs[0], mix.inputs["A"])
    tree.links.new(colors.outputs["Color"], mix.inputs["B"])
    emission_matches("gradient math mix emission", mat, tree, mix.outputs["Result"], tmp_path,
                     strength=1.0, uv=True, colors=True)


def lit_scene(material):
    scene, plane = plane_scene(material)
    common.light("Sun", "SUN", (0, 0, 5), (25.0, 10.0, 30.0), energy=3.0)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.2, 0.25, 0.3, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    return scene


def test_checker_into_principled_base_color(tmp_path):
    mat, tree = node_material("Lit checker")
    bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Roughness"].default_value = 0.6
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = 4.0
    checker.inputs["Color1"].default_value = (0.8, 0.2, 0.1, 1.0)
    checker.inputs["Color2"].default_value = (0.1, 0.5, 0.8, 1.0)
    tree.links.new(checker.outputs["Color"], bsdf.inputs["Base Color"])
    tree.links.new(bsdf.outputs["BSDF"], tree.nodes["Material Output"].inputs["Surface"])
    compare("checker principled", lit_scene(mat), tmp_path, photon_spp=128, cycles_spp=256)


def test_mix_shader_of_diffuse_and_glossy_by_noise(tmp_path):
    mat, tree = node_material("Mixed")
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (0.7, 0.3, 0.2, 1.0)
    glossy = tree.nodes.new("ShaderNodeBsdfGlossy")
    glossy.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    glossy.inputs["Roughness"].default_value = 0.5
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 3.0
    mix = tree.nodes.new("ShaderNodeMixShader")
    tree.links.new(noise.outputs["Fac"], mix.inputs["Fac"])
    tree.links.new(diffuse.outputs["BSDF"], mix.inputs[1])
    tree.links.new(glossy.outputs["BSDF"], mix.inputs[2])
    tree.links.new(mix.outputs["Shader"], tree.nodes["Material Output"].inputs["Surface"])
    compare("mix shader", lit_scene(mat), tmp_path, photon_spp=256, cycles_spp=256)


def test_voronoi_and_hue_saturation_into_emission(tmp_path):
    mat, tree = node_material("Voronoi")
    voronoi = tree.nodes.new("ShaderNodeTexVoronoi")
    voronoi.feature = "SMOOTH_F1"
    voronoi.inputs["Scale"].default_value = 4.0
    voronoi.inputs["Detail"].default_value = 1.5
    voronoi.inputs["Smoothness"].default_value = 0.6
    voronoi.normalize = True
    hue = tree.nodes.new("ShaderNodeHueSaturation")
    hue.inputs["Hue"].default_value = 0.3
    hue.inputs["Saturation"].default_value = 1.4
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.blend_type = "OVERLAY"
    tree.links.new(voronoi.outputs["Color"], hue.inputs["Color"])
    tree.links.new(voronoi.outputs["Distance"], mix.inputs["Factor"])
    tree.links.new(hue.outputs["Color"], mix.inputs["A"])
    mix.inputs["B"].default_value = (0.2, 0.6, 0.9, 1.0)
    emission_matches("voronoi hue emission", mat, tree, mix.outputs["Result"], tmp_path,
                     strength=1.0, photon_spp=128)


def test_wave_rings_with_distortion_into_emission(tmp_path):
    mat, tree = node_material("Wave")
    coords = tree.nodes.new("ShaderNodeTexCoord")
    wave = tree.nodes.new("ShaderNodeTexWave")
    wave.wave_type = "RINGS"
    wave.rings_direction = "SPHERICAL"
    wave.wave_profile = "TRI"
    wave.inputs["Scale"].default_value = 0.8
    wave.inputs["Distortion"].default_value = 4.0
    wave.inputs["Detail"].default_value = 2.5
    contrast = tree.nodes.new("ShaderNodeBrightContrast")
    contrast.inputs["Bright"].default_value = 0.1
    contrast.inputs["Contrast"].default_value = 0.4
    tree.links.new(coords.outputs["Object"], wave.inputs["Vector"])
    tree.links.new(wave.outputs["Color"], contrast.inputs["Color"])
    emission_matches("wave emission", mat, tree, contrast.outputs["Color"], tmp_path, strength=1.0)


def test_image_texture_repeated_into_emission(tmp_path):
    """An 8x8 PNG (sRGB) through UV x 1.5 (repeat) and the Image Texture node, bilinear."""
    mat, tree = node_material("Image")
    image = bpy.data.images.new("Tiles", 8, 8)
    pixels = []
    for y in range(8):
        for x in range(8):
            pixels += [((x * 37 + y * 11) % 8) / 7.0, ((x * 5 + y * 23) % 8) / 7.0,
                       ((x + y) % 2) * 0.8 + 0.1, 1.0]
    image.pixels = pixels
    image.filepath_raw = str(tmp_path / "tiles.png")
    image.file_format = "PNG"
    image.save()
    image = bpy.data.images.load(str(tmp_path / "tiles.png"))
    uv = tree.nodes.new("ShaderNodeUVMap")
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Scale"].default_value = (1.5, 1.5, 1.0)
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    tree.links.new(uv.outputs["UV"], mapping.inputs["Vector"])
    tree.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    emission_matches("image emission", mat, tree, tex.outputs["Color"], tmp_path,
                     strength=1.0, uv=True)


def test_noise_bump_into_principled_normal(tmp_path):
    """Noise heights through a Bump node into a Principled BSDF's Normal, under a low sun."""
    mat, tree = node_material("Bumpy")
    bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Base Color"].default_value = (0.7, 0.6, 0.5, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.7
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 3.0
    noise.inputs["Detail"].default_value = 1.0
    bump = tree.nodes.new("ShaderNodeBump")
    bump.inputs["Distance"].default_value = 0.3
    bump.inputs["Strength"].default_value = 0.8
    tree.links.new(noise.outputs["Fac"], bump.inputs["Height"])
    tree.links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
    tree.links.new(bsdf.outputs["BSDF"], tree.nodes["Material Output"].inputs["Surface"])
    scene, _ = plane_scene(mat)
    common.light("Sun", "SUN", (0, 0, 5), (60.0, 0.0, 30.0), energy=3.0)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.1, 0.1, 0.12, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    compare("noise bump", scene, tmp_path, photon_spp=256, cycles_spp=256)


@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_mixed_tree_noise_ramp_bump_mix_shader_vertex_colours(tmp_path, method):
    """Many nodes at once, lit: Noise into a Color Ramp for the Base Color (multiplied by the
    vertex colours), the same Noise through a Bump for the Normal, and the Principled BSDF
    mixed with a Glossy BSDF by a Voronoi distance; by the path tracer and by photon mapping
    (the tree serves photon tracing and gathering as well)."""
    mat, tree = node_material("Mixed tree")
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 4.0
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.1, 0.3, 0.05, 1.0)
    ramp.color_ramp.elements[1].color = (0.9, 0.8, 0.6, 1.0)
    colors = tree.nodes.new("ShaderNodeVertexColor")
    colors.layer_name = "Col"
    tint = tree.nodes.new("ShaderNodeMix")
    tint.data_type = "RGBA"
    tint.blend_type = "MULTIPLY"
    tint.inputs["Factor"].default_value = 1.0
    bump = tree.nodes.new("ShaderNodeBump")
    bump.inputs["Distance"].default_value = 0.2
    bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Roughness"].default_value = 0.6
    glossy = tree.nodes.new("ShaderNodeBsdfGlossy")
    glossy.inputs["Roughness"].default_value = 0.3
    voronoi = tree.nodes.new("ShaderNodeTexVoronoi")
    voronoi.inputs["Scale"].default_value = 3.0
    mix = tree.nodes.new("ShaderNodeMixShader")
    links = tree.links
    links.new(noise.outputs["Fac"], ramp.inputs["Fac"])
    links.new(ramp.outputs["Color"], tint.inputs["A"])
    links.new(colors.outputs["Color"], tint.inputs["B"])
    links.new(tint.outputs["Result"], bsdf.inputs["Base Color"])
    links.new(noise.outputs["Fac"], bump.inputs["Height"])
    links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
    links.new(voronoi.outputs["Distance"], mix.inputs["Fac"])
    links.new(bsdf.outputs["BSDF"], mix.inputs[1])
    links.new(glossy.outputs["BSDF"], mix.inputs[2])
    links.new(mix.outputs["Shader"], tree.nodes["Material Output"].inputs["Surface"])
    scene, _ = plane_scene(mat, colors=True)
    common.light("Sun", "SUN", (0, 0, 5), (35.0, 0.0, 30.0), energy=3.0)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.2, 0.25, 0.3, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    compare(f"mixed tree {method.lower()}", scene, tmp_path, photon_spp=256, cycles_spp=256,
            method=method)


def test_layer_weight_fresnel_and_reflection_on_a_sphere(tmp_path):
    """View-dependent inputs on a smooth sphere: Layer Weight (Facing) and Fresnel mix colours,
    plus the Reflection coordinates through a Separate XYZ, wired into Emission."""
    mat, tree = node_material("Rim")
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=0.9)
    sphere = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    sphere.data.materials.append(mat)
    weight = tree.nodes.new("ShaderNodeLayerWeight")
    weight.inputs["Blend"].default_value = 0.3
    fresnel = tree.nodes.new("ShaderNodeFresnel")
    fresnel.inputs["IOR"].default_value = 1.8
    coords = tree.nodes.new("ShaderNodeTexCoord")
    separate = tree.nodes.new("ShaderNodeSeparateXYZ")
    combine = tree.nodes.new("ShaderNodeCombineXYZ")
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.blend_type = "ADD"
    links = tree.links
    links.new(coords.outputs["Reflection"], separate.inputs["Vector"])
    links.new(weight.outputs["Facing"], combine.inputs["X"])
    links.new(fresnel.outputs["Fac"], combine.inputs["Y"])
    links.new(separate.outputs["Z"], combine.inputs["Z"])
    links.new(combine.outputs["Vector"], mix.inputs["A"])
    links.new(weight.outputs["Fresnel"], mix.inputs["Factor"])
    mix.inputs["B"].default_value = (0.1, 0.1, 0.3, 1.0)
    common.camera("Camera", (0.0, 0.0, 3.0), (0.0, 0.0, 0.0), 40.0)
    # The sphere's silhouette against the plane jumps from -0.4 to 1: more samples there.
    emission_matches("view-dependent emission", mat, tree, mix.outputs["Result"], tmp_path,
                     strength=1.0, camera=False, photon_spp=2048, cycles_spp=2048)


def test_noise_color_output_2d_into_emission(tmp_path):
    """The Noise texture's Color output (two more fBm evaluations at Cycles' seeded offsets),
    2D, with distortion."""
    mat, tree = node_material("Noise colour")
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.noise_dimensions = "2D"
    noise.inputs["Scale"].default_value = 3.0
    noise.inputs["Distortion"].default_value = 0.5
    emission_matches("noise colour emission", mat, tree, noise.outputs["Color"], tmp_path)


def test_rgb_curves_into_emission(tmp_path):
    """A UV gradient through RGB Curves whose combined and red curves are bent."""
    mat, tree = node_material("Curves")
    uv = tree.nodes.new("ShaderNodeUVMap")
    separate = tree.nodes.new("ShaderNodeSeparateXYZ")
    combine = tree.nodes.new("ShaderNodeCombineColor")
    curves = tree.nodes.new("ShaderNodeRGBCurve")
    curves.inputs["Fac"].default_value = 0.9
    combined, red = curves.mapping.curves[3], curves.mapping.curves[0]
    combined.points.new(0.3, 0.6)
    red.points.new(0.5, 0.2)
    red.points[0].location = (0.0, 0.1)
    curves.mapping.update()
    tree.links.new(uv.outputs["UV"], separate.inputs["Vector"])
    tree.links.new(separate.outputs["X"], combine.inputs["Red"])
    tree.links.new(separate.outputs["Y"], combine.inputs["Green"])
    combine.inputs["Blue"].default_value = 0.5
    tree.links.new(combine.outputs["Color"], curves.inputs["Color"])
    emission_matches("rgb curves emission", mat, tree, curves.outputs["Color"], tmp_path,
                     uv=True)


@pytest.mark.parametrize("dimensions", ["1D", "2D", "3D", "4D"])
def test_white_noise_on_cells_into_emission(tmp_path, dimensions):
    """White Noise on floored Object coordinates (one hashed colour per cell, so the image
    does not depend on where in a pixel the samples fall), W from the cell's x."""
    mat, tree = node_material(f"White noise {dimensions}")
    coords = tree.nodes.new("ShaderNodeTexCoord")
    scale = tree.nodes.new("ShaderNodeVectorMath")
    scale.operation = "SCALE"
    scale.inputs["Scale"].default_value = 3.0
    floor = tree.nodes.new("ShaderNodeVectorMath")
    floor.operation = "FLOOR"
    separate = tree.nodes.new("ShaderNodeSeparateXYZ")
    noise = tree.nodes.new("ShaderNodeTexWhiteNoise")
    noise.noise_dimensions = dimensions
    tree.links.new(coords.outputs["Object"], scale.inputs[0])
    tree.links.new(scale.outputs["Vector"], floor.inputs[0])
    tree.links.new(floor.outputs["Vector"], separate.inputs["Vector"])
    for socket in noise.inputs:  # only the enabled ones are found by name
        source = floor.outputs["Vector"] if socket.type == "VECTOR" else separate.outputs["X"]
        tree.links.new(source, socket)
    emission_matches(f"white noise {dimensions} emission", mat, tree, noise.outputs["Color"],
                     tmp_path)


def test_magic_into_emission(tmp_path):
    """The Magic texture on its default (Generated) coordinates, depth 5, distortion 2.5."""
    mat, tree = node_material("Magic")
    magic = tree.nodes.new("ShaderNodeTexMagic")
    magic.turbulence_depth = 5
    magic.inputs["Scale"].default_value = 1.5
    magic.inputs["Distortion"].default_value = 2.5
    emission_matches("magic emission", mat, tree, magic.outputs["Color"], tmp_path,
                     photon_spp=1024, cycles_spp=1024)


def test_brick_into_emission(tmp_path):
    """The Brick texture on Object coordinates: offset rows, squashed rows, smooth mortar,
    biased tints between two colours."""
    mat, tree = node_material("Brick")
    coords = tree.nodes.new("ShaderNodeTexCoord")
    brick = tree.nodes.new("ShaderNodeTexBrick")
    brick.offset = 0.3
    brick.offset_frequency = 2
    brick.squash = 1.6
    brick.squash_frequency = 3
    brick.inputs["Color1"].default_value = (0.8, 0.3, 0.1, 1.0)
    brick.inputs["Color2"].default_value = (0.3, 0.1, 0.05, 1.0)
    brick.inputs["Mortar"].default_value = (0.7, 0.7, 0.65, 1.0)
    brick.inputs["Scale"].default_value = 1.5
    brick.inputs["Mortar Size"].default_value = 0.05
    brick.inputs["Mortar Smooth"].default_value = 0.4
    brick.inputs["Bias"].default_value = 0.1
    tree.links.new(coords.outputs["Object"], brick.inputs["Vector"])
    emission_matches("brick emission", mat, tree, brick.outputs["Color"], tmp_path)


def test_blackbody_of_a_gradient_into_emission(tmp_path):
    """Blackbody colours from 700 K to 13000 K along the plane (UV x mapped by Map Range),
    past both ends of Cycles' fit."""
    mat, tree = node_material("Blackbody")
    uv = tree.nodes.new("ShaderNodeUVMap")
    separate = tree.nodes.new("ShaderNodeSeparateXYZ")
    map_range = tree.nodes.new("ShaderNodeMapRange")
    map_range.inputs["To Min"].default_value = 700.0
    map_range.inputs["To Max"].default_value = 13000.0
    blackbody = tree.nodes.new("ShaderNodeBlackbody")
    tree.links.new(uv.outputs["UV"], separate.inputs["Vector"])
    tree.links.new(separate.outputs["X"], map_range.inputs["Value"])
    tree.links.new(map_range.outputs["Result"], blackbody.inputs["Temperature"])
    emission_matches("blackbody emission", mat, tree, blackbody.outputs["Color"], tmp_path,
                     strength=0.5, uv=True)


@pytest.mark.parametrize("space", ["TANGENT", "OBJECT", "BLENDER_WORLD"])
def test_normal_map_into_emission(tmp_path, space):
    """A Normal Map node's output, as 0.5 N + 0.5, on a tilted plane whose UV map is rotated
    by 30 degrees (so its tangents follow no axis); the colour varies over the UV map and the
    strength is 0.7 (blended with the surface normal, as Cycles does)."""
    mat, tree = node_material(f"Normal map {space}")
    uv = tree.nodes.new("ShaderNodeUVMap")
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Location"].default_value = (0.3, 0.3, 0.9)
    mapping.inputs["Scale"].default_value = (0.4, 0.4, 0.0)
    normal_map = tree.nodes.new("ShaderNodeNormalMap")
    normal_map.space = space
    normal_map.inputs["Strength"].default_value = 0.7
    half = tree.nodes.new("ShaderNodeVectorMath")
    half.operation = "MULTIPLY_ADD"
    half.inputs[1].default_value = (0.5, 0.5, 0.5)
    half.inputs[2].default_value = (0.5, 0.5, 0.5)
    tree.links.new(uv.outputs["UV"], mapping.inputs["Vector"])
    tree.links.new(mapping.outputs["Vector"], normal_map.inputs["Color"])
    tree.links.new(normal_map.outputs["Normal"], half.inputs[0])
    emission_into_output(tree, half.outputs["Vector"])
    scene, plane = plane_scene(mat)
    layer = plane.data.uv_layers.new(name="UVMap")
    turn = math.radians(30.0)
    for loop, (u, v) in zip(plane.data.loops, [(0, 0), (1, 0), (1, 1), (0, 1)]):
        layer.data[loop.index].uv = (u * math.cos(turn) - v * math.sin(turn),
                                     u * math.sin(turn) + v * math.cos(turn))
    plane.rotation_euler = (math.radians(20.0), math.radians(-10.0), math.radians(15.0))
    compare(f"normal map {space.lower()} emission", scene, tmp_path, photon_spp=256,
            cycles_spp=256, relmse_max=EMISSION_RELMSE_MAX)


@pytest.mark.parametrize("space", ["OBJECT", "WORLD"])
def test_displacement_as_bump_into_emission(tmp_path, space):
    """A Noise texture into the Material Output's Displacement (Displacement node, Bump Only:
    Blender's default method), on a tilted and scaled plane, seen through the surface's
    Geometry Normal as 0.5 N + 0.5 in an Emission shader: the surface tree reads the bumped
    normal, as in Cycles."""
    mat, tree = node_material(f"Displaced {space}")
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 2.0
    noise.inputs["Detail"].default_value = 0.0
    displacement = tree.nodes.new("ShaderNodeDisplacement")
    displacement.space = space
    displacement.inputs["Scale"].default_value = 0.15
    geometry = tree.nodes.new("ShaderNodeNewGeometry")
    half = tree.nodes.new("ShaderNodeVectorMath")
    half.operation = "MULTIPLY_ADD"
    half.inputs[1].default_value = (0.5, 0.5, 0.5)
    half.inputs[2].default_value = (0.5, 0.5, 0.5)
    tree.links.new(noise.outputs["Fac"], displacement.inputs["Height"])
    tree.links.new(displacement.outputs["Displacement"],
                   tree.nodes["Material Output"].inputs["Displacement"])
    tree.links.new(geometry.outputs["Normal"], half.inputs[0])
    emission_into_output(tree, half.outputs["Vector"])
    scene, plane = plane_scene(mat)
    plane.rotation_euler = (math.radians(20.0), math.radians(-10.0), 0.0)
    plane.scale = (1.0, 1.0, 2.0)
    compare(f"displacement {space.lower()} emission", scene, tmp_path, photon_spp=256,
            cycles_spp=256, relmse_max=EMISSION_RELMSE_MAX)


def colour_mix_lamp(name, factor_node, factor_output, a, b, strength):
    """A node material emitting Mix(a, b) by `factor_node`'s `factor_output` (a new node of
    that type)."""
    mat, tree = node_material(name)
    factor = tree.nodes.new(factor_node)
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.inputs["A"].default_value = a
    mix.inputs["B"].default_value = b
    tree.links.new(factor.outputs[factor_output], mix.inputs["Factor"])
    emission_into_output(tree, mix.outputs["Result"], strength=strength)
    return mat, factor


def lamp_over_floor(lamp, half_size, height):
    """A square of material `lamp` (2 half_size wide, at `height`) over a diffuse floor
    filling the view."""
    floor = bpy.data.materials.new("Floor")
    if bpy.app.version < (5, 0, 0):
        floor.use_nodes = True
    floor.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 1.0
    scene, _ = plane_scene(floor)
    h = half_size
    common.quad("Lamp", [(-h, -h, height), (-h, h, height), (h, h, height), (h, -h, height)],
                lamp)
    return scene


@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_light_path_camera_ray_into_emission(tmp_path, method):
    """An emitting quad whose colour is Mix(orange, blue) by Light Path's Is Camera Ray, over
    a diffuse floor: the camera sees it blue, the floor is lit orange (the light reaching it
    is not seen by a camera ray), lit criterion (mean within 2 %, relMSE <= 0.01); by the path
    tracer and by photon mapping (photons are not camera rays)."""
    mat, _ = colour_mix_lamp("Camera only blue", "ShaderNodeLightPath", "Is Camera Ray",
                             (1.0, 0.4, 0.1, 1.0), (0.1, 0.3, 1.0, 1.0), 6.0)
    scene = lamp_over_floor(mat, 0.3, 0.6)
    compare(f"light path camera ray {method.lower()}", scene, tmp_path, photon_spp=256,
            cycles_spp=512, method=method)


def test_uv_maps_other_than_the_first_into_emission(tmp_path):
    """Three UV maps, the second the render one (Cycles' default): a UV Map node naming the
    third, the Texture Coordinate's UV (the render map) and an Image Texture's default
    coordinates (the render map) into a colour."""
    mat, tree = node_material("UV maps")
    third = tree.nodes.new("ShaderNodeUVMap")
    third.uv_map = "Third"
    coords = tree.nodes.new("ShaderNodeTexCoord")
    split_third = tree.nodes.new("ShaderNodeSeparateXYZ")
    split_render = tree.nodes.new("ShaderNodeSeparateXYZ")
    image = bpy.data.images.new("Ramp", 4, 4)
    image.pixels = [v for y in range(4) for x in range(4) for v in (x / 3, y / 3, 0.5, 1.0)]
    image.filepath_raw = str(tmp_path / "ramp.png")
    image.file_format = "PNG"
    image.save()
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = bpy.data.images.load(str(tmp_path / "ramp.png"))
    tex.extension = "EXTEND"
    combine = tree.nodes.new("ShaderNodeCombineColor")
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    tree.links.new(third.outputs["UV"], split_third.inputs["Vector"])
    tree.links.new(coords.outputs["UV"], split_render.inputs["Vector"])
    tree.links.new(split_third.outputs["X"], combine.inputs["Red"])
    tree.links.new(split_render.outputs["Y"], combine.inputs["Green"])
    tree.links.new(combine.outputs["Color"], mix.inputs["A"])
    tree.links.new(tex.outputs["Color"], mix.inputs["B"])
    emission_into_output(tree, mix.outputs["Result"])
    scene, plane = plane_scene(mat, uv=True)
    corners = [(0, 0), (1, 0), (1, 1), (0, 1)]
    for name, place in [("Second", lambda u, v: (0.8 * v + 0.1, 0.9 - 0.7 * u)),
                        ("Third", lambda u, v: (u * u, 0.5))]:
        layer = plane.data.uv_layers.new(name=name)
        for loop, (u, v) in zip(plane.data.loops, corners):
            layer.data[loop.index].uv = place(u, v)
    plane.data.uv_layers["Second"].active_render = True
    compare("uv maps emission", scene, tmp_path, photon_spp=256, cycles_spp=256,
            relmse_max=EMISSION_RELMSE_MAX)


def write_png16(path, width, height, rgb):
    """A 16-bit RGB PNG of `rgb(x, y)` in [0, 1] (row 0 at the top), written by hand: Blender
    saves images at 8 bits unless rendering."""
    import struct
    import zlib

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))
    rows = b"".join(
        b"\0" + b"".join(struct.pack(">3H", *(round(65535 * c) for c in rgb(x, y)))
                         for x in range(width))
        for y in range(height))
    header = struct.pack(">2I5B", width, height, 16, 2, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
                     + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


@pytest.mark.parametrize("kind", ["png16", "exr"])
def test_wide_images_into_emission(tmp_path, kind):
    """Images 8 bits cannot hold, through the Image Texture node (Non-Color, bilinear): a
    16-bit PNG of values below 0.01 (8 bits would round them to 0, 1/255 or 2/255), and an
    OpenEXR of values up to 4."""
    mat, tree = node_material(f"Wide {kind}")
    size = 8
    if kind == "png16":
        path = tmp_path / "dark.png"
        write_png16(path, size, size, lambda x, y: (0.01 * x / 7, 0.01 * y / 7, 0.003))
        strength = 60.0
    else:
        path = tmp_path / "bright.exr"
        image = bpy.data.images.new("Bright", size, size, float_buffer=True)
        image.pixels = [v for y in range(size) for x in range(size)
                        for v in (4.0 * x / 7, 0.5 + y / 7, 0.25, 1.0)]
        image.filepath_raw = str(path)
        image.file_format = "OPEN_EXR"
        image.save()
        strength = 0.5
    image = bpy.data.images.load(str(path))
    image.colorspace_settings.name = "Non-Color"
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    emission_matches(f"{kind} image emission", mat, tree, tex.outputs["Color"], tmp_path,
                     strength=strength, uv=True)


def test_principled_alpha_from_a_tree(tmp_path):
    """A Principled BSDF whose Alpha is a UV gradient (emission red, base colour black) above
    a blue-emitting plane, in a black world: the camera sees alpha x red + (1 - alpha) x
    blue, as Cycles mixes the BSDF with a Transparent BSDF by alpha."""
    mat, tree = node_material("Fading")
    bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Base Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    bsdf.inputs["Emission Color"].default_value = (1.0, 0.1, 0.05, 1.0)
    bsdf.inputs["Emission Strength"].default_value = 1.0
    uv = tree.nodes.new("ShaderNodeUVMap")
    gradient = tree.nodes.new("ShaderNodeTexGradient")
    tree.links.new(uv.outputs["UV"], gradient.inputs["Vector"])
    tree.links.new(gradient.outputs["Fac"], bsdf.inputs["Alpha"])
    tree.links.new(bsdf.outputs["BSDF"], tree.nodes["Material Output"].inputs["Surface"])
    below, below_tree = bpy.data.materials.new("Below"), None
    if bpy.app.version < (5, 0, 0):
        below.use_nodes = True
    below_tree = below.node_tree
    below_tree.nodes.remove(below_tree.nodes["Principled BSDF"])
    emission = below_tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (0.1, 0.3, 1.0, 1.0)
    below_tree.links.new(emission.outputs["Emission"],
                         below_tree.nodes["Material Output"].inputs["Surface"])
    scene, _ = plane_scene(mat, uv=True)
    common.quad("Below", [(-2, -2, -0.5), (2, -2, -0.5), (2, 2, -0.5), (-2, 2, -0.5)], below)
    compare("principled alpha", scene, tmp_path, photon_spp=1024, cycles_spp=1024,
            relmse_max=EMISSION_RELMSE_MAX)


def test_view_dependent_lamp_lights_a_floor(tmp_path):
    """A lamp whose emission depends on the view (Layer Weight's Facing mixes two colours):
    light sampling evaluates it as seen from the shaded floor point, as Cycles does (it was
    evaluated head-on before), and the camera sees it from above. Lit criterion."""
    mat, weight = colour_mix_lamp("Rim lamp", "ShaderNodeLayerWeight", "Facing",
                                  (1.0, 0.3, 0.1, 1.0), (0.1, 0.4, 1.0, 1.0), 5.0)
    weight.inputs["Blend"].default_value = 0.5
    scene = lamp_over_floor(mat, 0.4, 0.4)
    compare("view-dependent lamp", scene, tmp_path, photon_spp=256, cycles_spp=512)


def test_light_path_ray_length_into_emission(tmp_path):
    """Light Path's Ray Length through a Map Range into a lamp's Emission, over a diffuse
    floor: the camera sees the lamp by its distance from the near clip plane (Cycles starts
    camera rays there), the floor is lit by it at the floor point's distance (light sampling
    and bounces). Lit criterion; a warning says photons would read 0."""
    mat, tree = node_material("Distance")
    light_path = tree.nodes.new("ShaderNodeLightPath")
    map_range = tree.nodes.new("ShaderNodeMapRange")
    map_range.inputs["From Min"].default_value = 0.3
    map_range.inputs["From Max"].default_value = 3.5
    map_range.inputs["To Min"].default_value = 0.1
    tree.links.new(light_path.outputs["Ray Length"], map_range.inputs["Value"])
    emission_into_output(tree, map_range.outputs["Result"], strength=2.0)
    scene = lamp_over_floor(mat, 0.4, 0.5)
    scene.camera.data.clip_start = 0.5
    compare("light path ray length", scene, tmp_path, photon_spp=256, cycles_spp=512)
