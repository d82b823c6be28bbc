"""Volume set-ups users build, beyond the single media of test_volumes.py, against Cycles
through the add-on, 32x32: Photon's path tracer at 128 spp against Cycles at 512, mean within 2 %
and relMSE <= 0.01 (`cycles_compare.compare`). Volume bounces stay at Blender's default, 0.

- fog lit by the world alone (a uniform background around a fog box), seen from outside and
  with the camera inside the fog: the light the fog scatters from the world, whose
  phase-sampled rays leave the fog through its boundary (a surface that lets them through);
- glass holding a liquid (a Glass BSDF surface with Volume Absorption inside), and with a
  scattering Principled Volume inside (jelly);
- fog containing that liquid glass, under a point light (nested media);
- a Mix Shader of Volume Scatter and Volume Absorption by a Gradient Texture;
- a Principled Volume glowing by Blackbody (temperature 1500 K);
- a Principled Volume of different scattering and absorption colours that also emits;
- a smoke cube repeated by an Array modifier, and a fog cube instanced three times by
  collection instances (Empties), turned;
- a cloud lit from behind through a negative anisotropy (back scattering);
- ground fog: a fog cube that the floor cuts through.
"""

import bpy
import pytest

import common
from cycles_compare import compare
import volume_scenes
from volume_scenes import cube, shader_material, sphere, sun, volume_material

SIZE = 32

pytestmark = pytest.mark.slow


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def floor_scene(world=0.05, cam=((0.0, -4.0, 3.0), (53.0, 0.0, 0.0))):
    """A fresh scene of this file's size (`volume_scenes.floor_scene`)."""
    return volume_scenes.floor_scene(SIZE, world, cam)


def glass_volume_material(name, volume_kind, **volume_inputs):
    """A Glass BSDF (IOR 1.33) surface with a `volume_kind` node into the Volume socket."""
    mat, _ = shader_material(name, "ShaderNodeBsdfGlass", "Surface", IOR=1.33)
    tree = mat.node_tree
    volume = tree.nodes.new(volume_kind)
    for key, value in volume_inputs.items():
        volume.inputs[key].default_value = value
    tree.links.new(volume.outputs[0], tree.nodes["Material Output"].inputs["Volume"])
    return mat


SCENES = {}


def scene(build):
    SCENES[build.__name__] = build
    return build


@scene
def glass_holding_liquid():
    s = floor_scene()
    mat = glass_volume_material("Liquid glass", "ShaderNodeVolumeAbsorption",
                                Color=(0.2, 0.6, 0.9, 1.0), Density=2.0)
    sphere("Liquid", mat, 0.8, (0.0, 0.0, 0.8))
    sun()
    return s


@scene
def jelly_scatter_in_glass():
    s = floor_scene()
    mat = glass_volume_material("Jelly", "ShaderNodeVolumePrincipled", Density=3.0,
                                Color=(0.9, 0.5, 0.3, 1.0))
    sphere("Jelly", mat, 0.8, (0.0, 0.0, 0.8))
    sun()
    return s


@scene
def fog_containing_liquid_glass():
    s = floor_scene(world=0.0)
    fog, _ = volume_material("Fog", "ShaderNodeVolumeScatter", Density=0.15)
    cube("Fog", fog, 5.0, (0.0, 0.0, 2.49))
    mat = glass_volume_material("Liquid glass", "ShaderNodeVolumeAbsorption",
                                Color=(0.9, 0.4, 0.2, 1.0), Density=1.0)
    sphere("Liquid", mat, 0.6, (0.0, 0.0, 0.8))
    common.light("Lamp", "POINT", (0.8, 0.3, 3.0), energy=400.0)
    return s


@scene
def mix_scatter_absorption_gradient():
    s = floor_scene()
    mat = bpy.data.materials.new("Mix")
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    t = mat.node_tree
    t.nodes.remove(t.nodes["Principled BSDF"])
    a = t.nodes.new("ShaderNodeVolumeScatter")
    a.inputs["Density"].default_value = 2.0
    b = t.nodes.new("ShaderNodeVolumeAbsorption")
    b.inputs["Density"].default_value = 2.0
    b.inputs["Color"].default_value = (0.9, 0.3, 0.1, 1.0)
    g = t.nodes.new("ShaderNodeTexGradient")
    m = t.nodes.new("ShaderNodeMixShader")
    t.links.new(g.outputs["Fac"], m.inputs[0])
    t.links.new(a.outputs[0], m.inputs[1])
    t.links.new(b.outputs[0], m.inputs[2])
    t.links.new(m.outputs[0], t.nodes["Material Output"].inputs["Volume"])
    cube("Mix", mat, 1.2, (0.0, 0.0, 0.8))
    sun()
    return s


