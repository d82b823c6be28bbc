"""Scene export: Blender's own glTF exporter plus hooks that write Photon's glTF extensions.

`export_scene` writes the scene being rendered to a .glb. Two routes, one chosen per render:

- in process (Blender running in the background, `-b`, or bpy as a Python module): call
  `bpy.ops.export_scene.gltf` directly from `RenderEngine.render`, which works there;
- in a child Blender (the interactive UI): F12 runs `render()` in a job thread where the exporter,
  which needs a window context, can fail (glTF-Blender-IO issue 1943). The scene is written to a
  temporary .blend with `bpy.data.libraries.write` (context-free, fast) and a background Blender
  (`bpy.app.binary_path -b --factory-startup --python export.py -- SNAPSHOT.blend OUT.glb`)
  opens it and runs the same in-process export.

The environment variable PHOTON_EXPORT=inprocess|subprocess overrides the choice (for tests).

Nothing the export drops is silent: `export_in_process` returns the warnings of the glTF
exporter (its loggers) and of the hooks below (logger `photon.export`), and the child process
prints them on stderr as JSON progress lines (`{"stage": "export", "warning": ...}`), which the
engine turns into WARNING reports as it does for the renderer's own warnings.

`glTF2ExportUserExtension` (re-exported by the add-on's top-level module, where the exporter
looks for it) writes, always with required=False so that other viewers still open the file:
PHOTON_light on light nodes (point/spot radius, sun angle, area lights, which the exporter drops),
PHOTON_camera on camera nodes (lens shift, depth of field, panoramic projections),
PHOTON_object on mesh nodes (camera and shadow ray visibility),
PHOTON_material_subsurface on materials (the Principled BSDF's subsurface inputs),
PHOTON_material_nodes on materials whose node tree Photon evaluates (node_tree.py; the texture
space of each object goes in PHOTON_object for Generated coordinates), PHOTON_world
(background colour x strength, or an equirectangular environment image written next to the .glb
as a float EXR) and PHOTON_render (final resolution, transparent film) on the scene. The fields
are specified in docs/gltf_extensions.md.

This file runs both inside the add-on and as the child's script, so it imports only bpy, the
standard library and numpy (shipped with Blender).
"""

from __future__ import annotations

import base64
import contextlib
import json
import logging
import math
import os
import struct
import sys
from pathlib import Path

import bpy
import mathutils

try:
    from . import node_tree, points_curves, preflight
except ImportError:  # run as the child's script: the add-on's folder holds node_tree.py
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import node_tree
    import points_curves
    import preflight

GLTF_EXPORT_ARGS = dict(
    export_format="GLB", export_lights=True, export_cameras=True, export_extras=True,
    export_apply=True, export_current_frame=True, use_renderable=True, export_animations=False,
    use_active_scene=True,
    # Instances of the depsgraph (Geometry Nodes "Instance on Points", particle systems that
    # render objects): one node each, sharing the instanced mesh.
    export_gn_mesh=True,
    # The frame's evaluated geometry, shape keys and armatures applied: the renderer reads
    # neither morph targets nor skins, and with them the exporter writes the rest mesh (the
    # shape keys' values and the pose only as glTF weights and joints).
    export_morph=False, export_skins=False,
)

# Name under which the child process registers this module so the exporter finds the hook.
CHILD_MODULE = "photon_gltf_export"

# The hooks' messages; collected with the glTF exporter's during an export.
LOG = logging.getLogger("photon.export")
# The glTF exporter's loggers (io_scene_gltf2.io.com.debug.Log).
GLTF_LOGGERS = ("glTFImporter", "glTFImporter_errors")
# Exporter warnings about what the hooks carry anyway: the area lights (PHOTON_light), and light
# node trees, which the pre-flight report already names (preflight.light_features).
CARRIED_BY_HOOKS = ("Unsupported light source AREA",
                    "No quadratic light falloff node attached to emission strength property")


class ExportError(Exception):
    """The scene could not be exported; the message is meant for the user."""


# ---------------------------------------------------------------------------------------------
# Hooks
# ---------------------------------------------------------------------------------------------

class glTF2ExportUserExtension:  # noqa: N801 - the name the glTF exporter looks for
    """Hooks called by Blender's glTF exporter (one instance per export)."""

    def __init__(self):
        from io_scene_gltf2.io.com.gltf2_io_extensions import Extension
        self._extension = Extension

    def _add(self, gltf_object, name, data):
        if gltf_object.extensions is None:
            gltf_object.extensions = {}
        gltf_object.extensions[name] = self._extension(name=name, extension=data, required=False)

    def gather_node_hook(self, gltf_node, blender_object, export_settings):
        if blender_object is not None and blender_object.type == "LIGHT":
            data = light_extension(blender_object)
            if data:
                self._add(gltf_node, "PHOTON_light", data)
        if blender_object is not None and blender_object.type in GEOMETRY_TYPES:
            data = visibility_extension(blender_object)
            if blender_object.name in SHUTTER_POSES:
                data["motion"] = SHUTTER_POSES[blender_object.name]
            if blender_object.name in DEFORM_STEPS:
                data["deform"] = DEFORM_STEPS[blender_object.name]
            space = texture_space(blender_object)
            if space and uses_node_materials(blender_object):
                data["texture_space"] = space
            if data:
                self._add(gltf_node, "PHOTON_object", data)
        if blender_object is not None and blender_object.type == "CAMERA":
            data = camera_extension(blender_object, bpy.context.scene)
            if data:
                self._add(gltf_node, "PHOTON_camera", data)

    def gather_material_hook(self, gltf_material, blender_material, export_settings):
        data = subsurface_extension(blender_material)
        if data:
            self._add(gltf_material, "PHOTON_material_subsurface", data)
        folder = Path(export_settings["gltf_filedirectory"])
        tree, problems = node_tree.material_nodes(blender_material, folder)
        if tree:
            self._add(gltf_material, "PHOTON_material_nodes", tree)
        elif problems:  # listed by `photon info`; the pre-flight report names them in Blender
            self._add(gltf_material, "PHOTON_material_nodes", {"warnings": problems})
        if missing_base_color_image(blender_material):
            pbr = gltf_material.pbr_metallic_roughness
            if pbr is not None and pbr.base_color_texture is None:
                pbr.base_color_factor = list(MISSING_IMAGE_COLOR)

    def gather_scene_hook(self, gltf_scene, blender_scene, export_settings):
        folder = Path(export_settings["gltf_filedirectory"])
        self._add(gltf_scene, "PHOTON_world", world_extension(blender_scene.world, folder))
        self._add(gltf_scene, "PHOTON_render", render_extension(blender_scene))


