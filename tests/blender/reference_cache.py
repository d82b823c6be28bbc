"""Cycles references rendered once per test run and shared by the tests that render the same
scene at the same settings (the cases of one parametrized test that differ only in Photon's
method or sample count, say), so that each distinct Cycles image is paid for once.

An entry's key is the test function (its pytest node id without the parameters: references are
shared between different test functions only where they name a common scope) and a digest,
taken just before the render with every setting already made, of everything in `bpy.data` that
a render can see: every ID's plain properties (numbers, strings, enums, arrays) and those of the
structs it holds (node trees with their nodes, sockets and links, modifiers, light linking,
render and Cycles settings with the samples and seed), the names of the IDs it points to, mesh
and curve coordinates, and image pixels. Photon's own settings (`scene.photon`, which Cycles
never reads) and the output path are left out. A property the digest missed could let two cases
that differ only in it share one reference, and a Photon that ignored that property would then
pass: every shared reference is named in the test's output ("shared with an earlier case"), so
that a new parametrized test can be checked for it.

Each pytest process keeps its own entries: with pytest-xdist every worker has its own folder
(its own temporary directory), and tests/run hands each worker whole test files
(`--dist loadfile`), so the cases that can share a reference meet in the same worker.

Between runs the references are kept in the store, tests/data/cycles_references/<Blender
version>/, a file per key (its name a hash of the test function or scope, the digest and the
file type): a Cycles render of a scene whose digest is unchanged is the same image on every run
(a fixed seed, a CPU render), so the tests read it instead of rendering Cycles. An EXR is kept
as half floats (a relative rounding of at most 2^-11 per value, far below every tolerance the
tests assert against a reference: their means are compared to 0.3 % and more, and 48 x 32
references at 1024 samples hold noise of a few per cent per pixel). A key without a stored file
renders Cycles as before and says so ("rendered, none stored"): a changed scene, a new test, or
another Blender version (bpy 5.0's keys are its own; only 4.5's are stored). The store is
written by tests/blender/store_references.sh, which empties this version's folder and renders
every reference anew; run it, and commit the folder, after a change to a test's scene or Cycles
settings (a file whose scene changed is never read again: its key went with the scene, and the
script's fresh folder drops it).
"""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

import numpy as np

# Properties that are bookkeeping, not what a render reads (or that would make two builds of
# one scene differ: run-time ids, user counts, the RNA type itself).
SKIPPED = {"rna_type", "bl_rna", "original", "id_data", "users", "session_uid", "is_evaluated",
           "tag", "is_runtime_data", "is_missing", "preview", "photon", "use_fake_user",
           "use_extra_user", "is_embedded_data", "is_library_indirect", "library_weak_reference",
           "asset_data", "override_library", "bindcode", "is_dirty", "is_editmode",
           "name_full", "is_evaluated", "is_updated", "users_collection",
           "users_scene", "display_name", "is_float", "has_data", "frame_duration",
           "tool_settings", "sequence_editor", "keying_sets", "keying_sets_all",
           "timeline_markers", "safe_areas", "statistics"}
# Collections longer than this are summarised by their length (mesh elements are hashed below).
MAX_ITEMS = 256
# How deep the walk follows structs held by an ID (node tree → node → socket → value).
DEPTH = 5
# bpy.data collections a render can read.
ID_COLLECTIONS = ("scenes", "objects", "meshes", "materials", "lights", "cameras", "worlds",
                  "node_groups", "images", "curves", "hair_curves", "pointclouds", "volumes",
                  "particles", "textures", "collections", "lattices", "metaballs", "fonts",
                  "lightprobes")

# The stored references: Cycles renders kept between test runs, written by
# tests/blender/store_references.sh (PHOTON_STORE_REFERENCES=1 renders every reference and
# stores it), one folder per Blender version.
STORE = Path(__file__).resolve().parents[1] / "data" / "cycles_references"
# Largest magnitude kept as a half float (its largest finite value is 65504).
HALF_LIMIT = 60000.0

_entries: dict[tuple, Path] = {}
# Where the first render of each key is kept: a folder under pytest's temporary directory, set by
# conftest.py's session fixture.
folder: Path | None = None


