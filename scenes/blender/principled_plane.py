"""A plane with Blender's default Principled material (base colour 0.8, IOR 1.5, Specular IOR
Level 0.5) at roughness 0.5 and 1.0, lit by a 3 W/m² sun at 40 degrees, seen at a range of angles.

Only direct light reaches the camera (one plane, black world), so the image tests the Principled
layering itself: the dielectric specular layer over the diffuse base, where the diffuse gives up
what the (energy-compensated) specular layer reflects. An estimate of that layer albedo that
differed from Cycles' made Photon 1.9 % dark at roughness 1.

Run:  .venv/bin/python scenes/blender/make_references.py principled_r05 principled_r10
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

WIDTH = HEIGHT = 64
SAMPLES = 512
ROUGHNESS = {"principled_r05": 0.5, "principled_r10": 1.0}


def build(name: str):
    scene = common.reset_scene(WIDTH, HEIGHT)
    mat = common.principled("Default", (0.8, 0.8, 0.8), roughness=ROUGHNESS[name])
    common.quad("Plane", [(-30, -30, 0), (30, -30, 0), (30, 30, 0), (-30, 30, 0)], mat)
    common.camera("Camera", (0.0, -6.0, 3.0), (63.0, 0.0, 0.0), 50.0)
    common.light("Sun", "SUN", (0, 0, 5), (40.0, 0.0, 200.0), energy=3.0)
    return scene, mat


def make(name: str, out_dir: Path, samples: int):
    _, mat = build(name)
    extra = {
        "description": f"{name}: see the docstring of scenes/blender/principled_plane.py",
        "materials": {"Plane": common.principled_values(mat)},
    }
    return common.make_reference(name, out_dir, samples=samples, extra=extra)
