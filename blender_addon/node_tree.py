"""PHOTON_material_nodes: a material's shader node tree as the renderer evaluates it.

`material_nodes(material)` walks the tree from the active Material Output's Surface and returns
`(extension, problems)`:

- `extension` is the JSON the renderer compiles (src/shader/, documented in
  docs/gltf_extensions.md): `{"nodes": [...], "output": {"node": i, "output": id}}`, the nodes in an
  order where every link points to an earlier node. Node groups are flattened (a node inside a
  group is named "Group/Node"), links are followed as Cycles follows them (node_graph.py:
  reroutes, muted links and nodes), unconnected inputs are written as constants (Blender's
  socket values), links carry the output's identifier, and only the nodes reachable from the
  Surface are written. Colour Ramps are baked into 256 entries with Blender's own
  `ColorRamp.evaluate`, so every interpolation mode matches.
- `problems` names every node (or node setting, or linked input) the renderer cannot evaluate.
  When there is one, `extension` is None: the material keeps the glTF path (Blender's exporter
  and its metallic-roughness values) and the pre-flight report names what is lost, so nothing
  is dropped without a word. What feeds the Material Output's Displacement is written by the
  material's displacement method (`_displacement_trees`): as `extension["displacement"]`, a
  tree of the same form whose output is the normal Cycles' bump gives (a Bump node of distance
  1 over the displacement's component along the normal; "Bump Only" and "Displacement and
  Bump"), and as `extension["displace"]`, a tree whose output is the world-space vector the
  renderer moves each vertex by ("Displacement Only" and "Displacement and Bump"). What feeds
  the Volume socket is
  written as `extension["volume"]`, a tree of the same form whose output is the volume shader
  (`volume_tree`, also used for the world's); a material with a Volume and no Surface is
  `{"nodes": [], "volume": …}`: its surface only bounds the medium. `extension` is also None for trees
  glTF carries exactly (a lone
  Principled BSDF with nothing linked into it), so such materials render as before.

It needs no bpy import: it reads nodes through their attributes (and runs in the export child).
"""

from __future__ import annotations

try:
    from . import object_attributes
    from .node_graph import Source, active_output, source
    from .shared import REC709, blender_5, material_tree, working_space
except ImportError:  # loaded by export.py as a top-level module in the export's child process
    import object_attributes
    from node_graph import Source, active_output, source
    from shared import REC709, blender_5, material_tree, working_space

