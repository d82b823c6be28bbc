"""Test scenes built with bpy for the add-on tests, and rendering them through
`bpy.ops.render.render()` with Photon (the add-on) or with Cycles (configured as for the committed
references in scenes/blender/common.py: no clamping, no glossy filter, Blackman-Harris 1.5 px).

Images are written with write_still to a linear EXR and read back (the Render Result image has
no pixels in background mode). Returns float32 (H, W, 3), row 0 = top.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import bpy
import numpy as np

import common  # scenes/blender/common.py
from refimage import read_exr

THREADS = os.cpu_count() or 2


def default_scene():
    """The factory-default scene (cube, 1000 W point light, camera) at 64x36 through the
    resolution percentage (640x360 at 10 %). The point light's radius is set to 0: Photon
    renders point lights as true points for now, Blender's default radius is 0.1 m."""
    bpy.ops.wm.read_factory_settings()
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 640, 360
    scene.render.resolution_percentage = 10
    bpy.data.objects["Light"].data.shadow_soft_size = 0.0
    return scene


def _floor_and_box(width, height):
    scene = common.reset_scene(width, height)
    grey = common.principled("Grey", (0.8, 0.8, 0.8))
    red = common.principled("Red", (0.8, 0.2, 0.1), roughness=0.4)
    common.quad("Floor", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], grey)
    common.box("Box", (1.0, 1.0, 1.0), red, (0.0, 0.0, 0.0), 30.0)
    common.camera("Camera", (4.0, -4.0, 3.2), (62.0, 0.0, 45.0), 50.0)
    return scene


def area_light_scene():
    """A box on a floor under a 1 m square area light (300 W) pointing down; black world."""
    scene = _floor_and_box(64, 36)
    common.light("Area", "AREA", (0.5, -0.5, 2.5), energy=300.0, shape="SQUARE", size=1.0)
    return scene


def area_light_photon_path(samples: int, seed: int = 1):
    """`area_light_scene` rendered by Photon's path tracer with `samples` and `seed` (Cycles
    configured alike): the farm tests' scene."""
    scene = area_light_scene()
    common.configure_cycles(scene, samples, seed=seed, threads=THREADS)
    scene.render.engine = "PHOTON"
    scene.photon.samples = samples
    scene.photon.seed = seed
    scene.photon.method = "PATH"
    return scene


def sun_world_scene():
    """A box on a floor lit by a 3 W/m² sun at 40 degrees and a blue-grey world (0.2, 0.3,
    0.5) x 1."""
    scene = _floor_and_box(64, 36)
    common.light("Sun", "SUN", (0, 0, 5), (40.0, 0.0, 30.0), energy=3.0)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.2, 0.3, 0.5, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    return scene


def synthetic_hdri(width=64, height=32) -> "bpy.types.Image":
    """A float image made here: a sky gradient (blue-white at the zenith, darker towards the
    horizon, dark brown ground) and one bright 6x4-pixel patch ("the sun") off the axes, at
    u = 0.62-0.72, 0.19-0.31 of the height from the top, so that a mirrored or shifted mapping
    lights the scene from elsewhere."""
    rows = (np.arange(height) + 0.5) / height  # 0 at the top
    sky = np.where(rows[:, None] < 0.5,
                   np.array([0.35, 0.5, 0.9]) * (1.2 - rows[:, None]),
                   np.array([0.08, 0.06, 0.04]))
    rgb = np.broadcast_to(sky[:, None, :], (height, width, 3)).copy()
    u0 = int(0.62 * width)
    v0 = int(0.19 * height)
    rgb[v0:v0 + 4, u0:u0 + 6] = (60.0, 50.0, 40.0)
    rgba = np.concatenate([rgb, np.ones((height, width, 1))], axis=2)[::-1]  # rows bottom-up
    image = bpy.data.images.new("SyntheticSky", width, height, alpha=True, float_buffer=True)
    image.pixels.foreach_set(rgba.astype(np.float32).ravel())
    image.pack()  # keeps the pixels in a snapshot .blend too
    return image