# Object types the glTF exporter writes as meshes.
GEOMETRY_TYPES = ("MESH", "CURVE", "SURFACE", "META", "FONT")


def texture_space(obj) -> dict:
    """The object's texture space (Generated coordinates map it to [0, 1]^3), in object
    coordinates; empty for objects without one."""
    data = getattr(obj, "data", None)
    location = getattr(data, "texspace_location", None)
    size = getattr(data, "texspace_size", None)
    if location is None or size is None:
        return {}
    return {"location": [float(v) for v in location], "size": [float(v) for v in size]}


def uses_node_materials(obj) -> bool:
    """Whether one of the object's materials is written as PHOTON_material_nodes."""
    return any(slot.material is not None and node_tree.material_nodes(slot.material)[0]
               for slot in getattr(obj, "material_slots", ()))


def visibility_extension(obj) -> dict:
    """PHOTON_object: the object's camera and shadow ray visibility when one is off (the
    other ray types are named by the pre-flight report), and "holdout" when the object is a
    holdout (its own setting, or a holdout collection of the view layer holding it)."""
    camera = bool(getattr(obj, "visible_camera", True))
    shadow = bool(getattr(obj, "visible_shadow", True))
    data = {} if camera and shadow else {"visible_camera": camera, "visible_shadow": shadow}
    if getattr(obj, "is_holdout", False) or obj.name in holdout_objects(bpy.context.view_layer):
        data["holdout"] = True
    return data


def holdout_objects(view_layer) -> set:
    """Names of the objects in the view layer's holdout collections (a collection is a holdout
    when it or a collection above it is; excluded ones hold nothing)."""
    names = set()
    if view_layer is None:
        return names
    stack = [(layer, False) for layer in view_layer.layer_collection.children]
    while stack:
        layer, above = stack.pop()
        if layer.exclude:
            continue
        holdout = above or layer.holdout
        if holdout:
            names.update(obj.name for obj in layer.collection.objects)
        stack.extend((child, holdout) for child in layer.children)
    return names


def light_extension(obj) -> dict:
    """PHOTON_light for a light object: its colour and power as Cycles combines them (the
    light's colour x its blackbody colour when "Temperature" is on x the colour of the Emission
    node of its node tree; power x 2^exposure x the node's strength), which the glTF exporter
    gets wrong with a node tree (it keeps only the node's colour); plus what glTF cannot say:
    point/spot radius, Soft Falloff and which rays see the lamp (camera; scattered rays when
    diffuse, glossy and transmission visibility are all on), Cycles' exact spot cone (size and
    blend), sun angle, area lights."""
    light = obj.data
    color, strength = light_tint(light)
    scale = 2.0 ** float(getattr(light, "exposure", 0.0)) * strength
    if light.type in ("POINT", "SPOT"):
        data = {"radius": float(light.shadow_soft_size), "power": float(light.energy) * scale,
                "color": color, "soft_falloff": bool(getattr(light, "use_soft_falloff", True)),
                "visible_camera": bool(getattr(obj, "visible_camera", False)),
                "visible_bounces": all(bool(getattr(obj, prop, True)) for prop in
                                       ("visible_diffuse", "visible_glossy",
                                        "visible_transmission"))}
        if light.type == "SPOT":
            data["spot_size"] = float(light.spot_size)
            data["spot_blend"] = float(light.spot_blend)
        return data
    if light.type == "SUN":
        return {"angle": float(light.angle), "strength": float(light.energy) * scale,
                "color": color}
    if light.type != "AREA":
        return {}
    size = float(light.size)
    size_y = float(light.size_y) if light.shape in ("RECTANGLE", "ELLIPSE") else size
    power = float(light.energy) * scale
    if not getattr(light, "normalize", True):
        # Without "normalize" Blender's power is per square metre; Photon always normalises.
        area = size * size_y * (math.pi / 4.0 if light.shape in ("DISK", "ELLIPSE") else 1.0)
        power *= area
    return {"type": "area", "shape": light.shape, "size": size, "size_y": size_y,
            "power": power, "color": color, "spread": float(light.spread),
            "visible_camera": bool(obj.visible_camera)}


def light_tint(light) -> tuple[list[float], float]:
    """(colour, strength factor) of a light as Cycles renders it: light.color x its blackbody
    colour (when use_temperature is on) x the Emission node's colour, and the node's strength
    (or the strength of a Light Falloff node's Quadratic output feeding it). What the node tree
    does beyond that is named by `light_node_problems` (the pre-flight report)."""
    color = [float(c) for c in light.color[:3]]
    if getattr(light, "use_temperature", False):
        color = [c * float(t) for c, t in zip(color, light.temperature_color[:3])]
    emission = light_emission_node(light)
    if emission is None:
        return color, 1.0
    node_color = emission.inputs["Color"]
    if not node_color.is_linked:
        color = [c * float(n) for c, n in zip(color, node_color.default_value[:3])]
    elif _blackbody_temperature(node_color) is not None:
        blackbody = blackbody_color(light, _blackbody_temperature(node_color))
        color = [c * b for c, b in zip(color, blackbody)]
    strength_input = emission.inputs["Strength"]
    strength = float(strength_input.default_value)
    if strength_input.is_linked:
        source = strength_input.links[0].from_node
        falloff_strength = source.inputs.get("Strength") if source.type == "LIGHT_FALLOFF" else None
        strength = 1.0
        if falloff_strength is not None and not falloff_strength.is_linked:
            strength = float(falloff_strength.default_value)
    return color, strength


def _blackbody_temperature(socket):
    """The temperature of a Blackbody node (its input unlinked) linked into `socket`, else
    None."""
    if not socket.is_linked:
        return None
    node = socket.links[0].from_node
    if node.type != "BLACKBODY" or node.inputs["Temperature"].is_linked:
        return None
    return float(node.inputs["Temperature"].default_value)


def blackbody_color(light, kelvin: float) -> list[float]:
    """Blender's blackbody colour of `kelvin`, read from the light's own temperature colour
    (Light.temperature_color, Blender's table) by setting its temperature for a moment."""
    saved = light.temperature, light.use_temperature
    try:
        light.temperature, light.use_temperature = kelvin, True  # the colour needs both
        return [float(c) for c in light.temperature_color[:3]]
    finally:
        light.temperature, light.use_temperature = saved


def light_emission_node(light):
    """The Emission node feeding the active Light Output of a light's node tree (Cycles uses the
    tree when use_nodes is on); None without one."""
    tree = light.node_tree if getattr(light, "use_nodes", False) else None
    if tree is None:
        return None
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_LIGHT"]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    if output is None or not output.inputs["Surface"].is_linked:
        return None
    node = output.inputs["Surface"].links[0].from_node
    return node if node.type == "EMISSION" else None


