"""Material, world and light previews: Blender's preview scene written as glTF for the renderer.

With `bl_use_preview`, Blender renders the preview images of the Material, World and Light tabs
(and the material and world icons) with the scene's engine: `render()` is called with
`is_preview` from a job thread, on a scene of Blender's own that lives outside `bpy.data`
(for a material: `preview_sphere` or the other preview shapes, `Floor`, the area lights
`SquaredLight` and `CircularLight`, `Camera`; for a world only the camera; for a light
`preview_lamp` over a floor). Blender's glTF exporter cannot export it: it exports
`bpy.context.scene`, and it needs `context.active_object` and a window, which the job thread has
not. So `write_scene` writes the preview depsgraph itself, as `scene.gltf` + `scene.bin`:

- every mesh-like object instance (`to_mesh` of the evaluated object: modifiers, shape keys)
  as triangles with Blender's corner normals, the active render UV map and, for materials
  reading colour attributes, the active colour attribute (COLOR_0); one primitive per material
  slot; the object's texture space and camera/shadow ray visibility in PHOTON_object;
- each material as PHOTON_material_nodes (node_tree.py, also for a lone Principled BSDF, which
  the renderer then evaluates as in a render), PHOTON_material_subsurface, and glTF
  metallic-roughness values as the fallback for a tree with nodes Photon does not evaluate:
  the Principled BSDF's unlinked Base Color, Metallic, Roughness, emission and transmission, or
  the material's viewport display colour without one (magenta for a missing base colour
  image, as in a render);
- lights as in the glTF export (lights.py; point, spot and sun lights are
  KHR_lights_punctual lights whose colour and power PHOTON_light replaces);
- the camera (perspective or orthographic, fitted as Blender fits the sensor) with
  PHOTON_camera, and the scene's PHOTON_world and PHOTON_render.

Blender's material preview floor is hidden from the camera by its material (Alpha = 1 − Light
Path's Is Camera Ray, which Photon does not evaluate): such a material's objects are written
with `visible_camera` off and its tree with that Alpha unlinked (1), which is what the tree
does in Cycles.

Axes: glTF is Y-up; a Blender point (x, y, z) is written (x, z, −y), as Blender's exporter
does, so the renderer's Blender-coordinate conventions (Generated and Object texture
coordinates, PHOTON_world's directions) hold.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from . import export, node_tree
from .camera import camera_extension
from .lights import light_extension
from .node_graph import source
from .shared import GEOMETRY_TYPES
from .world import world_extension

# Blender (x, y, z) -> glTF (x, z, -y).
AXES = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
# glTF component types and accessor types used here.
FLOAT, VEC2, VEC3, VEC4 = 5126, "VEC2", "VEC3", "VEC4"


def write_scene(depsgraph, folder: Path) -> Path:
    """Write the (preview) scene of `depsgraph` to `folder`/scene.gltf (+ scene.bin and the
    images of node trees) and return the .gltf's path."""
    writer = _Writer(folder)
    scene = depsgraph.scene
    for instance in depsgraph.object_instances:
        obj = instance.object
        matrix = np.array(instance.matrix_world, dtype=np.float64)
        if obj.type in GEOMETRY_TYPES:
            writer.add_mesh_object(obj, matrix)
        elif obj.type == "LIGHT":
            writer.add_light(obj, matrix)
        elif obj.type == "CAMERA":
            writer.add_camera(obj, matrix, scene)
    return writer.finish(scene)


def camera_projection(camera, width: float, height: float) -> dict:
    """The glTF camera of a Blender camera rendering `width` x `height` (pixel aspect
    included): the sensor (or the orthographic scale) spans the fitted side, as in Blender."""
    fit = camera.sensor_fit
    horizontal = width >= height if fit == "AUTO" else fit == "HORIZONTAL"
    aspect = width / height
    if camera.type == "ORTHO":
        half = 0.5 * float(camera.ortho_scale)
        xmag, ymag = (half, half / aspect) if horizontal else (half * aspect, half)
        return {"type": "orthographic", "orthographic": {
            "xmag": xmag, "ymag": ymag, "znear": float(camera.clip_start),
            "zfar": float(camera.clip_end)}}
    sensor = float(camera.sensor_height if fit == "VERTICAL" else camera.sensor_width)
    half = math.atan(0.5 * sensor / float(camera.lens))
    yfov = 2.0 * math.atan(math.tan(half) / aspect) if horizontal else 2.0 * half
    return {"type": "perspective", "perspective": {
        "yfov": yfov, "aspectRatio": aspect, "znear": float(camera.clip_start),
        "zfar": float(camera.clip_end)}}