# Nodes the renderer evaluates, by bl_idname, with the settings it reads.
SETTINGS = {
    "ShaderNodeTexCoord": (),
    "ShaderNodeUVMap": (),
    "ShaderNodeVertexColor": (),
    "ShaderNodeAttribute": ("attribute_name", "attribute_type"),
    "ShaderNodeNewGeometry": (),
    "ShaderNodeObjectInfo": (),
    "ShaderNodeHairInfo": (),
    "ShaderNodeWireframe": ("use_pixel_size",),
    "ShaderNodeLightPath": (),
    "ShaderNodeAmbientOcclusion": ("samples", "inside", "only_local"),
    "ShaderNodeBevel": ("samples",),
    "ShaderNodeValue": (),
    "ShaderNodeRGB": (),
    "ShaderNodeMapping": ("vector_type",),
    "ShaderNodeMath": ("operation", "use_clamp"),
    "ShaderNodeMix": ("data_type", "blend_type", "clamp_factor", "clamp_result"),
    "ShaderNodeValToRGB": (),
    "ShaderNodeRGBCurve": (),
    "ShaderNodeMapRange": ("data_type", "interpolation_type", "clamp"),
    "ShaderNodeClamp": ("clamp_type",),
    "ShaderNodeInvert": (),
    "ShaderNodeSeparateXYZ": (),
    "ShaderNodeCombineXYZ": (),
    "ShaderNodeSeparateColor": ("mode",),
    "ShaderNodeCombineColor": ("mode",),
    "ShaderNodeTexChecker": (),
    "ShaderNodeTexGradient": ("gradient_type",),
    "ShaderNodeTexNoise": ("noise_type", "noise_dimensions", "normalize"),
    "ShaderNodeTexVoronoi": ("voronoi_dimensions", "feature", "distance", "normalize"),
    "ShaderNodeTexImage": ("interpolation", "projection", "extension"),
    "ShaderNodeTexWave": ("wave_type", "bands_direction", "rings_direction", "wave_profile"),
    "ShaderNodeTexWhiteNoise": ("noise_dimensions",),
    "ShaderNodeTexMagic": ("turbulence_depth",),
    "ShaderNodeTexGabor": ("gabor_type",),
    "ShaderNodeTexBrick": ("offset", "offset_frequency", "squash", "squash_frequency"),
    "ShaderNodeBlackbody": (),
    "ShaderNodeHueSaturation": (),
    "ShaderNodeGamma": (),
    "ShaderNodeBrightContrast": (),
    "ShaderNodeVectorMath": ("operation",),
    "ShaderNodeBump": ("invert",),
    "ShaderNodeNormalMap": ("space",),
    "ShaderNodeDisplacement": ("space",),
    "ShaderNodeVectorDisplacement": ("space",),
    "ShaderNodeFresnel": (),
    "ShaderNodeLayerWeight": (),
    "ShaderNodeBsdfPrincipled": ("distribution",),
    "ShaderNodeBsdfDiffuse": (),
    "ShaderNodeBsdfGlossy": ("distribution",),
    "ShaderNodeBsdfAnisotropic": ("distribution",),
    "ShaderNodeBsdfMetallic": ("distribution", "fresnel_type"),
    "ShaderNodeBsdfSheen": ("distribution",),
    "ShaderNodeBsdfToon": ("component",),
    "ShaderNodeBsdfHairPrincipled": ("model", "parametrization"),
    "ShaderNodeBsdfHair": ("component",),
    "ShaderNodeBsdfGlass": ("distribution",),
    "ShaderNodeBsdfRefraction": ("distribution",),
    "ShaderNodeEmission": (),
    "ShaderNodeBsdfTransparent": (),
    "ShaderNodeBsdfRayPortal": (),
    "ShaderNodeBsdfTranslucent": (),
    "ShaderNodeHoldout": (),
    "ShaderNodeMixShader": (),
    "ShaderNodeAddShader": (),
    "ShaderNodeVolumePrincipled": (),
    "ShaderNodeVolumeScatter": ("phase",),
    "ShaderNodeVolumeAbsorption": (),
}

# Inputs the renderer reads, per node type (others must stay unlinked; their values are
# ignored as glTF's path ignores them).
READ_INPUTS = {
    "ShaderNodeBsdfPrincipled": {"Base Color", "Metallic", "Roughness", "IOR", "Alpha",
                                 "Specular IOR Level", "Specular Tint", "Transmission Weight",
                                 "Emission Color", "Emission Strength", "Normal",
                                 "Anisotropic", "Anisotropic Rotation", "Tangent",
                                 "Coat Weight", "Coat Roughness", "Coat IOR", "Coat Tint",
                                 "Coat Normal", "Sheen Weight", "Sheen Roughness", "Sheen Tint",
                                 "Diffuse Roughness", "Thin Film Thickness", "Thin Film IOR"},
    "ShaderNodeBsdfDiffuse": {"Color", "Roughness", "Normal"},
    "ShaderNodeBsdfGlossy": {"Color", "Roughness", "Normal", "Anisotropy", "Rotation",
                             "Tangent"},
    "ShaderNodeBsdfAnisotropic": {"Color", "Roughness", "Normal", "Anisotropy", "Rotation",
                                  "Tangent"},
    "ShaderNodeBsdfSheen": {"Color", "Roughness", "Normal"},
    "ShaderNodeBsdfToon": {"Color", "Size", "Smooth", "Normal"},
    "ShaderNodeBsdfHairPrincipled": {"Color", "Melanin", "Melanin Redness", "Tint",
                                     "Absorption Coefficient", "Roughness", "Radial Roughness",
                                     "Coat", "IOR", "Offset", "Random Color", "Random Roughness",
                                     "Random"},
    "ShaderNodeBsdfHair": {"Color", "Offset", "RoughnessU", "RoughnessV"},
    "ShaderNodeBsdfMetallic": {"Base Color", "Edge Tint", "IOR", "Extinction", "Roughness",
                               "Anisotropy", "Rotation", "Normal", "Tangent"},
    "ShaderNodeBsdfGlass": {"Color", "Roughness", "IOR", "Normal"},
    "ShaderNodeBsdfRefraction": {"Color", "Roughness", "IOR", "Normal"},
    "ShaderNodeBsdfTranslucent": {"Color", "Normal"},
    "ShaderNodeBsdfTransparent": {"Color"},
    # Unlinked, Position and Direction are implicit: the shading point, the ray's direction.
    "ShaderNodeBsdfRayPortal": {"Color", "Position", "Direction"},
    # The attribute names (Density Attribute, …) are written as the node's "attributes".
    "ShaderNodeVolumePrincipled": {"Color", "Density", "Anisotropy", "Absorption Color",
                                   "Emission Strength", "Emission Color",
                                   "Blackbody Intensity", "Blackbody Tint", "Temperature"},
    "ShaderNodeVolumeScatter": {"Color", "Density", "Anisotropy", "IOR", "Backscatter", "Alpha",
                                "Diameter"},
    "ShaderNodeVolumeAbsorption": {"Color", "Density"},
}

