"""Build the light-unit test scenes in Blender, export them to glTF and render Cycles references.

A 40 x 40 m diffuse plane at z = 0 (Principled BSDF, base colour 0.8, Specular IOR Level 0,
roughness 1: pure Lambert, albedo 0.8), seen from a camera at (0, 0, 5) looking straight down
(-z, image top = +y), 40 degree field of view, square image. World black. One light each:

  point_plane  point light, power POINT_POWER W, radius 0 (shadow_soft_size = 0), at (0, 0, 2)
  sun_plane    sun, strength SUN_STRENGTH W/m^2, angle 0, tilted SUN_TILT_DEG about +x
               (light travels towards (0, sin t, -cos t): irradiance SUN_STRENGTH * cos t)
  spot_plane   spot light as the point light, pointing down, spot_size 60 deg, spot_blend 0

Expected radiance of the plane (Cycles units, Lambert): L = 0.8/pi * E with
  point/spot (inside the cone): E = P/(4 pi) * h / d^3   (h = 2 m, d = distance to the light)
  sun:                          E = S * cos(tilt)
Each sidecar JSON holds an "analytic_check" comparing the reference with that formula.

Run:  .venv/bin/python scenes/blender/lights_plane.py [--samples N] [--only NAME]
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

WIDTH = HEIGHT = 64
SAMPLES = 1024
ALBEDO = 0.8
CAMERA_HEIGHT = 5.0
FOV_DEG = 40.0
LIGHT_HEIGHT = 2.0
POINT_POWER = 1000.0
SUN_STRENGTH = 5.0
SUN_TILT_DEG = 30.0
SPOT_SIZE_DEG = 60.0
SPOT_BLEND = 0.0
SCENES = ["point_plane", "sun_plane", "spot_plane"]


def build(name: str):
    scene = common.reset_scene(WIDTH, HEIGHT)
    mat = common.principled("Plane", (ALBEDO,) * 3, specular_ior_level=0.0, roughness=1.0)
    s = 20.0
    common.quad("Plane", [(-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)], mat)
    common.camera("Camera", (0.0, 0.0, CAMERA_HEIGHT), (0.0, 0.0, 0.0), FOV_DEG)
    if name == "point_plane":
        lt = common.light("Point", "POINT", (0, 0, LIGHT_HEIGHT), energy=POINT_POWER,
                          shadow_soft_size=0.0)
    elif name == "sun_plane":
        lt = common.light("Sun", "SUN", (0, 0, 10), (SUN_TILT_DEG, 0, 0), energy=SUN_STRENGTH,
                          angle=0.0)
    elif name == "spot_plane":
        lt = common.light("Spot", "SPOT", (0, 0, LIGHT_HEIGHT), energy=POINT_POWER,
                          shadow_soft_size=0.0, spot_size=math.radians(SPOT_SIZE_DEG),
                          spot_blend=SPOT_BLEND)
    else:
        raise ValueError(name)
    return scene, mat, lt


def light_info(lt) -> dict:
    d = lt.data
    info = {"type": d.type, "location": list(lt.location), "rotation_euler_deg":
            [math.degrees(a) for a in lt.rotation_euler], "color": list(d.color),
            "exposure": d.exposure}
    if d.type == "SUN":
        info.update(strength_W_per_m2=d.energy, angle=d.angle,
                    irradiance_on_plane=d.energy * math.cos(math.radians(SUN_TILT_DEG)))
    else:
        info.update(power_W=d.energy, radius=d.shadow_soft_size,
                    intensity_W_per_sr=d.energy / (4 * math.pi),
                    irradiance_below_light=d.energy / (4 * math.pi * LIGHT_HEIGHT ** 2))
        if d.type == "SPOT":
            info.update(spot_size_deg=math.degrees(d.spot_size), spot_blend=d.spot_blend,
                        lit_radius_on_plane_m=LIGHT_HEIGHT * math.tan(d.spot_size / 2))
    return info


def analytic_image(name: str, width: int, height: int):
    """Radiance at the pixel centres (no pixel filter) and the mask of pixels to compare."""
    t = math.tan(math.radians(FOV_DEG) / 2)
    xs = ((np.arange(width) + 0.5) / width * 2 - 1) * t * CAMERA_HEIGHT
    ys = (1 - (np.arange(height) + 0.5) / height * 2) * t * CAMERA_HEIGHT  # row 0 = top = +y
    x, y = np.meshgrid(xs, ys)
    if name == "sun_plane":
        e = np.full_like(x, SUN_STRENGTH * math.cos(math.radians(SUN_TILT_DEG)))
        mask = np.ones_like(x, dtype=bool)
    else:
        d2 = x * x + y * y + LIGHT_HEIGHT ** 2
        e = POINT_POWER / (4 * math.pi) * LIGHT_HEIGHT / d2 ** 1.5
        mask = np.ones_like(x, dtype=bool)
        if name == "spot_plane":
            r = np.sqrt(x * x + y * y)
            r_cone = LIGHT_HEIGHT * math.tan(math.radians(SPOT_SIZE_DEG) / 2)
            e = np.where(r < r_cone, e, 0.0)
            mask = r < 0.9 * r_cone
    radiance = ALBEDO / math.pi * e
    return np.repeat(radiance[:, :, None], 3, axis=2).astype(np.float32), mask


def make(name: str, out_dir: Path, samples: int):
    _, mat, lt = build(name)
    extra = {
        "description": f"{name}: see the docstring of scenes/blender/lights_plane.py",
        "materials": {"Plane": common.principled_values(mat)},
        "light": light_info(lt),
        "camera": {"location": [0, 0, CAMERA_HEIGHT], "looks_along": "-z (Blender), image top = +y",
                   "fov_deg": FOV_DEG},
        "plane_radiance_formula": "L = 0.8/pi * E",
    }
    return common.make_reference(name, out_dir, samples=samples, extra=extra,
                                 analytic=lambda w, h: analytic_image(name, w, h))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--samples", type=int, default=SAMPLES)
    ap.add_argument("--only", choices=SCENES)
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent)
    args = ap.parse_args(argv)
    for name in SCENES:
        if args.only in (None, name):
            make(name, args.out, args.samples)


if __name__ == "__main__":
    main()