@scene
def blackbody_principled_volume():
    s = floor_scene(world=0.0)
    mat, _ = volume_material("Fire", "ShaderNodeVolumePrincipled", Density=1.0,
                             **{"Blackbody Intensity": 1.0, "Temperature": 1500.0})
    sphere("Fire", mat, 0.8, (0.0, 0.0, 1.0))
    return s


@scene
def array_modifier_smoke():
    s = floor_scene()
    mat, _ = volume_material("Smoke", "ShaderNodeVolumePrincipled", Density=1.5)
    obj = cube("Smoke", mat, 0.6, (-1.0, 0.0, 0.5))
    arr = obj.modifiers.new("Array", "ARRAY")
    arr.count = 3
    arr.relative_offset_displace = (1.5, 0.0, 0.0)
    sun()
    return s


@scene
def backlit_negative_anisotropy():
    s = floor_scene(world=0.0)
    mat, _ = volume_material("Cloud", "ShaderNodeVolumePrincipled", Density=1.0, Anisotropy=-0.6)
    cube("Cloud", mat, 1.2, (0.0, 0.0, 0.8))
    common.light("Lamp", "POINT", (0.0, 2.5, 1.0), energy=500.0)
    return s


@scene
def principled_volume_colours_emission():
    s = floor_scene()
    mat, _ = volume_material("Coloured", "ShaderNodeVolumePrincipled", Density=1.5,
                             Color=(0.2, 0.8, 0.3, 1.0),
                             **{"Absorption Color": (0.8, 0.2, 0.2, 1.0),
                                "Emission Strength": 0.3,
                                "Emission Color": (0.2, 0.3, 1.0, 1.0)})
    cube("Coloured", mat, 1.2, (0.0, 0.0, 0.8))
    sun()
    return s


@scene
def smoke_through_floor():
    s = floor_scene()
    mat, _ = volume_material("Ground fog", "ShaderNodeVolumeScatter", Density=1.0)
    cube("Ground fog", mat, 2.0, (0.0, 0.0, 0.3))
    sun()
    return s


@scene
def collection_instanced_fog():
    s = floor_scene()
    coll = bpy.data.collections.new("FogProto")
    mat, _ = volume_material("Fog", "ShaderNodeVolumeScatter", Density=2.0)
    proto = cube("Proto", mat, 0.7, (0.0, 0.0, 0.0))
    for c in list(proto.users_collection):
        c.objects.unlink(proto)
    coll.objects.link(proto)
    for i, x in enumerate((-1.0, 0.0, 1.0)):
        e = bpy.data.objects.new(f"Inst{i}", None)
        e.instance_type = "COLLECTION"
        e.instance_collection = coll
        e.location = (x, 0.0, 0.5 + 0.2 * i)
        e.rotation_euler = (0.0, 0.0, 0.4 * i)
        common.link(e)
    sun()
    return s


@pytest.mark.parametrize("name", list(SCENES))
def test_volume_setup(tmp_path, name):
    compare(name, SCENES[name](), tmp_path, photon_spp=128, cycles_spp=512)


@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
@pytest.mark.parametrize("inside", [False, True], ids=["outside", "inside"])
def test_fog_lit_by_the_world(tmp_path, method, inside):
    """A 5 m fog box (Volume Scatter, density 0.2) on the floor under a white world of strength
    1, no lamp; the camera outside the box or inside it. The path tracer weighs each light
    sample in the fog against the phase-sampled ray from there, which must go on through the
    box's boundary to the world even after the path's last volume bounce (it read 23 % dark
    from outside and 40 % from inside while such a ray ended at the boundary)."""
    cam = ((0.0, -2.0, 1.5), (75.0, 0.0, 0.0)) if inside else ((0.0, -9.0, 4.0), (75.0, 0.0, 0.0))
    s = floor_scene(world=1.0, cam=cam)
    mat, _ = volume_material("Fog", "ShaderNodeVolumeScatter", Density=0.2)
    cube("Fog", mat, 5.0, (0.0, 0.0, 2.49))
    compare(f"world-lit fog {method.lower()} {'inside' if inside else 'outside'}", s, tmp_path,
            photon_spp=128 if method == "PATH" else 32, cycles_spp=512, method=method)
