"""A converged Cycles reference of a .glb (imported as cycles_time.py imports it, so translucent
materials render with Cycles' random walk): K renders of SPP samples with seeds 11.. averaged,
the relMSE between the two halves printed (the reference's own error is about a quarter of it).

Usage: .venv/bin/python docs/bench/subsurface_256px/cycles_reference.py SCENE.glb SIZE SPP K OUT.exr
"""
import sys
from pathlib import Path
sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scenes" / "blender"))
import numpy as np
import cycles_time as ct
from refimage import read_exr
import bpy
scene, size, spp, k, out = Path(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), Path(sys.argv[5])
(kind, width), warnings = ct.prepare(scene, (size, size), 2, None)
print("warnings", warnings, flush=True)
assert k >= 2, "K must be at least 2"
imgs = []
for seed in range(11, 11 + k):
    p = out.with_suffix(f".s{seed}.exr")
    t = ct.render(p, spp, seed)
    imgs.append(read_exr(p))
    print(scene.stem, "seed", seed, spp, "spp", round(t, 1), "s", flush=True)
mean = sum(imgs) / len(imgs)
a, b = sum(imgs[: k // 2]) / (k // 2), sum(imgs[k // 2:]) / (k - k // 2)
print("relMSE between halves", ct.rel_mse(a, b), "mean", float(mean.mean()), flush=True)
from refimage import write_exr
write_exr(out, mean)
print('wrote', out, flush=True)