def camera_hiding_bsdf(material) -> str | None:
    """The name of `material`'s Principled BSDF when it takes its Alpha from 1 − Light Path's
    Is Camera Ray (Math Subtract): invisible to camera rays, opaque to all others. Blender's
    material preview hides its floor so. None otherwise."""
    bsdf = export.principled_bsdf(material)
    alpha = bsdf.inputs.get("Alpha") if bsdf is not None else None
    math_node = source(alpha).node if alpha is not None else None
    if math_node is None or math_node.type != "MATH" or math_node.operation != "SUBTRACT":
        return None
    one, ray = source(math_node.inputs[0]), source(math_node.inputs[1])
    if one.linked or float(one.socket.default_value) != 1.0 or not ray.linked:
        return None
    if ray.node.type != "LIGHT_PATH" or ray.output.name != "Is Camera Ray":
        return None
    return bsdf.name


def fallback_material(material) -> dict:
    """glTF metallic-roughness values for `material`, used where no node tree is written: the
    unlinked inputs of its Principled BSDF, else its viewport display values."""
    bsdf = export.principled_bsdf(material)
    if bsdf is None:
        return {"pbrMetallicRoughness": {
            "baseColorFactor": [float(c) for c in material.diffuse_color],
            "metallicFactor": float(material.metallic),
            "roughnessFactor": float(material.roughness)}}

    def constant(name, default):
        socket = bsdf.inputs.get(name)
        if socket is None or source(socket).linked:
            return default
        value = socket.default_value
        return [float(v) for v in value] if hasattr(value, "__len__") else float(value)

    base = constant("Base Color", [0.8, 0.8, 0.8, 1.0])[:3]
    if export.missing_base_color_image(material):
        base = list(export.MISSING_IMAGE_COLOR[:3])
    alpha = constant("Alpha", 1.0)
    data = {"pbrMetallicRoughness": {"baseColorFactor": [*base, alpha],
                                     "metallicFactor": constant("Metallic", 0.0),
                                     "roughnessFactor": constant("Roughness", 0.5)},
            "extensions": {}}
    emission = [c * constant("Emission Strength", 0.0)
                for c in constant("Emission Color", [0.0, 0.0, 0.0, 1.0])[:3]]
    if max(emission) > 0.0:
        peak = max(emission)
        data["emissiveFactor"] = [c / max(peak, 1.0) for c in emission]
        if peak > 1.0:
            data["extensions"]["KHR_materials_emissive_strength"] = {"emissiveStrength": peak}
    transmission = constant("Transmission Weight", 0.0)
    if transmission > 0.0:
        data["extensions"]["KHR_materials_transmission"] = {"transmissionFactor": transmission}
    data["extensions"]["KHR_materials_ior"] = {"ior": constant("IOR", 1.5)}
    if alpha < 1.0:
        data["alphaMode"] = "BLEND"
    return data


def _node_matrix(matrix: np.ndarray, *, geometry: bool) -> list[float]:
    """A Blender world matrix as a glTF node matrix (column-major). Geometry is written in
    glTF axes (so the matrix is conjugated by the axis change); cameras and lights keep their
    local frame (-Z forward, +Y up in both conventions)."""
    change = np.eye(4)
    change[:3, :3] = AXES
    result = change @ matrix
    if geometry:
        result = result @ change.T
    return [float(v) for v in result.T.reshape(-1)]


