"""Cycles' time to an error, against the reference `photon bench` uses, so that Photon's and
Cycles' times to relMSE 0.01 can be compared in one run on one machine.

Renders a scene with Cycles (Blender as the `bpy` module) at several samples per pixel on a fixed
number of threads, with the same pixel filter as Photon, and measures each render's wall time
(`bpy.ops.render.render` with the EXR written: Cycles' scene sync, BVH build, render and output,
as `photon bench` times its child's whole render) and its relMSE against the reference. From the
(time, relMSE) points it gives the time to `--target-error` by log-log interpolation between the
two points that bracket it (else a bound, or an estimate from the last point with relMSE ∝ 1/t),
as `photon bench` does. With `--bench-dir` (the `--out` of `photon bench`) it takes the scene's
reference from there and prints Photon's times from the bench's summary next to Cycles'.

A `.blend` is rendered as it is (its camera, resolution from the reference). A `.glb`/`.gltf` is
imported with Blender's glTF importer and Photon's own extensions are put back where Cycles has
the same thing: `PHOTON_render` (film transparency, pixel filter), `PHOTON_world` (a constant
colour), `PHOTON_light` (soft-shadow radius, sun angle, spot cone, power and colour, area
lights), `PHOTON_material_subsurface` (the Principled subsurface inputs, random walk), and
one-sided emission of materials that are not double-sided (Photon emits from the front only,
Cycles from both sides unless told). Anything else Photon reads and Cycles would
render differently is listed as a warning before rendering.

Usage (the Cycles settings are the references' of common.configure_cycles: no clamping, no
glossy filter, light tree, adaptive sampling and denoising off; a .blend keeps its Clamp Direct
and Indirect, which the add-on's export gives Photon):

    .venv/bin/python scenes/blender/cycles_time.py scenes/cornell_box.glb \\
        --bench-dir bench_out --spp 16,32,64,128,256 --threads 2 [--json cycles.json]
    .venv/bin/python scenes/blender/cycles_time.py scene.glb --reference ref.exr --spp 64,256

`--adaptive-threshold T` turns Cycles' adaptive sampling on (Noise Threshold T, 0: automatic;
Min Samples automatic), to compare with `photon bench`'s `*-adaptive` methods, which pass the
same threshold.

A 1-sample render first loads Cycles' kernels and is not counted.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import struct
import sys
import time
from pathlib import Path

import bpy
from mathutils import Matrix

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import common  # noqa: E402
from refimage import read_exr, rel_mse  # noqa: E402

FILTER_TYPES = {"blackman-harris": "BLACKMAN_HARRIS", "gaussian": "GAUSSIAN", "box": "BOX"}


class Usage(Exception):
    """Bad input: the message is printed and the script exits with 2."""


def parse_filter(text: str) -> tuple[str, float]:
    """`TYPE[:WIDTH]` as `photon render --filter` reads it, as Blender's (type, width)."""
    name, _, width = text.partition(":")
    kind = FILTER_TYPES.get(name.strip().lower().replace("_", "-"))
    if kind is None:
        raise Usage(f"unknown pixel filter '{name}' (valid: {', '.join(FILTER_TYPES)})")
    try:
        value = float(width) if width else (1.0 if kind == "BOX" else 1.5)
    except ValueError:
        raise Usage(f"pixel filter width '{width}' is not a number") from None
    if not 0.01 <= value <= 10.0:
        raise Usage(f"pixel filter width {value} is outside Blender's range 0.01..10 px")
    return kind, value


def read_gltf_json(path: Path) -> dict:
    """The JSON of a .glb or .gltf file."""
    data = path.read_bytes()
    if data[:4] != b"glTF":
        return json.loads(data)
    length, kind = struct.unpack_from("<I4s", data, 12)
    if kind != b"JSON":
        raise Usage(f"{path}: the first chunk of the .glb is not JSON")
    return json.loads(data[20:20 + length])


# ---------------------------------------------------------------------------------------------
# The scene in Cycles
# ---------------------------------------------------------------------------------------------

