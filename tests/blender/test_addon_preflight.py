"""Nothing the export drops is silent. Rendering through `bpy.ops.render.render()` with Photon,
from both export routes (in process, and the background Blender the UI uses), every feature the
export cannot carry gives one WARNING report naming the material, node or object, the glTF
exporter's own warnings are reported too, and the final status line counts them; a scene that
renders fully gives none. In background mode Blender prints reports ("Warning: ...") and the
status line ("Fra:1 ... | Photon: ..." in Blender 4, "Photon: ..." in Blender 5) on stdout,
which is what these tests read.

The pre-flight rules not covered by the renders (Volume objects, lights, cameras)
are checked on `preflight.unsupported_features` directly.
"""

import math
import re

import bpy
import pytest

from helpers import photon_binary

ROUTES = ("inprocess", "subprocess")


@pytest.fixture
def scene(photon_addon, tmp_path):
    photon_binary()
    bpy.ops.wm.read_factory_settings()
    scene = bpy.context.scene
    scene.render.engine = "PHOTON"
    scene.render.resolution_x, scene.render.resolution_y = 32, 18
    scene.render.resolution_percentage = 100
    scene.photon.samples = 2
    # The default scene carries everything; an area light too (through PHOTON_light, although
    # the glTF exporter itself says "Unsupported light source AREA").
    area = bpy.data.lights.new("Panel", "AREA")
    area.energy = 50.0
    obj = bpy.data.objects.new("Panel", area)
    obj.location = (0.0, 0.0, 3.0)
    scene.collection.objects.link(obj)
    return scene


def render_warnings(capfd, route, monkeypatch) -> tuple[list[str], str]:
    """Render; return the WARNING reports (without the "Photon: " prefix) and the final status
    line."""
    monkeypatch.setenv("PHOTON_EXPORT", route)
    capfd.readouterr()
    bpy.ops.render.render()
    out = capfd.readouterr().out
    warnings = re.findall(r"^Warning: Photon: (.*)$", out, flags=re.M)
    # Blender 4 prints the status line after the frame's statistics ("Fra:1 ... | Photon:"),
    # Blender 5 alone ("Photon: 32x18, ...").
    status = [line for line in out.splitlines()
              if re.match(r"(.*\| )?Photon: \d+x\d+, ", line)]
    assert status, out[-2000:]
    return warnings, status[-1]


def add_unsupported_features(scene):
    """A Particle Info node (a node Photon does not evaluate: Noise, for one, it does)
    into the cube's base colour, a second cube whose volume's density is one too (volume
    trees are evaluated with the nodes surface trees have), and a particle
    system on the cube rendered as halos (hair particles are carried: points_curves.py)."""
    cube = bpy.data.objects["Cube"]
    tree = cube.active_material.node_tree
    noise = tree.nodes.new("ShaderNodeParticleInfo")
    noise.name = "Clouds"
    tree.links.new(noise.outputs["Random"], tree.nodes["Principled BSDF"].inputs["Base Color"])

    smoke = bpy.data.objects.new("Smoke", cube.data.copy())
    smoke.location = (3.0, 0.0, 0.0)
    scene.collection.objects.link(smoke)
    fog = bpy.data.materials.new("Fog")
    fog.use_nodes = True
    nodes = fog.node_tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    volume = nodes.new("ShaderNodeVolumeScatter")
    wisps = nodes.new("ShaderNodeParticleInfo")
    wisps.name = "Wisps"
    fog.node_tree.links.new(wisps.outputs["Random"], volume.inputs["Density"])
    fog.node_tree.links.new(volume.outputs["Volume"], nodes["Material Output"].inputs["Volume"])
    smoke.data.materials.clear()
    smoke.data.materials.append(fog)

    cube.modifiers.new("Sparks", "PARTICLE_SYSTEM")
    cube.particle_systems[0].name = "Sparks"
    cube.particle_systems[0].settings.type = "EMITTER"
    cube.particle_systems[0].settings.render_type = "HALO"
    cube.particle_systems[0].settings.count = 50


@pytest.mark.parametrize("route", ROUTES)
def test_plain_scene_gives_no_warning(scene, capfd, monkeypatch, route):
    warnings, status = render_warnings(capfd, route, monkeypatch)
    assert warnings == [], warnings
    assert "warning" not in status, status


@pytest.mark.parametrize("route", ROUTES)
def test_each_unsupported_feature_gives_one_warning(scene, capfd, monkeypatch, route):
    add_unsupported_features(scene)
    warnings, status = render_warnings(capfd, route, monkeypatch)
    expected = {
        "node": lambda w: "material 'Material'" in w and "Particle Info node 'Clouds'" in w,
        "volume": lambda w: "material 'Fog'" in w and "Particle Info node 'Wisps'" in w,
        "halos": lambda w: "object 'Cube'" in w and "'Sparks' rendered as HALO" in w,
    }
    for feature, matches in expected.items():
        hits = [w for w in warnings if matches(w)]
        assert len(hits) == 1, f"{feature}: {len(hits)} warnings in {warnings}"
    assert len(warnings) == len(expected), warnings
    assert "3 warnings" in status, status


