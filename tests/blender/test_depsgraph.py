"""What a render shows, exported as the render depsgraph has it: modifiers at their render
settings (a Subdivision Surface with viewport level 0 and render level 3 renders smooth; a
modifier enabled only for rendering is applied), collections excluded from the view layer,
objects and collections disabled for rendering left out, and objects disabled only in
viewports kept; particle instances written once each (emitting boxes lighting a floor).
Each scene is rendered by Cycles and by Photon through the add-on at 48x32:
mean within 2 % and relMSE <= 0.01. The viewport settings are put back after the export.
"""

import bpy
import pytest

import common
import scenes_bpy
from cycles_compare import compare
from volume_scenes import shader_material

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def lit_floor():
    scene = common.reset_scene(48, 32)
    grey = common.principled("Grey", (0.6, 0.6, 0.6))
    common.quad("Floor", [(-4, -4, 0), (4, -4, 0), (4, 4, 0), (-4, 4, 0)], grey)
    common.light("Sun", "SUN", (0, 0, 5), (35.0, 0.0, 30.0), energy=3.0)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.3, 0.35, 0.45, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    common.camera("Camera", (0.0, -4.5, 2.6), (60.0, 0.0, 0.0), 50.0)
    return scene


def test_subdivision_renders_at_its_render_level(tmp_path):
    scene = lit_floor()
    red = common.principled("Red", (0.8, 0.2, 0.1), roughness=0.3)
    cube = common.box("Cube", (1.6, 1.6, 1.6), red, (0.0, 0.3, 0.0), 30.0)
    subsurf = cube.modifiers.new("Subdivision", "SUBSURF")
    subsurf.levels = 0
    subsurf.render_levels = 3
    for polygon in cube.data.polygons:
        polygon.use_smooth = True
    compare("subdivision viewport 0 / render 3", scene, tmp_path)
    assert subsurf.levels == 0, "the viewport level is put back after the export"


def test_render_only_modifier_and_visibility(tmp_path):
    scene = lit_floor()
    blue = common.principled("Blue", (0.1, 0.3, 0.8))
    green = common.principled("Green", (0.2, 0.7, 0.2))
    # An Array modifier shown only in renders: three boxes in Cycles.
    row = common.box("Row", (0.5, 0.5, 0.5), blue, (-1.5, -0.5, 0.0), 0.0)
    array = row.modifiers.new("Array", "ARRAY")
    array.count = 3
    array.relative_offset_displace = (2.0, 0.0, 0.0)
    array.show_viewport = False
    # Disabled in viewports but rendered.
    kept = common.box("ViewportOff", (0.6, 0.6, 1.2), green, (1.4, 1.2, 0.0), 10.0)
    kept.hide_viewport = True
    # Disabled for rendering: an object, a collection, a collection inside a disabled one and
    # a collection excluded from the view layer. None of them may show.
    common.box("RenderOff", (1.0, 1.0, 1.0), green, (0.0, 1.0, 0.0), 0.0).hide_render = True
    hidden = bpy.data.collections.new("HiddenForRender")
    scene.collection.children.link(hidden)
    hidden.hide_render = True
    inner = bpy.data.collections.new("InsideHidden")
    hidden.children.link(inner)
    excluded = bpy.data.collections.new("Excluded")
    scene.collection.children.link(excluded)
    for collection, x in ((hidden, -1.0), (inner, 0.0), (excluded, 1.0)):
        obj = common.box(f"In{collection.name}", (0.7, 0.7, 0.7), green, (x, -1.5, 0.0), 0.0)
        scene.collection.objects.unlink(obj)
        collection.objects.link(obj)
    scene.view_layers[0].layer_collection.children["Excluded"].exclude = True
    compare("render-only modifier, render visibility", scene, tmp_path)
    assert not array.show_viewport and kept.hide_viewport, "viewport settings are put back"
    assert not bpy.data.objects["InExcluded"].hide_render, "render switches are put back"


def test_camera_and_shadow_ray_visibility(tmp_path):
    """A box hidden from the camera (its shadow and bounce light stay) and a box that casts
    no shadow (PHOTON_object)."""
    scene = lit_floor()
    red = common.principled("Red", (0.8, 0.2, 0.1))
    blue = common.principled("Blue", (0.1, 0.3, 0.8))
    common.box("Unseen", (0.9, 0.9, 1.4), red, (-0.9, 0.4, 0.0), 15.0).visible_camera = False
    common.box("NoShadow", (0.9, 0.9, 1.4), blue, (0.9, 0.2, 0.0), -10.0).visible_shadow = False
    compare("camera / shadow visibility", scene, tmp_path)


