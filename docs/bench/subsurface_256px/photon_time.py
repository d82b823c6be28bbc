"""Photon's time to a relMSE against a reference: renders `scene` with each binary at each spp
(wall time of the whole process, as `photon bench` times its child), alternating binaries,
and interpolates the time to the target in log-log as cycles_time.py does.

Usage: .venv/bin/python docs/bench/subsurface_256px/photon_time.py SCENE.glb --reference REF.exr \
           --bin before=PATH --bin after=PATH --spp 1,2,4,8 [--size 256] [--json OUT]
"""
import json, subprocess, sys, time
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scenes" / "blender"))
from refimage import read_exr, rel_mse
from cycles_time import time_to_target, describe
import argparse
ap = argparse.ArgumentParser()
ap.add_argument("scene"); ap.add_argument("--reference", required=True)
ap.add_argument("--bin", action="append", required=True, help="NAME=PATH")
ap.add_argument("--spp", default="1,2,4,8"); ap.add_argument("--size", type=int, default=256)
ap.add_argument("--method", default="auto"); ap.add_argument("--repeats", type=int, default=1)
ap.add_argument("--json")
a = ap.parse_args()
import tempfile
scratch = tempfile.mkdtemp(prefix="photon_time-")  # private: other runs may share /tmp
ref = read_exr(a.reference)
bins = dict(b.split("=", 1) for b in a.bin)
spps = [int(s) for s in a.spp.split(",")]
best = {(n, s): None for n in bins for s in spps}
for r in range(a.repeats):
    for s in spps:
        for n, path in bins.items():
            out = f"{scratch}/photon_time-{n}-{s}.exr"
            t0 = time.perf_counter()
            subprocess.run([path, "render", a.scene, "--width", str(a.size), "--height", str(a.size),
                            "--spp", str(s), "--threads", "2", "--method", a.method, "--seed", "1",
                            "-o", out, "--progress", "none"], check=True, capture_output=True)
            t = time.perf_counter() - t0
            e = rel_mse(read_exr(out), ref)
            if best[(n, s)] is None or t < best[(n, s)][0]:
                best[(n, s)] = (t, e)
            print(f"{n} {s} spp: {t:.2f} s relMSE {e:.5f}", file=sys.stderr, flush=True)
res = {}
for n in bins:
    pts = [best[(n, s)] for s in spps]
    res[n] = {"points": [{"spp": s, "seconds": t, "rel_mse": e} for s, (t, e) in zip(spps, pts)],
              "time_to_target": time_to_target(pts, 0.01)}
    print(f"{n}: " + ", ".join(f"{s} spp {t:.2f} s {e:.4f}" for s, (t, e) in zip(spps, pts))
          + f" -> time to relMSE 0.01: {describe(res[n]['time_to_target'])}")
if a.json:
    open(a.json, "w").write(json.dumps(res, indent=2) + "\n")