@pytest.mark.parametrize("route", ROUTES)
def test_gltf_exporter_warnings_are_reported(scene, capfd, monkeypatch, route):
    """An object whose mesh has no faces: the glTF exporter drops it with a warning, which the
    background Blender route used to print to a discarded stdout."""
    empty = bpy.data.objects.new("Nothing", bpy.data.meshes.new("NoFaces"))
    scene.collection.objects.link(empty)
    warnings, status = render_warnings(capfd, route, monkeypatch)
    assert len(warnings) == 1, warnings
    assert warnings[0].startswith("glTF exporter: ") and "'NoFaces'" in warnings[0], warnings
    assert "1 warning " in status, status


def messages_for(scene):
    from blender_addon import preflight
    return preflight.unsupported_features(scene, list(scene.objects))


def test_other_rules(photon_addon):
    """Volume objects (Curves objects are carried), light settings and camera settings, one
    message each; the default tree of a light with nodes, an Emission node's strength and an
    area light's spread (all carried) give none."""
    bpy.ops.wm.read_factory_settings()
    scene = bpy.context.scene
    assert messages_for(scene) == []

    light = bpy.data.objects["Light"].data
    light.use_nodes = True
    assert messages_for(scene) == [], "a light's default node tree changes nothing"
    light.node_tree.nodes["Emission"].inputs["Strength"].default_value = 2.0
    assert messages_for(scene) == [], "an Emission node's strength and colour are carried"
    tree = light.node_tree
    tree.links.new(tree.nodes.new("ShaderNodeWavelength").outputs["Color"],
                   tree.nodes["Emission"].inputs["Color"])
    area = bpy.data.lights.new("Narrow", "AREA")
    area.spread = math.radians(30.0)  # carried (PHOTON_light spread): no message
    scene.collection.objects.link(bpy.data.objects.new("Narrow", area))
    scene.collection.objects.link(bpy.data.objects.new("Cloud", bpy.data.volumes.new("Cloud")))
    # Carried as tubes (points_curves.py): no message.
    scene.collection.objects.link(bpy.data.objects.new("Fur", bpy.data.hair_curves.new("Fur")))
    scene.camera.data.dof.use_dof = True  # carried (PHOTON_camera): no message
    scene.camera.data.type = "CUSTOM"
    bpy.data.objects["Cube"].visible_shadow = False  # carried (PHOTON_object)
    bpy.data.objects["Cube"].visible_glossy = False

    messages = messages_for(scene)
    expected = ("light 'Light': the Wavelength node",
                "Volume object 'Cloud' is not rendered: it has no OpenVDB file",
                "camera 'Camera': Cycles' custom (OSL) camera",
                "object 'Cube': ray visibility")
    for start in expected:
        assert sum(m.startswith(start) for m in messages) == 1, (start, messages)
    assert len(messages) == len(expected), messages


def test_volume_settings_photon_does_not_use_are_named(photon_addon):
    """A smoke domain without baked data (it renders nothing, as in Cycles), a Volume Step Rate
    other than 1 (Photon tracks volumes without steps): one message each."""
    bpy.ops.wm.read_factory_settings()
    scene = bpy.context.scene
    domain = bpy.data.objects["Cube"].modifiers.new("Fluid", "FLUID")
    domain.fluid_type = "DOMAIN"
    scene.cycles.volume_step_rate = 4.0
    assert len(messages_for(scene)) == 2, messages_for(scene)
    expected = ("fluid domain 'Cube': no smoke or fire is rendered: it has no baked data",
                "render settings: Volume Step Rate 4")
    for start in expected:
        assert sum(m.startswith(start) for m in messages_for(scene)) == 1, messages_for(scene)