def _scatter_target():
    """A small box to be instanced, kept out of the render (its collection is disabled for
    rendering, as a scatter's source usually is)."""
    source = bpy.data.collections.new("Source")
    bpy.context.scene.collection.children.link(source)
    source.hide_render = True
    gold = common.principled("Gold", (0.9, 0.6, 0.1), roughness=0.4)
    pebble = common.box("Pebble", (0.25, 0.25, 0.35), gold, (0.0, 0.0, 0.0), 0.0)
    bpy.context.scene.collection.objects.unlink(pebble)
    source.objects.link(pebble)
    return pebble


def test_geometry_nodes_instances_on_points(tmp_path):
    """A Geometry Nodes scatter: a grid's points instance a box (Instance on Points)."""
    scene = lit_floor()
    pebble = _scatter_target()
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=4, y_subdivisions=3, size=2.4,
                                    location=(0.0, 0.3, 0.01))
    grid = bpy.context.active_object
    scenes_bpy.instance_on_points(grid, pebble, rotation_max=(0.0, 0.0, 3.0))
    compare("geometry nodes instances on points", scene, tmp_path)


@pytest.mark.parametrize("render_type", ["OBJECT", "COLLECTION"])
def test_particle_system_rendering_objects(tmp_path, render_type):
    """A particle system (emitter, rendered as an object or a collection) scattering a box
    over a plane."""
    scene = lit_floor()
    pebble = _scatter_target()
    grey = common.principled("Emitter", (0.6, 0.6, 0.6))
    emitter = common.quad("Emitter", [(-1.2, -0.8, 0.01), (1.2, -0.8, 0.01),
                                      (1.2, 1.4, 0.01), (-1.2, 1.4, 0.01)], grey)
    emitter.modifiers.new("Particles", "PARTICLE_SYSTEM")
    settings = emitter.particle_systems[0].settings
    settings.count = 14
    settings.frame_start = settings.frame_end = 1
    settings.physics_type = "NO"
    settings.render_type = render_type
    settings.instance_object = pebble
    if render_type == "COLLECTION":
        # The usual set-up: the instanced collection excluded from the view layer.
        rocks = bpy.data.collections.new("Rocks")
        scene.collection.children.link(rocks)
        blue = common.principled("Rock", (0.2, 0.3, 0.9), roughness=0.5)
        rock = common.box("Rock", (0.2, 0.3, 0.25), blue, (0.0, 0.0, 0.0), 0.0)
        scene.collection.objects.unlink(rock)
        rocks.objects.link(rock)
        scene.view_layers[0].layer_collection.children["Rocks"].exclude = True
        settings.instance_collection = rocks
    settings.particle_size = 1.0
    settings.use_rotation_instance = True
    emitter.show_instancer_for_render = True
    compare(f"particle system rendering {render_type.lower()}", scene, tmp_path)


@pytest.mark.parametrize("source", ["hidden", "rendered"])
def test_particle_instances_that_emit_light(tmp_path, source):
    """A hair particle system scattering six small emitting boxes (Emission, strength 50) over
    a floor under a dark world, the box they instance disabled for rendering or rendered (under
    the floor, out of sight): each instance is written once, so the floor gets each box's light
    once (the glTF exporter walks a particle system's instances twice, as duplis and as
    Geometry Nodes instances, and keeps the duplis of a rendered object: written twice, the
    instances' light doubled)."""
    scene = lit_floor()
    bpy.data.objects["Sun"].data.energy = 0.0
    scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.02
    glow, _ = shader_material("Glow", "ShaderNodeEmission", "Surface", Strength=50.0)
    lamp = common.box("Lamp", (0.1, 0.1, 0.1), glow, (0.0, 0.0, -3.0), 0.0)
    lamp.hide_render = source == "hidden"
    emitter = common.quad("Emitter", [(-1.5, -0.8, 0.6), (1.5, -0.8, 0.6), (1.5, 1.4, 0.6),
                                      (-1.5, 1.4, 0.6)], None)
    emitter.show_instancer_for_render = False
    emitter.modifiers.new("Particles", "PARTICLE_SYSTEM")
    settings = emitter.particle_systems[0].settings
    settings.type = "HAIR"
    settings.hair_length = 1.0
    settings.count = 6
    settings.render_type = "OBJECT"
    settings.instance_object = lamp
    # The floor's light alone: the boxes seen straight on left out.
    compare(f"emitting particle instances ({source})", scene, tmp_path, glint=1.0)