def light_node_problems(light) -> list[str]:
    """What a light's node tree does that `light_tint` does not carry ([] for none)."""
    tree = light.node_tree if getattr(light, "use_nodes", False) else None
    if tree is None:
        return []
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_LIGHT"]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    if output is None or not output.inputs["Surface"].is_linked:
        return ["its node tree has no shader on the Light Output (Cycles renders it black)"]
    emission = light_emission_node(light)
    if emission is None:
        node = output.inputs["Surface"].links[0].from_node
        return [f"the {node.bl_label} node '{node.name}' on its output is not exported (only an "
                f"Emission node is)"]
    problems = []
    if emission.inputs["Color"].is_linked and \
            _blackbody_temperature(emission.inputs["Color"]) is None:
        node = emission.inputs["Color"].links[0].from_node
        problems.append(f"the {node.bl_label} node '{node.name}' driving the emission colour "
                        f"is not exported")
    strength = emission.inputs["Strength"]
    if strength.is_linked:
        link = strength.links[0]
        node = link.from_node
        if node.type != "LIGHT_FALLOFF":
            problems.append(f"the {node.bl_label} node '{node.name}' driving the emission "
                            f"strength is not exported")
        elif link.from_socket.name != "Quadratic":
            problems.append(f"Light Falloff '{node.name}': its {link.from_socket.name} output "
                            f"is not exported (only Quadratic, the physical falloff, is)")
        elif node.inputs["Strength"].is_linked or node.inputs["Smooth"].is_linked \
                or float(node.inputs["Smooth"].default_value) != 0.0:
            problems.append(f"Light Falloff '{node.name}': a linked strength or a smooth "
                            f"falloff is not exported")
    return problems


def camera_extension(obj, scene) -> dict:
    """PHOTON_camera for a camera object: the lens shift in units of the image height, and depth
    of field as a thin lens (aperture radius, focus distance, blades, rotation, ratio), the way
    Cycles derives them from Blender's camera. Empty for a centred pinhole camera."""
    camera, data = obj.data, {}
    r = scene.render
    width = r.resolution_x * r.pixel_aspect_x
    height = r.resolution_y * r.pixel_aspect_y
    fit = camera.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if width >= height else "VERTICAL"
    # Blender's shift is a fraction of the fitted image side; Photon's of the image height.
    unit = width / height if fit == "HORIZONTAL" else 1.0
    if camera.shift_x != 0.0 or camera.shift_y != 0.0:
        data["shift"] = [float(camera.shift_x * unit), float(camera.shift_y * unit)]
    if camera.type == "PANO":
        panorama = panorama_extension(camera, width, height)
        if panorama:
            data["panorama"] = panorama
        return data
    poses = SHUTTER_POSES.get(obj.name)
    if poses:
        data["motion"] = poses
    dof = camera.dof
    if dof.use_dof:
        fstop = max(float(dof.aperture_fstop), 1e-5)
        if camera.type == "ORTHO":
            radius = 1.0 / (2.0 * fstop)
        else:
            radius = float(camera.lens) * 1e-3 / (2.0 * fstop)
        data["dof"] = {"aperture_radius": radius,
                       "focus_distance": max(focus_distance(obj), 1e-6),
                       "blades": int(dof.aperture_blades),
                       "rotation": float(dof.aperture_rotation),
                       "ratio": float(dof.aperture_ratio)}
    return data


# World matrices over the shutter (the camera's and moving objects'), by object name, while
# `shutter_poses_recorded` runs.
SHUTTER_POSES: dict[str, list[list[float]]] = {}
# Blender (x, y, z) is glTF (x, z, −y).
Z_UP_TO_Y_UP = mathutils.Matrix(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, 0), (0, 0, 0, 1)))


def shutter_times(scene) -> list[float]:
    """Frame times of the shutter's opening, middle and closing, as Cycles places them: the
    shutter (in frames) centred on the frame, starting or ending at it."""
    r = scene.render
    length = float(r.motion_blur_shutter)
    start = {"START": 0.0, "END": -length}.get(r.motion_blur_position, -0.5 * length)
    frame = scene.frame_current + scene.frame_subframe
    return [frame + start + k * 0.5 * length for k in range(3)]


def instances_in_their_instancers() -> dict:
    """The depsgraph's instances (particles, Geometry Nodes) now: their matrices relative to
    the object instancing them, rounded to 1e-5, by (instancer name, persistent id)."""
    placed = {}
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for instance in depsgraph.object_instances:
        if not instance.is_instance or instance.parent is None:
            continue
        relative = instance.parent.matrix_world.inverted_safe() @ instance.matrix_world
        key = (instance.parent.name, tuple(instance.persistent_id))
        placed[key] = tuple(round(x, 5) for row in relative for x in row)
    return placed


# Deforming meshes' vertex positions over the shutter, by object name, while
# `shutter_poses_recorded` runs: PHOTON_object's "deform".
DEFORM_STEPS: dict[str, dict] = {}


def deform_step_count(obj) -> int:
    """The moments at which Cycles samples `obj`'s motion and deformation: 2^(steps - 1) * 2 + 1
    for the object's motion blur steps (Object > Motion Blur > Steps; 3 by default)."""
    steps = max(1, int(getattr(getattr(obj, "cycles", None), "motion_steps", 1)))
    return (2 << (steps - 1)) + 1


def deforms_with_blur(obj) -> bool:
    """Whether `obj` is a mesh whose deformation (armature, animated shape keys) is blurred:
    Cycles' Object > Motion Blur and its Deformation switch on."""
    cycles = getattr(obj, "cycles", None)
    return (obj.type == "MESH" and preflight.deforms(obj)
            and getattr(cycles, "use_motion_blur", True)
            and getattr(cycles, "use_deform_motion", True))


def evaluated_positions(obj) -> str:
    """`obj`'s evaluated mesh vertices now (object space, glTF axes (x, z, -y)) as base64 of
    little-endian float32 triples, as the glTF exporter writes them."""
    import numpy as np
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = evaluated.to_mesh()
    try:
        co = np.empty(3 * len(mesh.vertices), dtype=np.float32)
        mesh.vertices.foreach_get("co", co)
    finally:
        evaluated.to_mesh_clear()
    co = co.reshape(-1, 3)
    gltf = np.stack([co[:, 0], co[:, 2], -co[:, 1]], axis=1).astype("<f4")
    return base64.b64encode(gltf.tobytes()).decode("ascii")


