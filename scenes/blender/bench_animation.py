"""Per-frame overhead of an animation rendered through the add-on (not a test: run by hand).

    PHOTON_BINARY=target/release/photon .venv/bin/python scenes/blender/bench_animation.py \
        [--frames 4] [--route inprocess|subprocess] [--levels 5]

The scene: Suzanne with a Subdivision Surface modifier (viewport level 1, render level 5:
1.0 M triangles at render time) turning about Z (keyframes), the factory camera and light, a
64x36 image at 1 sample, so nearly all of a frame's time is overhead: the pre-flight, the export
(in process or through a background Blender), the start of the renderer (reading the .glb,
building the BVH) and loading its image. `bpy.ops.render.render(animation=True)` runs in a child
Python (bpy as a module, that is Blender in background mode, as on a render farm); the engine's
final status line of each frame (printed by Blender) gives its export time and time to the
renderer's first progress line, and the child's render_pre/render_post handlers the wall time
per frame. Prints one line per frame and the mean, extrapolated to 100 frames.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]

CHILD = r"""
import os, sys, time, traceback
sys.path.insert(0, {repo!r})
import bpy
import blender_addon
blender_addon.register()
try:
    exec(compile(BODY, "bench", "exec"))
except BaseException:
    traceback.print_exc()
    os._exit(1)  # a registered Python engine would make the bpy module hang at exit
blender_addon.unregister()
sys.stdout.flush()
os._exit(0)  # the bpy module may still hang at exit (handlers holding closures)
"""

BODY = r"""
bpy.ops.wm.read_factory_settings()
scene = bpy.context.scene
bpy.data.objects.remove(bpy.data.objects["Cube"])
bpy.ops.mesh.primitive_monkey_add()
monkey = bpy.context.active_object
sub = monkey.modifiers.new("Subdivision", "SUBSURF")
sub.levels, sub.render_levels = 1, {levels}
for frame in range(1, {frames} + 1):
    monkey.rotation_euler.z = 0.2 * frame
    monkey.keyframe_insert("rotation_euler", index=2, frame=frame)
scene.frame_start, scene.frame_end = 1, {frames}
scene.render.engine = "PHOTON"
scene.render.resolution_x, scene.render.resolution_y = 640, 360
scene.render.resolution_percentage = 10
scene.photon.samples, scene.photon.method = 1, "PATH"
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.filepath = {out!r}
stamps = []
bpy.app.handlers.render_pre.append(lambda *a: stamps.append(("pre", time.perf_counter())))
bpy.app.handlers.render_post.append(lambda *a: stamps.append(("post", time.perf_counter())))
t0 = time.perf_counter()
bpy.ops.render.render(animation=True)
total = time.perf_counter() - t0
pre = [t for k, t in stamps if k == "pre"]
post = [t for k, t in stamps if k == "post"]
for a, b in zip(pre, post):
    print(f"BENCH frame {{b - a:.3f}}", flush=True)
print(f"BENCH total {{total:.3f}}", flush=True)
"""

STATUS = re.compile(r"Photon: (\d+x\d+).*?export ([\d.]+) s, first progress ([\d.]+) s, "
                    r"total ([\d.]+) s")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=4)
    parser.add_argument("--levels", type=int, default=5)
    parser.add_argument("--route", choices=("inprocess", "subprocess"), default="inprocess")
    args = parser.parse_args(argv)
    if not os.environ.get("PHOTON_BINARY"):
        raise SystemExit("set PHOTON_BINARY to the release binary")
    with tempfile.TemporaryDirectory(prefix="photon_bench_") as tmp:
        body = BODY.format(levels=args.levels, frames=args.frames, out=str(Path(tmp) / "frame_"))
        code = f"BODY = {body!r}\n" + CHILD.format(repo=str(REPO))
        env = dict(os.environ, PHOTON_EXPORT=args.route)
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              env=env, stdin=subprocess.DEVNULL)
    if proc.returncode != 0:
        print(proc.stdout[-3000:], proc.stderr[-3000:])
        raise SystemExit(f"child failed with code {proc.returncode}")
    statuses = [m.groups() for m in STATUS.finditer(proc.stdout)]
    walls = [float(line.split()[2]) for line in proc.stdout.splitlines()
             if line.startswith("BENCH frame")]
    total = float(next(line.split()[2] for line in proc.stdout.splitlines()
                       if line.startswith("BENCH total")))
    tri = re.findall(r"(\d+) triangles", proc.stdout)
    print(f"route {args.route}, {args.frames} frames, {tri[-1] if tri else '?'} triangles")
    print("frame  export s  first progress s  engine total s  frame wall s")
    for i, (size, export, first, engine_total) in enumerate(statuses):
        wall = walls[i] if i < len(walls) else float("nan")
        print(f"{i + 1:5d}  {float(export):8.2f}  {float(first):16.2f}  {float(engine_total):14.2f}"
              f"  {wall:12.2f}")
    later = walls[1:] or walls
    mean = statistics.mean(later)
    print(f"whole animation {total:.2f} s; mean frame wall time (frames 2..): {mean:.2f} s; "
          f"100 frames: {100 * mean:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