# Outputs the renderer provides where a node has more.
READ_OUTPUTS = {
    "ShaderNodeTexCoord": {"Generated", "Normal", "UV", "Object", "Reflection"},
    "ShaderNodeNewGeometry": {"Position", "Normal", "True Normal", "Incoming", "Backfacing"},
    "ShaderNodeTexVoronoi": {"Distance", "Color", "Position"},
}

# Settings values the renderer does not evaluate.
UNSUPPORTED_SETTINGS = {
    ("ShaderNodeMix", "data_type"): {"ROTATION"},
    ("ShaderNodeMapRange", "data_type"): {"FLOAT_VECTOR"},
    ("ShaderNodeSeparateColor", "mode"): {"HSL"},
    ("ShaderNodeCombineColor", "mode"): {"HSL"},
    ("ShaderNodeTexNoise", "noise_type"): {"MULTIFRACTAL", "RIDGED_MULTIFRACTAL",
                                           "HYBRID_MULTIFRACTAL", "HETERO_TERRAIN"},
    ("ShaderNodeTexNoise", "noise_dimensions"): {"4D"},
    ("ShaderNodeTexVoronoi", "voronoi_dimensions"): {"1D", "4D"},
    ("ShaderNodeTexImage", "projection"): {"BOX", "SPHERE", "TUBE"},
    ("ShaderNodeTexVoronoi", "feature"): {"DISTANCE_TO_EDGE", "N_SPHERE_RADIUS"},
    ("ShaderNodeVectorMath", "operation"): {"WRAP", "REFRACT", "FACEFORWARD", "POWER", "SIGN"},
    ("ShaderNodeBsdfSheen", "distribution"): {"ASHIKHMIN"},
    # Photon's Principled Hair is Chiang et al.'s model (src/bsdf/hair.rs).
    ("ShaderNodeBsdfHairPrincipled", "model"): {"HUANG"},
    # Photon's microfacets are GGX, with or without Multiscatter GGX's energy compensation.
    ("ShaderNodeBsdfRefraction", "distribution"): {"BECKMANN"},
    ("ShaderNodeBsdfGlass", "distribution"): {"BECKMANN"},
    ("ShaderNodeBsdfGlossy", "distribution"): {"BECKMANN", "ASHIKHMIN_SHIRLEY"},
    ("ShaderNodeBsdfAnisotropic", "distribution"): {"BECKMANN", "ASHIKHMIN_SHIRLEY"},
    ("ShaderNodeBsdfMetallic", "distribution"): {"BECKMANN"},
}