def deformation_recorded(scene, objects) -> dict[str, dict]:
    """PHOTON_object's "deform" of each deforming mesh of `objects`: its vertices at the frame
    and at `deform_step_count` moments evenly spread over the shutter. A mesh whose vertex count
    changes within the shutter is left out, with a warning."""
    deforming = [obj for obj in objects if deforms_with_blur(obj)]
    if not deforming:
        return {}
    times = shutter_times(scene)
    start, end = times[0], times[-1]
    frame, subframe = scene.frame_current, scene.frame_subframe
    steps = {obj.name: [] for obj in deforming}
    counts = {obj.name: deform_step_count(obj) for obj in deforming}
    try:
        for n in sorted(set(counts.values())):
            for k in range(n):
                t = start + (end - start) * k / (n - 1)
                scene.frame_set(math.floor(t), subframe=t - math.floor(t))
                for obj in deforming:
                    if counts[obj.name] == n:
                        steps[obj.name].append(evaluated_positions(obj))
    finally:
        scene.frame_set(frame, subframe=subframe)
    out = {}
    for obj in deforming:
        at_frame = evaluated_positions(obj)
        if len({len(s) for s in steps[obj.name]} | {len(at_frame)}) != 1:
            LOG.warning(f"object '{obj.name}': its deformation is not blurred (its vertex count "
                        f"changes within the shutter)")
            continue
        out[obj.name] = {"frame": at_frame, "steps": steps[obj.name]}
    return out


@contextlib.contextmanager
def shutter_poses_recorded(scene):
    """Within the block, SHUTTER_POSES holds, with Render > Motion Blur on, the world matrices
    (glTF axes, column-major) at `shutter_times` of the scene camera (scale removed) and, at
    their motion steps (`deform_step_count`) evenly spread over the shutter, of every rendered
    object the glTF exporter writes as a mesh with its Motion Blur switch on (Object > Motion
    Blur, as Cycles reads it), for those whose matrices differ;
    PHOTON_camera and PHOTON_object carry them as "motion". DEFORM_STEPS holds the deforming
    meshes' vertices over the shutter (`deformation_recorded`), PHOTON_object's "deform". The
    frame is put back afterwards."""
    if not scene.render.use_motion_blur:
        yield
        return
    objects = [obj for obj in scene.objects
               if obj == scene.camera or (obj.type in GEOMETRY_TYPES and not obj.hide_render
                                          and getattr(obj.cycles, "use_motion_blur", True))]
    # Objects take their own motion steps as in Cycles, the camera three.
    step_counts = {obj.name: 3 if obj == scene.camera else deform_step_count(obj)
                   for obj in objects}
    times = shutter_times(scene)
    frame, subframe = scene.frame_current, scene.frame_subframe
    poses = {obj.name: [] for obj in objects}
    carried = []
    try:
        for n in sorted(set(step_counts.values())):
            for k in range(n):
                t = times[0] + (times[-1] - times[0]) * k / (n - 1)
                scene.frame_set(math.floor(t), subframe=t - math.floor(t))
                carried.append(instances_in_their_instancers())
                for obj in (obj for obj in objects if step_counts[obj.name] == n):
                    # A camera node keeps Blender's camera axes; mesh nodes hold their vertices
                    # in glTF axes, so their matrices change axes on both sides.
                    if obj == scene.camera:
                        m = Z_UP_TO_Y_UP @ obj.matrix_world.normalized()
                    else:
                        m = Z_UP_TO_Y_UP @ obj.matrix_world @ Z_UP_TO_Y_UP.inverted()
                    poses[obj.name].append([float(m[r][c]) for c in range(4)
                                            for r in range(4)])
    finally:
        scene.frame_set(frame, subframe=subframe)
    SHUTTER_POSES.update({name: p for name, p in poses.items() if any(q != p[0] for q in p)})
    DEFORM_STEPS.update(deformation_recorded(scene, objects))
    for name in sorted({name for placed in carried[1:] for (name, _), m in placed.items()
                        if carried[0].get((name, _)) != m}):
        LOG.warning(f"object '{name}': its instances (particles, Geometry Nodes) move within "
                    f"the shutter on their own; only the motion of '{name}' carrying them is "
                    f"blurred")
    try:
        yield
    finally:
        SHUTTER_POSES.clear()
        DEFORM_STEPS.clear()


# The panoramic projections PHOTON_camera carries (the others are named by the pre-flight).
PANORAMAS = ("EQUIRECTANGULAR", "FISHEYE_EQUIDISTANT", "FISHEYE_EQUISOLID")


def panorama_extension(camera, width: float, height: float) -> dict:
    """The "panorama" of PHOTON_camera for a panoramic camera (Cycles' projection and its
    parameters; the equisolid sensor fitted to an image of `width` x `height` as Cycles fits
    it); empty for a projection Photon does not render."""
    kind = camera.panorama_type
    if kind == "EQUIRECTANGULAR":
        return {"type": kind,
                "longitude": [float(camera.longitude_min), float(camera.longitude_max)],
                "latitude": [float(camera.latitude_min), float(camera.latitude_max)]}
    if kind == "FISHEYE_EQUIDISTANT":
        return {"type": kind, "fov": float(camera.fisheye_fov)}
    if kind == "FISHEYE_EQUISOLID":
        fit = camera.sensor_fit
        horizontal = width > height if fit == "AUTO" else fit == "HORIZONTAL"
        size = float(camera.sensor_height if fit == "VERTICAL" else camera.sensor_width)
        sensor = [size, size * height / width] if horizontal else [size * width / height, size]
        return {"type": kind, "lens": float(camera.fisheye_lens),
                "fov": float(camera.fisheye_fov), "sensor": sensor}
    return {}


def focus_distance(obj) -> float:
    """The camera's focus distance: to its focus object (bone heads are not followed) along the
    camera axis, measured in the camera's unscaled frame as Cycles does, else the distance set."""
    dof = obj.data.dof
    target = dof.focus_object
    if target is None:
        return float(dof.focus_distance)
    frame = obj.matrix_world.normalized()
    local = frame.inverted() @ target.matrix_world.translation
    return abs(float(local.z))


# What Blender and Cycles show for an image whose file is missing.
MISSING_IMAGE_COLOR = (1.0, 0.0, 1.0, 1.0)


def image_file_missing(image) -> bool:
    """Whether `image` is a single file image (not packed, not generated) whose file does not
    exist: the glTF exporter then drops the texture without a word."""
    if image is None or image.source != "FILE" or image.packed_file is not None:
        return False
    path = bpy.path.abspath(image.filepath, library=image.library)
    return not os.path.isfile(path)


