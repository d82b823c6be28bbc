"""KHR_materials_diffuse_transmission: `photon render` of a glTF file against Cycles' render of
the equivalent Blender material. Blender 4.5's glTF importer does not read the extension, so the
test builds the equivalent node tree on the imported material: the extension's
mix(diffuse BRDF, diffuse BTDF, diffuseTransmission) is a Mix Shader of the Principled BSDF
(the diffuse base) and a Translucent BSDF of the transmission colour, by the factor. That is the
spec's formula exactly when the base has no specular layer above its diffuse lobe, so the files
set KHR_materials_specular's specularFactor to 0 (Blender's Specular IOR Level 0).

The scene (`backlit_stage`): a grey floor, a square and a box of the material standing on it,
and a sun behind them, so the camera sees their lit faces only through the transmission (on
today's main, which ignores the extension, they are dark). Mean within 1 %, 4x4-block relMSE at
most 0.01, 48x48 pixels, as test_gltf_import.py; Photon 512 spp, Cycles 1024. The photon
method's render of the plain factors is a known gap (`PHOTON_BOX_GAP`, an expected failure).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from helpers import read_exr, rel_mse
from test_gltf_import import (BLOCK_RELMSE_MAX, MEAN_TOL, Gltf, block_means, png_bytes,
                              quat_look, render_photon, stage, stripes)

SIZE = 48
DIFFUSE_TRANSMISSION = 0.7
TRANSMISSION_COLOR = [1.0, 0.55, 0.25]
BASE_COLOR = [0.3, 0.75, 0.4, 1.0]


def alpha_stripes() -> np.ndarray:
    """A factor texture: alpha 255 and 60 in vertical stripes (RGB white)."""
    rgba = np.full((16, 16, 4), 255, np.uint8)
    rgba[:, :, 3] = np.where(stripes()[:, :, 0] > 100, 255, 60)
    return rgba


def backlit_stage(textured: bool) -> Gltf:
    """test_gltf_import's stage (floor, camera, sun of 2000 lux), the camera lower and the sun
    behind the objects (travelling towards the camera), and a standing square and a box of
    the diffuse-transmission material."""
    doc = stage()
    camera, target = (0.0, 2.0, 4.5), (0.0, 0.6, 0.0)
    for node in doc.json["nodes"]:
        if node["name"] == "Camera":
            node["translation"] = list(camera)
            node["rotation"] = quat_look(np.subtract(target, camera))
        elif node["name"] == "Sun":
            node["rotation"] = quat_look((0.35, -0.6, 1.0))

    doc.use("KHR_materials_diffuse_transmission")
    doc.use("KHR_materials_specular")
    ext = {"diffuseTransmissionFactor": DIFFUSE_TRANSMISSION,
           "diffuseTransmissionColorFactor": TRANSMISSION_COLOR}
    if textured:
        # Nearest texels: Cycles filters an 8-bit sRGB image's encoded values, Photon's glTF
        # materials the decoded ones (README), which differ on sharp stripes.
        nearest = {"magFilter": 9728, "minFilter": 9728}
        ext["diffuseTransmissionTexture"] = {"index": doc.texture(alpha_stripes(), nearest)}
        ext["diffuseTransmissionColorTexture"] = {"index": doc.texture(stripes(period=2),
                                                                       nearest)}
    material = doc.material({
        "name": "Leaf", "doubleSided": True,
        "pbrMetallicRoughness": {"baseColorFactor": BASE_COLOR, "metallicFactor": 0.0,
                                 "roughnessFactor": 0.8},
        "extensions": {"KHR_materials_diffuse_transmission": ext,
                       "KHR_materials_specular": {"specularFactor": 0.0}}})
    square = doc.quad("Square", 0.7, material)
    doc.node({"name": "Square", "mesh": square, "translation": [-0.8, 0.75, 0.0],
              "rotation": quat_look((0.3, 0.0, 1.0))})
    box = doc.box("Box", 0.45, material)
    doc.node({"name": "Box", "mesh": box, "translation": [0.9, 0.45, -0.2],
              "rotation": quat_look((1.0, 0.0, -1.0))})
    return doc


def equivalent_tree(material, textured: bool, images: dict):
    """Blender's import of the material, with the extension built as nodes: Mix Shader(factor,
    Principled BSDF, Translucent BSDF(colour))."""
    tree = material.node_tree
    nodes, links = tree.nodes, tree.links
    principled = next(n for n in nodes if n.type == "BSDF_PRINCIPLED")
    output = next(n for n in nodes if n.type == "OUTPUT_MATERIAL")
    assert principled.inputs["Specular IOR Level"].default_value == 0.0
    translucent = nodes.new("ShaderNodeBsdfTranslucent")
    translucent.inputs["Color"].default_value = (*TRANSMISSION_COLOR, 1.0)
    mix = nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = DIFFUSE_TRANSMISSION
    if textured:
        factor = nodes.new("ShaderNodeTexImage")
        factor.image = images["factor"]
        factor.interpolation = "Closest"
        scale = nodes.new("ShaderNodeMath")
        scale.operation = "MULTIPLY"
        scale.inputs[1].default_value = DIFFUSE_TRANSMISSION
        links.new(factor.outputs["Alpha"], scale.inputs[0])
        links.new(scale.outputs["Value"], mix.inputs["Fac"])
        color = nodes.new("ShaderNodeTexImage")
        color.image = images["color"]
        color.interpolation = "Closest"
        tint = nodes.new("ShaderNodeMix")
        tint.data_type = "RGBA"
        tint.blend_type = "MULTIPLY"
        tint.inputs["Factor"].default_value = 1.0
        tint.inputs[6].default_value = (*TRANSMISSION_COLOR, 1.0)
        links.new(color.outputs["Color"], tint.inputs[7])
        links.new(tint.outputs[2], translucent.inputs["Color"])
    links.new(principled.outputs["BSDF"], mix.inputs[1])
    links.new(translucent.outputs["BSDF"], mix.inputs[2])
    links.new(mix.outputs["Shader"], output.inputs["Surface"])


def render_cycles_equivalent(path: Path, tmp_path: Path, textured: bool, samples: int):
    import bpy

    import common

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=str(path))
    images = {}
    if textured:
        for key, rgba, space in [("factor", alpha_stripes(), "Non-Color"),
                                 ("color", stripes(period=2), "sRGB")]:
            png = tmp_path / f"{key}.png"
            png.write_bytes(png_bytes(rgba))
            image = bpy.data.images.load(str(png))
            image.colorspace_settings.name = space
            image.alpha_mode = "CHANNEL_PACKED"
            images[key] = image
    equivalent_tree(bpy.data.materials["Leaf"], textured, images)
    scene = bpy.context.scene
    scene.camera = next(o for o in scene.objects if o.type == "CAMERA")
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    scene.render.engine = "CYCLES"
    common.configure_cycles(scene, samples, seed=1, threads=2)
    out = tmp_path / f"{path.stem}_cycles.exr"
    scene.render.filepath = str(out)
    scene.render.use_file_extension = False
    bpy.ops.render.render(write_still=True)
    return read_exr(out)


# The photon method reads the box 8 % dark in red (its inside is lit only through the walls'
# diffuse transmission) and the floor beside it 2 % dark: -1.18 % in all at 512 spp. More global
# photons shrink it (128 spp, the box's red: -8.6 % with the default 200 000, -5.4 % with 4 M,
# -5.0 % with 16 M; `photon render --method photon --photons N`): an estimate bias in the small
# box, not yet understood.
PHOTON_BOX_GAP = "photon method: the diffuse-transmitting box reads 8 % dark (open)"


@pytest.mark.slow
@pytest.mark.parametrize("textured, method", [
    (False, "path"),
    pytest.param(False, "photon", marks=pytest.mark.xfail(strict=True, reason=PHOTON_BOX_GAP)),
    (True, "path"),
    (True, "photon"),
], ids=["factors-path", "factors-photon", "textures-path", "textures-photon"])
def test_diffuse_transmission(tmp_path, textured, method):
    """A green base transmitting 70 % of its diffuse light in orange (with `textures`: the
    factor times a striped alpha, the colour times a striped sRGB texture), lit from behind."""
    name = "diffuse_transmission" + ("_textures" if textured else "")
    path = backlit_stage(textured).write(tmp_path / f"{name}.glb")
    ref = render_cycles_equivalent(path, tmp_path, textured, 1024)
    img = render_photon(path, tmp_path / f"{name}_{method}.exr", SIZE, 512,
                        ["--method", method])
    diff = float(img.mean() / ref.mean()) - 1.0
    err = rel_mse(block_means(img), block_means(ref))
    msg = (f"{name} ({method}): mean photon {img.mean():.5f} vs cycles {ref.mean():.5f} "
           f"({100 * diff:+.2f} %), 4x4-block relMSE {err:.5f}")
    print(msg)
    assert abs(diff) <= MEAN_TOL, msg
    assert err <= BLOCK_RELMSE_MAX, msg