# A lone Principled BSDF goes through glTF (Blender's exporter) only when these inputs hold
# what glTF's extensions carry and Blender's importer reads back: an untinted coat of IOR 1.5
# (KHR_materials_clearcoat), a sheen of weight 0 or 1 (KHR_materials_sheen has no weight), no
# thin film (Blender 4.5's exporter writes none).
GLTF_EXACT_PRINCIPLED = {"Coat IOR": (1.5,), "Coat Tint": ((1.0, 1.0, 1.0, 1.0),),
                         "Sheen Weight": (0.0, 1.0), "Diffuse Roughness": (0.0,),
                         "Thin Film Thickness": (0.0,)}

# The Math operations the renderer evaluates (src/shader/parse.rs).
MATH_OPS = {
    "ADD", "SUBTRACT", "MULTIPLY", "DIVIDE", "MULTIPLY_ADD", "POWER", "LOGARITHM", "SQRT",
    "INVERSE_SQRT", "ABSOLUTE", "EXPONENT", "MINIMUM", "MAXIMUM", "LESS_THAN", "GREATER_THAN",
    "SIGN", "COMPARE", "SMOOTH_MIN", "SMOOTH_MAX", "ROUND", "FLOOR", "CEIL", "TRUNC", "FRACT",
    "MODULO", "FLOORED_MODULO", "WRAP", "SNAP", "PINGPONG", "SINE", "COSINE", "TANGENT",
    "ARCSINE", "ARCCOSINE", "ARCTANGENT", "ARCTAN2", "SINH", "COSH", "TANH", "RADIANS",
    "DEGREES",
}

RAMP_TABLE_SIZE = 256

# The hair tube's vertex attributes the Hair Info node reads (points_curves.py writes them):
# "fibre" (intercept, strand length, diameter) and "curve" (the strand's index, whose hash is
# Random).
HAIR_INFO_ATTRIBUTES = {"fibre": "photon_hair", "curve": "photon_hair_curve"}


def hair_info_attributes(trees) -> set[str]:
    """The names of the hair attributes `trees` read (Hair Info nodes)."""
    return {name for tree in trees for n in tree["nodes"]
            if n["type"] == "ShaderNodeHairInfo" for name in n["attributes"].values()}
# Nodes with a black body's colour, which the renderer takes into the working colour space.
BLACKBODY_NODES = ("ShaderNodeBlackbody", "ShaderNodeVolumePrincipled")

# Image files the renderer decodes, by Blender's file_format, with their file extension.
IMAGE_FORMATS = {"PNG": "png", "JPEG": "jpg", "WEBP": "webp", "OPEN_EXR": "exr"}
# Colour spaces of image textures the renderer reads: colour (sRGB decoded, or linear Rec.709;
# both taken into the working space) or data ("Non-Color", the values as they are).
IMAGE_COLORSPACES = {"sRGB": "sRGB", "Non-Color": "Non-Color",
                     "Linear Rec.709": "Linear Rec.709"}


def _baked_curves(mapping) -> dict:
    """RGB Curves as Cycles bakes them: over the widest x range of the four curves, the
    combined curve then each channel's, at RAMP_TABLE_SIZE points."""
    curves = mapping.curves
    min_x = min(0.0, *(c.points[0].location[0] for c in curves))
    max_x = max(1.0, *(c.points[-1].location[0] for c in curves))
    mapping.initialize()
    table = []
    for i in range(RAMP_TABLE_SIZE):
        t = min_x + i / (RAMP_TABLE_SIZE - 1) * (max_x - min_x)
        combined = mapping.evaluate(curves[3], t)
        table.append([mapping.evaluate(curves[k], combined) for k in range(3)])
    return {"table": table, "min_x": min_x, "max_x": max_x}


def _image_source(image):
    """`(bytes or None, path or None, problem)`: where an image's encoded file is."""
    import os
    import bpy
    if image.source != "FILE":
        return None, None, f"is a {image.source.lower()} image"
    if image.file_format not in IMAGE_FORMATS:
        return None, None, (f"is a {image.file_format} file (Photon reads PNG, JPEG, WebP and "
                            f"OpenEXR)")
    if image.colorspace_settings.name not in IMAGE_COLORSPACES:
        return None, None, f"uses the colour space {image.colorspace_settings.name}"
    if image.packed_file is not None:
        return bytes(image.packed_file.data), None, ""
    path = bpy.path.abspath(image.filepath, library=image.library)
    if not os.path.isfile(path):
        return None, None, f"file '{path}' is missing"
    return None, path, ""