def missing_base_color_image(material) -> bool:
    """Warn (on LOG) about every image of `material`'s node tree whose file is missing, and
    return whether one of them feeds the Principled BSDF's Base Color: the exporter then leaves
    the base colour factor at its default, white, where Blender shows magenta."""
    tree = getattr(material, "node_tree", None)
    if tree is None:
        return False
    missing = [n for n in tree.nodes if n.type == "TEX_IMAGE" and image_file_missing(n.image)]
    for node in missing:
        LOG.warning(f"material '{material.name}': image '{node.image.name}' is missing (file "
                    f"'{bpy.path.abspath(node.image.filepath, library=node.image.library)}' not "
                    f"found); it renders magenta")
    bsdf = principled_bsdf(material)
    if bsdf is None or not missing:
        return False
    feeding = _upstream_nodes(bsdf.inputs["Base Color"])
    return any(node in feeding for node in missing)


def _upstream_nodes(socket) -> list:
    """The nodes linked, directly or not, into `socket` (within its tree)."""
    found, stack = [], [socket]
    while stack:
        for link in stack.pop().links:
            if link.from_node not in found:
                found.append(link.from_node)
                stack.extend(i for i in link.from_node.inputs if i.is_linked)
    return found


def subsurface_extension(material) -> dict:
    """PHOTON_material_subsurface: the subsurface inputs of the material's Principled BSDF (the
    one feeding the output, else the first), which the glTF exporter drops; empty when the
    weight is 0 or there is no Principled BSDF."""
    bsdf = principled_bsdf(material)
    if bsdf is None:
        return {}
    def value(name, default):
        socket = bsdf.inputs.get(name)  # older files' nodes lack some inputs
        return default if socket is None else socket.default_value

    weight = float(value("Subsurface Weight", 0.0))
    if weight <= 0.0:
        return {}
    # Cycles reads "Subsurface IOR" only for Random Walk (Skin); otherwise the BSDF's IOR.
    method = getattr(bsdf, "subsurface_method", "RANDOM_WALK")
    if method not in ("BURLEY", "RANDOM_WALK", "RANDOM_WALK_SKIN"):
        method = "RANDOM_WALK"  # e.g. an older Blender's legacy random walk
    skin = method == "RANDOM_WALK_SKIN"
    return {"method": method,
            "weight": weight,
            "radius": [float(c) for c in value("Subsurface Radius", (1.0, 0.2, 0.1))[:3]],
            "scale": float(value("Subsurface Scale", 0.05)),
            "ior": float(value("Subsurface IOR", 1.4) if skin else value("IOR", 1.5)),
            "anisotropy": float(value("Subsurface Anisotropy", 0.0))}


