"""Blender's Holdout shader against Cycles through the add-on: where the camera sees
a Holdout the image is black and its alpha 0, with a transparent film and with an opaque one;
other rays meet it as a black surface (it casts a shadow, reflects nothing).

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
from test_nodes import SIZE, node_material, plane_scene
from test_nodes_refraction import checker_floor

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s


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
    # `compare` writes RGB: the alpha of each engine again, in RGBA, with a transparent and
    # with an opaque film (the world seen where the quad is not: alpha 1 there).
    for transparent in (True, False):
        scene.render.film_transparent = transparent
        photon, cycles = _alpha_of_each_engine(scene, tmp_path, f"{name} {transparent}")
        print(f"{name}, transparent film {transparent}: alpha mean photon {photon.mean():.4f} "
              f"vs cycles {cycles.mean():.4f}")
        assert (photon == 0.0).sum() > 100, "the quad should leave a hole in the alpha"
        assert (photon == 1.0).sum() > 100, "the floor should stay opaque"
        assert np.abs(photon - cycles).mean() < 0.02


def _alpha_of_each_engine(scene, tmp_path, name):
    """Each engine's alpha (RGBA render with the scene's film) by engine name."""
    scene.render.image_settings.color_mode = "RGBA"
    alpha = {}
    for engine in ("CYCLES", "PHOTON"):
        path = tmp_path / f"{name}_{engine.lower()}_alpha.exr"
        scene.render.engine = engine
        scene.render.filepath = str(path)
        bpy.ops.render.render(write_still=True)
        alpha[engine] = read_exr(path, ("R", "G", "B", "A"))[:, :, 3]
    return alpha["PHOTON"], alpha["CYCLES"]


@pytest.mark.parametrize("how", ["object", "collection"])
def test_holdout_object_over_a_lit_floor(tmp_path, how):
    """A red diffuse quad held out (Object > Visibility > Holdout, or a holdout collection):
    black with alpha 0 where the camera sees it, its red material to every other ray (its
    shadow and red light on the floor), as Cycles renders it, with an opaque film."""
    common.reset_scene(SIZE, SIZE)
    scene, _ = plane_scene(checker_floor())
    red = common.principled("Red", (0.8, 0.1, 0.1), roughness=1.0)
    quad = common.quad("Hole", [(-0.7, -0.5, 0.5), (0.3, -0.5, 0.5), (0.3, 0.4, 0.5),
                                (-0.7, 0.4, 0.5)], red)
    if how == "object":
        quad.is_holdout = True
    else:
        held = bpy.data.collections.new("Held")
        scene.collection.children.link(held)
        for c in list(quad.users_collection):
            c.objects.unlink(quad)
        held.objects.link(quad)
        scene.view_layers[0].layer_collection.children["Held"].holdout = True
    common.light("Sun", "SUN", (0, 0, 5), (30.0, 0.0, 60.0), energy=3.0)
    name = f"holdout {how}"
    compare(name, scene, tmp_path, photon_spp=256, cycles_spp=512, method="PATH")
    photon, cycles = _alpha_of_each_engine(scene, tmp_path, name)
    print(f"{name}: alpha mean photon {photon.mean():.4f} vs cycles {cycles.mean():.4f}")
    assert (photon == 0.0).sum() > 100, "the quad should leave a hole in the alpha"
    assert np.abs(photon - cycles).mean() < 0.02
