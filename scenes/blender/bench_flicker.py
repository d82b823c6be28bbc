"""Frame-to-frame flicker of the photon method against the path tracer (not a test: run by hand).

    PHOTON_BINARY=target/release/photon .venv/bin/python scenes/blender/bench_flicker.py \
        [--frames 5] [--spp 64]

A static scene (the red box on a grey floor under a 1 m area light, scenes_bpy.area_light_scene,
64x36) and a camera flying sideways by 1 mm per frame: the image moves by well under a
hundredth of a pixel between frames, so what changes from one frame to the next is the
renderer's noise, i.e. the flicker a viewer would see in static regions. Rendered through the
add-on (`bpy.ops.render.render`, one frame at a time) with the path tracer and with the photon
method at the same samples per pixel, with the seed fixed (what the add-on passes for every
frame by default) and with the seed set to the frame number. Flicker = mean over pixels and
frame pairs of |I(f+1) - I(f)| / mean(I); also printed: each frame's relMSE against a
4x-samples path-traced render of frame 1 (the error itself), and the time per frame.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parents[1] / "tests" / "blender"))  # scenes_bpy: the test scenes
sys.path.insert(0, str(HERE.parents[1]))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=5)
    parser.add_argument("--spp", type=int, default=64)
    args = parser.parse_args(argv)
    import bpy  # noqa: F401
    import numpy as np
    import blender_addon
    import scenes_bpy
    from refimage import read_exr, rel_mse
    blender_addon.register()
    try:
        scene = scenes_bpy.area_light_scene()
        camera = scene.camera
        start = camera.location.copy()
        tmp = Path(tempfile.mkdtemp(prefix="photon_flicker_"))
        reference = _render_seeded(scene, camera, start, "PATH", 1, 1, 4 * args.spp, tmp,
                                   scenes_bpy, read_exr)
        for method in ("PATH", "PHOTON"):
            for seeds in ("fixed", "per frame"):
                images, seconds = [], []
                for frame in range(1, args.frames + 1):
                    seed = 1 if seeds == "fixed" else frame
                    t0 = time.perf_counter()
                    img = _render_seeded(scene, camera, start, method, frame, seed, args.spp,
                                         tmp, scenes_bpy, read_exr)
                    seconds.append(time.perf_counter() - t0)
                    images.append(img)
                flicker = np.mean([np.abs(b - a).mean() for a, b in zip(images, images[1:])])
                flicker /= float(np.mean(images))
                errors = [rel_mse(img, reference) for img in images]
                print(f"{method.lower():6s} seed {seeds:9s} {args.spp} spp: flicker "
                      f"{flicker:.4f}, relMSE vs reference {np.mean(errors):.5f}, "
                      f"{np.mean(seconds):.2f} s/frame", flush=True)
    finally:
        blender_addon.unregister()
    sys.stdout.flush()
    os._exit(0)  # the bpy module can hang at interpreter exit


def _render_seeded(scene, camera, start, method, frame, seed, spp, tmp, scenes_bpy, read_exr):
    """Render `frame` (camera moved by 1 mm per frame) with `method` and `seed`."""
    import bpy
    camera.location = start
    camera.location.x += 0.001 * (frame - 1)
    camera.location.y += 0.001 * (frame - 1)
    scenes_bpy.common.configure_cycles(scene, spp, seed=1, threads=scenes_bpy.THREADS)
    scene.render.engine = "PHOTON"
    scene.photon.samples, scene.photon.seed, scene.photon.threads = spp, seed, 0
    scene.photon.method = method
    path = tmp / f"{method}_{frame}_{seed}_{spp}.exr"
    scene.render.filepath = str(path)
    scene.render.use_file_extension = False
    bpy.ops.render.render(write_still=True)
    return read_exr(path)


if __name__ == "__main__":
    sys.exit(main())
