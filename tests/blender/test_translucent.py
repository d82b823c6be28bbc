"""Blender's Translucent BSDF against Cycles through the add-on: Lambertian
transmission, f = colour / pi on the side of the surface away from the light.

Every scene is 32x32 under a black world, the lit criterion (mean within 2 %, relMSE <= 0.01,
`cycles_compare.compare`), by the path tracer and by photon mapping (which stores photons on
the translucent surface from both sides and scatters them through the same lobe):

- a thin translucent plane seen from above, lit only from below: by a sun (a box under the
  plane casts a shadow the camera sees through it) and by an area light pointing up;
- a leaf: a Mix Shader of a green Diffuse BSDF and a yellow Translucent BSDF, a small square
  over a white floor under a slanting sun, so the camera sees the leaf's reflection and, beside
  it, the floor in the leaf's shadow, lit by the light the leaf lets through.
"""

import pytest

import common
from cycles_compare import compare
from test_nodes import node_material, plane_scene

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def translucent_into_output(tree, colour):
    translucent = tree.nodes.new("ShaderNodeBsdfTranslucent")
    translucent.inputs["Color"].default_value = colour
    tree.links.new(translucent.outputs["BSDF"],
                   tree.nodes["Material Output"].inputs["Surface"])
    return translucent


@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
@pytest.mark.parametrize("light", ["SUN", "AREA"])
def test_translucent_plane_lit_from_behind(tmp_path, light, method):
    mat, tree = node_material("Translucent")
    translucent_into_output(tree, (0.9, 0.6, 0.3, 1.0))
    scene, _ = plane_scene(mat)
    if light == "SUN":
        # Pointing up and slanting; the box's shadow on the plane's underside shows through.
        common.light("Sun", "SUN", (0, 0, -2), (160.0, 0.0, 20.0), energy=3.0)
        grey = common.principled("Box", (0.5, 0.5, 0.5), roughness=1.0)
        common.box("Box", (0.5, 0.5, 0.3), grey, (0.2, -0.1, -0.8), 20.0)
    else:
        common.light("Area", "AREA", (0.3, 0.0, -0.8), (180.0, 0.0, 0.0), energy=60.0,
                     size=0.8)
    compare(f"translucent plane {light.lower()} {method.lower()}", scene, tmp_path,
            photon_spp=256, cycles_spp=512, method=method)


@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_leaf_of_diffuse_and_translucent_over_a_floor(tmp_path, method):
    mat, tree = node_material("Leaf")
    diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (0.15, 0.5, 0.1, 1.0)
    translucent = tree.nodes.new("ShaderNodeBsdfTranslucent")
    translucent.inputs["Color"].default_value = (0.6, 0.8, 0.2, 1.0)
    mix = tree.nodes.new("ShaderNodeMixShader")
    mix.inputs["Fac"].default_value = 0.45
    tree.links.new(diffuse.outputs["BSDF"], mix.inputs[1])
    tree.links.new(translucent.outputs["BSDF"], mix.inputs[2])
    tree.links.new(mix.outputs["Shader"], tree.nodes["Material Output"].inputs["Surface"])
    floor = common.principled("Floor", (0.8, 0.8, 0.8), roughness=1.0)
    scene, _ = plane_scene(floor)
    h = 0.45
    common.quad("Leaf", [(-h, -h, 0.4), (h, -h, 0.4), (h, h, 0.4), (-h, h, 0.4)], mat)
    common.light("Sun", "SUN", (0, 0, 3), (35.0, 0.0, 30.0), energy=3.0)
    compare(f"leaf {method.lower()}", scene, tmp_path, photon_spp=256, cycles_spp=512,
            method=method)