def test_indirect_only_is_named_and_holdouts_are_carried(photon_addon):
    """'Indirect only' collections are not carried (named); holdout objects and collections
    are (nothing said, and PHOTON_object says "holdout" for their objects)."""
    bpy.ops.wm.read_factory_settings()
    scene = bpy.context.scene
    bpy.data.objects["Cube"].is_holdout = True
    for name in ("Held", "Indirect", "Gone"):
        scene.collection.children.link(bpy.data.collections.new(name))
    layers = scene.view_layers[0].layer_collection.children
    layers["Held"].holdout = True
    layers["Indirect"].indirect_only = True
    layers["Gone"].exclude = True
    layers["Gone"].holdout = True  # excluded: nothing of it renders
    inner = bpy.data.collections.new("Inner")
    bpy.data.collections["Held"].children.link(inner)
    bpy.ops.mesh.primitive_uv_sphere_add()
    ball = bpy.context.active_object
    for c in list(ball.users_collection):
        c.objects.unlink(ball)
    inner.objects.link(ball)  # held out through its parent collection
    bpy.ops.mesh.primitive_cone_add()
    free = bpy.context.active_object  # in the scene's own collection
    from blender_addon import export, preflight
    messages = preflight.unsupported_features(scene, list(scene.objects), scene.view_layers[0])
    assert [m for m in messages if m.startswith("collection 'Indirect': 'indirect only'")]
    assert len(messages) == 1, messages
    assert export.visibility_extension(bpy.data.objects["Cube"]) == {"holdout": True}
    assert export.visibility_extension(ball) == {"holdout": True}
    assert export.visibility_extension(free) == {}


def test_rolling_shutter_is_named(photon_addon):
    """Cycles' rolling shutter (rows exposed one after another) is not carried: one message
    with motion blur on, none while it is off."""
    bpy.ops.wm.read_factory_settings()
    scene = bpy.context.scene
    scene.render.use_motion_blur = True
    assert messages_for(scene) == []
    scene.cycles.rolling_shutter_type = "TOP"
    messages = messages_for(scene)
    assert len(messages) == 1 and messages[0].startswith("motion blur: the rolling shutter"), \
        messages


def test_thin_film_is_named_only_where_it_is_not_rendered(photon_addon):
    """A Principled BSDF's Thin Film is rendered on the node-tree route: a lone Principled
    BSDF with a film takes it (Blender's glTF exporter writes no film), constant or linked,
    and nothing is reported. Where the tree is not evaluated (a Toon BSDF beside it), the film
    is named with the node Photon cannot evaluate; a zero thickness gives no film message."""
    from blender_addon.node_tree import material_nodes
    bpy.ops.wm.read_factory_settings()
    scene = bpy.context.scene
    mat = bpy.data.objects["Cube"].active_material
    tree = mat.node_tree
    bsdf = tree.nodes["Principled BSDF"]
    assert material_nodes(mat)[0] is None, "a plain Principled BSDF keeps the glTF route"
    bsdf.inputs["Thin Film Thickness"].default_value = 400.0
    for roughness in (0.5, 0.0):
        bsdf.inputs["Diffuse Roughness"].default_value = roughness
        extension, problems = material_nodes(mat)
        assert extension is not None and not problems, problems
        inputs = [n for n in extension["nodes"] if n["type"] == "ShaderNodeBsdfPrincipled"][0]
        assert "Thin Film Thickness" in str(inputs) and "Thin Film IOR" in str(inputs), inputs
        assert messages_for(scene) == [], "Thin Film is rendered"
    value = tree.nodes.new("ShaderNodeValue")
    value.outputs[0].default_value = 300.0
    tree.links.new(value.outputs[0], bsdf.inputs["Thin Film Thickness"])
    assert material_nodes(mat)[0] is not None
    assert messages_for(scene) == [], "a linked Thin Film is rendered"
    hair = tree.nodes.new("ShaderNodeBsdfHairPrincipled")
    hair.model = "HUANG"  # a model Photon does not evaluate
    mix = tree.nodes.new("ShaderNodeMixShader")
    output = tree.nodes["Material Output"]
    tree.links.new(bsdf.outputs["BSDF"], mix.inputs[1])
    tree.links.new(hair.outputs["BSDF"], mix.inputs[2])
    tree.links.new(mix.outputs["Shader"], output.inputs["Surface"])
    messages = messages_for(scene)
    assert [m for m in messages if "Thin Film is not rendered" in m], messages
    assert [m for m in messages if hair.name in m and "Huang" in m], messages
    tree.links.remove(bsdf.inputs["Thin Film Thickness"].links[0])
    bsdf.inputs["Thin Film Thickness"].default_value = 0.0
    messages = messages_for(scene)
    assert not [m for m in messages if "Thin Film" in m], messages

def test_thin_film_on_metal_is_not_named(photon_addon):
    """Blender 5 puts a Principled BSDF's Thin Film on its metallic layer too, Blender 4.5 does
    not, and Photon renders each as its Cycles does: a metallic Principled BSDF with a film is
    named by neither."""
    bpy.ops.wm.read_factory_settings()
    scene = bpy.context.scene
    bsdf = bpy.data.objects["Cube"].active_material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Thin Film Thickness"].default_value = 400.0
    assert messages_for(scene) == []
    bsdf.inputs["Metallic"].default_value = 1.0
    assert messages_for(scene) == []
