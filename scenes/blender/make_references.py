"""Regenerate every Cycles reference in scenes/blender/ (.glb, .exr, .json) in one bpy process.

Usage (from the repository root, after tests/setup_python.sh):
    .venv/bin/python scenes/blender/make_references.py              # all scenes
    .venv/bin/python scenes/blender/make_references.py cornell sun_plane
    .venv/bin/python scenes/blender/make_references.py --quick      # 1/16 of the samples, to /tmp

Scenes: cornell, cornell_lambert (cornell.py); point_plane, sun_plane, spot_plane
(lights_plane.py); principled_r05, principled_r10 (principled_plane.py); subsurface, subsurface_s02
(subsurface.py); room_thin, room_thick (window_room.py); ring_open (open_ring.py). Takes about 15 minutes on 2 cores, almost all of it the Cornell boxes.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import cornell  # noqa: E402
import lights_plane  # noqa: E402
import open_ring  # noqa: E402
import principled_plane  # noqa: E402
import subsurface  # noqa: E402
import window_room  # noqa: E402

SCENES = {
    "cornell_lambert": (cornell.make, cornell.SAMPLES),
    "cornell": (cornell.make, cornell.SAMPLES),
    "point_plane": (lights_plane.make, lights_plane.SAMPLES),
    "sun_plane": (lights_plane.make, lights_plane.SAMPLES),
    "spot_plane": (lights_plane.make, lights_plane.SAMPLES),
    "principled_r05": (principled_plane.make, principled_plane.SAMPLES),
    "principled_r10": (principled_plane.make, principled_plane.SAMPLES),
    "subsurface": (subsurface.make, subsurface.SAMPLES),
    "subsurface_s02": (subsurface.make, subsurface.SAMPLES),
    "room_thin": (window_room.make, window_room.SAMPLES),
    "room_thick": (window_room.make, window_room.SAMPLES),
    "ring_open": (open_ring.make, open_ring.SAMPLES),
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenes", nargs="*", metavar="SCENE", help="any of: " + ", ".join(SCENES))
    ap.add_argument("--quick", action="store_true",
                    help="1/16 of the samples and output to /tmp/photon_refs (a smoke test)")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    unknown = [s for s in args.scenes if s not in SCENES]
    if unknown:
        ap.error(f"unknown scene(s) {unknown}; choose from {list(SCENES)}")
    out = args.out or (Path("/tmp/photon_refs") if args.quick else HERE)
    t0 = time.perf_counter()
    for name in args.scenes or list(SCENES):
        make, samples = SCENES[name]
        make(name, out, max(16, samples // 16) if args.quick else samples)
    print(f"all done in {time.perf_counter() - t0:.0f} s; files in {out}")


if __name__ == "__main__":
    main()
