"""The Metallic BSDF (Blender 4.3+) against Cycles through the add-on: a rough metal sphere
under a point lamp in a grey world (test_principled_layers' sphere scene, 48x48), its Fresnel
the F82 tint model (a base colour and an edge tint) or a physical conductor (copper's complex
index, which Photon gives to the same model by its exact values at 0° and 82°), and an
anisotropic one. Mean within 1 % of Cycles', relMSE over 4x4-pixel blocks <= 1e-3.
"""

import bpy
import pytest

from test_nodes_object import matches_cycles
from test_principled_layers import reset, sphere_scene

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def shader_on_a_fresh_material(name, node_type):
    """A fresh scene and a material whose surface is one new node of `node_type`."""
    reset()
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    shader = nodes.new(node_type)
    mat.node_tree.links.new(shader.outputs["BSDF"], nodes["Material Output"].inputs["Surface"])
    return mat, shader


@pytest.mark.parametrize("fresnel, anisotropy", [("F82", 0.0), ("PHYSICAL_CONDUCTOR", 0.0),
                                                 ("F82", 0.6)])
def test_metallic_sphere_under_a_lamp(tmp_path, fresnel, anisotropy):
    mat, metal = shader_on_a_fresh_material(f"Metal {fresnel}", "ShaderNodeBsdfMetallic")
    metal.fresnel_type = fresnel
    values = {"Base Color": (0.9, 0.55, 0.2, 1.0), "Edge Tint": (0.5, 0.7, 0.9, 1.0),
              "IOR": (0.27, 0.68, 1.32), "Extinction": (3.61, 2.63, 2.29), "Roughness": 0.35,
              "Anisotropy": anisotropy}
    for socket in metal.inputs:  # those the other Fresnel type hides are not found by name
        if socket.identifier in values:
            socket.default_value = values[socket.identifier]
    scene = sphere_scene(mat)
    matches_cycles(f"metallic {fresnel.lower()} anisotropy {anisotropy}", scene, tmp_path,
                   spp=512)
