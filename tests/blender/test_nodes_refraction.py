"""Blender's Refraction BSDF against Cycles through the add-on: the glass's
transmission lobe alone, of its colour, without Fresnel (nothing reflected; nothing passes at
total internal reflection), smooth or GGX-rough.

A tinted slab of it (rotated, so its sides show) over a checker floor lit by a grey world (no
sun: the sun's caustics through the slab, which Cycles finds as rare fireflies, are not what
is compared), 32x32, the lit criterion (mean within 2 %, relMSE <= 0.01, `cycles_compare.compare`),
smooth and rough by the path tracer and by photon mapping. The rough slabs by photon mapping
rendered +2.3 % (Refraction) and +9.6 % (Glass) too bright, relMSE 0.066 at 512 spp in 16 s:
photons stored on the slab's faces inside the glass kept the flux the camera paths' BSDF gives
them where its adjoint scales it by 1/eta^2, and were read through the narrow refraction lobe.
Photons inside a medium are now scaled (`tracing::adjoint_scale`) and dielectrics without a
Lambertian part are ray traced at any roughness (`classify`): -0.1 %, relMSE 0.0008 at 512 spp
(docs/bench/photon_method.md, "Photons inside glass").
"""

import bpy
import pytest

import common
from cycles_compare import compare
from test_nodes import node_material, plane_scene


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def checker_floor():
    mat = bpy.data.materials.new("Floor")
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    tree = mat.node_tree
    bsdf = tree.nodes["Principled BSDF"]
    bsdf.inputs["Roughness"].default_value = 1.0
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = 5.0
    checker.inputs["Color1"].default_value = (0.8, 0.8, 0.8, 1.0)
    checker.inputs["Color2"].default_value = (0.1, 0.15, 0.3, 1.0)
    tree.links.new(checker.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def slab_over_a_checker_floor(node_type, roughness):
    """The scene: a tinted slab of a `node_type` BSDF (GGX) of `roughness` and IOR 1.45."""
    mat, tree = node_material(f"{node_type} {roughness}")
    bsdf = tree.nodes.new(node_type)
    bsdf.distribution = "GGX"
    bsdf.inputs["Color"].default_value = (0.9, 0.75, 0.5, 1.0)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["IOR"].default_value = 1.45
    tree.links.new(bsdf.outputs["BSDF"], tree.nodes["Material Output"].inputs["Surface"])
    scene, _ = plane_scene(checker_floor())
    common.box("Slab", (1.1, 1.1, 0.35), mat, (0.0, 0.0, 0.45), 25.0)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    return scene


# The slabs by photon mapping at 128 spp (2.2-2.7 s; 512 spp took 10-14 s, most of it photon
# tracing for the 8 generations of maps): relMSE 0.0015 (smooth Refraction), 0.0021 (rough
# Refraction) and 0.0024 (rough Glass) against 8192-spp Cycles images, so a bound of three
# times the noise.
PHOTON_BUDGET = dict(photon_spp=128, relmse_max=0.008)


@pytest.mark.slow
@pytest.mark.parametrize("roughness,method", [(0.0, "PATH"), (0.3, "PATH"), (0.0, "PHOTON"),
                                              (0.3, "PHOTON")])
def test_refraction_slab_over_a_checker_floor(tmp_path, roughness, method):
    scene = slab_over_a_checker_floor("ShaderNodeBsdfRefraction", roughness)
    budget = PHOTON_BUDGET if method == "PHOTON" else dict(photon_spp=512)
    compare(f"refraction slab {roughness} {method.lower()}", scene, tmp_path, cycles_spp=1024,
            method=method, **budget)


@pytest.mark.slow
@pytest.mark.parametrize("roughness,method", [(0.0, "PATH"), (0.3, "PATH"), (0.3, "PHOTON")])
def test_tinted_glass_slab_over_a_checker_floor(tmp_path, roughness, method):
    """The Glass BSDF beside it (GGX): its colour weighs the reflection and each crossing
    alike (it tinted the transmission by the colour's square root before: +24.7 % here,
    smooth)."""
    scene = slab_over_a_checker_floor("ShaderNodeBsdfGlass", roughness)
    budget = PHOTON_BUDGET if method == "PHOTON" else dict(photon_spp=512)
    compare(f"glass slab {roughness} {method.lower()}", scene, tmp_path, cycles_spp=1024,
            method=method, **budget)


def test_beckmann_refraction_is_not_evaluated_and_reported():
    """Photon's microfacets are GGX: a Refraction BSDF with Beckmann's distribution keeps the
    tree off PHOTON_material_nodes, and the pre-flight report names the node; GGX is
    evaluated and reported by nothing."""
    from blender_addon import preflight
    from blender_addon.node_tree import material_nodes
    mat, tree = node_material("Beckmann")
    refraction = tree.nodes.new("ShaderNodeBsdfRefraction")
    tree.links.new(refraction.outputs["BSDF"], tree.nodes["Material Output"].inputs["Surface"])
    scene, _ = plane_scene(mat)
    refraction.distribution = "GGX"
    assert material_nodes(mat)[0] is not None
    assert preflight.unsupported_features(scene, list(scene.objects)) == []
    refraction.distribution = "BECKMANN"
    extension, problems = material_nodes(mat)
    assert extension is None and problems, problems
    messages = preflight.unsupported_features(scene, list(scene.objects))
    assert [m for m in messages if refraction.name in m], messages
