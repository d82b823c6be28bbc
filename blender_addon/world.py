"""PHOTON_world: the world as Cycles renders it, read from the world's node tree.

`world_description(world, folder)` reads the shader feeding the active World Output as a
weighted sum of backgrounds (constant colours, an equirectangular environment image written
next to the .glb as a float EXR, Blender's Nishita, Preetham and Hosek-Wilkie skies), once for
camera rays and once for the others, and names what it cannot carry (the pre-flight report
shows those). Links are followed as Cycles follows them (node_graph.py: muted links and nodes,
reroutes, node groups). It imports only bpy, numpy, node_graph.py and shared.py: it runs in
the export's child process too.
"""

from __future__ import annotations

import struct
from pathlib import Path

import bpy

try:
    from .node_graph import active_output, source
    from .shared import LOG, REC709, working_space
except ImportError:  # loaded by export.py as a top-level module in the export's child process
    from node_graph import active_output, source
    from shared import LOG, REC709, working_space


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
    (written into `folder` as a float EXR, see `environment_extension`) or a Sky Texture of
    the Nishita, Preetham or Hosek-Wilkie model (its settings, evaluated by the renderer),
    mixed by Mix Shader (a constant factor) and Add Shader nodes. A Mix Shader whose factor is
    a Light Path node's "Is Camera Ray" gives camera rays another background than the rest: the
    tree is read once for each, and when they differ the camera's goes under "camera". One
    background of weight 1 is written alone ({"color", "strength"[, "environment" | "sky"]}),
    several under "mix" with their weights. Anything else is named in the problems and left out
    (a Background's colour fed by another node keeps its own colour value)."""
    black = {"color": [0.0, 0.0, 0.0], "strength": 1.0}
    if world is None:
        return black, []
    if not world_uses_nodes(world):
        return {"color": [float(c) for c in world.color[:3]], "strength": 1.0}, []
    problems: list[str] = []
    written: dict[str, dict] = {}  # environment images already written, by node name
    output = active_output(world.node_tree, "ShaderNodeOutputWorld")
    surface = output.inputs.get("Surface") if output is not None else None
    shader = source(surface) if surface is not None else None
    if shader is None or not shader.linked:
        return black, []
    views = [_world_shader(shader, 1.0, camera, folder, written, problems)
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


def _world_shader(shader, weight, camera, folder, written, problems) -> list[tuple[float, dict]]:
    """The backgrounds a world shader (`shader`, a `node_graph.Source`) adds up to, each with
    its weight, as a ray that is (`camera`) or is not a camera ray sees them."""
    if not shader.linked or weight == 0.0:
        return []
    node, groups = shader.node, shader.groups
    kind = node.bl_idname
    if kind in ("ShaderNodeBackground", "ShaderNodeEmission"):
        return [(weight, _world_background_layer(node, groups, folder, written, problems))]
    if kind == "ShaderNodeAddShader":
        return [layer for socket in node.inputs[:2] for layer in
                _world_shader(source(socket, groups), weight, camera, folder, written,
                              problems)]
    if kind == "ShaderNodeMixShader":
        factor = _mix_factor(node, groups, camera, problems)
        parts = ((node.inputs[1], 1.0 - factor), (node.inputs[2], factor))
        return [layer for socket, share in parts for layer in
                _world_shader(source(socket, groups), weight * share, camera, folder, written,
                              problems)]
    problems.append(f"{node.bl_label} node '{node.name}' is not exported; the world renders "
                    f"without it")
    return []


def _mix_factor(node, groups, camera: bool, problems) -> float:
    """A Mix Shader's factor in [0, 1]: its value, or for a Light Path node's "Is Camera Ray"
    whether the ray is a camera ray."""
    factor = source(node.inputs["Fac"], groups)
    value = min(max(float(factor.socket.default_value), 0.0), 1.0)
    if not factor.linked:
        return value
    if factor.node.bl_idname == "ShaderNodeLightPath" and factor.output.name == "Is Camera Ray":
        return 1.0 if camera else 0.0
    problems.append(f"Mix Shader '{node.name}': its factor comes from {factor.node.bl_label} "
                    f"'{factor.node.name}', which is not exported; the factor's own value "
                    f"{float(node.inputs['Fac'].default_value):.3g} is used")
    return min(max(float(node.inputs["Fac"].default_value), 0.0), 1.0)


def _world_background_layer(node, groups, folder, written, problems) -> dict:
    """One Background (or Emission) node: its colour and strength, or the Environment or Sky
    Texture feeding its colour."""
    color = source(node.inputs["Color"], groups)
    strength = source(node.inputs["Strength"], groups)
    # A linked input keeps the node's own value where Photon cannot follow the link.
    color_value = (node.inputs["Color"] if color.linked else color.socket).default_value
    strength_value = (node.inputs["Strength"] if strength.linked else strength.socket).default_value
    layer = {"color": [float(c) for c in color_value[:3]], "strength": float(strength_value)}
    if strength.linked:
        problems.append(f"{node.bl_label} '{node.name}': a linked Strength is not exported; its "
                        f"value {layer['strength']:.3g} is used")
    if not color.linked:
        return layer
    texture = color.node
    if texture.bl_idname == "ShaderNodeTexEnvironment":
        layer["color"] = [0.0, 0.0, 0.0]  # what Cycles shows without a usable image
        if folder is not None:
            if texture.name not in written:
                written[texture.name] = environment_extension(texture, folder, color.groups)
            if written[texture.name]:
                layer["environment"] = written[texture.name]
        return layer
    if texture.bl_idname == "ShaderNodeTexSky" and texture.sky_type in SKY_TYPES:
        layer["color"] = [0.0, 0.0, 0.0]
        layer["sky"] = sky_extension(texture, color.groups)
        return layer
    what = (f"the {texture.sky_type} sky model" if texture.bl_idname == "ShaderNodeTexSky"
            else f"{texture.bl_label} node '{texture.name}'")
    problems.append(f"{what} feeding '{node.name}' is not exported; the background renders its "
                    f"own colour")
    return layer


# Sky Texture models Photon evaluates: Nishita's single scattering, named "Nishita" up to
# Blender 4.5 and "Single Scattering" from Blender 5.0; Blender 5's Multiple Scattering (García
# Liñán's spectral sky, Blender 5.0's default); Preetham's and Hosek-Wilkie's analytic skies.
NISHITA_SKY_TYPES = ("NISHITA", "SINGLE_SCATTERING")
SKY_TYPES = NISHITA_SKY_TYPES + ("MULTIPLE_SCATTERING", "PREETHAM", "HOSEK_WILKIE")


def sky_extension(node, groups: tuple = ()) -> dict:
    """The "sky" of PHOTON_world for a Sky Texture node of a model Photon evaluates (inside the
    group nodes `groups`): its settings (radians, metres, factors; the Preetham and Hosek-Wilkie
    skies' sun direction, turbidity and ground albedo) and the rotation of a Mapping node
    feeding its vector. Blender 5 calls the dust density "aerosol density"; its Multiple
    Scattering sky has the Nishita sky's settings and keeps its own type."""
    rotation = _mapping_rotation(node, groups)
    if node.sky_type in ("PREETHAM", "HOSEK_WILKIE"):
        data = {"type": node.sky_type, "sun_direction": [float(c) for c in node.sun_direction],
                "turbidity": float(node.turbidity), "rotation": rotation}
        if node.sky_type == "HOSEK_WILKIE":
            data["ground_albedo"] = float(node.ground_albedo)
        return data
    dust = getattr(node, "aerosol_density", None)
    kind = "MULTIPLE_SCATTERING" if node.sky_type == "MULTIPLE_SCATTERING" else "NISHITA"
    return {"type": kind, "sun_disc": bool(node.sun_disc),
            "sun_size": float(node.sun_size), "sun_intensity": float(node.sun_intensity),
            "sun_elevation": float(node.sun_elevation),
            "sun_rotation": float(node.sun_rotation), "altitude": float(node.altitude),
            "air": float(node.air_density),
            "dust": float(node.dust_density if dust is None else dust),
            "ozone": float(node.ozone_density), "rotation": rotation}


def environment_extension(node, folder: Path, groups: tuple = ()) -> dict:
    """The "environment" of PHOTON_world for an Environment Texture node (inside the group nodes
    `groups`): its image written to
    `folder` as a float EXR (linear RGB; 8-bit sRGB images are linearised as Cycles does and
    taken into the file's working colour space), the
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
        if working_space() != REC709:
            rgb = rgb @ _rec709_to_working().T
    safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in image.name)
    uri = f"world_{safe}.exr"
    write_exr_rgb(folder / uri, np.ascontiguousarray(rgb, dtype=np.float32))
    return {"uri": uri, "rotation": _mapping_rotation(node, groups),
            "interpolation": "closest" if node.interpolation == "Closest" else "linear"}


def _rec709_to_working():
    """Blender's matrix from linear Rec.709 to the file's working colour space (numpy 3x3)."""
    import numpy as np
    from mathutils import Color
    columns = [Color(e).from_rec709_linear_to_scene_linear()
               for e in ((1, 0, 0), (0, 1, 0), (0, 0, 1))]
    return np.array([[c[row] for c in columns] for row in range(3)], dtype=np.float32)


def _mapping_rotation(node, groups: tuple) -> list[float]:
    """Euler XYZ rotation (radians) applied to the lookup direction, read from a Mapping node
    feeding the texture's Vector (Point, Vector and Normal types rotate the direction, Texture
    inverts; location and scale are ignored); zero when the vector is not mapped."""
    vector = node.inputs.get("Vector")
    mapping = None if vector is None else source(vector, groups).node
    if mapping is None or mapping.bl_idname != "ShaderNodeMapping":
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

