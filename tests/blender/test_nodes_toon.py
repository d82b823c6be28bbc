"""The Toon BSDF against Cycles through the add-on (path tracer): a sphere under a point lamp
in a grey world (test_principled_layers' sphere scene, 48x48), its Diffuse and Glossy
components with a soft edge. Mean within 1 % of Cycles', relMSE over 4x4-pixel blocks
<= 1e-3.
"""

import pytest

from test_nodes_metallic import shader_on_a_fresh_material
from test_nodes_object import matches_cycles
from test_principled_layers import sphere_scene

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


@pytest.mark.parametrize("component, size, smooth", [("DIFFUSE", 0.5, 0.1),
                                                     ("GLOSSY", 0.2, 0.15)])
def test_toon_sphere_under_a_lamp(tmp_path, component, size, smooth):
    mat, toon = shader_on_a_fresh_material(f"Toon {component}", "ShaderNodeBsdfToon")
    toon.component = component
    toon.inputs["Color"].default_value = (0.9, 0.4, 0.2, 1.0)
    toon.inputs["Size"].default_value = size
    toon.inputs["Smooth"].default_value = smooth
    scene = sphere_scene(mat)
    matches_cycles(f"toon {component.lower()}", scene, tmp_path, spp=512)