def _value(socket):
    v = getattr(socket, "default_value", None)
    if v is None:
        return None
    try:
        return [float(x) for x in v]
    except TypeError:
        return float(v)


def _close(value, expected) -> bool:
    """Whether a socket value (number or list) equals `expected` to 1e-6."""
    if isinstance(expected, tuple):
        return isinstance(value, list) and len(value) == len(expected) and all(
            abs(a - b) <= 1e-6 for a, b in zip(value, expected))
    return not isinstance(value, list) and abs(value - expected) <= 1e-6


def _active_uv_maps(material) -> set[str]:
    """The active UV maps of the meshes that use `material` (the glTF exporter computes their
    tangents, TANGENT, on the active UV map)."""
    return {mesh.uv_layers.active.name for mesh in _material_meshes(material)
            if mesh.uv_layers.active is not None}


# UV maps the renderer reads (src/shader/ UV_SETS): TEXCOORD_0 to _3.
UV_SETS = 4


def _material_meshes(material):
    import bpy
    return [mesh for mesh in bpy.data.meshes
            if any(m is not None and m.name == material.name for m in mesh.materials)]


def _uv_set(material, name: str):
    """`(TEXCOORD index or None, problem)` of the UV map `name` ('' for the render UV map,
    Cycles' default) in the meshes using `material`: Blender's exporter writes a mesh's UV
    maps in order as TEXCOORD_0, _1, …"""
    sets = set()
    for mesh in _material_meshes(material):
        names = [layer.name for layer in mesh.uv_layers]
        wanted = name or next((l.name for l in mesh.uv_layers if l.active_render), None)
        if wanted in names:
            sets.add(names.index(wanted))
    if len(sets) > 1:
        return None, (f"reads UV map '{name or 'the render UV map'}', which is not the same "
                      f"TEXCOORD in every mesh using the material")
    index = sets.pop() if sets else 0
    if index >= UV_SETS:
        return None, f"reads UV map {index + 1}; Photon reads the first {UV_SETS}"
    return index, ""


def uses_tangents(extension) -> bool:
    """Whether a tree (`material_nodes`' extension) has a Normal Map node in tangent space."""
    return any(n["type"] == "ShaderNodeNormalMap" and n.get("space", "TANGENT") == "TANGENT"
               for n in extension["nodes"])


