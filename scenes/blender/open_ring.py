"""An open, zero-thickness mirror ring (a cylinder without caps) standing on a diffuse floor, lit
by a small spherical lamp low on one side, black world: light reflected off the ring's outside
makes a caustic on the floor right next to its wall, while the floor inside the ring receives
no light at all (the lamp is below the ring's rim). A photon estimate that gathers across the
wall shows light inside.

Floor: 4 x 4 m, Principled with Specular IOR Level 0 and roughness 1, base colour 0.8. Ring:
radius 0.5 m, 0.4 m high, 64 segments, metallic 1, roughness 0, base colour 0.9. Lamp: 200 W
point light, radius 0.03 m, at (1, 0, 0.12). Camera 3 m above the origin looking straight down,
50 degree field of view, 64 x 64.

    .venv/bin/python scenes/blender/make_references.py ring_open
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

W = H = 64
SAMPLES = 8192  # per seed; the reference averages two seeds
RING_RADIUS, RING_HEIGHT, SEGMENTS = 0.5, 0.4, 64
CAMERA_HEIGHT, FOV_DEG = 3.0, 50.0
LAMP_RADIUS = 0.03


def build():
    scene = common.reset_scene(W, H)
    floor = common.principled("Floor", (0.8,) * 3, specular_ior_level=0.0, roughness=1.0)
    metal = common.principled("Mirror", (0.9,) * 3, roughness=0.0)
    metal.node_tree.nodes["Principled BSDF"].inputs["Metallic"].default_value = 1.0
    common.quad("Floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], floor)
    n, r, h = SEGMENTS, RING_RADIUS, RING_HEIGHT
    v = [(r * math.cos(2 * math.pi * i / n), r * math.sin(2 * math.pi * i / n), z)
         for z in (0.0, h) for i in range(n)]
    f = [(i, (i + 1) % n, n + (i + 1) % n, n + i) for i in range(n)]
    common.mesh_object("Ring", v, f, metal)
    common.light("Lamp", "POINT", (1.0, 0.0, 0.12), energy=200.0, shadow_soft_size=LAMP_RADIUS)
    common.camera("Camera", (0.0, 0.0, CAMERA_HEIGHT), (0.0, 0.0, 0.0), FOV_DEG)
    return scene


def inject_lamp_radius(glb: Path) -> None:
    """Give the lamp its soft-shadow radius (our PHOTON_light extension), which Blender's glTF
    exporter drops and the add-on writes back."""
    def edit(doc):
        for node in doc.get("nodes", []):
            if node.get("name") == "Lamp":
                node.setdefault("extensions", {})["PHOTON_light"] = {"radius": LAMP_RADIUS}
        common.add_extension_used(doc, "PHOTON_light")
    common.edit_glb_json(glb, edit)


def make(name: str, out_dir: Path, samples: int):
    build()
    extra = {
        "description": f"{name}: see the docstring of scenes/blender/open_ring.py",
        "ring": {"radius": RING_RADIUS, "height": RING_HEIGHT, "segments": SEGMENTS},
        "camera": {"height": CAMERA_HEIGHT, "fov_deg": FOV_DEG, "looks_along": "-z"},
    }
    info = common.make_reference(name, out_dir, samples=samples, extra=extra)
    inject_lamp_radius(out_dir / f"{name}.glb")
    return info