def principled_bsdf(material):
    """The material's Principled BSDF feeding the active output's Surface, else its first one;
    None without one."""
    tree = getattr(material, "node_tree", None)
    if tree is None:
        return None
    bsdfs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled"]
    for out in (n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"):
        surface = out.inputs.get("Surface")
        if out.is_active_output and surface is not None and surface.is_linked:
            if surface.links[0].from_node in bsdfs:
                return surface.links[0].from_node
    return bsdfs[0] if bsdfs else None


def world_extension(world, folder: Path | None = None) -> dict:
    """PHOTON_world (see `world_description`)."""
    return world_description(world, folder)[0]


def world_problems(world) -> list[str]:
    """What of `world`'s node tree PHOTON_world does not carry, one message each (for the
    pre-flight report)."""
    return world_description(world)[1]


def world_description(world, folder: Path | None = None) -> tuple[dict, list[str]]:
    """PHOTON_world for `world`, and the list of what it could not carry.

    Without nodes the world's viewport colour; without a world black. With nodes, the shader
    feeding the active World Output's Surface, read as a weighted sum of backgrounds:
    Background (and Emission) nodes whose colour is a constant, an Environment Texture
    (written into `folder` as a float EXR, see `environment_extension`) or a Nishita Sky
    Texture (its settings, evaluated by the renderer), mixed by Mix Shader (a constant factor)
    and Add Shader nodes. A Mix Shader whose factor is a Light Path node's "Is Camera Ray"
    gives camera rays another background than the rest: the tree is read once for each, and
    when they differ the camera's goes under "camera". One background of weight 1 is written
    as before ({"color", "strength"[, "environment" | "sky"]}), several under "mix" with their
    weights. Anything else is named in the problems and left out (a Background's colour fed by
    another node keeps its own colour value)."""
    black = {"color": [0.0, 0.0, 0.0], "strength": 1.0}
    if world is None:
        return black, []
    if not world_uses_nodes(world):
        return {"color": [float(c) for c in world.color[:3]], "strength": 1.0}, []
    problems: list[str] = []
    written: dict[str, dict] = {}  # environment images already written, by node name
    outputs = [n for n in world.node_tree.nodes if n.bl_idname == "ShaderNodeOutputWorld"]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    surface = output.inputs.get("Surface") if output is not None else None
    if surface is None or not surface.is_linked:
        return black, []
    views = [_world_shader(surface.links[0].from_node, 1.0, camera, folder, written, problems)
             for camera in (False, True)]
    # Each problem was found twice, once per view.
    problems = list(dict.fromkeys(problems))
    lighting, seen_by_camera = (_background_json(v) for v in views)
    data = lighting or black
    if seen_by_camera != lighting:
        data = {**data, "camera": seen_by_camera or black}
    return data, [f"world '{world.name}': {p}" for p in problems]


def _background_json(layers: list[tuple[float, dict]]) -> dict:
    """One background as PHOTON_world writes it; empty for none."""
    layers = [(w, layer) for w, layer in layers if w != 0.0]
    if not layers:
        return {}
    if len(layers) == 1 and layers[0][0] == 1.0:
        return layers[0][1]
    return {"mix": [{"weight": w, **layer} for w, layer in layers]}


def _linked_node(socket):
    """The node feeding `socket` past reroutes and muted links; None when unlinked."""
    while socket is not None and socket.is_linked:
        link = socket.links[0]
        if link.is_muted:
            return None
        node = link.from_node
        if node.bl_idname != "NodeReroute":
            return node
        socket = node.inputs[0]
    return None


def _world_shader(node, weight, camera, folder, written, problems) -> list[tuple[float, dict]]:
    """The backgrounds `node` (a world shader) adds up to, each with its weight, as a ray that
    is (`camera`) or is not a camera ray sees them."""
    if node is None or weight == 0.0:
        return []
    kind = node.bl_idname
    if kind in ("ShaderNodeBackground", "ShaderNodeEmission"):
        return [(weight, _world_background_layer(node, folder, written, problems))]
    if kind == "ShaderNodeAddShader":
        return [layer for socket in node.inputs[:2] for layer in
                _world_shader(_linked_node(socket), weight, camera, folder, written, problems)]
    if kind == "ShaderNodeMixShader":
        factor = _mix_factor(node, camera, problems)
        parts = ((node.inputs[1], 1.0 - factor), (node.inputs[2], factor))
        return [layer for socket, share in parts for layer in
                _world_shader(_linked_node(socket), weight * share, camera, folder, written,
                              problems)]
    problems.append(f"{node.bl_label} node '{node.name}' is not exported; the world renders "
                    f"without it")
    return []


def _mix_factor(node, camera: bool, problems) -> float:
    """A Mix Shader's factor in [0, 1]: its value, or for a Light Path node's "Is Camera Ray"
    whether the ray is a camera ray."""
    socket = node.inputs["Fac"]
    source = _linked_node(socket)
    if source is None:
        return min(max(float(socket.default_value), 0.0), 1.0)
    link = socket.links[0]
    while link.from_node.bl_idname == "NodeReroute":
        link = link.from_node.inputs[0].links[0]
    if source.bl_idname == "ShaderNodeLightPath" and link.from_socket.name == "Is Camera Ray":
        return 1.0 if camera else 0.0
    problems.append(f"Mix Shader '{node.name}': its factor comes from {source.bl_label} "
                    f"'{source.name}', which is not exported; the factor's own value "
                    f"{float(socket.default_value):.3g} is used")
    return min(max(float(socket.default_value), 0.0), 1.0)


def _world_background_layer(node, folder, written, problems) -> dict:
    """One Background (or Emission) node: its colour and strength, or the Environment or Sky
    Texture feeding its colour."""
    color_input, strength_input = node.inputs["Color"], node.inputs["Strength"]
    layer = {"color": [float(c) for c in color_input.default_value[:3]],
             "strength": float(strength_input.default_value)}
    if strength_input.is_linked:
        problems.append(f"{node.bl_label} '{node.name}': a linked Strength is not exported; its "
                        f"value {layer['strength']:.3g} is used")
    texture = _linked_node(color_input)
    if texture is None:
        return layer
    if texture.bl_idname == "ShaderNodeTexEnvironment":
        layer["color"] = [0.0, 0.0, 0.0]  # what Cycles shows without a usable image
        if folder is not None:
            if texture.name not in written:
                written[texture.name] = environment_extension(texture, folder)
            if written[texture.name]:
                layer["environment"] = written[texture.name]
        return layer
    if texture.bl_idname == "ShaderNodeTexSky" and texture.sky_type == "NISHITA":
        layer["color"] = [0.0, 0.0, 0.0]
        layer["sky"] = sky_extension(texture)
        return layer
    what = (f"the {texture.sky_type} sky model" if texture.bl_idname == "ShaderNodeTexSky"
            else f"{texture.bl_label} node '{texture.name}'")
    problems.append(f"{what} feeding '{node.name}' is not exported; the background renders its "
                    f"own colour")
    return layer


def sky_extension(node) -> dict:
    """The "sky" of PHOTON_world for a Sky Texture node of the Nishita model: its settings
    (radians, metres, factors) and the rotation of a Mapping node feeding its vector."""
    return {"type": "NISHITA", "sun_disc": bool(node.sun_disc),
            "sun_size": float(node.sun_size), "sun_intensity": float(node.sun_intensity),
            "sun_elevation": float(node.sun_elevation),
            "sun_rotation": float(node.sun_rotation), "altitude": float(node.altitude),
            "air": float(node.air_density), "dust": float(node.dust_density),
            "ozone": float(node.ozone_density), "rotation": _mapping_rotation(node)}


def environment_extension(node, folder: Path) -> dict:
    """The "environment" of PHOTON_world for an Environment Texture node: its image written to
    `folder` as a float EXR (linear RGB; 8-bit sRGB images are linearised as Cycles does), the
    rotation of a Mapping node feeding its vector, and its interpolation. Empty (with a warning
    on LOG) when the node has no image, the image has no pixels or the projection is not
    equirectangular: the world is then black, as in Cycles."""
    image = node.image
    if image is None:
        return {}
    if node.projection != "EQUIRECTANGULAR":
        LOG.warning(f"world texture '{image.name}': only the equirectangular projection is "
                    f"supported, not {node.projection}; the world is black")
        return {}
    width, height = image.size
    if width == 0 or height == 0:
        LOG.warning(f"world texture '{image.name}' has no pixels (file missing? "
                    f"{image.filepath}); the world is black")
        return {}
    import numpy as np  # shipped with Blender; imported here so the module loads without it
    pixels = np.empty(len(image.pixels), dtype=np.float32)
    image.pixels.foreach_get(pixels)
    rgb = pixels.reshape(height, width, -1)[::-1, :, :3]  # Blender's rows start at the bottom
    if rgb.shape[2] < 3:
        rgb = np.repeat(rgb[:, :, :1], 3, axis=2)
    if not image.is_float and image.colorspace_settings.name == "sRGB":
        rgb = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in image.name)
    uri = f"world_{safe}.exr"
    write_exr_rgb(folder / uri, np.ascontiguousarray(rgb, dtype=np.float32))
    return {"uri": uri, "rotation": _mapping_rotation(node),
            "interpolation": "closest" if node.interpolation == "Closest" else "linear"}


def _mapping_rotation(node) -> list[float]:
    """Euler XYZ rotation (radians) applied to the lookup direction, read from a Mapping node
    feeding the texture's Vector (Point, Vector and Normal types rotate the direction, Texture
    inverts; location and scale are ignored);
    zero when the vector is not mapped."""
    vector = node.inputs.get("Vector")
    if vector is None or not vector.is_linked:
        return [0.0, 0.0, 0.0]
    mapping = vector.links[0].from_node
    if mapping.bl_idname != "ShaderNodeMapping":
        return [0.0, 0.0, 0.0]
    euler = mapping.inputs["Rotation"].default_value.copy()
    if mapping.vector_type == "TEXTURE":
        euler = euler.to_matrix().inverted().to_euler("XYZ")
    return [float(a) for a in euler]


