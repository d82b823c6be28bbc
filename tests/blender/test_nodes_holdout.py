"""Blender's Holdout shader (issue 19) against Cycles through the add-on: where the camera sees
a Holdout the image is black and, with a transparent film, its alpha 0; other rays meet it as
a black surface (it casts a shadow, reflects nothing). (Cycles also writes alpha 0 there with
an opaque film, where Photon writes 1: the pre-flight report says so.)

The scene, 32x32: a diffuse floor with a Checker under a sun, and a holdout quad above it
covering part of the view and shadowing part of the floor. RGB with the lit criterion (mean
within 2 %, relMSE <= 0.01); alpha within 0.02 of Cycles' on average (edge pixels differ by
their anti-aliasing), 0 on the quad and 1 on the floor.
"""

import bpy
import numpy as np
import pytest

import common
from cycles_compare import compare
from helpers import read_exr
from test_nodes import node_material, plane_scene
from test_nodes_refraction import checker_floor


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_holdout_quad_over_a_lit_floor(tmp_path, method):
    mat, tree = node_material("Holdout")
    holdout = tree.nodes.new("ShaderNodeHoldout")
    tree.links.new(holdout.outputs["Holdout"], tree.nodes["Material Output"].inputs["Surface"])
    scene, _ = plane_scene(checker_floor())
    common.quad("Hole", [(-0.7, -0.5, 0.5), (0.3, -0.5, 0.5), (0.3, 0.4, 0.5),
                         (-0.7, 0.4, 0.5)], mat)
    common.light("Sun", "SUN", (0, 0, 5), (30.0, 0.0, 60.0), energy=3.0)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.2, 0.2, 0.25, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    name = f"holdout {method.lower()}"
    compare(name, scene, tmp_path, photon_spp=256, cycles_spp=512, method=method)
    # `compare` writes RGB with an opaque film: the alpha of each engine again, in RGBA with
    # a transparent film.
    scene.render.image_settings.color_mode = "RGBA"
    scene.render.film_transparent = True
    alpha = {}
    for engine in ("CYCLES", "PHOTON"):
        path = tmp_path / f"{name}_{engine.lower()}_alpha.exr"
        scene.render.engine = engine
        scene.render.filepath = str(path)
        bpy.ops.render.render(write_still=True)
        alpha[engine] = read_exr(path, ("R", "G", "B", "A"))[:, :, 3]
    photon, cycles = alpha["PHOTON"], alpha["CYCLES"]
    print(f"{name}: alpha mean photon {photon.mean():.4f} vs cycles {cycles.mean():.4f}")
    assert (photon == 0.0).sum() > 100, "the quad should leave a hole in the alpha"
    assert (photon == 1.0).sum() > 100, "the floor should stay opaque"
    assert np.abs(photon - cycles).mean() < 0.02


def test_holdout_with_an_opaque_film_is_reported():
    """The pre-flight report names a Holdout seen with an opaque film (Photon writes alpha 1
    there, Cycles 0), and says nothing of it with a transparent film."""
    from blender_addon import preflight
    mat, tree = node_material("Hole")
    holdout = tree.nodes.new("ShaderNodeHoldout")
    tree.links.new(holdout.outputs["Holdout"], tree.nodes["Material Output"].inputs["Surface"])
    scene, _ = plane_scene(mat)
    scene.render.film_transparent = False
    opaque = preflight.unsupported_features(scene, list(scene.objects))
    assert [m for m in opaque if "material 'Hole'" in m and "Holdout" in m], opaque
    scene.render.film_transparent = True
    assert preflight.unsupported_features(scene, list(scene.objects)) == []
