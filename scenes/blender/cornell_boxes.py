"""Two Cornell boxes built in Blender, lit by Blender area lamps, for timing the default render
against Cycles on boxes other than the shipped one (docs/bench/cornell_and_methods.md).

- `cornell_area`: the classic proportions (Goral, Torrance, Greenberg & Battaile 1984; the
  measured box of the Cornell program): a 5.55 m room of one-sided quads open towards the
  camera, red wall left, green wall right, a short and a tall white box, a 1.3 x 1.05 m area
  lamp of 120 W 1 cm under the ceiling facing down, seen by the camera. Materials are Blender's default Principled
  BSDF with only the base colour set (roughness 0.5, Specular IOR Level 0.5), as a user would
  leave them.
- `cornell_wide`: a wide low room (6 x 4 x 2 m inside) with walls 10 cm thick (boxes), a small
  bright lamp (a 0.3 m square area lamp of 20 W, off centre, hidden from the camera as
  Blender's lamps are by default), a low wide box and a tall narrow
  one; Lambertian materials (roughness 1, Specular IOR Level 0); the camera just inside the
  open front with a 70-degree field of view.

Both: black world, no Clamp Indirect or Filter Glossy, square image (256 x 256 in the .blend; `cycles_time.py` sets it from the
reference), Blackman-Harris 1.5 px filter.

Usage:  .venv/bin/python scenes/blender/cornell_boxes.py OUT_DIR
writes OUT_DIR/{cornell_area,cornell_wide}.blend (for scenes/blender/cycles_time.py) and
OUT_DIR/{cornell_area,cornell_wide}.glb, exported through the add-on (for `photon bench`).
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import common  # noqa: E402
from volume_scenes import save_scenes  # noqa: E402

SIZE = 256

RED = (0.63, 0.065, 0.05)
GREEN = (0.14, 0.45, 0.091)
WHITE = (0.725, 0.71, 0.68)


def unclamped(scene):
    """No Clamp Indirect and no Filter Glossy (Blender's defaults are 10 and 1), which the
    add-on's export carries to Photon: both renderers then converge to the same image as the
    references, which use neither."""
    scene.cycles.sample_clamp_indirect = 0.0
    scene.cycles.blur_glossy = 0.0


def cornell_area(size=SIZE):
    """The classic box (module docstring)."""
    scene = common.reset_scene(size, size)
    white = common.principled("White", WHITE)
    red = common.principled("Red", RED)
    green = common.principled("Green", GREEN)
    s, h = 2.775, 5.55
    common.quad("Floor", [(-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)], white)
    common.quad("Ceiling", [(-s, -s, h), (-s, s, h), (s, s, h), (s, -s, h)], white)
    common.quad("Back", [(-s, s, 0), (s, s, 0), (s, s, h), (-s, s, h)], white)
    common.quad("Left", [(-s, -s, 0), (-s, s, 0), (-s, s, h), (-s, -s, h)], red)
    common.quad("Right", [(s, s, 0), (s, -s, 0), (s, -s, h), (s, s, h)], green)
    common.box("ShortBox", (1.65, 1.65, 1.65), white, (0.93, -0.7, 0.0), -17.0)
    common.box("TallBox", (1.65, 1.65, 3.3), white, (-0.93, 0.7, 0.0), 17.0)
    lamp = common.light("Lamp", "AREA", (0.0, 0.0, h - 0.01), energy=120.0, shape="RECTANGLE",
                        size=1.3, size_y=1.05)
    lamp.data.color = (1.0, 0.85, 0.6)
    lamp.visible_camera = True
    common.camera("Camera", (0.0, -s - 8.0, s), (90.0, 0.0, 0.0), 39.3)
    unclamped(scene)
    return scene


def cornell_wide(size=SIZE):
    """The wide low box with a small lamp (module docstring)."""
    scene = common.reset_scene(size, size)
    flat = dict(roughness=1.0, specular_ior_level=0.0)
    white = common.principled("White", WHITE, **flat)
    red = common.principled("Red", RED, **flat)
    green = common.principled("Green", GREEN, **flat)
    w, d, h, t = 3.0, 2.0, 2.0, 0.1  # half width, half depth, height, wall thickness
    common.box("Floor", (2 * w + 2 * t, 2 * d + t, t), white, (0.0, t / 2, -t), 0.0)
    common.box("Ceiling", (2 * w + 2 * t, 2 * d + t, t), white, (0.0, t / 2, h), 0.0)
    common.box("Back", (2 * w + 2 * t, t, h), white, (0.0, d + t / 2, 0.0), 0.0)
    common.box("Left", (t, 2 * d, h), red, (-w - t / 2, 0.0, 0.0), 0.0)
    common.box("Right", (t, 2 * d, h), green, (w + t / 2, 0.0, 0.0), 0.0)
    common.box("LowBox", (1.4, 0.9, 0.5), white, (1.2, 0.1, 0.0), -12.0)
    common.box("TallBox", (0.5, 0.5, 1.5), white, (-1.6, 0.9, 0.0), 20.0)
    common.light("Lamp", "AREA", (-0.8, 0.4, h - 0.01), energy=20.0, shape="SQUARE", size=0.3)
    unclamped(scene)
    common.camera("Camera", (0.0, -d - 0.4, 1.0), (90.0, 0.0, 0.0), 70.0)
    return scene


SCENES = {"cornell_area": cornell_area, "cornell_wide": cornell_wide}


def main(out_dir: Path):
    save_scenes(out_dir, [(name, lambda out, build=build: build()) for name, build in SCENES.items()])


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(Path(sys.argv[1]))
