"""The add-on's glTF export with bpy: the hooks write PHOTON_light (point radius, sun angle,
area lights), PHOTON_world and PHOTON_render, never as required extensions; the background-
Blender route (used in the UI) writes the same file as the in-process route; and the export
time of a 1-million-triangle mesh (printed, for the notes).
"""

import dataclasses
import json
import math
import struct
import time
from pathlib import Path

import bpy
import pytest


def read_glb_json(path: Path) -> dict:
    data = path.read_bytes()
    (length,) = struct.unpack_from("<I", data, 12)
    return json.loads(data[20:20 + length])


def nodes_by_name(doc: dict) -> dict:
    return {n["name"]: n for n in doc["nodes"]}


@pytest.fixture
def lights_scene(photon_addon):
    bpy.ops.wm.read_factory_settings()
    scene = bpy.context.scene
    area = bpy.data.lights.new("AreaL", "AREA")
    area.shape, area.size, area.size_y, area.energy = "RECTANGLE", 2.0, 0.5, 200.0
    area.color = (1.0, 0.5, 0.25)
    scene.collection.objects.link(bpy.data.objects.new("AreaL", area))
    sun = bpy.data.lights.new("SunL", "SUN")
    sun.angle = 0.1
    scene.collection.objects.link(bpy.data.objects.new("SunL", sun))
    bpy.data.objects["Light"].data.shadow_soft_size = 0.25
    scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.2, 0.3, 0.4, 1)
    scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 2.0
    scene.render.resolution_percentage = 50
    scene.render.film_transparent = True
    scene.cycles.pixel_filter_type, scene.cycles.filter_width = "GAUSSIAN", 2.5
    return scene


def check_extensions(doc: dict):
    assert not any(e.startswith("PHOTON_") for e in doc.get("extensionsRequired", []))
    assert {"PHOTON_light", "PHOTON_world", "PHOTON_render"} <= set(doc["extensionsUsed"])
    nodes = nodes_by_name(doc)
    area = nodes["AreaL"]["extensions"]["PHOTON_light"]
    assert area["type"] == "area" and area["shape"] == "RECTANGLE"
    assert area["size"] == pytest.approx(2.0) and area["size_y"] == pytest.approx(0.5)
    assert area["power"] == pytest.approx(200.0)
    assert area["color"] == pytest.approx([1.0, 0.5, 0.25])
    assert nodes["SunL"]["extensions"]["PHOTON_light"]["angle"] == pytest.approx(0.1)
    assert nodes["Light"]["extensions"]["PHOTON_light"]["radius"] == pytest.approx(0.25)
    ext = doc["scenes"][doc.get("scene", 0)]["extensions"]
    assert ext["PHOTON_world"]["color"] == pytest.approx([0.2, 0.3, 0.4])
    assert ext["PHOTON_world"]["strength"] == pytest.approx(2.0)
    assert ext["PHOTON_render"] == {"width": 960, "height": 540, "film_transparent": True,
                                    "filter": {"type": "GAUSSIAN", "width": 2.5},
                                    "clamp_indirect": 10.0,  # Blender's default clamp
                                    "filter_glossy": 1.0}  # and Filter Glossy


def test_hooks_write_photon_extensions(lights_scene, tmp_path):
    from blender_addon import export
    glb = tmp_path / "scene.glb"
    export.export_in_process(glb, "blender_addon")
    check_extensions(read_glb_json(glb))
    assert "blender_addon" not in bpy.context.preferences.addons.keys()


def test_background_blender_route_writes_the_same_file(lights_scene, tmp_path):
    from blender_addon import export, runner
    inproc, child, snapshot = tmp_path / "a.glb", tmp_path / "b.glb", tmp_path / "snap.blend"
    export.export_in_process(inproc, "blender_addon")
    t0 = time.perf_counter()
    export.write_snapshot(lights_scene, snapshot)
    runner.run(export.child_command(snapshot, child), None, None, what="glTF export")
    print(f"snapshot + export in a child process: {time.perf_counter() - t0:.2f} s")
    doc = read_glb_json(child)
    check_extensions(doc)
    assert doc == read_glb_json(inproc)


