"""A translucent box (Principled BSDF, Subsurface Weight 1, random walk) standing on a white
plane, lit by a 3 W/m² sun at 45 degrees, for comparing Photon's dipole diffusion with Cycles'
random-walk subsurface scattering.

Blender's glTF exporter drops the subsurface inputs, so after the export `inject_subsurface`
writes them into the .glb as our PHOTON_material_subsurface extension (the add-on will do this
itself; the injection is kept in that one function).

Two scenes: `subsurface` (Subsurface Scale 0.1) and `subsurface_s02` (0.02).

Run:  .venv/bin/python scenes/blender/subsurface.py [OUT_DIR]
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

WIDTH = HEIGHT = 64
SAMPLES = 256
SUBSURFACE = {"weight": 1.0, "radius": [1.0, 0.2, 0.1], "scale": 0.1, "ior": 1.4,
              "anisotropy": 0.0}
# Scene name → Subsurface Scale: mean free paths (0.1, 0.02, 0.01) and five times shorter.
SCALES = {"subsurface": 0.1, "subsurface_s02": 0.02}


def build(scale: float):
    scene = common.reset_scene(WIDTH, HEIGHT)
    floor = common.principled("Floor", (0.8, 0.8, 0.8), roughness=1.0, specular_ior_level=0.0)
    common.quad("Plane", [(-6, -6, 0), (6, -6, 0), (6, 6, 0), (-6, 6, 0)], floor)
    wax = common.principled("Wax", (0.8, 0.5, 0.3), roughness=0.5)
    bsdf = wax.node_tree.nodes["Principled BSDF"]
    bsdf.subsurface_method = "RANDOM_WALK"
    # By socket name over all inputs: the IOR socket is hidden (and unused) with RANDOM_WALK.
    sockets = {i.name: i for i in bsdf.inputs}
    for key, value in dict(SUBSURFACE, scale=scale).items():
        sockets["Subsurface " + ("IOR" if key == "ior" else key.title())].default_value = value
    common.box("Box", (1.0, 1.0, 1.0), wax, (0, 0, 0), 30.0)
    common.camera("Camera", (0.0, -4.0, 2.5), (60.0, 0.0, 0.0), 45.0)
    common.light("Sun", "SUN", (0, 0, 5), (45.0, 0.0, 30.0), energy=3.0)
    return scene, wax


def inject_subsurface(glb: Path, materials: dict[str, dict]) -> None:
    """Add PHOTON_material_subsurface to the named materials of a .glb."""
    def edit(doc):
        for mat in doc.get("materials", []):
            if mat.get("name") in materials:
                ext = mat.setdefault("extensions", {})
                ext["PHOTON_material_subsurface"] = materials[mat["name"]]
        common.add_extension_used(doc, "PHOTON_material_subsurface")
    common.edit_glb_json(glb, edit)


def make(name: str, out_dir: Path, samples: int):
    values = dict(SUBSURFACE, scale=SCALES[name])
    build(values["scale"])
    extra = {"description": f"{name}: see the docstring of scenes/blender/subsurface.py",
             "subsurface": values}
    info = common.make_reference(name, out_dir, samples=samples, extra=extra)
    inject_subsurface(out_dir / f"{name}.glb", {"Wax": values})
    return info


if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent
    for scene_name in SCALES:
        make(scene_name, out, SAMPLES)
