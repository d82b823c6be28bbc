"""Build `glossy_spheres.glb`: a second glossy scene for the path tracer's noise against Cycles'
(docs/bench/lights.md), without glass, so that no caustic of a small light rules its error.

Four spheres (radius 0.6, smooth shaded) on a rough glossy floor: a polished gold metal
(roughness 0.15), a rough silver metal (0.45), a red base under a clear coat (base roughness
0.5, Coat Weight 1, coat roughness 0.05) and a glossy blue dielectric (0.2). Light: a 1 x 0.5 m
area light of 150 W above and in front, out of the camera's view, a 2 W/m^2 sun with a 2 degree
disc from behind and the left, and Blender's default grey world (0.05). The area light and the
sun each make highlights on every sphere, of a large and of a small light.

The scene is exported by the Photon add-on's own exporter (the glTF export with its hooks, as
the render button does), so `cycles_time.py` and `photon` read the same lights.

Run:  .venv/bin/python scenes/blender/glossy_spheres.py [--out GLB]

(default: docs/bench/glossy_spheres_128px/glossy_spheres.glb, outside scenes/ so that the
image-hash test does not render it).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import bpy

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parents[1]))
import common  # noqa: E402

WIDTH, HEIGHT = 160, 96
SPHERE_RADIUS = 0.6


def principled(name, base_color, **inputs):
    """A Principled material: base colour and the named inputs (Blender's input names)."""
    mat = common.principled(name, base_color)
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    for key, value in inputs.items():
        bsdf.inputs[key.replace("_", " ")].default_value = value
    return mat


def sphere(name, material, x, y):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=SPHERE_RADIUS,
                                         location=(x, y, SPHERE_RADIUS))
    obj = bpy.context.active_object
    obj.name = name
    bpy.ops.object.shade_smooth()
    obj.data.materials.append(material)
    return obj


def build():
    scene = common.reset_scene(WIDTH, HEIGHT)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.05, 0.05, 0.05, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    floor = principled("Floor", (0.45, 0.45, 0.42), Roughness=0.35)
    common.quad("Floor", [(-8, -8, 0), (8, -8, 0), (8, 8, 0), (-8, 8, 0)], floor)
    spheres = [
        ("Gold", principled("Gold", (0.95, 0.7, 0.3), Metallic=1.0, Roughness=0.15)),
        ("Silver", principled("Silver", (0.9, 0.9, 0.9), Metallic=1.0, Roughness=0.45)),
        ("Coated", principled("Coated", (0.6, 0.04, 0.04), Roughness=0.5, Coat_Weight=1.0,
                              Coat_Roughness=0.05)),
        ("Blue", principled("Blue", (0.05, 0.15, 0.6), Roughness=0.2)),
    ]
    for i, (name, mat) in enumerate(spheres):
        sphere(name, mat, -2.1 + 1.4 * i, 0.3 * (i % 2))
    common.camera("Camera", (0.0, -6.0, 2.2), (75.0, 0.0, 0.0), 50.0)
    area = common.light("Area", "AREA", (0.5, -2.5, 3.0), (40.0, 0.0, 10.0), energy=150.0)
    area.data.shape = "RECTANGLE"
    area.data.size = 1.0
    area.data.size_y = 0.5
    common.light("Sun", "SUN", (0, 0, 10), (-50.0, 0.0, -35.0), energy=2.0,
                 angle=math.radians(2.0))
    return scene


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    default = HERE.parents[1] / "docs" / "bench" / "glossy_spheres_128px" / "glossy_spheres.glb"
    ap.add_argument("--out", type=Path, default=default)
    args = ap.parse_args(argv)
    build()
    import blender_addon
    from blender_addon import export
    blender_addon.register()
    try:
        warnings = export.export_in_process(args.out, "blender_addon")
    finally:
        blender_addon.unregister()
    for w in warnings:
        print("warning:", w)
    print("wrote", args.out)


if __name__ == "__main__":
    main()
