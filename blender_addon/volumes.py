"""Volume objects (OpenVDB grids: imported .vdb files, baked smoke and fire) as boxes the glTF
exporter writes, and the smoke and fire of baked fluid domains, for the time of an export.

The glTF exporter skips Volume objects. Within `as_boxes(scene, glb)` each Volume the render
shows, as the depsgraph yields it (`volume_instances`: a Volume object in the scene, in a
collection an Empty instances, instanced by a particle system or by Geometry Nodes, or the
Volume geometry a Geometry Nodes tree makes: Volume Cube, Mesh to Volume, Points to Volume),
has a mesh object in the scene: a box around its grids (one voxel of margin, where
interpolation still reaches), at the instance's world matrix, with the Volume's material, or
with Cycles' default volume shader (a Principled Volume reading the "density" grid) when it has
none. The boxes of one Volume share one mesh, which the renderer stores once as a prototype
with its grids. A Volume object without modifiers is read from its OpenVDB file on disk; the
grids of every other Volume (Geometry Nodes', those a Volume object's modifiers change, a
packed file's) exist only in Blender's memory and are written once, with `VolumeGrids.save`,
to an OpenVDB file beside the .glb. `gather_node_hook` writes each box's `PHOTON_object`
"volume": the file of the current frame, its grid names, where this Blender puts a voxel's
value, the volume's space (its density per unit of the object's length or of the world's) and
its clipping value (voxels below it hold no medium); the renderer reads the grids the
material's tree names (docs/gltf_extensions.md).

A fluid domain of type Gas (smoke and fire) is rendered as Cycles renders it: its own mesh (the
box the Fluid modifier makes, the adaptive domain's box included) filled with the frame's baked
grids. Mantaflow writes them, with its OpenVDB cache, to `data/fluid_data_####.vdb` in the
cache directory: "density", "flame", "temperature" (Mantaflow's heat), "color_r/g/b",
"velocity", half floats; with noise, `noise/fluid_noise_####.vdb` holds the upres
"density_noise" and "flame_noise", which Cycles renders in their place. Cycles reads the same
grids from memory, under its own attribute names: "density" and "flame" as they are, "heat" as
Mantaflow's heat × ½ and "temperature" made from the flame, the domain's Ignition + flame ×
(Maximum − Ignition) where the flame is above 0.01, else 0; each over the mesh's texture space,
a value at each cell's centre. The domain's `PHOTON_object` "volume" says so: `attributes` maps
those names to the file's grids, `index_to_object` places the voxels. A domain without baked
data at the frame renders nothing, as in Cycles.

This file runs inside the add-on and as the export child's script: it imports only bpy and the
standard library.
"""

from __future__ import annotations

import contextlib
import struct
from pathlib import Path

import bpy

# What a box object's `PHOTON_object` "volume" holds, by the box's object name.
BOXES: dict[str, dict] = {}
# Names of the meshes of the objects whose evaluated geometry is only the Volumes they make or
# instance (Geometry Nodes), during an export: the glTF exporter warns that it omits them.
ONLY_VOLUMES: set[str] = set()
# Name of the material made for Volume objects without one.
DEFAULT_MATERIAL = "Photon default volume"
# Grid value types the renderer reads (float and three-float grids).
READ_TYPES = ("FLOAT", "DOUBLE", "VECTOR_FLOAT", "VECTOR_DOUBLE")
# Blender 5 puts a voxel's value at its index in the grid (OpenVDB's convention), Blender 4 at
# index + ½ (the centre of the cell from index to index + 1).
VALUES_AT_INDEX = bpy.app.version >= (5, 0, 0)


def medium_extent(scene) -> str:
    """Which part of a Volume object's box Cycles fills with its medium (`PHOTON_object`
    "volume" "extent"): Blender 5's unbiased volumes fill the bounding box of the voxels at or
    above the Clipping value, grown by one voxel ("bounds"); Blender 4, and Blender 5 when
    Light Paths > Volumes > Biased ray-marches them, fill the OpenVDB leaves (8³ voxels)
    holding such voxels ("leaves")."""
    biased = getattr(getattr(scene, "cycles", None), "volume_biased", False)
    return "bounds" if VALUES_AT_INDEX and not biased else "leaves"