class _Writer:
    """Collects the glTF objects and the binary buffer of one scene."""

    def __init__(self, folder: Path):
        self.folder = Path(folder)
        self.buffer = bytearray()
        self.gltf = {"asset": {"version": "2.0", "generator": "Photon add-on (preview)"},
                     "nodes": [], "meshes": [], "materials": [], "cameras": [],
                     "accessors": [], "bufferViews": []}
        self.lights: list[dict] = []
        self.material_index: dict[str, int] = {}
        self.mesh_index: dict[str, int] = {}
        self.used: set[str] = set()

    # ----- buffer ------------------------------------------------------------------------
    def accessor(self, array: np.ndarray, kind: str, *, bounds=False) -> int:
        data = np.ascontiguousarray(array, dtype="<f4")
        self.buffer.extend(b"\0" * (-len(self.buffer) % 4))
        self.gltf["bufferViews"].append({"buffer": 0, "byteOffset": len(self.buffer),
                                         "byteLength": data.nbytes})
        self.buffer.extend(data.tobytes())
        entry = {"bufferView": len(self.gltf["bufferViews"]) - 1, "componentType": FLOAT,
                 "count": int(data.shape[0]), "type": kind}
        if bounds:
            entry["min"] = [float(v) for v in data.min(axis=0)]
            entry["max"] = [float(v) for v in data.max(axis=0)]
        self.gltf["accessors"].append(entry)
        return len(self.gltf["accessors"]) - 1

    # ----- objects -----------------------------------------------------------------------
    def add_mesh_object(self, obj, matrix: np.ndarray):
        materials = [slot.material for slot in obj.material_slots]
        if obj.name_full not in self.mesh_index:
            mesh = self.mesh(obj, materials)
            if mesh is None:
                return
            self.mesh_index[obj.name_full] = mesh
        node = {"name": obj.name, "mesh": self.mesh_index[obj.name_full],
                "matrix": _node_matrix(matrix, geometry=True)}
        data = export.visibility_extension(obj)
        if any(m is not None and camera_hiding_bsdf(m) for m in materials):
            data["visible_camera"] = False
            data.setdefault("visible_shadow", bool(getattr(obj, "visible_shadow", True)))
        space = export.texture_space(obj)
        if space:
            data["texture_space"] = space
        if data:
            node["extensions"] = {"PHOTON_object": data}
            self.used.add("PHOTON_object")
        self.gltf["nodes"].append(node)

    def mesh(self, obj, materials) -> int | None:
        """The glTF mesh of an evaluated object, one primitive per material slot used; None
        for an object without triangles."""
        mesh = obj.to_mesh()
        try:
            mesh.calc_loop_triangles()
            count = len(mesh.loop_triangles)
            if count == 0:
                return None
            loops = np.empty(3 * count, dtype=np.int32)
            mesh.loop_triangles.foreach_get("loops", loops)
            corners = np.empty(3 * count, dtype=np.int32)
            mesh.loop_triangles.foreach_get("vertices", corners)
            slots = np.empty(count, dtype=np.int32)
            mesh.loop_triangles.foreach_get("material_index", slots)
            points = np.empty(3 * len(mesh.vertices), dtype=np.float32)
            mesh.vertices.foreach_get("co", points)
            normals = np.empty(3 * len(mesh.loops), dtype=np.float32)
            mesh.corner_normals.foreach_get("vector", normals)
            attributes = {
                "POSITION": points.reshape(-1, 3)[corners] @ AXES.T,
                "NORMAL": normals.reshape(-1, 3)[loops] @ AXES.T,
            }
            uv_layer = next((uv for uv in mesh.uv_layers if uv.active_render), None)
            if uv_layer is not None:
                uv = np.empty(2 * len(mesh.loops), dtype=np.float32)
                uv_layer.data.foreach_get("uv", uv)
                uv = uv.reshape(-1, 2)[loops]
                uv[:, 1] = 1.0 - uv[:, 1]  # glTF's v runs down the image
                attributes["TEXCOORD_0"] = uv
            colors = self.colors(mesh, loops, corners, materials)
            if colors is not None:
                attributes["COLOR_0"] = colors
        finally:
            obj.to_mesh_clear()
        primitives = []
        for slot in np.unique(slots):
            keep = np.repeat(slots == slot, 3)
            accessors = {name: self.accessor(values[keep], VEC2 if name == "TEXCOORD_0"
                                             else VEC4 if name == "COLOR_0" else VEC3,
                                             bounds=name == "POSITION")
                         for name, values in attributes.items()}
            primitive = {"attributes": accessors}
            material = materials[slot] if 0 <= slot < len(materials) else None
            if material is not None:
                primitive["material"] = self.material(material)
            primitives.append(primitive)
        self.gltf["meshes"].append({"name": obj.name, "primitives": primitives})
        return len(self.gltf["meshes"]) - 1

    def colors(self, mesh, loops, corners, materials):
        """The active colour attribute per triangle corner (linear RGBA) when one of the
        materials' node trees reads colour attributes, else None."""
        reads = False
        for material in materials:
            if material is None:
                continue
            tree = node_tree.material_nodes(material, keep_trivial=True)[0]
            reads = reads or bool(tree) and any(
                n["type"] in ("ShaderNodeVertexColor", "ShaderNodeAttribute")
                for n in tree["nodes"])
        attribute = mesh.color_attributes.active_color
        if not reads or attribute is None:
            return None
        values = np.empty(4 * len(attribute.data), dtype=np.float32)
        attribute.data.foreach_get("color", values)
        index = corners if attribute.domain == "POINT" else loops
        return values.reshape(-1, 4)[index]

    def material(self, material) -> int:
        if material.name_full in self.material_index:
            return self.material_index[material.name_full]
        entry = {"name": material.name, "doubleSided": True, **fallback_material(material)}
        extensions = entry.pop("extensions", {})
        # The camera-hiding alpha is carried as the object's camera visibility instead.
        hiding = camera_hiding_bsdf(material)
        tree, _problems = node_tree.material_nodes(
            material, self.folder, keep_trivial=True,
            unlinked={(hiding, "Alpha")} if hiding else frozenset())
        if tree:
            extensions["PHOTON_material_nodes"] = tree
        subsurface = export.subsurface_extension(material)
        if subsurface:
            extensions["PHOTON_material_subsurface"] = subsurface
        if extensions:
            entry["extensions"] = extensions
            self.used.update(extensions)
        self.gltf["materials"].append(entry)
        self.material_index[material.name_full] = len(self.gltf["materials"]) - 1
        return self.material_index[material.name_full]

    def add_light(self, obj, matrix: np.ndarray):
        data = light_extension(obj)
        if not data:
            return
        node = {"name": obj.name, "matrix": _node_matrix(matrix, geometry=False),
                "extensions": {"PHOTON_light": data}}
        kind = obj.data.type
        if kind != "AREA":
            # Photon reads colour and power from PHOTON_light; the KHR light gives the type.
            light = {"type": {"POINT": "point", "SPOT": "spot", "SUN": "directional"}[kind],
                     "color": [1.0, 1.0, 1.0], "intensity": 1.0}
            if kind == "SPOT":
                light["spot"] = {"innerConeAngle": 0.0,
                                 "outerConeAngle": 0.5 * float(obj.data.spot_size)}
            self.lights.append(light)
            node["extensions"]["KHR_lights_punctual"] = {"light": len(self.lights) - 1}
        self.used.add("PHOTON_light")
        self.gltf["nodes"].append(node)

    def add_camera(self, obj, matrix: np.ndarray, scene):
        r = scene.render
        scale = r.resolution_percentage / 100.0
        width = max(1, int(r.resolution_x * scale)) * r.pixel_aspect_x
        height = max(1, int(r.resolution_y * scale)) * r.pixel_aspect_y
        self.gltf["cameras"].append(camera_projection(obj.data, width, height))
        node = {"name": obj.name, "camera": len(self.gltf["cameras"]) - 1,
                "matrix": _node_matrix(matrix, geometry=False)}
        data = camera_extension(obj, scene)
        if data:
            node["extensions"] = {"PHOTON_camera": data}
            self.used.add("PHOTON_camera")
        self.gltf["nodes"].append(node)

    # ----- file --------------------------------------------------------------------------
    def finish(self, scene) -> Path:
        gltf = self.gltf
        gltf["scenes"] = [{"nodes": list(range(len(gltf["nodes"]))), "extensions": {
            "PHOTON_world": world_extension(scene.world, self.folder),
            "PHOTON_render": export.render_extension(scene)}}]
        gltf["scene"] = 0
        self.used.update(("PHOTON_world", "PHOTON_render"))
        if self.lights:
            gltf["extensions"] = {"KHR_lights_punctual": {"lights": self.lights}}
            self.used.add("KHR_lights_punctual")
        gltf["extensionsUsed"] = sorted(self.used)
        for key in ("meshes", "materials", "cameras", "accessors", "bufferViews"):
            if not gltf[key]:
                del gltf[key]
        if self.buffer:
            (self.folder / "scene.bin").write_bytes(bytes(self.buffer))
            gltf["buffers"] = [{"uri": "scene.bin", "byteLength": len(self.buffer)}]
        path = self.folder / "scene.gltf"
        path.write_text(json.dumps(gltf))
        return path
