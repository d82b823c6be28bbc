"""Hair BSDFs on curves against Cycles through the add-on (path tracer): a patch of a few
hundred hair curves (test_points_curves' Curves object, Cycles' round 3D curves) over a grey
floor under a sun and a dim world, the camera close. The Principled Hair BSDF (Chiang model)
with Melanin Concentration 0.8 and with Direct Coloring, and the Hair BSDF's Reflection and
Transmission. Photon renders each curve as an 8-sided tube enlarged to the curve's mean width
(blender_addon/points_curves.py), the fibre's offset h taken from the tube's smooth normal.
"""

import pytest

import common
from cycles_compare import compare
from test_points_curves import hair, lit_floor

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def hair_material(name, node_type):
    """A material whose surface is one `node_type` node; returns (material, node)."""
    import bpy

    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    node = tree.nodes.new(node_type)
    tree.links.new(node.outputs["BSDF"], tree.nodes["Material Output"].inputs["Surface"])
    return mat, node


def hair_scene(material):
    """The lit floor (made first: `lit_floor` clears the file, so `material` is made by a
    function) with a close camera over a patch of 400 strands of `material()`."""
    scene = lit_floor()
    scene.render.resolution_x, scene.render.resolution_y = 64, 48
    scene.cycles_curves.shape = "THICK"
    scene.camera.location = (0.0, -2.2, 1.6)
    hair("Fur", material(), strands=400, radius=0.012)
    return scene


@pytest.mark.parametrize("parametrization", ["MELANIN", "COLOR"])
def test_principled_hair_on_curves(tmp_path, parametrization):
    def material():
        mat, node = hair_material(f"Hair {parametrization}", "ShaderNodeBsdfHairPrincipled")
        node.model = "CHIANG"
        # Unavailable sockets are not found by name: set each in its parametrization.
        node.parametrization = "MELANIN"
        node.inputs["Melanin"].default_value = 0.8
        node.parametrization = "COLOR"
        node.inputs["Color"].default_value = (0.45, 0.22, 0.08, 1.0)
        node.parametrization = parametrization
        return mat

    compare(f"principled hair {parametrization.lower()}", hair_scene(material), tmp_path,
            photon_spp=256, cycles_spp=1024)


@pytest.mark.parametrize("component", ["Reflection", "Transmission"])
def test_hair_bsdf_on_curves(tmp_path, component):
    def material():
        mat, node = hair_material(f"Hair BSDF {component}", "ShaderNodeBsdfHair")
        node.component = component
        node.inputs["Color"].default_value = (0.7, 0.45, 0.25, 1.0)
        node.inputs["RoughnessU"].default_value = 0.2
        node.inputs["RoughnessV"].default_value = 0.5
        return mat

    compare(f"hair bsdf {component.lower()}", hair_scene(material), tmp_path,
            photon_spp=256, cycles_spp=1024)