def grid_fields(scene) -> dict:
    """The `PHOTON_object` "volume" fields that say how this Blender's Cycles reads grids:
    where a voxel's value sits, how lookups interpolate (Blender 5 reads one voxel drawn by
    the trilinear weights, Blender 4 their weighted sum) and which part holds the medium."""
    fields = {"extent": medium_extent(scene)}
    if VALUES_AT_INDEX:
        fields.update(values_at_index=True, interpolation="stochastic")
    return fields


def volume_file(obj) -> tuple[str | None, str | None]:
    """`(path, None)`: the absolute path of the OpenVDB file `obj` (a Volume object) shows at
    the current frame; `(None, reason)` when Photon cannot read its grids."""
    volume = obj.data
    if not volume.grids.load():
        return None, f"its OpenVDB file cannot be read ({volume.grids.error_message})"
    path = bpy.path.abspath(volume.grids.frame_filepath)
    if not path:
        return None, "it has no OpenVDB file"
    return path, None


def problems(obj) -> list[str]:
    """What of Volume object `obj` is not rendered as Blender shows it."""
    what = f"Volume object '{obj.name}'"
    original = getattr(obj, "original", obj)
    if from_its_file(original):
        path, reason = volume_file(original)
        if path is None:
            return [f"{what} is not rendered: {reason}"]
        grids = original.data.grids
    else:  # its modifiers' or its packed file's grids, written out by the export
        grids = original.evaluated_get(bpy.context.evaluated_depsgraph_get()).data.grids
        if len(grids) == 0:
            return [f"{what} is not rendered: it has no grids"]
    return _unread_grids(what, grids)


def _unread_grids(what, grids) -> list[str]:
    unread = [g.name for g in grids if g.data_type not in READ_TYPES]
    return [f"{what}: grids of other types are not read ({', '.join(unread)})"] if unread else []


def instanced_problems(depsgraph, named) -> list[str]:
    """What of the Volumes that `depsgraph` instances (particle systems, Geometry Nodes,
    collection instances) or Geometry Nodes make is not rendered, each Volume object once and
    none of those whose names are in `named` (reported as objects of the scene)."""
    seen = set(named)
    out = []
    for inst in depsgraph.object_instances:
        evaluated = inst.object
        if not inst.is_instance or evaluated.type != "VOLUME":
            continue
        original = evaluated.original
        if original.name in seen:
            continue
        seen.add(original.name)
        if original.type == "VOLUME":
            out += problems(original)
        else:
            out += _unread_grids(f"object '{original.name}': the volume its Geometry Nodes make",
                                 evaluated.data.grids)
    return out


def fluid_domain(obj):
    """The settings of `obj`'s rendered Fluid modifier of type Domain with gas (smoke and fire),
    or None."""
    for modifier in getattr(obj, "modifiers", ()):
        if modifier.type == "FLUID" and modifier.fluid_type == "DOMAIN" \
                and modifier.show_render and modifier.domain_settings.domain_type == "GAS":
            return modifier.domain_settings
    return None


def fluid_file(obj, frame) -> tuple[Path | None, str | None]:
    """`(path, None)`: the OpenVDB file of fluid domain `obj`'s baked grids at `frame`;
    `(None, reason)` when it has none Photon reads (it then renders nothing)."""
    settings = fluid_domain(obj)
    if not settings.cache_frame_start <= frame <= settings.cache_frame_end:
        return None, f"frame {frame} is outside its cache's frames"
    if settings.cache_data_format != "OPENVDB":
        return None, "its cache's data format is not OpenVDB"
    folder = Path(bpy.path.abspath(settings.cache_directory))
    path = folder / "data" / f"fluid_data_{frame:04d}.vdb"
    if not path.is_file():
        return None, f"it has no baked data at frame {frame} (bake it: Cycles renders nothing)"
    if settings.use_noise:
        path = folder / "noise" / f"fluid_noise_{frame:04d}.vdb"
        if not path.is_file():
            return None, f"its noise is not baked at frame {frame}"
    return path, None


def _vdb_string(data, at):
    (size,) = struct.unpack_from("<I", data, at)
    return data[at + 4:at + 4 + size].decode("utf-8", "replace"), at + 4 + size