@pytest.mark.parametrize("autoexec", [True, False])
def test_background_blender_runs_python_drivers_as_the_user_does(photon_addon, tmp_path, autoexec):
    """The background Blender of the UI route runs the file's Python drivers when the user's
    Blender does (Blender's -y), and not otherwise: a driver that only Python can evaluate
    (it calls str) turns the cube by 0.35 rad per frame; exported at frame 3."""
    from blender_addon import export, runner
    bpy.ops.wm.read_factory_settings()
    scene = bpy.context.scene
    cube = bpy.data.objects["Cube"]
    driver = cube.driver_add("rotation_euler", 2).driver
    driver.type = "SCRIPTED"
    driver.expression = "float(str(frame)) * 0.35"
    scene.frame_current = 3
    cube.rotation_euler.z = 0.0
    saved = bpy.context.preferences.filepaths.use_scripts_auto_execute
    bpy.context.preferences.filepaths.use_scripts_auto_execute = autoexec
    try:
        assert export.scripts_may_run() == autoexec
        snapshot, glb = tmp_path / "snap.blend", tmp_path / "child.glb"
        export.write_snapshot(scene, snapshot)
        runner.run(export.child_command(snapshot, glb, export.scripts_may_run()), None, None,
                   what="glTF export")
    finally:
        bpy.context.preferences.filepaths.use_scripts_auto_execute = saved
    node = next(n for n in read_glb_json(glb)["nodes"] if n["name"] == "Cube")
    # glTF is Y-up: Blender's rotation about Z is a rotation about glTF's -Y... its angle:
    x, y, z, w = node.get("rotation", [0.0, 0.0, 0.0, 1.0])
    angle = 2.0 * math.atan2(math.sqrt(x * x + y * y + z * z), w)
    assert angle == pytest.approx(1.05 if autoexec else 0.0, abs=1e-4), node


def test_world_without_nodes_uses_world_colour(photon_addon):
    """Blender 4: a world with use_nodes off renders its colour. Blender 5 always renders the
    node tree (World.use_nodes is deprecated), so there the Background node is read."""
    from blender_addon import world as world_module
    world = bpy.data.worlds.new("Plain")
    if bpy.app.version >= (5, 0, 0):
        world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.1, 0.2, 0.3, 1)
    else:
        world.use_nodes = False
    world.color = (0.1, 0.2, 0.3)
    assert world_module.world_extension(world) == {"color": pytest.approx([0.1, 0.2, 0.3]),
                                                   "strength": 1.0}
    assert world_module.world_extension(None)["color"] == [0.0, 0.0, 0.0]


def test_export_time_one_million_triangles(photon_addon, tmp_path):
    from blender_addon import export
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=710, y_subdivisions=710, size=2.0)
    obj = bpy.context.active_object
    triangles = sum(len(p.vertices) - 2 for p in obj.data.polygons)
    assert triangles >= 1_000_000
    bpy.ops.object.camera_add(location=(0, 0, 5))
    glb = tmp_path / "grid.glb"
    t0 = time.perf_counter()
    export.export_in_process(glb, "blender_addon")
    dt = time.perf_counter() - t0
    print(f"export of {triangles} triangles: {dt:.2f} s, {glb.stat().st_size / 1e6:.1f} MB")


