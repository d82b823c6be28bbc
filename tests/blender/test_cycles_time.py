"""`scenes/blender/cycles_time.py` renders a glTF scene in Cycles as Photon renders it: a
`PHOTON_light` area lamp (which Blender's glTF importer drops, leaving an empty at the node)
emits along the node's local −Z, as `scene/gltf/lights.rs` reads it.

A floor and a block lit by one tilted square area lamp, with a dim world, built here with
scenes/build_scenes.py's writer: the lamp's direction after the import against the node's
rotation, then Photon's path tracer against Cycles at 32 × 32 (a lamp turned the wrong way lights
another part of the floor: the gallery bust read 76 % brighter in Photon before the fix).
"""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from helpers import photon_binary, read_exr, rel_mse

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scenes"))
import build_scenes as bs  # noqa: E402

SIZE = 32
SPP = 256
LAMP_AT = [-1.2, 1.6, 0.4]
LAMP_TARGET = [0.4, 0.0, -0.3]


def write_scene(folder: Path) -> Path:
    """The test scene as a .glb in `folder`."""
    saved = bs.HERE
    bs.HERE = str(folder)
    try:
        g = bs.Gltf()
        grey = g.material("Grey", base=(0.6, 0.6, 0.6), roughness=1.0, lambert=True)
        g.node("Floor", mesh=g.mesh("Floor", bs.floor_quad(3.0), grey))
        g.node("Block", mesh=g.mesh("Block", bs.cube(), grey), translation=[0.3, 0.125, 0.0],
               scale=[0.25, 0.25, 0.25])
        g.node("Lamp", translation=LAMP_AT, rotation=bs.clean(bs.look_at(LAMP_AT, LAMP_TARGET)),
               photon_light={"type": "area", "shape": "SQUARE", "size": 0.4, "power": 60.0,
                             "color": [1.0, 1.0, 1.0], "visible_camera": False})
        g.scene_extension("PHOTON_world", {"color": [0.02, 0.02, 0.02], "strength": 1.0})
        g.camera("Camera", [0.0, 2.2, 2.6], [0.0, 0.2, 0.0], 45.0, 1.0)
        bs.render_settings(g, SIZE, SIZE)
        g.write("area_lamp.glb")
    finally:
        bs.HERE = saved
    return folder / "area_lamp.glb"


def rotate(q, v):
    """glTF quaternion (x, y, z, w) applied to vector v."""
    x, y, z, w = q
    u = np.array([x, y, z])
    v = np.asarray(v, float)
    return v + 2.0 * np.cross(u, np.cross(u, v) + w * v)


def test_area_lamp_faces_the_nodes_minus_z(tmp_path):
    import cycles_time
    glb = write_scene(tmp_path)
    cycles_time.prepare(glb, (SIZE, SIZE), 2, None)
    import bpy
    lamps = [o for o in bpy.context.scene.objects if o.type == "LIGHT"]
    assert [o.data.type for o in lamps] == ["AREA"], lamps
    lamp = lamps[0]
    q = bs.clean(bs.look_at(LAMP_AT, LAMP_TARGET))
    gx, gy, gz = rotate(q, [0.0, 0.0, -1.0])
    expected = np.array([gx, -gz, gy])  # glTF Y-up to Blender Z-up
    m = lamp.matrix_world
    emits = -np.array([m[0][2], m[1][2], m[2][2]])
    emits /= np.linalg.norm(emits)
    assert np.dot(emits, expected) > 0.9999, (emits, expected)
    position = np.array([m[0][3], m[1][3], m[2][3]])
    x, y, z = LAMP_AT
    assert np.allclose(position, [x, -z, y], atol=1e-5), position
    assert math.isclose(lamp.data.size, 0.4, rel_tol=1e-6)
    assert math.isclose(lamp.data.energy, 60.0, rel_tol=1e-6)


@pytest.mark.slow
def test_area_lamp_lights_the_floor_as_photon_does(tmp_path):
    import cycles_time
    glb = write_scene(tmp_path)
    out = tmp_path / "photon.exr"
    cmd = [str(photon_binary()), "render", str(glb), "-o", str(out), "--width", str(SIZE),
           "--height", str(SIZE), "--spp", str(SPP), "--seed", "1", "--threads", "2",
           "--method", "path", "--progress", "none"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600,
                          stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, f"{' '.join(cmd)}\n{proc.stderr[-3000:]}"
    photon = read_exr(out)
    _, warnings = cycles_time.prepare(glb, (SIZE, SIZE), 2, None)
    assert warnings == [], warnings
    cycles_time.render(tmp_path / "cycles.exr", SPP, 1)
    cycles = read_exr(tmp_path / "cycles.exr")
    mean = float(photon.mean() / cycles.mean() - 1.0)
    # The halves of the image: a lamp turned the wrong way moves light between them.
    left = float(photon[:, : SIZE // 2].mean() / cycles[:, : SIZE // 2].mean() - 1.0)
    right = float(photon[:, SIZE // 2:].mean() / cycles[:, SIZE // 2:].mean() - 1.0)
    error = rel_mse(photon, cycles)
    print(f"mean {mean:+.2%} left {left:+.2%} right {right:+.2%} relMSE {error:.4f}")
    assert abs(mean) <= 0.03, mean
    assert abs(left) <= 0.04 and abs(right) <= 0.04, (left, right)
    assert error <= 0.02, error


if __name__ == "__main__":
    pytest.main([__file__, "-q", "-s"])