def vdb_resolution(path) -> tuple[int, int, int] | None:
    """The voxels per axis of the first grid of Mantaflow's OpenVDB file `path` (its
    "file_base_resolution" metadata: the grid's size, which an adaptive domain changes)."""
    data = Path(path).read_bytes()
    try:
        at = 8 + 4 + 8 + 1 + 36  # magic, version, library version, offsets flag, UUID
        (count,) = struct.unpack_from("<I", data, at)
        at += 4
        for _ in range(count):  # the file's metadata
            _, at = _vdb_string(data, at)
            _, at = _vdb_string(data, at)
            (size,) = struct.unpack_from("<I", data, at)
            at += 4 + size
        at += 4  # grid count
        for _ in range(3):  # name, tree type, instance parent
            _, at = _vdb_string(data, at)
        at += 3 * 8 + 4  # stream offsets, compression flags
        (count,) = struct.unpack_from("<I", data, at)
        at += 4
        for _ in range(count):
            name, at = _vdb_string(data, at)
            kind, at = _vdb_string(data, at)
            (size,) = struct.unpack_from("<I", data, at)
            if name == "file_base_resolution" and kind == "vec3i" and size == 12:
                return struct.unpack_from("<3i", data, at + 4)
            at += 4 + size
    except (struct.error, UnicodeDecodeError):
        return None
    return None


def fluid_volume(obj, path, scene) -> dict | None:
    """The `PHOTON_object` "volume" of fluid domain `obj` of `scene` whose frame's grids are in
    `path` (module documentation), or None when the file's grid size is not found."""
    settings = fluid_domain(obj)
    resolution = vdb_resolution(path)
    if resolution is None or min(resolution) <= 0:
        return None
    mesh = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    location, size = mesh.texspace_location, mesh.texspace_size
    cell = [2.0 * size[a] / resolution[a] for a in range(3)]
    first = [location[a] - size[a] + 0.5 * cell[a] for a in range(3)]
    ignition, hottest = settings.flame_ignition, settings.flame_max_temp
    # With noise, the upres density and flame (the noise file's "density_noise" and
    # "flame_noise") stand for the simulation's; its heat stays in the data file, unread.
    suffix = "_noise" if settings.use_noise else ""
    attributes = {"density": {"grid": f"density{suffix}"},
                  "flame": {"grid": f"flame{suffix}"},
                  "temperature": {"grid": f"flame{suffix}", "above": 0.01,
                                  "offset": ignition, "scale": hottest - ignition}}
    if not settings.use_noise:
        attributes["heat"] = {"grid": "temperature", "scale": 0.5}
    return {"uri": str(path),
            "grids": sorted(attributes),
            "space": "world",
            "clipping": settings.clipping,
            **grid_fields(scene),
            "values_at_index": True,
            "index_to_object": [cell[0], 0.0, 0.0, 0.0, 0.0, cell[1], 0.0, 0.0,
                                0.0, 0.0, cell[2], 0.0, *first, 1.0],
            "attributes": attributes}


def fluid_problems(obj, frame) -> list[str]:
    """What of fluid domain `obj`'s smoke and fire at `frame` is not rendered as Cycles
    renders it."""
    settings = fluid_domain(obj)
    what = f"fluid domain '{obj.name}'"
    path, reason = fluid_file(obj, frame)
    if path is None:
        return [f"{what}: no smoke or fire is rendered: {reason}"]
    if not reads_fluid_grids(obj):
        return [f"{what}: no smoke or fire is rendered: its material reads none of its grids "
                f"(as in Cycles)"]
    out = []
    if settings.use_noise and _reads(obj, "heat"):
        out.append(f"{what}: its \"heat\" attribute is not read with noise (the noise file "
                   f"has none); the material sees none")
    if _reads(obj, "color"):
        out.append(f"{what}: its \"color\" attribute (the flows' smoke colours) is not read; "
                   f"the material sees none")
    if vdb_resolution(path) is None:
        out.append(f"{what}: its OpenVDB file {path} does not give its grids' size; its smoke "
                   f"and fire are not rendered")
    return out


def reads_fluid_grids(obj) -> bool:
    """Whether `obj`'s materials read any of a fluid domain's grids (its attributes, or a
    Volume Info node): Cycles builds a domain's volume from the grids it reads, so with none
    nothing renders."""
    names = ("density", "flame", "heat", "temperature", "color")
    return any(_reads(obj, name) for name in names) or any(
        node.bl_idname == "ShaderNodeVolumeInfo"
        for slot in obj.material_slots
        if slot.material is not None and slot.material.node_tree is not None
        for node in slot.material.node_tree.nodes)


