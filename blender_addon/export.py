"""Scene export: Blender's own glTF exporter plus hooks that write Photon's glTF extensions.

`export_scene` writes the scene being rendered to a .glb. Two routes, one chosen per render:

- in process (Blender running in the background, `-b`, or bpy as a Python module): call
  `bpy.ops.export_scene.gltf` directly from `RenderEngine.render`, which works there;
- in a child Blender (the interactive UI): F12 runs `render()` in a job thread where the exporter,
  which needs a window context, can fail. The scene is written to a
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

The hooks take each extension from the module that knows it: lights.py (PHOTON_light),
camera.py (PHOTON_camera), motion.py (the poses and deformation over the shutter), world.py
(PHOTON_world), node_tree.py (PHOTON_material_nodes); the object and material extensions and
the export routes are here.

This file runs both inside the add-on and as the child's script, so it imports only bpy, the
standard library, numpy (shipped with Blender) and the add-on's modules that do the same
(never engine, preflight, preview or the interface).
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import sys
from pathlib import Path

import bpy

try:
    from . import (camera, lights, motion, node_tree, object_attributes, points_curves,
                   volumes, world)
    from .node_graph import active_output, source, upstream
    from .shared import GEOMETRY_TYPES, LOG, REC709, working_space
except ImportError:  # run as the child's script: the add-on's folder holds the other modules
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import camera
    import lights
    import motion
    import node_tree
    import object_attributes
    import points_curves
    import volumes
    import world
    from node_graph import active_output, source, upstream
    from shared import GEOMETRY_TYPES, LOG, REC709, working_space

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

# The glTF exporter's loggers (io_scene_gltf2.io.com.debug.Log).
GLTF_LOGGERS = ("glTFImporter", "glTFImporter_errors")
# Exporter warnings about what the hooks carry anyway: the area lights (PHOTON_light), and light
# node trees, which the pre-flight report already names (preflight.light_features).
CARRIED_BY_HOOKS = ("Unsupported light source AREA",
                    "No quadratic light falloff node attached to emission strength property")


# The exporter's warning about a mesh without faces, which an object whose Geometry Nodes make
# only volumes has (the volumes are exported as boxes: volumes.as_boxes).
EMPTY_MESH = "Mesh '{}' has no primitives and will be omitted."


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
        # Blender's light and shadow linking as numbered sets (lights.light_linking).
        self._emitters, self._receivers, _ = lights.light_linking(bpy.context.scene.objects)

    def _light_linking(self, blender_object) -> dict:
        """PHOTON_object's "light_linking" of `blender_object`: its sets as an emitter and
        those it is left out of; {} without linking."""
        name = blender_object.name
        return {**self._emitters.get(name, {}), **self._receivers.get(name, {})}

    def _add(self, gltf_object, name, data):
        if gltf_object.extensions is None:
            gltf_object.extensions = {}
        gltf_object.extensions[name] = self._extension(name=name, extension=data, required=False)

    def gather_node_hook(self, gltf_node, blender_object, export_settings):
        if blender_object is not None and blender_object.type == "LIGHT":
            data = lights.light_extension(blender_object)
            if data:
                self._add(gltf_node, "PHOTON_light", data)
            linking = self._light_linking(blender_object)
            if linking:
                self._add(gltf_node, "PHOTON_object", {"light_linking": linking})
        if blender_object is not None and blender_object.type in GEOMETRY_TYPES:
            data = visibility_extension(blender_object)
            if blender_object.name in motion.SHUTTER_POSES:
                data["motion"] = motion.SHUTTER_POSES[blender_object.name]
            if blender_object.name in motion.DEFORM_STEPS:
                data["deform"] = motion.DEFORM_STEPS[blender_object.name]
            space = texture_space(blender_object)
            if space and uses_node_materials(blender_object):
                data["texture_space"] = space
            if blender_object.name in volumes.BOXES:
                data["volume"] = volumes.BOXES[blender_object.name]
            linking = self._light_linking(blender_object)
            if linking:
                data["light_linking"] = linking
            if data:
                self._add(gltf_node, "PHOTON_object", data)
        if blender_object is not None and blender_object.type == "CAMERA":
            data = camera.camera_extension(blender_object, bpy.context.scene,
                                           motion.SHUTTER_POSES.get(blender_object.name))
            if data:
                self._add(gltf_node, "PHOTON_camera", data)

    def vtree_after_filter_hook(self, vtree, export_settings):
        """Write each particle instance once. The exporter walks an instancer's depsgraph
        instances twice: as duplis (nodes of the instanced object, which its filter then drops
        when that object is disabled for rendering) and again, for Geometry Nodes
        (`export_gn_mesh`), as nodes of its data; for particle systems both walks yield the
        same instances, so those of a rendered object would stand twice at one place (twice
        the light of an emitting instance, two coincident boundaries of a volume). After the
        filter, a data node is dropped where a dupli node of the same parent stands at the
        same matrix."""
        for parent in list(vtree.nodes.values()):
            children = [vtree.nodes[uuid] for uuid in parent.children if uuid in vtree.nodes]
            duplis = {_matrix_key(c.matrix_world) for c in children
                      if c.blender_object is not None and c.matrix_world is not None}
            if not duplis:
                continue
            for child in children:
                if child.blender_object is None and child.matrix_world is not None \
                        and _matrix_key(child.matrix_world) in duplis:
                    _drop_node(vtree, parent, child)

    def gather_attribute_keep(self, keep_attribute, export_settings):
        """Keep the mesh attributes node trees read by name (Attribute nodes of type
        Geometry), written as `_NAME`."""
        if keep_attribute.attr_name in NAMED_ATTRIBUTES:
            keep_attribute.keep = True
            if not keep_attribute.attr_name.startswith("_"):
                keep_attribute.attr_name = "_" + keep_attribute.attr_name

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
        described = world.world_extension(blender_scene.world, folder)
        volume = world_volume(blender_scene.world, folder)
        if volume is not None:
            described = {**described, "volume": volume}
        self._add(gltf_scene, "PHOTON_world", described)
        self._add(gltf_scene, "PHOTON_render", render_extension(blender_scene))
        slots = object_attributes.attribute_slots()
        if reads_object_info() or slots:
            for gltf_node, info in object_infos(export_settings["vtree"], slots):
                known = (gltf_node.extensions or {}).get("PHOTON_object")
                if known is not None:
                    known.extension["info"] = info
                else:
                    self._add(gltf_node, "PHOTON_object", {"info": info})


def _matrix_key(matrix):
    """A world matrix, rounded, as a key for finding nodes at one place."""
    return tuple(round(float(matrix[r][c]), 5) for r in range(3) for c in range(4))


def _drop_node(vtree, parent, node):
    """Remove `node` (a leaf of the exporter's tree: an instance of data) from `vtree`."""
    parent.children.remove(node.uuid)
    parent.children_type.pop(node.uuid, None)
    for uuid in node.children:
        vtree.nodes.pop(uuid, None)
    vtree.nodes.pop(node.uuid, None)


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
    other ray types are named by the pre-flight report), "holdout" when the object is a
    holdout (its own setting, or a holdout collection of the view layer holding it), and
    "shadow_catcher" when it is one."""
    seen = bool(getattr(obj, "visible_camera", True))
    shadow = bool(getattr(obj, "visible_shadow", True))
    data = {} if seen and shadow else {"visible_camera": seen, "visible_shadow": shadow}
    if getattr(obj, "is_holdout", False) or obj.name in holdout_objects(bpy.context.view_layer):
        data["holdout"] = True
    if getattr(obj, "is_shadow_catcher", False):
        data["shadow_catcher"] = True
    return data


def reads_object_info() -> bool:
    """Whether some material or node group has an Object Info node."""
    trees = [m.node_tree for m in bpy.data.materials if m.node_tree is not None]
    trees += list(bpy.data.node_groups)
    return any(n.bl_idname == "ShaderNodeObjectInfo" for t in trees for n in t.nodes)


def object_infos(vtree, slots=None):
    """`(glTF node, PHOTON_object "info")` of every mesh node the exporter wrote: what
    Object Info reads of its object as Cycles syncs it (blender/object.cpp): the location of
    the node, the colour of the object it shows (of its instancer for an instance, as Blender's
    depsgraph gives it), the pass index of the object it shows, and the random id of the
    depsgraph instance it is (found by its world matrix: Geometry Nodes and particle
    instances, objects of instanced collections), else Cycles' hash of the object's name;
    with `slots` (object_attributes.attribute_slots), the values of the Object and Instancer
    attributes the node trees read, in slot order."""
    def key(matrix):
        return tuple(round(float(matrix[r][c]), 4) for r in range(3) for c in range(4))

    lookup = object_attributes.InstanceLookup(slots) if slots else None
    instances = {}
    for inst in bpy.context.evaluated_depsgraph_get().object_instances:
        if inst.is_instance:
            values = None
            if lookup is not None:
                # A Geometry Nodes instance's index among its instancer's instances (the
                # dupli's second level: the first numbers the geometry's components).
                index = inst.persistent_id[1] if inst.particle_system is None else -1
                values = lookup.values(inst.object, parent=inst.parent,
                                       particles=inst.particle_system, index=index)
            # An instance's colour is its instancer's (Blender's depsgraph copies it).
            instances.setdefault(key(inst.matrix_world), []).append(
                (inst.object.original.name, getattr(inst.object.data, "name", None),
                 inst.random_id & 0xFFFFFFFF, inst.object, values, list(inst.parent.color)))
    for vnode in vtree.nodes.values():
        gltf_node = getattr(vnode, "node", None)
        if gltf_node is None or gltf_node.mesh is None or vnode.matrix_world is None:
            continue
        obj = vnode.blender_object
        candidates = instances.get(key(vnode.matrix_world), [])
        if obj is not None:
            found = [c for c in candidates if c[0] == obj.name]
        else:
            data = getattr(vnode.data, "name", None)
            found = [c for c in candidates if c[1] == data] or candidates
        if found:
            random_id, shown, values, color = found[0][2:6]
        elif obj is not None:
            random_id, shown, color = cycles_name_hash(obj.name), obj, obj.color
            values = lookup.values(obj) if lookup is not None else None
        else:
            continue
        info = {
            "location": [float(v) for v in vnode.matrix_world.translation],
            "color": [float(v) for v in color],
            "pass_index": int(shown.pass_index),
            "random_id": random_id,
        }
        if values is not None:
            info["attributes"] = values
        yield gltf_node, info


def cycles_name_hash(name: str) -> int:
    """Cycles' random id of an object that is not an instance: Jenkins' lookup3 of two words
    (`hash_uint2`) over the name's multiplicative string hash (each byte a signed char) and 0."""
    mask = 0xFFFFFFFF
    h = 0
    for byte in name.encode("utf-8"):
        h = (h * 37 + (byte if byte < 128 else byte - 256)) & mask

    def rot(x, k):
        return ((x << k) | (x >> (32 - k))) & mask

    b = c = (0xDEADBEEF + (2 << 2) + 13) & mask
    a = (b + h) & mask  # the second word, 0, leaves b as it is
    c = ((c ^ b) - rot(b, 14)) & mask
    a = ((a ^ c) - rot(c, 11)) & mask
    b = ((b ^ a) - rot(a, 25)) & mask
    c = ((c ^ b) - rot(b, 16)) & mask
    a = ((a ^ c) - rot(c, 4)) & mask
    b = ((b ^ a) - rot(a, 14)) & mask
    c = ((c ^ b) - rot(b, 24)) & mask
    return c


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
    feeding = [found.node for found in upstream(bsdf.inputs["Base Color"])]
    return any(node in feeding for node in missing)


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
    output = active_output(tree, "ShaderNodeOutputMaterial")
    surface = output.inputs.get("Surface") if output is not None else None
    shader = source(surface).node if surface is not None else None
    if shader is not None and shader in bsdfs:
        return shader
    return bsdfs[0] if bsdfs else None