def hdri_scene(rotation_z_deg=30.0):
    """The box on the floor lit only by `synthetic_hdri` through an Environment Texture (linear
    interpolation) rotated by a Mapping node, Background strength 1.5; no lights."""
    scene = _floor_and_box(64, 36)
    tree = scene.world.node_tree
    env = tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = synthetic_hdri()
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, math.radians(rotation_z_deg))
    coords = tree.nodes.new("ShaderNodeTexCoord")
    tree.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
    tree.links.new(mapping.outputs["Vector"], env.inputs["Vector"])
    bg = tree.nodes["Background"]
    tree.links.new(env.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = 1.5
    return scene


def instance_on_points(obj, instanced, *, rotation_max=None, rise_with_time=False):
    """Give `obj` a Geometry Nodes modifier that instances `instanced` on its points (Instance
    on Points), turned by random angles up to `rotation_max` (x, y, z) when given, and with
    the points rising by the scene time in seconds with `rise_with_time`."""
    modifier = obj.modifiers.new("Scatter", "NODES")
    tree = bpy.data.node_groups.new("Scatter", "GeometryNodeTree")
    modifier.node_group = tree
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    group_in = tree.nodes.new("NodeGroupInput")
    group_out = tree.nodes.new("NodeGroupOutput")
    on_points = tree.nodes.new("GeometryNodeInstanceOnPoints")
    info = tree.nodes.new("GeometryNodeObjectInfo")
    info.inputs["Object"].default_value = instanced
    points = group_in.outputs["Geometry"]
    if rise_with_time:
        time = tree.nodes.new("GeometryNodeInputSceneTime")
        rise = tree.nodes.new("ShaderNodeCombineXYZ")
        lift = tree.nodes.new("GeometryNodeSetPosition")
        tree.links.new(time.outputs["Seconds"], rise.inputs["Z"])
        tree.links.new(rise.outputs["Vector"], lift.inputs["Offset"])
        tree.links.new(points, lift.inputs["Geometry"])
        points = lift.outputs["Geometry"]
    tree.links.new(points, on_points.inputs["Points"])
    tree.links.new(info.outputs["Geometry"], on_points.inputs["Instance"])
    if rotation_max is not None:
        rotate = tree.nodes.new("FunctionNodeRandomValue")
        rotate.data_type = "FLOAT_VECTOR"
        rotate.inputs["Max"].default_value = rotation_max
        tree.links.new(rotate.outputs["Value"], on_points.inputs["Rotation"])
    tree.links.new(on_points.outputs["Instances"], group_out.inputs["Geometry"])
    return modifier


def render(scene, engine: str, path: Path, samples: int, seed: int = 1,
           reference_scope: str | None = None) -> np.ndarray:
    """Render the scene camera with 'PHOTON' or 'CYCLES' to `path` (EXR) and read it back. A
    Cycles render of what this test function (or the tests that pass the same
    `reference_scope`) already rendered with Cycles, the same scene and settings, is shared
    (reference_cache.py)."""
    common.configure_cycles(scene, samples, seed=seed, threads=THREADS)
    scene.render.engine = engine
    if engine == "PHOTON":
        scene.photon.samples = samples
        scene.photon.seed = seed
        scene.photon.threads = 0
    scene.render.filepath = str(path)
    scene.render.use_file_extension = False
    if engine == "CYCLES":
        import reference_cache
        image, _ = reference_cache.cached_render(lambda: _write_still(engine, path), path,
                                                 reference_scope)
        return image
    return _write_still(engine, path)


def _write_still(engine: str, path: Path) -> np.ndarray:
    bpy.ops.render.render(write_still=True)
    if not path.exists():
        raise AssertionError(f"{engine} wrote no image at {path}")
    return read_exr(path)


def read_layers(path) -> dict:
    """The channels of the multilayer EXR at `path` by full name (`ViewLayer.Combined.R`, …).
    Blender 5 writes one part per pass, Blender 4 a single part: every part is read."""
    import OpenEXR

    with OpenEXR.File(str(path), separate_channels=True) as f:
        return {name: np.array(chan.pixels) for part in f.parts
                for name, chan in part.channels.items()}


def render_layers(scene, engine: str, path: Path, samples: int) -> dict:
    """Render the scene camera with `engine` to a multilayer EXR at `path` (the view layers'
    passes) and return its channels by full name (`read_layers`). Cycles' render is shared or
    stored as `render`'s (reference_cache.py)."""
    common.configure_cycles(scene, samples, seed=1, threads=THREADS)
    common.set_multilayer_exr(scene.render.image_settings)
    scene.render.engine = engine
    scene.photon.samples = samples
    scene.render.filepath = str(path)
    scene.render.use_file_extension = False

    def render():
        bpy.ops.render.render(write_still=True)
        return read_layers(path)

    if engine == "CYCLES":
        import reference_cache
        return reference_cache.cached_render(render, path, read=read_layers)[0]
    return render()