def _principled_volume_reads(node) -> set[str]:
    """The attributes a Principled Volume node reads, as Cycles asks for them: its Density
    and Color Attributes when it has density, its Temperature Attribute when it glows as a
    black body."""

    def active(name):
        socket = node.inputs.get(name)
        return socket is not None and (socket.is_linked or socket.default_value > 0.0)

    def named(kind):
        return getattr(node.inputs.get(f"{kind} Attribute"), "default_value", "")

    reads = {named("Density"), named("Color")} if active("Density") else set()
    if active("Blackbody Intensity"):
        reads.add(named("Temperature"))
    return reads - {""}


def _reads(obj, attribute) -> bool:
    """Whether the nodes of `obj`'s materials read `attribute` (a Principled Volume's
    attribute inputs, an Attribute node)."""
    for slot in obj.material_slots:
        tree = slot.material.node_tree if slot.material is not None else None
        for node in tree.nodes if tree is not None else ():
            if node.bl_idname == "ShaderNodeVolumePrincipled" \
                    and attribute in _principled_volume_reads(node):
                return True
            if node.bl_idname == "ShaderNodeAttribute" and node.attribute_name == attribute:
                return True
    return False


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


def _box(evaluated):
    """Corners (object space) of a box around the grids of `evaluated` (an evaluated Volume
    object): their voxels' bounds and one voxel more each side."""
    lo = [float("inf")] * 3
    hi = [float("-inf")] * 3
    margin = 0.0
    for grid in evaluated.data.grids:
        matrix = grid.matrix_object
        margin = max(margin, *(sum(matrix[r][c] ** 2 for r in range(3)) ** 0.5
                               for c in range(3)))
    for corner in evaluated.bound_box:
        for a in range(3):
            lo[a] = min(lo[a], corner[a] - margin)
            hi[a] = max(hi[a], corner[a] + margin)
    return lo, hi


def from_its_file(original) -> bool:
    """Whether Volume object `original` renders the grids of its OpenVDB file on disk as they
    are (no modifier changes them, the file is not packed into the .blend): Photon then reads
    that file."""
    return original.type == "VOLUME" and original.data.packed_file is None \
        and not any(m.show_render for m in original.modifiers)


def _source(key, name, evaluated, uri, material, scene) -> dict:
    """What the boxes of one Volume (`evaluated`, an evaluated object showing it) share: the
    box's corners and mesh name, its material, and the `PHOTON_object` "volume" reading `uri`."""
    volume = evaluated.data
    return {"key": key,
            "name": name,
            "box": _box(evaluated),
            "material": material,
            "volume": {"uri": uri,
                       "grids": [g.name for g in volume.grids if g.data_type in READ_TYPES],
                       "space": volume.render.space.lower(),
                       "clipping": volume.render.clipping,
                       **grid_fields(scene)}}


