"""A white box on a grey ground under Blender 5's Multiple Scattering sky (the Sky Texture's
default type from Blender 5.0, which Blender 4.5 does not have), at two sun elevations, exported
through the add-on and rendered by Cycles 5.0 as the references of
tests/blender/test_multiple_scattering_sky.py.

The scenes: `sky_ms_12` (sun at 12 degrees) and `sky_ms_50` (50 degrees), both with the sun
rotated 150 degrees (ahead of the camera, to its right), the node's other settings at Blender's
defaults (sun size 0.545 degrees, altitude 100 m, air, aerosol and ozone densities 1), the
Background at strength 1. 48 x 32 pixels; a 1.2 m box turned 25 degrees on an 80 m ground
(Principled grey 0.5 and white 0.8), the camera 6 m back and 1.6 m up looking 8 degrees down, so
the upper third of the image is sky.

Each scene is exported with the add-on (`export.export_in_process`, as F12 does) to NAME.glb and
rendered by Cycles twice (seeds 1 and 2); NAME.exr is their mean and NAME.json records the
samples, the render times and the relMSE between the two seeds.

Run under Blender 5 (bpy 5.0.1):  /work/venv5/bin/python scenes/blender/multiple_scattering_sky.py [OUT_DIR] [--samples N]
(OUT_DIR defaults to scenes/blender/).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import bpy

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent.parent))
import common  # noqa: E402

WIDTH, HEIGHT = 48, 32
SAMPLES = 4096
SEEDS = (1, 2)
SCENES = {"sky_ms_12": 12.0, "sky_ms_50": 50.0}
SUN_ROTATION_DEG = 150.0


def build(elevation_deg: float):
    scene = common.reset_scene(WIDTH, HEIGHT)
    grey = common.principled("Grey", (0.5, 0.5, 0.5))
    white = common.principled("White", (0.8, 0.8, 0.8))
    common.quad("Ground", [(-40, -40, 0), (40, -40, 0), (40, 40, 0), (-40, 40, 0)], grey)
    common.box("Box", (1.2, 1.2, 1.2), white, (0.0, 0.0, 0.0), 25.0)
    common.camera("Camera", (0.0, -6.0, 1.6), (82.0, 0.0, 0.0), 60.0)
    tree = scene.world.node_tree
    background = tree.nodes["Background"]
    background.inputs["Strength"].default_value = 1.0
    sky = tree.nodes.new("ShaderNodeTexSky")
    sky.sky_type = "MULTIPLE_SCATTERING"
    sky.sun_elevation = math.radians(elevation_deg)
    sky.sun_rotation = math.radians(SUN_ROTATION_DEG)
    tree.links.new(sky.outputs["Color"], background.inputs["Color"])
    return scene, sky


def make(name: str, elevation_deg: float, out_dir: Path, samples: int) -> dict:
    from blender_addon import export

    def addon_export(glb: Path):
        warnings = list(export.export_in_process(glb, "blender_addon"))
        if warnings:
            raise RuntimeError(f"{name}: the export warned: {warnings}")

    _, sky = build(elevation_deg)
    extra = {
        "gltf_export": "the add-on's export (blender_addon.export.export_in_process)",
        "sky": {"sky_type": sky.sky_type, "sun_elevation_deg": elevation_deg,
                "sun_rotation_deg": SUN_ROTATION_DEG, "sun_size": sky.sun_size,
                "sun_intensity": sky.sun_intensity, "sun_disc": sky.sun_disc,
                "altitude": sky.altitude, "air_density": sky.air_density,
                "aerosol_density": sky.aerosol_density, "ozone_density": sky.ozone_density,
                "background_strength": 1.0},
    }
    return common.make_reference(name, out_dir, samples=samples, seeds=SEEDS,
                                 export=addon_export, extra=extra)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out_dir", nargs="?", type=Path, default=HERE)
    parser.add_argument("--samples", type=int, default=SAMPLES)
    parser.add_argument("--only", choices=sorted(SCENES))
    args = parser.parse_args()
    if "MULTIPLE_SCATTERING" not in bpy.types.ShaderNodeTexSky.bl_rna.properties[
            "sky_type"].enum_items.keys():
        sys.exit(f"Blender {bpy.app.version_string} has no Multiple Scattering sky: run this "
                 f"script under Blender 5 (bpy 5.0)")
    import blender_addon

    blender_addon.register()
    try:
        args.out_dir.mkdir(parents=True, exist_ok=True)
        for name, elevation in SCENES.items():
            if args.only in (None, name):
                make(name, elevation, args.out_dir, args.samples)
    finally:
        blender_addon.unregister()


if __name__ == "__main__":
    main()
