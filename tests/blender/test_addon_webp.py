"""A WebP texture renders: Blender's glTF exporter writes a WebP image as it is, in
`EXT_texture_webp` marked required (no PNG fallback), and the renderer used to refuse the file.
The factory-default cube's base colour is fed by a 4x4 checker of saturated colours saved as WebP
by Blender (32x32 texels, lossless at quality 100, lossy VP8 at 90); 64x36 pixels, Photon through the add-on
against Cycles in the same test: mean within 2 %, relMSE <= 0.01, and the checker's colours
are on the cube in both images (a render that ignored the texture would be grey).
"""

import json
import struct

import bpy
import numpy as np
import pytest

import common
import scenes_bpy
from helpers import photon_binary, rel_mse

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s

PHOTON_SPP = 256
CYCLES_SPP = 1024
MEAN_TOL = 0.02
RELMSE_MAX = 0.01
# Saturated red, green, blue and yellow in a 4x4 checker.
COLOURS = np.array([(0.9, 0.1, 0.1), (0.1, 0.8, 0.1), (0.1, 0.2, 0.9), (0.9, 0.8, 0.1)])


def webp_scene(path, quality):
    scene = scenes_bpy.default_scene()
    # Cells of 8x8 texels: lossy WebP keeps chroma at half resolution.
    texels = np.ones((32, 32, 4), np.float32)
    for y in range(32):
        for x in range(32):
            texels[y, x, :3] = COLOURS[(x // 8 + 2 * (y // 8)) % 4]
    image = bpy.data.images.new("Checker", 32, 32)
    image.pixels.foreach_set(texels.ravel())
    image.filepath_raw = str(path)
    image.file_format = "WEBP"
    image.save(quality=quality)
    image.source = "FILE"
    image.reload()
    assert path.read_bytes()[8:12] == b"WEBP"
    tree = bpy.data.materials["Material"].node_tree
    node = tree.nodes.new("ShaderNodeTexImage")
    node.image = image
    node.interpolation = "Closest"
    tree.links.new(node.outputs["Color"], tree.nodes["Principled BSDF"].inputs["Base Color"])
    return scene


def glb_json(path):
    data = path.read_bytes()
    (length,) = struct.unpack_from("<I", data, 12)
    return json.loads(data[20:20 + length])


@pytest.mark.parametrize("quality, chunk", [(100, b"VP8L"), (90, b"VP8 ")])
def test_webp_texture_matches_cycles(photon_addon, tmp_path, quality, chunk):
    photon_binary()
    webp = tmp_path / "checker.webp"
    scene = webp_scene(webp, quality)
    assert webp.read_bytes()[12:16] == chunk  # lossless / lossy as intended

    # What the exporter writes: the WebP image in the extension, required, no fallback.
    glb = tmp_path / "scene.glb"
    common.export_glb(glb)
    doc = glb_json(glb)
    assert "EXT_texture_webp" in doc.get("extensionsRequired", []), doc.get("extensionsRequired")
    assert "source" not in doc["textures"][0], doc["textures"]
    assert doc["images"][0]["mimeType"] == "image/webp"

    ref = scenes_bpy.render(scene, "CYCLES", tmp_path / "cycles.exr", CYCLES_SPP)
    img = scenes_bpy.render(scene, "PHOTON", tmp_path / "photon.exr", PHOTON_SPP)
    assert img.shape == ref.shape == (36, 64, 3)
    err = rel_mse(img, ref)
    diff = float(img.mean() / ref.mean()) - 1.0
    msg = (f"WebP quality {quality}: mean photon {img.mean():.5f} vs cycles {ref.mean():.5f} "
           f"({100 * diff:+.2f} %), relMSE {err:.5f}")
    print(msg)
    assert abs(diff) <= MEAN_TOL, msg
    assert err <= RELMSE_MAX, msg
    # The checker is visible: some cube pixels are clearly red-, green- and blue-dominant.
    for name, image in (("Photon", img), ("Cycles", ref)):
        lit = image[image.sum(axis=2) > 0.05]
        for c, colour in enumerate("RGB"):
            others = np.delete(lit, c, axis=1).max(axis=1)
            dominant = int((lit[:, c] > 2.0 * others).sum())
            assert dominant >= 10, f"{name}: {dominant} {colour}-dominant pixels; {msg}"