def volume_instances(scene, glb) -> list[tuple[dict, object, object]]:
    """Every Volume the render of `scene` shows, as the depsgraph yields them: Volume objects
    in the scene, in collections that Empties instance, instanced by particle systems or by
    Geometry Nodes, and Volume geometry that Geometry Nodes make (Volume Cube, Mesh to Volume,
    Points to Volume) or Volume objects' modifiers change. Each is `(source, world matrix,
    owner)`: `source` (`_source`) is shared by every instance of one Volume, so that its grids
    are read once; `owner` is the object whose ray visibility and holdout the box takes (the
    Volume object, or the object whose modifiers make the volume).

    A Volume object without modifiers is read from its OpenVDB file; other volumes exist only
    in memory, and their evaluated grids are written once each to an OpenVDB file beside
    `glb` (the scene's file: `NAME.glb` gets `NAME.volume0.vdb`, ...). Volumes that are not
    rendered, or whose grids cannot be read, are left out."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    sources: dict = {}
    placed = []
    for inst in depsgraph.object_instances:
        evaluated = inst.object
        if evaluated.type != "VOLUME":
            continue
        shown_by = inst.parent if inst.is_instance else evaluated
        if shown_by is None or shown_by.original.hide_render:
            continue
        original = evaluated.original
        if from_its_file(original):
            key = ("file", original.name)
            if key not in sources:
                path, _ = volume_file(original)
                material = next((s.material for s in original.material_slots if s.material),
                                None)
                sources[key] = None if path is None else _source(
                    key, original.name, evaluated, path, material, scene)
        else:
            key = ("evaluated", evaluated.data.as_pointer())
            if key not in sources:
                sources[key] = _evaluated_source(key, original, evaluated, glb, len(sources),
                                                 scene)
        source = sources[key]
        if source is None or not all(a < b for a, b in zip(*source["box"])):
            continue
        placed.append((source, inst.matrix_world.copy(), original))
        maker = inst.parent if inst.is_instance else None
        if maker is not None and maker.type == "MESH" and len(maker.data.vertices) == 0:
            ONLY_VOLUMES.add(maker.original.data.name)
    return placed


def _evaluated_source(key, original, evaluated, glb, number, scene) -> dict | None:
    """The source (`_source`) of a volume that exists only in the evaluated depsgraph (Geometry
    Nodes' volume geometry, a Volume object's modifiers), its grids written to an OpenVDB file
    beside `glb` numbered `number`; None when it has no grid or cannot be written."""
    grids = evaluated.data.grids
    if len(grids) == 0:
        return None
    path = Path(glb).with_suffix(f".volume{number}.vdb")
    if not grids.save(str(path)) or not path.is_file():
        return None
    materials = [s.material for s in evaluated.material_slots if s.material is not None]
    material = getattr(materials[0], "original", None) if materials else None
    return _source(key, f"{original.name} volume", evaluated, str(path), material, scene)


def _box_mesh(name, lo, hi):
    mesh = bpy.data.meshes.new(name)
    corners = [(x, y, z) for z in (lo[2], hi[2]) for y in (lo[1], hi[1]) for x in (lo[0], hi[0])]
    # Faces wound outwards.
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    mesh.from_pydata(corners, [], faces)
    mesh.update()
    return mesh


@contextlib.contextmanager
def as_boxes(scene, glb, holdouts=frozenset()):
    """Within the block, each rendered instance of a Volume of `scene` whose grids Photon
    reads has a box mesh object standing for it (`volume_instances`; grids that exist only in
    memory are written to OpenVDB files beside `glb`, the scene's file), and each rendered
    fluid domain of gas carries its baked grids or, without them at the frame, is hidden
    (module documentation); undone after. `holdouts`: names of the objects in holdout
    collections, whose boxes are holdouts."""
    made = []
    meshes = {}
    hidden = []
    domains = []
    try:
        for obj in list(scene.objects):
            if obj.type == "MESH" and not obj.hide_render and fluid_domain(obj) is not None:
                path, _ = fluid_file(obj, scene.frame_current)
                volume = fluid_volume(obj, path, scene) if path is not None else None
                if volume is None or not reads_fluid_grids(obj):
                    obj.hide_render = True  # nothing to render, as in Cycles
                    hidden.append(obj)
                else:
                    BOXES[obj.name] = volume
                    domains.append(obj.name)
        placed = volume_instances(scene, glb)
        for k, (source, matrix, owner) in enumerate(placed):
            if source["key"] not in meshes:
                lo, hi = source["box"]
                meshes[source["key"]] = _box_mesh(source["name"], lo, hi)
                meshes[source["key"]].materials.append(source["material"]
                                                       or _default_material())
            box = bpy.data.objects.new(f"{source['name']} (volume {k})",
                                       meshes[source["key"]])
            scene.collection.objects.link(box)
            box.matrix_world = matrix
            for setting in ("visible_camera", "visible_shadow", "is_holdout"):
                setattr(box, setting, getattr(owner, setting, getattr(box, setting)))
            if owner.name in holdouts:
                box.is_holdout = True
            BOXES[box.name] = source["volume"]
            made.append(box)
        if made or hidden:
            bpy.context.view_layer.update()
        yield
    finally:
        for obj in hidden:
            obj.hide_render = False
        for name in domains:
            BOXES.pop(name, None)
        ONLY_VOLUMES.clear()
        for box in made:
            BOXES.pop(box.name, None)
            bpy.data.objects.remove(box)
        for mesh in meshes.values():
            bpy.data.meshes.remove(mesh)
