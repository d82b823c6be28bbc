"""Volume objects (OpenVDB grids: imported .vdb files, baked smoke and fire) as boxes the glTF
exporter writes, for the time of an export.

The glTF exporter skips Volume objects. Within `as_boxes(scene)` each rendered Volume object
whose grids come from a file on disk has a mesh object beside it: a box around its grids (one
voxel of margin, where interpolation still reaches), at its place, with its material, or with
Cycles' default volume shader (a Principled Volume reading the "density" grid) when it has none.
`gather_node_hook` writes the box's `PHOTON_object` "volume": the file of the current frame, its
grid names, where this Blender puts a voxel's value, the volume's space (its density per unit
of the object's length or of the world's) and its clipping value (voxels below it hold no
medium); the renderer reads the grids the material's tree names (docs/gltf_extensions.md).

This file runs inside the add-on and as the export child's script: it imports only bpy and the
standard library.
"""

from __future__ import annotations

import contextlib

import bpy

# What a box object's `PHOTON_object` "volume" holds, by the box's object name.
BOXES: dict[str, dict] = {}
# Name of the material made for Volume objects without one.
DEFAULT_MATERIAL = "Photon default volume"
# Grid value types the renderer reads (float and three-float grids).
READ_TYPES = ("FLOAT", "DOUBLE", "VECTOR_FLOAT", "VECTOR_DOUBLE")
# Blender 5 puts a voxel's value at its index in the grid (OpenVDB's convention), Blender 4 at
# index + ½ (the centre of the cell from index to index + 1).
VALUES_AT_INDEX = bpy.app.version >= (5, 0, 0)


def volume_file(obj) -> tuple[str | None, str | None]:
    """`(path, None)`: the absolute path of the OpenVDB file `obj` (a Volume object) shows at
    the current frame; `(None, reason)` when Photon cannot read its grids."""
    volume = obj.data
    if volume.packed_file is not None:
        return None, "its OpenVDB file is packed into the .blend (unpack it to render it)"
    if not volume.grids.load():
        return None, f"its OpenVDB file cannot be read ({volume.grids.error_message})"
    path = bpy.path.abspath(volume.grids.frame_filepath)
    if not path:
        return None, "it has no OpenVDB file (its grids come from modifiers alone)"
    return path, None


def problems(obj) -> list[str]:
    """What of Volume object `obj` is not rendered as Blender shows it."""
    what = f"Volume object '{obj.name}'"
    path, reason = volume_file(obj)
    if path is None:
        return [f"{what} is not rendered: {reason}"]
    out = []
    if any(m.show_render for m in obj.modifiers):
        out.append(f"{what}: its modifiers are not applied; Photon renders the grids of its "
                   f"file")
    unread = [g.name for g in obj.data.grids if g.data_type not in READ_TYPES]
    if unread:
        out.append(f"{what}: grids of other types are not read ({', '.join(unread)})")
    return out


def _default_material():
    material = bpy.data.materials.get(DEFAULT_MATERIAL)
    if material is None:
        material = bpy.data.materials.new(DEFAULT_MATERIAL)
        if bpy.app.version < (5, 0, 0):  # always on (and deprecated) in Blender 5
            material.use_nodes = True
        nodes = material.node_tree.nodes
        nodes.clear()
        principled = nodes.new("ShaderNodeVolumePrincipled")
        output = nodes.new("ShaderNodeOutputMaterial")
        material.node_tree.links.new(principled.outputs["Volume"], output.inputs["Volume"])
    return material


def _box(obj):
    """Corners (object space) of a box around `obj`'s grids: their voxels' bounds and one
    voxel more each side."""
    lo = [float("inf")] * 3
    hi = [float("-inf")] * 3
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    margin = 0.0
    for grid in obj.data.grids:
        matrix = grid.matrix_object
        margin = max(margin, *(sum(matrix[r][c] ** 2 for r in range(3)) ** 0.5
                               for c in range(3)))
    for corner in evaluated.bound_box:
        for a in range(3):
            lo[a] = min(lo[a], corner[a] - margin)
            hi[a] = max(hi[a], corner[a] + margin)
    return lo, hi


def _box_mesh(name, lo, hi):
    mesh = bpy.data.meshes.new(name)
    corners = [(x, y, z) for z in (lo[2], hi[2]) for y in (lo[1], hi[1]) for x in (lo[0], hi[0])]
    # Faces wound outwards.
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    mesh.from_pydata(corners, [], faces)
    mesh.update()
    return mesh


@contextlib.contextmanager
def as_boxes(scene):
    """Within the block, each rendered Volume object of `scene` whose grids Photon reads has a
    box mesh object standing for it (module documentation); removed after."""
    made = []
    try:
        for obj in list(scene.objects):
            if obj.type != "VOLUME" or obj.hide_render:
                continue
            path, _ = volume_file(obj)
            if path is None:
                continue
            lo, hi = _box(obj)
            if not all(a < b for a, b in zip(lo, hi)):
                continue
            box = bpy.data.objects.new(f"{obj.name} (volume)", _box_mesh(obj.name, lo, hi))
            for collection in obj.users_collection:
                collection.objects.link(box)
            box.matrix_world = obj.matrix_world
            material = next((s.material for s in obj.material_slots if s.material), None)
            box.data.materials.append(material or _default_material())
            BOXES[box.name] = {"uri": path,
                               "grids": [g.name for g in obj.data.grids
                                         if g.data_type in READ_TYPES],
                               "space": obj.data.render.space.lower(),
                               "clipping": obj.data.render.clipping}
            if VALUES_AT_INDEX:
                BOXES[box.name]["values_at_index"] = True
            made.append(box)
        if made:
            bpy.context.view_layer.update()
        yield
    finally:
        for box in made:
            mesh = box.data
            BOXES.pop(box.name, None)
            bpy.data.objects.remove(box)
            bpy.data.meshes.remove(mesh)
