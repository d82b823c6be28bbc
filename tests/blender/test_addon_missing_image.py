"""An image texture whose file is missing renders magenta (1, 0, 1), as in Blender and Cycles,
with a warning naming the image, from both export routes; it used to render white (the glTF
exporter drops the texture silently and leaves the base colour factor at 1). The factory-default
cube's base colour is fed by such an image; 32x18 pixels, rendered with Photon and with Cycles.
"""

import re

import bpy
import numpy as np
import pytest

import common
import scenes_bpy
from helpers import photon_binary
from refimage import read_exr

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s

SPP = 16


@pytest.fixture
def scene(photon_addon, tmp_path):
    photon_binary()
    scene = scenes_bpy.default_scene()
    scene.render.resolution_x, scene.render.resolution_y = 32, 18
    scene.render.resolution_percentage = 100
    common.configure_cycles(scene, SPP, seed=1, threads=scenes_bpy.THREADS)
    scene.photon.samples, scene.photon.seed = SPP, 1
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.use_file_extension = False
    image = bpy.data.images.new("Bricks", 8, 8)
    image.source = "FILE"
    image.filepath = str(tmp_path / "textures" / "bricks.png")  # never written
    tree = bpy.data.materials["Material"].node_tree
    node = tree.nodes.new("ShaderNodeTexImage")
    node.image = image
    tree.links.new(node.outputs["Color"], tree.nodes["Principled BSDF"].inputs["Base Color"])
    return scene


def render(scene, engine, path):
    scene.render.engine = engine
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    return read_exr(path)


def magenta_check(image, engine):
    """The cube's centre pixel is magenta: red and blue alike, green near 0."""
    r, g, b = image[9, 16]
    print(f"{engine}: cube centre RGB {r:.4f} {g:.4f} {b:.4f}")
    assert r > 0.05 and abs(b / r - 1.0) < 0.1 and g < 0.05 * r, f"{engine}: centre {r, g, b}"


@pytest.mark.parametrize("route", ("inprocess", "subprocess"))
def test_missing_image_renders_magenta_with_a_warning(scene, tmp_path, capfd, monkeypatch,
                                                      route):
    monkeypatch.setenv("PHOTON_EXPORT", route)
    magenta_check(render(scene, "CYCLES", tmp_path / "cycles.exr"), "Cycles")
    capfd.readouterr()
    photon = render(scene, "PHOTON", tmp_path / "photon.exr")
    out = capfd.readouterr().out
    warnings = re.findall(r"^Warning: Photon: (.*)$", out, flags=re.M)
    named = [w for w in warnings if "image 'Bricks'" in w and "bricks.png" in w]
    assert len(named) == 1 and "magenta" in named[0], warnings
    magenta_check(photon, "Photon")