class _Walker:
    def __init__(self, material, folder=None, unlinked=frozenset()):
        self.material = material
        self.what = f"material '{material.name}'"
        self.folder = folder
        self.unlinked = unlinked
        self.images: dict[str, str] = {}
        self.nodes: list[dict] = []
        self.index: dict[tuple, int] = {}
        self.problems: list[str] = []
        self.trivial = True

    def image_uri(self, image) -> str:
        """The file name of `image` beside the .glb (written there when exporting)."""
        if image.name in self.images:
            return self.images[image.name]
        safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in image.name)
        uri = f"photon_image_{len(self.images)}_{safe}.{IMAGE_FORMATS[image.file_format]}"
        self.images[image.name] = uri
        if self.folder is not None:
            import shutil
            from pathlib import Path
            data, path, _ = _image_source(image)
            target = Path(self.folder) / uri
            if data is not None:
                target.write_bytes(data)
            else:
                shutil.copyfile(path, target)
        return uri

    def scene_attribute(self, node, name, entry):
        """An Attribute node of type Object or Instancer gets its `object_slot` (the values
        are the objects', PHOTON_object "info"), one of type View Layer its `value`."""
        kind = node.attribute_type
        if kind == "VIEW_LAYER":
            entry["value"] = object_attributes.view_layer_value(node.attribute_name)
        elif kind in object_attributes.PER_OBJECT:
            slot = object_attributes.attribute_slots()[(kind, node.attribute_name)]
            if slot >= object_attributes.OBJECT_ATTRIBUTES:
                self.problems.append(
                    f"{self.what}: Attribute node '{name}' reads {kind.lower()} attribute "
                    f"'{node.attribute_name}'; Photon carries "
                    f"{object_attributes.OBJECT_ATTRIBUTES} object and instancer attributes "
                    f"in a scene")
            entry["object_slot"] = slot

    def node_name(self, node, groups):
        return "/".join([g.name for g in groups] + [node.name])

    def visit(self, node, groups) -> int | None:
        """The index of `node` in the list (written after its inputs), None if unsupported."""
        key = (tuple(g.as_pointer() for g in groups), node.as_pointer())
        if key in self.index:
            return self.index[key]
        kind = node.bl_idname
        name = self.node_name(node, groups)
        if kind not in SETTINGS:
            self.problems.append(f"{self.what}: {node.bl_label} node '{name}' is not evaluated "
                                 f"by Photon")
            self.index[key] = None
            return None
        entry = {"name": name, "type": kind}
        if kind in BLACKBODY_NODES and working_space() != REC709:
            entry["working_space"] = working_space()  # its black body's colour is given in it
        for setting in SETTINGS[kind]:
            value = getattr(node, setting, None)
            if value is None:
                continue
            if value in UNSUPPORTED_SETTINGS.get((kind, setting), ()):
                self.problems.append(f"{self.what}: {node.bl_label} node '{name}' with "
                                     f"{setting} {value} is not evaluated by Photon")
            entry[setting] = value if isinstance(value, (bool, str)) else float(value)
        if kind == "ShaderNodeTexImage":
            image = node.image
            problem = "has no image" if image is None else _image_source(image)[2]
            if problem:
                self.problems.append(f"{self.what}: Image Texture node '{name}': the image "
                                     f"{problem}; Photon does not evaluate it")
            else:
                entry["image"] = {"uri": self.image_uri(image),
                                  "colorspace": IMAGE_COLORSPACES[
                                      image.colorspace_settings.name]}
        if kind == "ShaderNodeBsdfPrincipled" and blender_5():
            entry["thin_film_model"] = "BLENDER_5"  # its film's spectra and the metal's film
        if kind == "ShaderNodeTexVoronoi" and blender_5():
            entry["cell_hash"] = "PCG"  # Blender 5 hashes integer cells (Blender 4: lookup3)
        if kind == "ShaderNodeMath" and node.operation not in MATH_OPS:
            self.problems.append(f"{self.what}: Math node '{name}' with operation "
                                 f"{node.operation} is not evaluated by Photon")
        if kind == "ShaderNodeObjectInfo":
            entry["material_index"] = int(self.material.pass_index)
        if kind == "ShaderNodeHairInfo":
            entry["attributes"] = dict(HAIR_INFO_ATTRIBUTES)
        if kind == "ShaderNodeAttribute":
            self.scene_attribute(node, name, entry)
        if kind in ("ShaderNodeValue", "ShaderNodeRGB"):
            entry["value"] = _value(node.outputs[0])
        if kind == "ShaderNodeValToRGB":
            ramp = node.color_ramp
            entry["interpolation"] = "LINEAR"
            entry["table"] = [list(ramp.evaluate(i / (RAMP_TABLE_SIZE - 1)))
                              for i in range(RAMP_TABLE_SIZE)]
        if kind == "ShaderNodeVolumePrincipled":
            entry["attributes"] = {
                key: node.inputs[f"{key.capitalize()} Attribute"].default_value
                for key in ("density", "color", "temperature")}
        if kind == "ShaderNodeRGBCurve":
            entry.update(_baked_curves(node.mapping))
        if kind in ("ShaderNodeTexCoord", "ShaderNodeUVMap", "ShaderNodeTexImage"):
            uv_set, problem = _uv_set(self.material, getattr(node, "uv_map", ""))
            if problem:
                self.problems.append(f"{self.what}: {node.bl_label} node '{name}' {problem}")
            elif uv_set:
                entry["uv_set"] = uv_set
        if kind == "ShaderNodeNormalMap" and node.space == "TANGENT" and node.uv_map:
            others = {m for m in _active_uv_maps(self.material) if m != node.uv_map}
            if others:
                self.problems.append(f"{self.what}: Normal Map node '{name}' reads UV map "
                                     f"'{node.uv_map}', but Photon has tangents only for the "
                                     f"active UV map ('{sorted(others)[0]}')")
        if kind == "ShaderNodeMix" and getattr(node, "factor_mode", "UNIFORM") != "UNIFORM":
            self.problems.append(f"{self.what}: Mix node '{name}' with a non-uniform factor is "
                                 f"not evaluated by Photon")
        if kind not in ("ShaderNodeBsdfPrincipled",) or node.distribution != "MULTI_GGX":
            # glTF has no GGX without energy compensation.
            self.trivial = False
        else:
            for key, exact in GLTF_EXACT_PRINCIPLED.items():
                socket = node.inputs.get(key)
                value = _value(socket) if socket is not None else None
                if value is not None and not any(_close(value, e) for e in exact):
                    self.trivial = False
        inputs = {}
        read = READ_INPUTS.get(kind)
        for socket in node.inputs:
            if not socket.enabled:
                continue
            src = source(socket, groups)
            if (name, socket.identifier) in self.unlinked:
                src = Source(None, None, groups, socket)
            if read is not None and socket.identifier not in read:
                if src.linked:
                    self.problems.append(f"{self.what}: input '{socket.name}' of "
                                         f"{node.bl_label} node '{name}' is linked; Photon "
                                         f"does not evaluate it")
                continue
            if src.linked:
                from_node, out, from_groups = src.node, src.output, src.groups
                allowed = READ_OUTPUTS.get(from_node.bl_idname)
                if allowed is not None and out.identifier not in allowed:
                    self.problems.append(
                        f"{self.what}: output '{out.name}' of {from_node.bl_label} node "
                        f"'{self.node_name(from_node, from_groups)}' is not evaluated by Photon")
                    continue
                index = self.visit(from_node, from_groups)
                if index is None:
                    continue
                inputs[socket.identifier] = {"node": index, "output": out.identifier}
                self.trivial = False
            else:
                const = src.socket
                if const.type == "SHADER" or (const.type == "VECTOR" and const.hide_value):
                    continue  # implicit: no closure, or the texture's default coordinates
                value = _value(const)
                if value is not None:
                    inputs[socket.identifier] = value
        entry["inputs"] = inputs
        self.nodes.append(entry)
        self.index[key] = len(self.nodes) - 1
        return self.index[key]


