"""Build the Cornell box in Blender, export it to glTF and render the Cycles reference.

Two variants:
  cornell          Principled BSDF with only the base colour set (Blender's defaults otherwise:
                   roughness 0.5, IOR 1.5, Specular IOR Level 0.5): tests Photon's Principled model.
  cornell_lambert  the same with Specular IOR Level 0 and roughness 1: pure Lambert.

Geometry (Blender coordinates, Z up; metres): the room is x in [-1, 1], y in [-1, 1], z in [0, 2],
open towards -y. Red wall at x = -1, green wall at x = +1, white floor, ceiling and back wall.
Short box 0.6 x 0.6 x 0.6 and tall box 0.6 x 0.6 x 1.2, white. The light is a 0.5 x 0.5 m
emissive quad (Principled, base colour black, emission colour white, strength EMISSION_STRENGTH)
that fills a hole of the same size in the ceiling, facing down, so its back side (Cycles mesh
emission is two-sided) shines out of the box instead of onto the ceiling.
Camera at (0, -3.8, 1) looking along +y, 40 degree field of view, square image.

Run:  .venv/bin/python scenes/blender/cornell.py [--samples N] [--only cornell|cornell_lambert]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

WIDTH = HEIGHT = 64
SAMPLES = 4096
EMISSION_STRENGTH = 20.0
LIGHT_HALF = 0.25  # the light quad is 2*LIGHT_HALF on a side

RED = (0.63, 0.065, 0.05)
GREEN = (0.14, 0.45, 0.091)
WHITE = (0.725, 0.71, 0.68)


def build(lambert: bool):
    scene = common.reset_scene(WIDTH, HEIGHT)
    surf = dict(specular_ior_level=0.0, roughness=1.0) if lambert else {}
    white = common.principled("White", WHITE, **surf)
    red = common.principled("Red", RED, **surf)
    green = common.principled("Green", GREEN, **surf)
    emitter = common.principled("Light", (0.0, 0.0, 0.0), emission_color=(1.0, 1.0, 1.0),
                                emission_strength=EMISSION_STRENGTH, **surf)

    # Walls: quads facing into the room.
    common.quad("Floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], white)
    common.quad("BackWall", [(-1, 1, 0), (1, 1, 0), (1, 1, 2), (-1, 1, 2)], white)
    common.quad("LeftWall", [(-1, -1, 0), (-1, 1, 0), (-1, 1, 2), (-1, -1, 2)], red)
    common.quad("RightWall", [(1, 1, 0), (1, -1, 0), (1, -1, 2), (1, 1, 2)], green)

    # Ceiling with a square hole for the light: an outer and an inner ring of 8 vertices.
    h = LIGHT_HALF
    outer = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
    inner = [(-h, -h), (h, -h), (h, h), (-h, h)]
    verts = [(x, y, 2.0) for x, y in outer + inner]
    # Four trapezoids, wound so that the normal points down (-z) into the room.
    faces = [(0, 4, 5, 1), (1, 5, 6, 2), (2, 6, 7, 3), (3, 7, 4, 0)]
    common.mesh_object("Ceiling", verts, faces, white)
    common.quad("Light", [(-h, -h, 2.0), (-h, h, 2.0), (h, h, 2.0), (h, -h, 2.0)], emitter)

    common.box("ShortBox", (0.6, 0.6, 0.6), white, (0.35, -0.3, 0.0), -17.0)
    common.box("TallBox", (0.6, 0.6, 1.2), white, (-0.35, 0.35, 0.0), 17.0)

    common.camera("Camera", (0.0, -3.8, 1.0), (90.0, 0.0, 0.0), 40.0)
    return scene, {"White": white, "Red": red, "Green": green, "Light": emitter}


def make(name: str, out_dir: Path, samples: int):
    lambert = name == "cornell_lambert"
    _, mats = build(lambert)
    extra = {
        "description": __doc__.split("\n\n")[0],
        "materials": {k: common.principled_values(m) for k, m in mats.items()},
        "light": {"type": "emissive quad in the ceiling", "size_m": [2 * LIGHT_HALF] * 2,
                  "height_m": 2.0, "emission_strength": EMISSION_STRENGTH,
                  "radiance": EMISSION_STRENGTH, "power_W_one_side": EMISSION_STRENGTH * 3.141592653589793 * (2 * LIGHT_HALF) ** 2},
        "camera": {"location": [0, -3.8, 1], "looks_along": "+y (Blender)", "fov_deg": 40},
    }
    return common.make_reference(name, out_dir, samples=samples, extra=extra)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--samples", type=int, default=SAMPLES)
    ap.add_argument("--only", choices=["cornell", "cornell_lambert"])
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent)
    args = ap.parse_args(argv)
    for name in ["cornell_lambert", "cornell"]:
        if args.only in (None, name):
            make(name, args.out, args.samples)


if __name__ == "__main__":
    main()