def test_subsurface_extension(photon_addon, tmp_path):
    """PHOTON_material_subsurface carries the Principled BSDF's subsurface inputs and method,
    and only for materials whose subsurface weight is above 0."""
    from blender_addon import export
    bpy.ops.wm.read_factory_settings()
    skin = bpy.data.materials.new("Skin")
    if bpy.app.version < (5, 0, 0):
        skin.use_nodes = True
    bpy.data.objects["Cube"].data.materials[0] = skin
    bsdf = skin.node_tree.nodes["Principled BSDF"]
    bsdf.subsurface_method = "RANDOM_WALK_SKIN"  # the method that reads Subsurface IOR
    for name, value in (("Subsurface Weight", 0.8), ("Subsurface Radius", (1.0, 0.2, 0.1)),
                        ("Subsurface Scale", 0.05), ("Subsurface IOR", 1.33),
                        ("Subsurface Anisotropy", 0.25)):
        bsdf.inputs[name].default_value = value
    plain = bpy.data.materials.new("Plain")
    if bpy.app.version < (5, 0, 0):
        plain.use_nodes = True
    bpy.ops.mesh.primitive_plane_add(location=(0, 0, -2))
    bpy.context.active_object.data.materials.append(plain)
    glb = tmp_path / "sss.glb"
    export.export_in_process(glb, "blender_addon")
    doc = read_glb_json(glb)
    assert "PHOTON_material_subsurface" not in doc.get("extensionsRequired", [])
    materials = {m["name"]: m for m in doc["materials"]}
    sss = materials["Skin"]["extensions"]["PHOTON_material_subsurface"]
    assert sss == {"method": "RANDOM_WALK_SKIN",
                   "weight": pytest.approx(0.8), "radius": pytest.approx([1.0, 0.2, 0.1]),
                   "scale": pytest.approx(0.05), "ior": pytest.approx(1.33),
                   "anisotropy": pytest.approx(0.25)}
    assert "PHOTON_material_subsurface" not in materials["Plain"].get("extensions", {})


def test_environment_texture_is_written_as_float_exr(photon_addon, tmp_path):
    """An Environment Texture feeding the Background: PHOTON_world gets "environment" with the
    image's file name, the Mapping node's rotation and the interpolation, and the EXR beside
    the .glb holds the image's pixels exactly (top row first, 32-bit float)."""
    import OpenEXR
    import numpy as np
    import scenes_bpy
    from blender_addon import export
    scene = scenes_bpy.hdri_scene(rotation_z_deg=30.0)
    glb = tmp_path / "scene.glb"
    export.export_in_process(glb, "blender_addon")
    doc = read_glb_json(glb)
    world = doc["scenes"][doc.get("scene", 0)]["extensions"]["PHOTON_world"]
    env = world["environment"]
    assert env["uri"] == "world_SyntheticSky.exr" and env["interpolation"] == "linear"
    assert env["rotation"] == pytest.approx([0.0, 0.0, math.radians(30.0)])
    assert world["strength"] == pytest.approx(1.5)
    image = scene.world.node_tree.nodes["Environment Texture"].image
    w, h = image.size
    want = np.empty(w * h * 4, np.float32)
    image.pixels.foreach_get(want)
    want = want.reshape(h, w, 4)[::-1, :, :3]
    with OpenEXR.File(str(tmp_path / env["uri"]), separate_channels=True) as f:
        channels = f.channels()
        got = np.stack([channels[c].pixels for c in "RGB"], axis=2)
    assert got.dtype == np.float32 and got.shape == (h, w, 3)
    assert np.array_equal(got, want)


def test_scene_settings_map_to_render_settings(photon_addon):
    """scene.photon has the defaults of runner.RenderSettings and maps onto it field by field
    (enum items lower-cased as the renderer's flags spell them)."""
    from blender_addon import properties, runner
    bpy.ops.wm.read_factory_settings()
    props = bpy.context.scene.photon
    defaults = dataclasses.asdict(runner.RenderSettings())
    got = dataclasses.asdict(properties.render_settings(props))
    assert got.keys() == defaults.keys()
    for key, value in defaults.items():  # floats are stored as float32 by Blender
        assert got[key] == (pytest.approx(value) if isinstance(value, float) else value), key
    props.method, props.quality, props.irradiance_cache = "PHOTON", "FINAL", "ON"
    props.samples, props.time_limit, props.custom_photons, props.ic_accuracy = 8, 1.5, True, 0.3
    got = properties.render_settings(props)
    assert (got.method, got.quality, got.irradiance_cache) == ("photon", "final", "on")
    assert (got.samples, got.custom_photons) == (8, True)
    assert got.time_limit == pytest.approx(1.5) and got.ic_accuracy == pytest.approx(0.3)