def one_sided_emission(material, warnings: list) -> None:
    """Let `material` emit from its front only, as Photon does for a glTF material that is not
    double-sided: its Principled emission strength times (1 − Backfacing), and only the front
    sampled as a light."""
    tree = material.node_tree
    bsdf = next((n for n in tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
    if bsdf is None or bsdf.inputs["Emission Strength"].is_linked:
        warnings.append(f"material '{material.name}': emission left two-sided (no plain "
                        "Principled emission strength to mask)")
        return
    strength = bsdf.inputs["Emission Strength"]
    geometry = tree.nodes.new("ShaderNodeNewGeometry")
    front = tree.nodes.new("ShaderNodeMath")
    front.operation = "SUBTRACT"
    front.inputs[0].default_value = 1.0
    tree.links.new(geometry.outputs["Backfacing"], front.inputs[1])
    scaled = tree.nodes.new("ShaderNodeMath")
    scaled.operation = "MULTIPLY"
    scaled.inputs[1].default_value = strength.default_value
    tree.links.new(front.outputs["Value"], scaled.inputs[0])
    tree.links.new(scaled.outputs["Value"], strength)
    material.cycles.emission_sampling = "FRONT"


def photon_light(obj, ext: dict, warnings: list) -> None:
    """PHOTON_light on an imported punctual light: Blender's values Photon renders with."""
    light = obj.data
    if "power" in ext:
        light.energy = ext["power"]
    if "strength" in ext:
        light.energy = ext["strength"]
    if "color" in ext:
        light.color = ext["color"]
    if light.type in ("POINT", "SPOT"):
        light.shadow_soft_size = ext.get("radius", 0.0)
    if light.type == "SPOT":
        if "spot_size" in ext:
            light.spot_size = ext["spot_size"]
        if "spot_blend" in ext:
            light.spot_blend = ext["spot_blend"]
    if light.type == "SUN":
        light.angle = ext.get("angle", 0.0)


def area_light(node_obj, ext: dict) -> None:
    """A PHOTON_light area light at the node: Blender's area light emitting along the glTF node's
    local −Z, as Photon's does. The importer makes the node (no glTF light on it) an empty whose
    matrix is the node's with Y-up turned to Z-up, so the node's −Z is the empty's +Y: the lamp is
    the empty turned +90° about its X (which keeps the lamp's X and Y along the node's)."""
    light = bpy.data.lights.new(node_obj.name + "_area", "AREA")
    light.shape = ext.get("shape", "SQUARE")
    light.size = ext.get("size", 1.0)
    light.size_y = ext.get("size_y", light.size)
    light.energy = ext.get("power", 10.0)
    light.color = ext.get("color", (1.0, 1.0, 1.0))
    if "spread" in ext:
        light.spread = ext["spread"]
    obj = bpy.data.objects.new(node_obj.name + "_area", light)
    obj.matrix_world = node_obj.matrix_world @ Matrix.Rotation(math.pi / 2.0, 4, "X")
    obj.visible_camera = ext.get("visible_camera", True)
    bpy.context.scene.collection.objects.link(obj)


def subsurface(name: str, ext: dict, warnings: list) -> None:
    """PHOTON_material_subsurface on an imported material: the Principled BSDF's subsurface
    inputs back, with Blender's default method (random walk, whose boundary uses the BSDF's IOR;
    the extension's `ior` is Subsurface IOR, read only by the skin method)."""
    material = bpy.data.materials.get(name)
    tree = material.node_tree if material is not None else None
    bsdf = next((n for n in tree.nodes if n.type == "BSDF_PRINCIPLED"), None) if tree else None
    if bsdf is None:
        warnings.append(f"material '{name}': PHOTON_material_subsurface has no Principled BSDF "
                        "to go on")
        return
    bsdf.subsurface_method = "RANDOM_WALK"
    sockets = {i.name: i for i in bsdf.inputs}  # the IOR socket is hidden with RANDOM_WALK
    for key, socket in (("weight", "Subsurface Weight"), ("radius", "Subsurface Radius"),
                        ("scale", "Subsurface Scale"), ("ior", "Subsurface IOR"),
                        ("anisotropy", "Subsurface Anisotropy")):
        if key in ext:
            sockets[socket].default_value = ext[key]


def import_gltf(path: Path) -> tuple[dict, list]:
    """Import `path` into an empty scene and put back Photon's extensions (module docstring);
    returns the PHOTON_render extension and the warnings."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=str(path))
    doc = read_gltf_json(path)
    warnings = []
    scene = bpy.context.scene
    gltf_scene = doc.get("scenes", [{}])[doc.get("scene", 0)]
    ext = gltf_scene.get("extensions", {})
    world_ext = ext.get("PHOTON_world")
    world = bpy.data.worlds.new("World")
    scene.world = world
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Strength"].default_value = 0.0
    if world_ext is not None:
        unsupported = sorted(set(world_ext) - {"color", "strength"})
        if unsupported:
            warnings.append(f"PHOTON_world {unsupported}: only a constant colour is set")
        color = world_ext.get("color", [0.0, 0.0, 0.0])
        background.inputs["Color"].default_value = (*color, 1.0)
        background.inputs["Strength"].default_value = world_ext.get("strength", 1.0)
    for i, node in enumerate(doc.get("nodes", [])):
        node_ext = node.get("extensions", {})
        obj = bpy.data.objects.get(node.get("name", f"node{i}"))
        for name in sorted(set(node_ext) - {"PHOTON_light", "KHR_lights_punctual"}):
            if name.startswith("PHOTON_"):
                warnings.append(f"node '{node.get('name')}': {name} is not reproduced")
        light_ext = node_ext.get("PHOTON_light")
        if light_ext is None:
            continue
        if obj is None:
            warnings.append(f"node '{node.get('name')}': not found after the import")
        elif light_ext.get("type") == "area":
            area_light(obj, light_ext)
        elif obj.type == "LIGHT":
            photon_light(obj, light_ext, warnings)
    # Punctual lights without PHOTON_light are points to Photon: no soft-shadow radius.
    for obj in scene.objects:
        if obj.type == "LIGHT" and obj.data.type in ("POINT", "SPOT"):
            names = [n.get("name") for n in doc.get("nodes", [])
                     if "PHOTON_light" in n.get("extensions", {})]
            if obj.name not in names:
                obj.data.shadow_soft_size = 0.0
    for material in doc.get("materials", []):
        m_ext = material.get("extensions", {})
        for name in sorted(set(m_ext) - {"PHOTON_material_subsurface"}):
            if name.startswith("PHOTON_"):
                warnings.append(f"material '{material.get('name')}': {name} is not reproduced")
        if "PHOTON_material_subsurface" in m_ext:
            subsurface(material.get("name", ""), m_ext["PHOTON_material_subsurface"], warnings)
        emits = any(material.get("emissiveFactor", [0, 0, 0]))
        if emits and not material.get("doubleSided", False):
            blender = bpy.data.materials.get(material.get("name", ""))
            if blender is None:
                warnings.append(f"material '{material.get('name')}': not found after the import")
            else:
                one_sided_emission(blender, warnings)
    return ext.get("PHOTON_render", {}), warnings


def prepare(scene_path: Path, size: tuple[int, int], threads: int,
            filter_arg: str | None) -> tuple[tuple[str, float], list]:
    """Open or import the scene and set Cycles up; returns the pixel filter and the warnings."""
    if scene_path.suffix.lower() == ".blend":
        bpy.ops.wm.open_mainfile(filepath=str(scene_path))
        render_ext, warnings = {}, []
    elif scene_path.suffix.lower() in (".glb", ".gltf"):
        render_ext, warnings = import_gltf(scene_path)
    else:
        raise Usage(f"{scene_path}: expected a .glb, .gltf or .blend file")
    scene = bpy.context.scene
    if scene.camera is None:
        cameras = [o for o in scene.objects if o.type == "CAMERA"]
        if not cameras:
            raise Usage(f"{scene_path}: the scene has no camera")
        scene.camera = cameras[0]
    scene.render.engine = "CYCLES"
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    # A .blend keeps its Clamp Direct / Indirect: the add-on's export carries them to Photon.
    clamps = (scene.cycles.sample_clamp_direct, scene.cycles.sample_clamp_indirect)
    common.configure_cycles(scene, 1, seed=1, threads=threads)
    if scene_path.suffix.lower() == ".blend":
        scene.cycles.sample_clamp_direct, scene.cycles.sample_clamp_indirect = clamps
    scene.render.film_transparent = bool(render_ext.get("film_transparent", False))
    if filter_arg is not None:
        kind, width = parse_filter(filter_arg)
    elif "filter" in render_ext:
        f = render_ext["filter"]
        kind = f.get("type", "BLACKMAN_HARRIS")
        width = f.get("width", 1.0 if kind == "BOX" else 1.5)
    else:
        kind, width = "BLACKMAN_HARRIS", 1.5
    scene.cycles.pixel_filter_type = kind
    scene.cycles.filter_width = width
    return (kind, width), warnings


def render(path: Path, spp: int, seed: int) -> float:
    """One Cycles render of the current scene to `path`; its wall time in seconds."""
    scene = bpy.context.scene
    scene.cycles.samples = spp
    scene.cycles.seed = seed
    scene.render.filepath = str(path)
    scene.render.use_file_extension = False
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    return time.perf_counter() - start


# ---------------------------------------------------------------------------------------------
# Time to an error
# ---------------------------------------------------------------------------------------------

def time_to_target(points: list, target: float) -> dict:
    """The time the (seconds, relMSE) curve, in order of samples, reaches `target`."""
    if not points:
        return {"status": "no points"}
    if points[0][1] <= target:
        return {"status": "at_most", "seconds": points[0][0]}
    for (t0, e0), (t1, e1) in zip(points, points[1:]):
        if e0 > target >= e1:
            # log e = a + b log t through both points.
            b = (math.log(e1) - math.log(e0)) / (math.log(t1) - math.log(t0))
            if b == 0.0 or not math.isfinite(b):
                return {"status": "reached", "seconds": t1}
            t = math.exp(math.log(t0) + (math.log(target) - math.log(e0)) / b)
            return {"status": "reached", "seconds": t}
    t, e = points[-1]
    return {"status": "not_reached", "best_rel_mse": e, "seconds": t,
            "extrapolated_seconds": t * e / target}


def describe(result: dict) -> str:
    status = result.get("status")
    if status == "reached":
        return f"{result['seconds']:.2f} s"
    if status == "at_most":
        return f"≤ {result['seconds']:.2f} s"
    if status == "not_reached":
        return (f"not reached (best {result['best_rel_mse']:.4f} at {result['seconds']:.2f} s; "
                f"≈ {result['extrapolated_seconds']:.1f} s at relMSE ∝ 1/t)")
    return str(status)


def bench_reference(bench_dir: Path, stem: str) -> Path:
    """The newest reference of scene `stem` in a `photon bench` output directory."""
    refs = sorted((bench_dir / "refs").glob(f"{stem}-*.exr"), key=lambda p: p.stat().st_mtime)
    refs = [p for p in refs if ".half" not in p.name]
    if not refs:
        raise Usage(f"{bench_dir / 'refs'} holds no reference of '{stem}' (run photon bench "
                    f"on the scene with --out {bench_dir} first)")
    return refs[-1]


def photon_times(bench_dir: Path, stem: str) -> tuple[dict, list]:
    """Photon's times to the bench's target error and its (method, budget, seconds, relMSE)
    rows for `stem`, from the bench's summary.json and results.csv (empty when missing)."""
    times, rows = {}, []
    summary = bench_dir / "summary.json"
    if summary.exists():
        for scene in json.loads(summary.read_text()).get("scenes", []):
            if scene.get("scene") == stem:
                times = scene.get("time_to_target", {})
    results = bench_dir / "results.csv"
    if results.exists():
        with results.open() as f:
            for row in csv.DictReader(f):
                if row.get("scene") == stem:
                    rows.append(row)
    return times, rows


def main(argv: list) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", type=Path, help=".glb, .gltf or .blend")
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--reference", type=Path, help="the reference EXR")
    source.add_argument("--bench-dir", type=Path,
                        help="a photon bench --out directory: its reference of the scene, and "
                             "Photon's times printed alongside")
    parser.add_argument("--spp", default="16,32,64,128,256",
                        help="comma-separated samples per pixel (default 16,32,64,128,256)")
    parser.add_argument("--threads", type=int, default=2, help="Cycles' threads (default 2)")
    parser.add_argument("--filter", help="pixel filter TYPE[:WIDTH] as photon --filter "
                                         "(default: the scene's, else blackman-harris:1.5)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--repeats", type=int, default=1,
                        help="runs per sample count; the fastest counts (default 1)")
    parser.add_argument("--target-error", type=float, default=0.01)
    parser.add_argument("--out", type=Path, default=Path("/tmp/cycles_time"),
                        help="where the renders go")
    parser.add_argument("--json", type=Path, help="also write the results here")
    parser.add_argument("--adaptive-threshold", type=float,
                        help="Cycles' adaptive sampling on with this Noise Threshold (0: "
                             "automatic); off without it")
    args = parser.parse_args(argv)
    if args.adaptive_threshold is not None and not args.adaptive_threshold >= 0:
        raise Usage("--adaptive-threshold must be >= 0 (0: automatic)")
    try:
        spps = [int(s) for s in args.spp.split(",") if s.strip()]
    except ValueError:
        raise Usage(f"--spp {args.spp!r}: expected comma-separated integers") from None
    if not spps or min(spps) < 1 or args.threads < 1 or args.repeats < 1:
        raise Usage("--spp, --threads and --repeats must be positive")
    if not args.scene.exists():
        raise Usage(f"{args.scene}: no such file")
    if args.filter is not None:
        parse_filter(args.filter)
    stem = args.scene.stem
    reference_path = args.reference or bench_reference(args.bench_dir, stem)
    if not reference_path.exists():
        raise Usage(f"{reference_path}: no such reference")
    reference = read_exr(reference_path)
    size = (reference.shape[1], reference.shape[0])
    (kind, width), warnings = prepare(args.scene, size, args.threads, args.filter)
    for w in warnings:
        print(f"cycles_time: warning: {w}", file=sys.stderr)
    if args.adaptive_threshold is not None:
        cycles_settings = bpy.context.scene.cycles
        cycles_settings.use_adaptive_sampling = True
        cycles_settings.adaptive_threshold = args.adaptive_threshold
        cycles_settings.adaptive_min_samples = 0
    args.out.mkdir(parents=True, exist_ok=True)
    render(args.out / "warmup.exr", 1, args.seed)
    points = []
    for spp in sorted(set(spps)):
        path = args.out / f"{stem}-cycles-{spp}.exr"
        seconds = min(render(path, spp, args.seed) for _ in range(args.repeats))
        error = rel_mse(read_exr(path), reference)
        points.append((seconds, error))
        print(f"cycles_time: {stem} cycles {spp} spp: {seconds:.2f} s, relMSE {error:.5f}",
              file=sys.stderr)
    cycles = time_to_target(points, args.target_error)
    print(f"\n{stem} {size[0]}x{size[1]}, {args.threads} threads, filter {kind} {width:g} px, "
          f"reference {reference_path}")
    print("\n| renderer | spp | seconds | relMSE |\n|---|---:|---:|---:|")
    for spp, (seconds, error) in zip(sorted(set(spps)), points):
        print(f"| Cycles | {spp} | {seconds:.2f} | {error:.5f} |")
    times, rows = photon_times(args.bench_dir, stem) if args.bench_dir else ({}, [])
    for row in rows:
        print(f"| Photon {row['method']} | {row['budget']} | {float(row['seconds']):.2f} | "
              f"{float(row['rel_mse']):.5f} |")
    print(f"\ntime to relMSE {args.target_error}: Cycles {describe(cycles)}")
    for method, result in times.items():
        print(f"time to the bench's target: Photon {method} {describe(result)}")
    if args.json:
        args.json.write_text(json.dumps({
            "scene": str(args.scene), "width": size[0], "height": size[1],
            "threads": args.threads, "filter": {"type": kind, "width": width},
            "reference": str(reference_path), "target_rel_mse": args.target_error,
            "adaptive_threshold": args.adaptive_threshold,
            "cycles": [{"spp": s, "seconds": t, "rel_mse": e}
                       for s, (t, e) in zip(sorted(set(spps)), points)],
            "cycles_time_to_target": cycles, "photon_time_to_target": times,
            "warnings": warnings}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except Usage as e:
        print(f"cycles_time: error: {e}", file=sys.stderr)
        sys.exit(2)