def film_filter(scene) -> dict:
    """Cycles' pixel filter (Render > Film > Pixel Filter): its type and width in pixels. Blender
    gives Cycles a 1-px box whatever the width field says, so a box is written 1 px wide;
    without the Cycles add-on's settings, Blender's default (Blackman-Harris, 1.5 px)."""
    cycles = getattr(scene, "cycles", None)
    kind = getattr(cycles, "pixel_filter_type", "BLACKMAN_HARRIS")
    width = 1.0 if kind == "BOX" else float(getattr(cycles, "filter_width", 1.5))
    return {"type": kind, "width": width}


def render_extension(scene) -> dict:
    """PHOTON_render: the final image size (resolution x percentage), transparent film, the
    pixel filter, Blender's Volume bounces, Clamp Direct / Clamp Indirect and the Caustics
    settings (Light Paths, Cycles' settings) and the file's working colour space."""
    r = scene.render
    scale = r.resolution_percentage / 100.0
    extension = {"width": max(1, int(r.resolution_x * scale)),
                 "height": max(1, int(r.resolution_y * scale)),
                 "film_transparent": bool(r.film_transparent),
                 "filter": film_filter(scene)}
    cycles = getattr(scene, "cycles", None)
    volume_bounces = int(getattr(cycles, "volume_bounces", 0))
    if volume_bounces:  # 0, Blender's default, is the extension's too
        extension["volume_bounces"] = volume_bounces
    # 0 (no limit) is the extension's default; Blender's Clamp Indirect defaults to 10.
    for key, setting in (("clamp_direct", "sample_clamp_direct"),
                         ("clamp_indirect", "sample_clamp_indirect")):
        limit = float(getattr(cycles, setting, 0.0))
        if limit > 0.0:
            extension[key] = limit
    # Reflective and Refractive Caustics are on in Blender and in the extension by default;
    # Filter Glossy is 1 in Blender and 0 (off) in the extension.
    for key in ("caustics_reflective", "caustics_refractive"):
        if not bool(getattr(cycles, key, True)):
            extension[key] = False
    blur = float(getattr(cycles, "blur_glossy", 0.0))
    if blur > 0.0:
        extension["filter_glossy"] = blur
    space = working_space()
    if space != REC709:  # the extension's default
        extension["working_space"] = space
    return extension


