"""The file's working colour space (PHOTON_render "working_space"): Blender 5 renders in the
file's linear space (Rec.709, Rec.2020 or ACEScg) and Photon with it. Colours in node trees are
already in that space; an sRGB image, the Nishita sky and a black body's colour are converted
into it.

Under Blender 5 the scene is made in an ACEScg file; under Blender 4.5, which has Linear Rec.709
only, the same scene renders in Rec.709. Either way it is rendered by Cycles and by Photon
through the add-on: a floor textured by a saturated sRGB image, a saturated emitting panel and
one emitting a Blackbody node's colour, lit by the sky (mean within 2 %, relMSE <= 0.01). Without the conversion the ACEScg render is
off by more than that (the docstring of `test_image_and_sky_in_the_working_space`).
"""

import math

import bpy
import pytest

import common
from cycles_compare import compare

SIZE = 32
# Blender 5's working space for the test; Blender 4.5 has Rec.709 alone.
SPACE = "ACEScg" if hasattr(bpy.data, "colorspace") else None
INTEROP_ID = {"ACEScg": "lin_ap1_scene", None: None}[SPACE]


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def working_space_scene(tmp_path):
    """The scene (module documentation), in the working space `SPACE`."""
    scene = common.reset_scene(SIZE, SIZE)
    if SPACE is not None:
        bpy.ops.wm.set_working_color_space(working_space=SPACE)
        assert bpy.data.colorspace.working_space == SPACE
    image = bpy.data.images.new("Tiles", 4, 4)
    tiles = [(0.9, 0.1, 0.1), (0.1, 0.8, 0.2), (0.15, 0.2, 0.95), (0.95, 0.85, 0.1)]
    pixels = []
    for y in range(4):
        for x in range(4):
            pixels += [*tiles[(x + 2 * y) % 4], 1.0]
    image.pixels = pixels
    image.filepath_raw = str(tmp_path / "tiles.png")
    image.file_format = "PNG"
    image.save()
    image = bpy.data.images.load(str(tmp_path / "tiles.png"))
    floor = common.principled("Floor", (1.0, 1.0, 1.0), roughness=1.0)
    tree = floor.node_tree
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    texture.interpolation = "Closest"
    tree.links.new(texture.outputs["Color"], tree.nodes["Principled BSDF"].inputs["Base Color"])
    plane = common.quad("Floor", [(-4, -4, 0), (4, -4, 0), (4, 4, 0), (-4, 4, 0)], floor)
    uv = plane.data.uv_layers.new(name="UVMap")
    for loop, (u, v) in zip(plane.data.loops, [(0, 0), (1, 0), (1, 1), (0, 1)]):
        uv.data[loop.index].uv = (u, v)
    green = emitting_panel("Green", (1.0, 0.5, 0.01))
    green.inputs["Color"].default_value = (0.05, 0.9, 0.1, 1.0)
    blackbody = emitting_panel("Blackbody", (-2.0, 0.5, 0.01))
    kelvin = blackbody.id_data.nodes.new("ShaderNodeBlackbody")
    kelvin.inputs["Temperature"].default_value = 2000.0
    blackbody.id_data.links.new(kelvin.outputs["Color"], blackbody.inputs["Color"])
    world = scene.world.node_tree
    sky = world.nodes.new("ShaderNodeTexSky")
    sky.sky_type = "SINGLE_SCATTERING" if bpy.app.version >= (5, 0, 0) else "NISHITA"
    sky.sun_elevation = math.radians(35.0)
    sky.sun_rotation = math.radians(200.0)
    background = world.nodes["Background"]
    background.inputs["Strength"].default_value = 0.05
    world.links.new(sky.outputs["Color"], background.inputs["Color"])
    common.camera("Camera", (0.0, -5.0, 2.2), (70.0, 0.0, 0.0), 50.0)
    return scene


def emitting_panel(name, corner):
    """A 1 m square on the floor at `corner` emitting (strength 2); its Emission node."""
    material = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        material.use_nodes = True
    nodes = material.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 2.0
    material.node_tree.links.new(emission.outputs["Emission"],
                                 nodes["Material Output"].inputs["Surface"])
    x, y, z = corner
    common.quad(name, [(x, y, z), (x + 1, y, z), (x + 1, y + 1, z), (x, y + 1, z)], material)
    return emission


@pytest.mark.slow
def test_image_and_sky_in_the_working_space(tmp_path):
    """The scene against Cycles. Measured under Blender 5.0.1 in ACEScg before the conversion
    (image texels and sky left in Rec.709): see the add-on README."""
    scene = working_space_scene(tmp_path)
    compare(f"working space {SPACE or 'Linear Rec.709'}", scene, tmp_path, photon_spp=256,
            cycles_spp=512)


def test_render_extension_names_the_working_space(tmp_path):
    """PHOTON_render carries the working space when it is not Rec.709 (Blender 5), and nothing
    when it is (Blender 4.5 always)."""
    from blender_addon import export
    scene = working_space_scene(tmp_path)
    extension = export.render_extension(scene)
    assert extension.get("working_space") == INTEROP_ID, extension
    if SPACE is not None:
        bpy.ops.wm.set_working_color_space(working_space="Linear Rec.709")
        assert "working_space" not in export.render_extension(scene)