def write_exr_rgb(path: Path, rgb):
    """Write an (H, W, 3) float32 array (row 0 = top) as an uncompressed scanline OpenEXR file
    with FLOAT channels R, G, B: exact, and the same in every Blender version (Image.save gives
    no control over precision)."""
    height, width, _ = rgb.shape

    def attribute(name, kind, value: bytes) -> bytes:
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value

    channels = b"".join(c + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in (b"B", b"G", b"R"))
    window = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    header = (struct.pack("<ii", 20000630, 2)
              + attribute("channels", "chlist", channels + b"\0")
              + attribute("compression", "compression", b"\0")
              + attribute("dataWindow", "box2i", window)
              + attribute("displayWindow", "box2i", window)
              + attribute("lineOrder", "lineOrder", b"\0")
              + attribute("pixelAspectRatio", "float", struct.pack("<f", 1.0))
              + attribute("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0))
              + attribute("screenWindowWidth", "float", struct.pack("<f", 1.0))
              + b"\0")
    line_bytes = 3 * 4 * width
    first = len(header) + 8 * height
    offsets = struct.pack(f"<{height}Q", *(first + y * (8 + line_bytes) for y in range(height)))
    with open(path, "wb") as f:
        f.write(header + offsets)
        for y in range(height):
            row = rgb[y].astype("<f4")
            f.write(struct.pack("<ii", y, line_bytes))
            f.write(b"".join(row[:, c].tobytes() for c in (2, 1, 0)))


def world_uses_nodes(world) -> bool:
    """Whether the world's node tree is what renders. Blender 5 always uses it (World.use_nodes
    is deprecated there and reading it warns); Blender 4 only when use_nodes is on."""
    if world.node_tree is None:
        return False
    return bpy.app.version >= (5, 0, 0) or world.use_nodes


def film_filter(scene) -> dict:
    """Cycles' pixel filter (Render > Film > Pixel Filter): its type and width in pixels. Blender
    gives Cycles a 1-px box whatever the width field says, so a box is written 1 px wide;
    without the Cycles add-on's settings, Blender's default (Blackman-Harris, 1.5 px)."""
    cycles = getattr(scene, "cycles", None)
    kind = getattr(cycles, "pixel_filter_type", "BLACKMAN_HARRIS")
    width = 1.0 if kind == "BOX" else float(getattr(cycles, "filter_width", 1.5))
    return {"type": kind, "width": width}


def render_extension(scene) -> dict:
    """PHOTON_render: the final image size (resolution x percentage), transparent film and the
    pixel filter."""
    r = scene.render
    scale = r.resolution_percentage / 100.0
    return {"width": max(1, int(r.resolution_x * scale)),
            "height": max(1, int(r.resolution_y * scale)),
            "film_transparent": bool(r.film_transparent),
            "filter": film_filter(scene)}


# ---------------------------------------------------------------------------------------------
# Export routes
# ---------------------------------------------------------------------------------------------

def export_route() -> str:
    """'inprocess' in background Blender, 'subprocess' in the UI; PHOTON_EXPORT overrides."""
    forced = os.environ.get("PHOTON_EXPORT", "").strip().lower()
    if forced in ("inprocess", "subprocess"):
        return forced
    return "inprocess" if bpy.app.background else "subprocess"


class _Collector(logging.Handler):
    """Keeps the messages (WARNING and above) logged during an export, each once."""

    def __init__(self):
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record):
        text = record.getMessage().strip()
        if record.name in GLTF_LOGGERS:
            if text in CARRIED_BY_HOOKS:
                return
            text = f"glTF exporter: {text}"
        if text and text not in self.messages:
            self.messages.append(text)


@contextlib.contextmanager
def collected_warnings():
    """Collect what the glTF exporter and the hooks warn about within the block."""
    collector = _Collector()
    loggers = [logging.getLogger(name) for name in (*GLTF_LOGGERS, LOG.name)]
    for logger in loggers:
        logger.addHandler(collector)
    try:
        yield collector.messages
    finally:
        for logger in loggers:
            logger.removeHandler(collector)


@contextlib.contextmanager
def render_visibility(scene):
    """Within the block the viewport shows what a render shows, and is put back after it.

    The glTF exporter reads the viewport's evaluated depsgraph: modifiers at their viewport
    settings (a Subdivision Surface at its viewport level, render-only modifiers left out) and
    without objects or collections disabled in viewports but enabled for rendering. Here every
    modifier's viewport switch follows its render switch, Subdivision Surface and Multires take
    their render levels, and rendered objects and collections are enabled in viewports.
    Objects only in collections excluded from the view layer or disabled for rendering (also
    through a parent collection), which the exporter would still write, are disabled for
    rendering; their instances (particles, Geometry Nodes) are still exported, as Cycles renders
    them."""
    saved = []

    def assign(owner, attribute, value):
        old = getattr(owner, attribute)
        if old != value:
            try:
                setattr(owner, attribute, value)
            except (AttributeError, TypeError, RuntimeError):  # linked, read-only data
                return
            saved.append((owner, attribute, old))

    try:
        # Only ever enabled in viewports: an object disabled there is not evaluated, and the
        # instances of it (particles, Geometry Nodes) would be lost with it. What must not
        # render is disabled for rendering, which the exporter's filter reads.
        for collection in scene.collection.children_recursive:
            if not collection.hide_render:
                assign(collection, "hide_viewport", False)
        rendered = rendered_objects(bpy.context.view_layer)
        for obj in scene.objects:
            if obj.name_full not in rendered:
                assign(obj, "hide_render", True)
            if not obj.hide_render:
                assign(obj, "hide_viewport", False)
            for modifier in obj.modifiers:
                assign(modifier, "show_viewport", modifier.show_render)
                if modifier.type in ("SUBSURF", "MULTIRES"):
                    assign(modifier, "levels", modifier.render_levels)
        if saved:
            bpy.context.view_layer.update()
        yield
    finally:
        for owner, attribute, old in reversed(saved):
            setattr(owner, attribute, old)
        if saved:
            bpy.context.view_layer.update()


# Name of the pass-through Geometry Nodes group that `shape_keys_applied` adds for an export.
PASS_THROUGH = "Photon pass-through (export)"


@contextlib.contextmanager
def shape_keys_applied(scene):
    """Within the block, mesh objects with shape keys and no modifier carry a pass-through
    Geometry Nodes modifier (group input to group output), removed after it.

    For a mesh object without modifiers, the glTF exporter writes the original mesh (so that
    objects sharing a mesh share it in the file) and the shape keys only as morph targets,
    which the renderer does not read: the frame's shape-key values would be lost. Any modifier
    makes it write the evaluated mesh, shape keys applied."""
    owners = [obj for obj in scene.objects
              if obj.type == "MESH" and len(obj.modifiers) == 0 and obj.data.shape_keys
              and not obj.hide_render]

    def pass_through():
        group = bpy.data.node_groups.new(PASS_THROUGH, "GeometryNodeTree")
        group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
        group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
        group.links.new(group.nodes.new("NodeGroupInput").outputs[0],
                        group.nodes.new("NodeGroupOutput").inputs[0])
        return group, None

    with points_curves.node_modifier_added(owners, pass_through) as added:
        if added:
            bpy.context.view_layer.update()
        yield


