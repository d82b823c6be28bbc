"""A room lit only by a sun through a window opening, black world (the photon method's worst
case before its searches kept to one side of a surface).

Interior 4 x 4 m, 2.5 m high (x, y in [-2, 2], z in [0, 2.5]); window in the wall y = -2,
x in [-0.4, 0.4], z in [1.2, 1.7]. Sun (angle 0, SUN_STRENGTH W/m^2) rotated SUN_TILT_DEG
about +x, so light travels towards (0, sin t, -cos t) and lands on the floor through the window.
Camera inside near the back wall looking at the window wall (90 deg field of view).

Variants (`--walls`):
  thin   every surface a single zero-thickness plane (floor, ceiling, 3 walls, window wall as
         4 planes around the hole), normals facing inwards
  thick  the same interior faces, but every wall/floor/ceiling a closed box WALL m thick
  closed thin, plus one plane closing the window
Materials: `--material lambert` (Principled, Specular IOR Level 0, roughness 1) or `principled`
(Blender's default Principled, base colour only), base colour ALBEDO.

References (scenes/blender/room_thin.*, room_thick.*: Principled default material, 48 x 48):
    .venv/bin/python scenes/blender/make_references.py room_thin room_thick
Experiments: .venv/bin/python scenes/blender/window_room.py --walls thin --out /tmp/room [--cycles N]
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

W = H = 48
SAMPLES = 4096  # per seed; the reference averages two seeds
HALF, HEIGHT = 2.0, 2.5
WIN_X, WIN_Z0, WIN_Z1 = 0.4, 1.2, 1.7
WALL = 0.2
ALBEDO = 0.8
SUN_STRENGTH = 4.0
SUN_TILT_DEG = 50.0


FLIP = False


def rect(name, axis, c, u0, u1, v0, v1, inward, mat):
    """Axis-aligned rectangle at coordinate `c` on `axis`, normal along +/-axis (`inward` sign)."""
    def p(u, v):
        if axis == "x":
            return (c, u, v)
        if axis == "y":
            return (u, c, v)
        return (u, v, c)
    corners = [p(u0, v0), p(u1, v0), p(u1, v1), p(u0, v1)]
    # counter-clockwise seen from +axis for (x: y,z), (y: z,x -> flip), (z: x,y)
    plus = {"x": True, "y": False, "z": True}[axis]
    if (plus != (inward > 0)) != FLIP:
        corners.reverse()
    return common.quad(name, corners, mat)


def cuboid(name, lo, hi, mat):
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    v = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0),
         (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]
    f = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    return common.mesh_object(name, v, f, mat)


def build(walls: str, material: str):
    scene = common.reset_scene(W, H)
    if material == "lambert":
        mat = common.principled("Wall", (ALBEDO,) * 3, specular_ior_level=0.0, roughness=1.0)
    else:
        mat = common.principled("Wall", (ALBEDO,) * 3)
    h, t = HALF, WALL
    if walls in ("thin", "closed"):
        rect("Floor", "z", 0.0, -h, h, -h, h, +1, mat)
        rect("Ceiling", "z", HEIGHT, -h, h, -h, h, -1, mat)
        rect("WallE", "x", h, -h, h, 0, HEIGHT, -1, mat)
        rect("WallW", "x", -h, -h, h, 0, HEIGHT, +1, mat)
        rect("WallN", "y", h, -h, h, 0, HEIGHT, -1, mat)
        rect("WinL", "y", -h, -h, -WIN_X, 0, HEIGHT, +1, mat)
        rect("WinR", "y", -h, WIN_X, h, 0, HEIGHT, +1, mat)
        rect("WinB", "y", -h, -WIN_X, WIN_X, 0, WIN_Z0, +1, mat)
        rect("WinT", "y", -h, -WIN_X, WIN_X, WIN_Z1, HEIGHT, +1, mat)
        if walls == "closed":
            rect("Pane", "y", -h, -WIN_X, WIN_X, WIN_Z0, WIN_Z1, +1, mat)
    else:
        cuboid("Floor", (-h - t, -h - t, -t), (h + t, h + t, 0), mat)
        cuboid("Ceiling", (-h - t, -h - t, HEIGHT), (h + t, h + t, HEIGHT + t), mat)
        cuboid("WallE", (h, -h, 0), (h + t, h, HEIGHT), mat)
        cuboid("WallW", (-h - t, -h, 0), (-h, h, HEIGHT), mat)
        cuboid("WallN", (-h, h, 0), (h, h + t, HEIGHT), mat)
        cuboid("WinL", (-h, -h - t, 0), (-WIN_X, -h, HEIGHT), mat)
        cuboid("WinR", (WIN_X, -h - t, 0), (h, -h, HEIGHT), mat)
        cuboid("WinB", (-WIN_X, -h - t, 0), (WIN_X, -h, WIN_Z0), mat)
        cuboid("WinT", (-WIN_X, -h - t, WIN_Z1), (WIN_X, -h, HEIGHT), mat)
    common.camera("Camera", (0.0, 1.9, 1.3), (85.0, 0.0, 180.0), 90.0)
    common.light("Sun", "SUN", (0, -5, 6), (SUN_TILT_DEG, 0, 0), energy=SUN_STRENGTH, angle=0.0)
    return scene


def make(name: str, out_dir: Path, samples: int):
    """The committed references: `room_thin` and `room_thick`, Principled default material."""
    walls = name.removeprefix("room_")
    build(walls, "principled")
    extra = {
        "description": f"{name}: see the docstring of scenes/blender/window_room.py",
        "walls": walls,
        "window": {"half_width": WIN_X, "sill": WIN_Z0, "lintel": WIN_Z1},
        "sun": {"strength_w_m2": SUN_STRENGTH, "tilt_deg": SUN_TILT_DEG, "angle": 0.0},
    }
    return common.make_reference(name, out_dir, samples=samples, extra=extra)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--walls", choices=["thin", "thick", "closed"], default="thin")
    ap.add_argument("--material", choices=["lambert", "principled"], default="principled")
    ap.add_argument("--out", type=Path, default=Path("/tmp/room"))
    ap.add_argument("--window", type=float, nargs=3, metavar=("HALF_X", "Z0", "Z1"),
                    help="window half-width and sill/lintel heights (default 0.4 1.2 1.7)")
    ap.add_argument("--flip", action="store_true", help="thin planes' normals face outwards")
    ap.add_argument("--cycles", type=int, default=0, help="also render a Cycles EXR with N spp")
    args = ap.parse_args(argv)
    global FLIP, WIN_X, WIN_Z0, WIN_Z1
    FLIP = args.flip
    suffix = ""
    if args.window:
        WIN_X, WIN_Z0, WIN_Z1 = args.window
        suffix = "_win{:g}x{:g}".format(2 * WIN_X, WIN_Z1 - WIN_Z0)
    scene = build(args.walls, args.material)
    args.out.mkdir(parents=True, exist_ok=True)
    name = f"room_{args.walls}_{args.material}" + ("_flip" if args.flip else "") + suffix
    common.export_glb(args.out / f"{name}.glb")
    print("wrote", args.out / f"{name}.glb")
    if args.cycles:
        common.configure_cycles(scene, args.cycles, 1, 2)
        dt = common.render_exr(scene, args.out / f"{name}_cycles.exr", 1)
        print(f"cycles {args.cycles} spp in {dt:.1f} s")


if __name__ == "__main__":
    main()