def world_volume(blender_world, folder=None):
    """The tree feeding the world's Volume socket (node_tree.volume_tree), or None."""
    if blender_world is None or not world.world_uses_nodes(blender_world):
        return None
    output = active_output(blender_world.node_tree, "ShaderNodeOutputWorld")
    if output is None:
        return None
    return node_tree.volume_tree(blender_world, output, folder=folder)[0]


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
            if text in CARRIED_BY_HOOKS or any(text == EMPTY_MESH.format(name)
                                               for name in volumes.ONLY_VOLUMES):
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


# The names of the mesh attributes the scene's node trees read, during an export.
NAMED_ATTRIBUTES: set[str] = set()


def named_attributes(trees) -> set[str]:
    """The attribute names the trees' Attribute nodes of type Geometry read."""
    return {n["attribute_name"] for tree in trees for n in tree["nodes"]
            if n["type"] == "ShaderNodeAttribute" and n.get("attribute_name")
            and n.get("attribute_type", "GEOMETRY") == "GEOMETRY"} | node_tree.hair_info_attributes(trees)


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
        NAMED_ATTRIBUTES.clear()
        NAMED_ATTRIBUTES.update(named_attributes(trees))
        if NAMED_ATTRIBUTES:
            # Blender's exporter writes the attributes the hook keeps (`_NAME`).
            args["export_attributes"] = True
        if any(node_tree.uses_tangents(tree) for tree in trees):
            # Normal Map nodes in tangent space read the meshes' tangents (MikkTSpace, as
            # Cycles computes them).
            args["export_tangents"] = True
        with collected_warnings() as warnings, render_visibility(scene), \
                shape_keys_applied(scene), points_curves.as_meshes(scene), \
                volumes.as_boxes(scene, Path(glb), holdout_objects(bpy.context.view_layer)), \
                motion.shutter_poses_recorded(scene), \
                lights.temperature_hidden(scene):
            result = bpy.ops.export_scene.gltf(filepath=str(glb), **args)
    except Exception as exc:  # the operator raises RuntimeError with Blender's own report
        raise ExportError(f"glTF export failed: {exc}") from None
    finally:
        NAMED_ATTRIBUTES.clear()
        if added is not None:
            prefs.addons.remove(added)
    if "FINISHED" not in result or not Path(glb).is_file():
        raise ExportError(f"glTF export did not write {glb} ({result})")
    return warnings


def child_command(snapshot: Path, glb: Path | None, autoexec: bool = False) -> list[str]:
    """The command that exports a snapshot .blend in a separate process: Blender itself, or the
    Python interpreter when bpy runs as a module (bpy.app.binary_path is then empty). Without
    `glb` the child serves an animation (`_serve`). `autoexec`: Python scripts and drivers in
    the file may run (Blender's -y), as the user's Blender allows them."""
    script = str(Path(__file__).resolve())
    target = [str(glb)] if glb is not None else ["--serve"]
    if bpy.app.binary_path:
        return [bpy.app.binary_path, "-b", "--factory-startup", "--python-exit-code", "1",
                *(["-y"] if autoexec else []), "--python", script,
                "--", str(snapshot), *target]
    return [sys.executable, script, "--", str(snapshot), *target,
            *(["--autoexec"] if autoexec else [])]


def scripts_may_run() -> bool:
    """Whether the user's Blender runs Python drivers and scripts of blend files."""
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
    from `frame_set`, as in the user's Blender."""
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