def rendered_objects(view_layer) -> set[str]:
    """Names of the objects a render of `view_layer` can show: those in a collection that is
    neither excluded from the view layer nor disabled for rendering, itself or through a
    parent (the object's own render switch is not looked at)."""
    found = set()
    stack = [(view_layer.layer_collection, False)]
    while stack:
        layer, hidden = stack.pop()
        if layer.exclude:
            continue
        hidden = hidden or layer.collection.hide_render
        if not hidden:
            found.update(obj.name_full for obj in layer.collection.objects)
        stack.extend((child, hidden) for child in layer.children)
    return found


def node_trees(scene) -> list[dict]:
    """The PHOTON_material_nodes trees of the scene's materials (those written)."""
    seen, trees = set(), []
    for obj in scene.objects:
        for slot in getattr(obj, "material_slots", ()):
            material = slot.material
            if material is None or material.name in seen:
                continue
            seen.add(material.name)
            tree = node_tree.material_nodes(material)[0]
            if tree:
                trees.append(tree)
    return trees


def reads_vertex_colors(trees) -> bool:
    """Whether a tree reads vertex colours (a Color Attribute or Attribute node)."""
    return any(n["type"] in ("ShaderNodeVertexColor", "ShaderNodeAttribute")
               for tree in trees for n in tree["nodes"])


def export_in_process(glb: Path, hook_module: str) -> list[str]:
    """Run Blender's glTF exporter on the current scene and return its warnings and the hooks'.
    `hook_module` is the name in sys.modules that holds `glTF2ExportUserExtension`: the exporter
    only looks at enabled add-ons, so it is listed there for the duration of the export if it is
    not already."""
    prefs = bpy.context.preferences
    added = None
    if hook_module not in prefs.addons.keys():
        added = prefs.addons.new()
        added.module = hook_module
    try:
        scene = bpy.context.scene
        args = dict(GLTF_EXPORT_ARGS)
        trees = node_trees(scene)
        if reads_vertex_colors(trees):
            # The exporter writes COLOR_0 only for colours wired straight into Base Color;
            # node trees Photon evaluates read the active colour attribute as COLOR_0.
            args["export_vertex_color"] = "ACTIVE"
        if any(node_tree.uses_tangents(tree) for tree in trees):
            # Normal Map nodes in tangent space read the meshes' tangents (MikkTSpace, as
            # Cycles computes them).
            args["export_tangents"] = True
        with collected_warnings() as warnings, render_visibility(scene), \
                shape_keys_applied(scene), points_curves.as_meshes(scene), \
                shutter_poses_recorded(scene):
            result = bpy.ops.export_scene.gltf(filepath=str(glb), **args)
    except Exception as exc:  # the operator raises RuntimeError with Blender's own report
        raise ExportError(f"glTF export failed: {exc}") from None
    finally:
        if added is not None:
            prefs.addons.remove(added)
    if "FINISHED" not in result or not Path(glb).is_file():
        raise ExportError(f"glTF export did not write {glb} ({result})")
    return warnings


def child_command(snapshot: Path, glb: Path | None, autoexec: bool = False) -> list[str]:
    """The command that exports a snapshot .blend in a separate process: Blender itself, or the
    Python interpreter when bpy runs as a module (bpy.app.binary_path is then empty). Without
    `glb` the child serves an animation (`_serve`). `autoexec`: Python scripts and drivers in
    the file may run (Blender's -y), as the user's session allows them."""
    script = str(Path(__file__).resolve())
    target = [str(glb)] if glb is not None else ["--serve"]
    if bpy.app.binary_path:
        return [bpy.app.binary_path, "-b", "--factory-startup", "--python-exit-code", "1",
                *(["-y"] if autoexec else []), "--python", script,
                "--", str(snapshot), *target]
    return [sys.executable, script, "--", str(snapshot), *target,
            *(["--autoexec"] if autoexec else [])]


def scripts_may_run() -> bool:
    """Whether the user's session runs Python drivers and scripts of blend files."""
    return bool(bpy.context.preferences.filepaths.use_scripts_auto_execute)


def write_snapshot(scene, path: Path):
    """Write `scene` and everything it uses to a .blend, without needing a window context."""
    bpy.data.libraries.write(str(path), {scene}, fake_user=True, path_remap="ABSOLUTE")


def _child_main(argv: list[str]) -> int:
    """Entry point of the child process: open the snapshot, export it (or serve frames)."""
    args = argv[argv.index("--") + 1:]
    snapshot, target = args[:2]
    sys.modules[CHILD_MODULE] = sys.modules[__name__]
    if "--autoexec" in args and not bpy.app.binary_path:  # Blender itself was given -y
        bpy.context.preferences.filepaths.use_scripts_auto_execute = True
    bpy.ops.wm.open_mainfile(filepath=snapshot)
    if target == "--serve":
        return _serve()
    try:
        warnings = export_in_process(Path(target), CHILD_MODULE)
    except ExportError as exc:
        print(f"photon-export: error: {exc}", file=sys.stderr, flush=True)
        return 2
    for warning in warnings:  # read by runner.run as progress events
        _emit(warning=warning)
    return 0


def _emit(**event):
    print(json.dumps({"stage": "export", **event}), file=sys.stderr, flush=True)


def _serve() -> int:
    """Export one frame of the opened file per request line on stdin, `{"frame": F,
    "subframe": S, "glb": PATH}`, each answered on stderr by its warnings and then
    `{"exported": PATH}` or `{"error": MESSAGE}` (runner.Server). Ends when stdin closes.
    One background Blender thus exports every frame of an animation: the frame's state comes
    from `frame_set`, as in the user's session."""
    for line in sys.stdin:
        if not line.strip():
            continue
        request = json.loads(line)
        scene = bpy.context.scene
        scene.frame_set(int(request["frame"]), subframe=float(request.get("subframe", 0.0)))
        try:
            warnings = export_in_process(Path(request["glb"]), CHILD_MODULE)
        except ExportError as exc:
            _emit(error=str(exc))
            continue
        for warning in warnings:
            _emit(warning=warning)
        _emit(exported=request["glb"])
    return 0


if __name__ == "__main__":
    code = _child_main(sys.argv)
    sys.stdout.flush()
    sys.stderr.flush()
    # Leave without the interpreter's shutdown: the bpy module can hang there (seen with a
    # file holding Python drivers); the export is written and closed.
    os._exit(code)