def material_nodes(material, folder=None, *, keep_trivial=False, unlinked=frozenset()):
    """`(extension or None, problems)` for `material` (module docstring). With `folder` (the
    .glb's), the images of Image Texture nodes are written there. `keep_trivial`: describe a
    tree glTF carries exactly too (the preview writer, preview.py, has no glTF material).
    `unlinked`: inputs, as (node name, input identifier), read as their unlinked values."""
    tree = material_tree(material)
    if tree is None:
        return None, []
    output = active_output(tree, "ShaderNodeOutputMaterial")
    if output is None:
        return None, []
    walker = _Walker(material, folder, unlinked)
    volume, volume_problems = volume_tree(material, output, walker)
    src = source(output.inputs["Surface"])
    if not src.linked:
        if volume_problems:
            return None, [f"{p}; the material renders without its volume"
                          for p in volume_problems]
        # A Volume alone: the surface only bounds the medium.
        return ({"nodes": [], "volume": volume}, []) if volume is not None else (None, [])
    out = src.output
    index = walker.visit(src.node, src.groups)
    displacement, displace, problems = _displacement_trees(material, output, walker)
    problems = walker.problems + problems + volume_problems
    if problems or index is None:
        return None, [f"{p}; the material falls back to glTF's metallic-roughness values "
                      f"(Blender's exporter)" for p in problems]
    if walker.trivial and displacement is None and displace is None and volume is None \
            and not keep_trivial:
        return None, []
    extension = {"nodes": walker.nodes, "output": {"node": index, "output": out.identifier}}
    if displacement is not None:
        extension["displacement"] = displacement
    if displace is not None:
        extension["displace"] = displace
    if volume is not None:
        extension["volume"] = volume
    return extension, []