def test_byte_srgb_environment_is_linearised(photon_addon, tmp_path):
    """An 8-bit sRGB image (as a PNG or JPEG HDRI preview would be) is written linear, as Cycles
    reads it; a Texture-type Mapping node's rotation is exported inverted."""
    import OpenEXR
    import numpy as np
    import scenes_bpy
    from blender_addon import world
    scene = scenes_bpy.hdri_scene()
    node = scene.world.node_tree.nodes["Environment Texture"]
    image = bpy.data.images.new("Bytes", 2, 1, alpha=True, float_buffer=False)
    assert image.colorspace_settings.name == "sRGB" and not image.is_float
    image.pixels.foreach_set(np.array([0.5, 0.5, 0.5, 1, 1, 0, 0.2, 1], np.float32))
    node.image = image
    mapping = scene.world.node_tree.nodes["Mapping"]
    mapping.vector_type = "TEXTURE"
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, 0.4)
    data = world.world_extension(scene.world, tmp_path)
    assert data["environment"]["rotation"] == pytest.approx([0.0, 0.0, -0.4], abs=1e-6)
    with OpenEXR.File(str(tmp_path / data["environment"]["uri"]), separate_channels=True) as f:
        r = f.channels()["R"].pixels
        b = f.channels()["B"].pixels
    srgb = lambda v: ((v + 0.055) / 1.055) ** 2.4  # noqa: E731
    # Bytes store 0.5 as 128/255 and 0.2 as 51/255.
    assert r[0, 0] == pytest.approx(srgb(128 / 255), rel=1e-4) and r[0, 1] == pytest.approx(1.0)
    assert b[0, 1] == pytest.approx(srgb(51 / 255), rel=1e-4)


def test_background_route_carries_sky_hair_points_and_camera_motion(photon_addon, tmp_path):
    """A Nishita sky, a moving camera with motion blur on, a Point Cloud, a Curves object and a
    hair particle system: both export routes write the same file, with the sky's settings, the
    camera's three shutter poses, one sphere mesh placed per point and the tube meshes; the
    temporary modifiers, objects and node groups are gone afterwards."""
    import test_motion_blur
    import test_points_curves
    import common
    from blender_addon import export, runner
    scene = test_motion_blur.sliding_camera_scene("CENTER")
    tree = scene.world.node_tree
    sky = tree.nodes.new("ShaderNodeTexSky")
    sky.sky_type = "SINGLE_SCATTERING" if bpy.app.version >= (5, 0, 0) else "NISHITA"
    sky.sun_elevation = math.radians(30.0)
    tree.links.new(sky.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    material = common.principled("Fur", (0.5, 0.3, 0.2))
    test_points_curves.point_cloud("Cloud", 12, material)
    test_points_curves.hair("Strands", material, strands=10)
    floor = bpy.data.objects["Floor"]
    floor.modifiers.new("Grass", "PARTICLE_SYSTEM")
    floor.particle_systems[0].settings.type = "HAIR"
    floor.particle_systems[0].settings.count = 20
    groups, objects = len(bpy.data.node_groups), len(bpy.data.objects)

    inproc, child, snapshot = tmp_path / "a.glb", tmp_path / "b.glb", tmp_path / "snap.blend"
    export.export_in_process(inproc, "blender_addon")
    export.write_snapshot(scene, snapshot)
    runner.run(export.child_command(snapshot, child), None, None, what="glTF export")
    doc = read_glb_json(inproc)
    assert doc == read_glb_json(child)
    world = doc["scenes"][doc.get("scene", 0)]["extensions"]["PHOTON_world"]
    assert world["sky"]["sun_elevation"] == pytest.approx(math.radians(30.0))
    motion = nodes_by_name(doc)["Camera"]["extensions"]["PHOTON_camera"]["motion"]
    assert len(motion) == 3 and motion[0] != motion[2]
    meshes = [doc["meshes"][n["mesh"]]["name"] for n in doc["nodes"] if "mesh" in n]
    spheres = [n for n in doc["nodes"] if n.get("name") == "GN Instance" and "scale" in n]
    assert len(spheres) >= 12, meshes
    assert len(meshes) >= 3 + 1 + 12 + 2, meshes  # floor, boxes, spheres, two tube meshes
    assert (len(bpy.data.node_groups), len(bpy.data.objects)) == (groups, objects)
    assert not any(m.name == "Photon points and curves" for o in bpy.data.objects
                   for m in o.modifiers)