def _plain(value):
    """A property value as nested tuples of rounded numbers and strings."""
    if isinstance(value, (bool, int, str)) or value is None:
        return value
    if isinstance(value, float):
        return round(value, 7)
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        return repr(value)
    return tuple(np.round(array, 7).ravel().tolist()) + tuple(array.shape)


def _walk(struct, out: list, depth: int) -> None:
    import bpy

    if isinstance(struct, bpy.types.NodeLink):
        out.append(("link", struct.from_node.name, struct.from_socket.identifier,
                    struct.to_node.name, struct.to_socket.identifier, struct.is_muted))
        return
    # A socket's node and links lead back into the tree, which is walked once from the top.
    back = {"node", "links"} if isinstance(struct, bpy.types.NodeSocket) else set()
    if isinstance(struct, bpy.types.RenderSettings):
        back = {"filepath"}  # where the image is written, not what it shows
    for prop in struct.bl_rna.properties:
        ident = prop.identifier
        if ident in SKIPPED or ident in back:
            continue
        try:
            value = getattr(struct, ident)
        except Exception:  # noqa: BLE001 - some properties raise outside their context
            continue
        kind = prop.type
        if kind in {"BOOLEAN", "INT", "FLOAT", "STRING", "ENUM"}:
            if kind == "ENUM" and getattr(prop, "is_enum_flag", False):
                value = tuple(sorted(value))
            out.append((ident, _plain(value)))
        elif kind == "POINTER":
            if value is None:
                out.append((ident, None))
            elif isinstance(value, bpy.types.ID) and not value.is_embedded_data:
                out.append((ident, "ID", type(value).__name__, value.name))
            elif depth > 0:
                out.append((ident, "{"))
                _walk(value, out, depth - 1)
                out.append("}")
        elif kind == "COLLECTION" and depth > 0:
            count = len(value)
            out.append((ident, count))
            if count > MAX_ITEMS:
                continue
            for item in value:
                if item is None:
                    out.append(None)
                elif isinstance(item, bpy.types.ID):
                    out.append(("ID", type(item).__name__, item.name))
                else:
                    out.append("[")
                    _walk(item, out, depth - 1)
                    out.append("]")


def _geometry(block, digest) -> None:
    """Coordinates and pixels that the property walk only counts."""
    import bpy

    def add(collection, attribute, width):
        values = np.zeros(len(collection) * width, dtype=np.float32)
        collection.foreach_get(attribute, values)
        digest.update(np.round(values, 6).tobytes())

    if isinstance(block, bpy.types.Mesh):
        add(block.vertices, "co", 3)
        digest.update(_faces(block).encode())
        for attribute in block.attributes:
            digest.update(attribute.name.encode())
    elif isinstance(block, bpy.types.Image) and block.size[0] * block.size[1] > 0:
        pixels = np.zeros(len(block.pixels), dtype=np.float32)
        block.pixels.foreach_get(pixels)
        digest.update(pixels.tobytes())
    elif hasattr(bpy.types, "Curves") and isinstance(block, bpy.types.Curves):
        add(block.points, "position", 3)
    elif hasattr(bpy.types, "PointCloud") and isinstance(block, bpy.types.PointCloud):
        add(block.points, "co", 3)


def _faces(mesh) -> str:
    """The mesh's faces as a sorted list of their corners (vertex index and UVs), each face
    starting at its lowest vertex: the same for two builds of one mesh whose faces come out in
    another order (Blender's UV sphere orders them differently from one call to the next)."""
    def values(collection, attribute, width, dtype):
        out = np.zeros(len(collection) * width, dtype=dtype)
        collection.foreach_get(attribute, out)
        return out

    corners = values(mesh.loops, "vertex_index", 1, np.int32)
    starts = values(mesh.polygons, "loop_start", 1, np.int32)
    totals = values(mesh.polygons, "loop_total", 1, np.int32)
    uvs = [np.round(values(layer.uv, "vector", 2, np.float32), 6).reshape(-1, 2).tolist()
           for layer in mesh.uv_layers]
    faces = []
    for start, total in zip(starts.tolist(), totals.tolist()):
        ring = list(range(start, start + total))
        first = min(range(total), key=lambda k: corners[ring[k]])
        ring = ring[first:] + ring[:first]
        faces.append(tuple((int(corners[c]),) + tuple(tuple(uv[c]) for uv in uvs) for c in ring))
    return repr(sorted(faces))