def volume_tree(owner, output, surface=None, folder=None):
    """`(tree or None, problems)`: what feeds the Volume socket of `output` (a Material or
    World Output of `owner`), a tree of `material_nodes`' form whose output is the volume
    shader. `surface`: the surface's walker, whose images it shares."""
    socket = output.inputs.get("Volume")
    src = source(socket) if socket is not None else None
    if src is None or not src.linked:
        return None, []
    walker = _Walker(owner, surface.folder if surface else folder,
                     surface.unlinked if surface else frozenset())
    if surface is not None:
        walker.images = surface.images
    if type(owner).__name__ == "World":
        walker.what = f"world '{owner.name}'"
    index = walker.visit(src.node, src.groups)
    if walker.problems or index is None:
        return None, walker.problems
    return {"nodes": walker.nodes, "output": {"node": index, "output": src.output.identifier}}, []


def _displacement_trees(material, output, surface):
    """`(bump tree or None, displace tree or None, problems)`: what feeds the Material Output's
    Displacement, as Cycles renders it by the material's displacement method. "Bump Only" and
    "Displacement and Bump" bump the normal as Cycles' `bump_from_displacement` does: the
    displacement vector's component along the normal as the height of a Bump node (distance 1;
    over true displacement its slope taken in object space), whose normal the surface then
    reads (the bump tree's output). "Displacement Only" and "Displacement and Bump" move the
    mesh's vertices by the vector (the displace tree's output, world space as Cycles adds it
    to the vertex). `surface` is the surface's walker (images are shared)."""
    socket = output.inputs.get("Displacement")
    if socket is None:
        return None, None, []
    src = source(socket)
    if not src.linked:
        return None, None, []
    method = getattr(material, "displacement_method", "BUMP")
    if method not in ("BUMP", "DISPLACEMENT", "BOTH"):
        return None, None, [f"material '{material.name}': displacement method {method} is not "
                            f"rendered by Photon"]
    def walked():
        """A walker over what feeds the Displacement socket, and the index of its source node."""
        walker = _Walker(material, surface.folder, surface.unlinked)
        walker.images = surface.images
        return walker, walker.visit(src.node, src.groups)

    bump = displace = None
    if method in ("DISPLACEMENT", "BOTH"):
        walker, index = walked()
        if walker.problems or index is None:
            return None, None, walker.problems
        displace = {"nodes": walker.nodes,
                    "output": {"node": index, "output": src.output.identifier}}
        if method == "BOTH" and blender_5():
            # Blender 5's Cycles shades flat faces smooth under the bump.
            displace["smooth_flat_faces"] = True
    if method in ("BUMP", "BOTH"):
        walker, index = walked()
        if walker.problems or index is None:
            return None, None, walker.problems
        geometry = len(walker.nodes)
        bump_node = {"name": "Displacement as bump/Bump", "type": "ShaderNodeBump",
                     "invert": False,
                     "inputs": {"Strength": 1.0, "Distance": 1.0,
                                "Height": {"node": geometry + 1, "output": "Value"}}}
        if method == "BOTH":
            bump_node["object_space"] = True
        walker.nodes += [
            {"name": "Displacement as bump/Geometry", "type": "ShaderNodeNewGeometry",
             "inputs": {}},
            {"name": "Displacement as bump/Height", "type": "ShaderNodeVectorMath",
             "operation": "DOT_PRODUCT",
             "inputs": {"Vector": {"node": index, "output": src.output.identifier},
                        "Vector_001": {"node": geometry, "output": "Normal"}}},
            bump_node,
        ]
        bump = {"nodes": walker.nodes, "output": {"node": geometry + 2, "output": "Normal"}}
    return bump, displace, []
