"""What the export's modules share: the logger their warnings go to, the object types the
glTF exporter writes as meshes and the file's working colour space. It imports nothing but the
standard library (and bpy where it reads the file)."""

import logging

# The export's own messages; collected with the glTF exporter's during an export
# (export.collected_warnings) and shown to the user.
LOG = logging.getLogger("photon.export")

# Object types the glTF exporter writes as meshes.
GEOMETRY_TYPES = ("MESH", "CURVE", "SURFACE", "META", "FONT")

# Blender 4's only working colour space, the renderer's default.
REC709 = "lin_rec709_scene"


def blender_5() -> bool:
    """Whether the file is rendered by Blender 5 (whose Cycles changed some textures and
    materials: the add-on says so where the renderer must follow)."""
    import bpy
    return bpy.app.version >= (5, 0, 0)


def working_space() -> str:
    """The file's working colour space as its Color Interop Forum id (Blender 5's
    `bpy.data.colorspace`; Blender 4 renders in linear Rec.709)."""
    import bpy
    colorspace = getattr(bpy.data, "colorspace", None)
    return getattr(colorspace, "working_space_interop_id", "") or REC709


def material_tree(material):
    """The node tree a material renders with, or None. Blender 5 always renders a material's
    tree (Material.use_nodes is deprecated there and reading it warns); Blender 4 only with
    use_nodes on."""
    import bpy
    tree = getattr(material, "node_tree", None)
    if tree is None or bpy.app.version >= (5, 0, 0):
        return tree
    return tree if getattr(material, "use_nodes", False) else None