def scene_digest() -> str:
    """The digest of what a render of the current bpy data can see."""
    import bpy

    digest = hashlib.sha256()
    for collection_name in ID_COLLECTIONS:
        collection = getattr(bpy.data, collection_name, None)
        if collection is None:
            continue
        for block in sorted(collection, key=lambda b: b.name):
            out: list = [collection_name, block.name]
            _walk(block, out, DEPTH)
            digest.update(repr(out).encode())
            _geometry(block, digest)
    return digest.hexdigest()


def test_function() -> str:
    """The running test's node id without its parameters."""
    current = os.environ.get("PYTEST_CURRENT_TEST", "")
    return current.split(" ")[0].split("[")[0]


def _store_file(key: tuple, suffix: str) -> Path:
    """Where the stored reference of `key` (test function or scope, digest, suffix) lives: one
    folder per Blender version (its Cycles renders differ between versions)."""
    import bpy

    version = ".".join(str(v) for v in bpy.app.version)
    name = hashlib.sha256(repr(key).encode()).hexdigest()[:32]
    return STORE / version / f"{name}{suffix}"


def _write_stored(rendered: Path, stored: Path) -> None:
    """Keep a rendered reference in the store: an EXR as half floats, ZIP-compressed (a channel
    with values beyond half's range, a depth pass say, stays 32-bit float), anything else as
    it is."""
    stored.parent.mkdir(parents=True, exist_ok=True)
    if rendered.suffix.lower() != ".exr":
        shutil.copyfile(rendered, stored)
        return
    import OpenEXR

    with OpenEXR.File(str(rendered), separate_channels=True) as f:
        if len(f.parts) != 1:
            shutil.copyfile(rendered, stored)
            return
        planes = {}
        for name, channel in f.channels().items():
            values = np.asarray(channel.pixels)
            finite = values[np.isfinite(values)]
            fits = values.dtype.kind == "f" and (finite.size == 0
                                                 or np.abs(finite).max() < HALF_LIMIT)
            planes[name] = np.ascontiguousarray(values.astype(np.float16) if fits else values)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    partial = stored.with_suffix(".partial" + stored.suffix)
    with OpenEXR.File(header, planes) as out:
        out.write(str(partial))
    partial.replace(stored)


def _read_default(path: Path):
    from refimage import read_exr
    return read_exr(path)


def cached_render(render, path: Path, scope: str | None = None, read=None):
    """`render()` (which renders the scene as it is now set up, writes its file at `path` and
    returns what the test reads of it) run once per test function (or `scope`, a name the tests
    that share references across their functions pass) and scene digest, taken with every
    setting the render reads already set; later calls with the same key copy the first file to
    `path` and return `read(path)` (default: its RGB). A reference kept in the store
    (tests/data/cycles_references, this Blender version's folder) is used in place of
    rendering it at all. Returns (image, whether it was shared or stored)."""
    path = Path(path)
    read = read or _read_default
    try:
        key = (scope or test_function(), scene_digest(), path.suffix)
    except Exception as exc:  # noqa: BLE001 - a scene the walk cannot read is rendered, not shared
        print(f"cycles reference {path.name}: not shared ({type(exc).__name__}: {exc})")
        return render(), False
    stored = _entries.get(key)
    if stored is not None:
        shutil.copyfile(stored, path)
        print(f"cycles reference {path.name}: shared with an earlier case of {key[0]}")
        return read(path), True
    kept = _store_file(key, path.suffix)
    if kept.exists() and os.environ.get("PHOTON_STORE_REFERENCES") != "1":
        shutil.copyfile(kept, path)
        print(f"cycles reference {path.name}: stored ({kept.parent.name}/{kept.name})")
        _entries[key] = kept
        return read(path), True
    if STORE.exists():
        print(f"cycles reference {path.name}: rendered, none stored for {key[0]} in "
              f"{kept.parent.name}/{kept.name}")
    image = render()
    if os.environ.get("PHOTON_STORE_REFERENCES") == "1":
        _write_stored(path, kept)
    if folder is not None:
        stored = folder / f"{len(_entries)}{path.suffix}"
        shutil.copyfile(path, stored)
        _entries[key] = stored
    return image, False
