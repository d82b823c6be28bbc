"""F12 with Photon through the add-on (`bpy.ops.render.render()`, engine PHOTON, $PHOTON_BINARY)
against Cycles rendering the same Blender scene in the same test: mean brightness within 3 % and
relMSE <= 0.02 for the factory-default scene, an area light (PHOTON_light), a sun with a world
colour (PHOTON_world) and an HDRI world (PHOTON_world environment). Images are 64x36.
"""

import time

import bpy

import numpy as np
import pytest

import scenes_bpy
from helpers import photon_binary, rel_mse

PHOTON_SPP = 256
CYCLES_SPP = 1024
MEAN_TOL = 0.03
RELMSE_MAX = 0.02


@pytest.fixture(autouse=True)
def binary(photon_addon):
    return photon_binary()


def compare(name, build, tmp_path, cycles_spp=CYCLES_SPP, methods=(("AUTO", PHOTON_SPP),)):
    """Render `build()` with Cycles, then with Photon for each (method, samples) of `methods`;
    each must match."""
    scene = build()
    t0 = time.perf_counter()
    ref = scenes_bpy.render(scene, "CYCLES", tmp_path / "cycles.exr", cycles_spp)
    cycles_seconds = time.perf_counter() - t0
    for method, spp in methods:
        scene.photon.method = method
        t1 = time.perf_counter()
        img = scenes_bpy.render(scene, "PHOTON", tmp_path / "photon.exr", spp)
        t2 = time.perf_counter()
        assert img.shape == ref.shape == (36, 64, 3), (img.shape, ref.shape)
        assert np.isfinite(img).all()
        err = rel_mse(img, ref)
        diff = float(img.mean() / ref.mean()) - 1.0
        msg = (f"{name} ({method.lower()}): mean photon {img.mean():.5f} vs cycles "
               f"{ref.mean():.5f} ({100 * diff:+.2f} %), relMSE {err:.5f}; cycles {cycles_spp} "
               f"spp {cycles_seconds:.1f} s, photon {spp} spp {t2 - t1:.1f} s "
               f"(export + render + load)")
        print(msg)
        assert abs(diff) <= MEAN_TOL, msg
        assert err <= RELMSE_MAX, msg


@pytest.mark.slow
def test_default_scene_matches_cycles(tmp_path):
    compare("default scene", scenes_bpy.default_scene, tmp_path)


@pytest.mark.slow
def test_area_light_matches_cycles(tmp_path):
    compare("area light", scenes_bpy.area_light_scene, tmp_path)


@pytest.mark.slow
def test_sun_and_world_match_cycles(tmp_path):
    compare("sun + world", scenes_bpy.sun_world_scene, tmp_path)


@pytest.mark.slow
def test_hdri_world_matches_cycles(tmp_path):
    """Lit only by an equirectangular environment image (PHOTON_world environment, written as
    EXR by the add-on): orientation, rotation and brightness as in Cycles."""
    compare("HDRI world", scenes_bpy.hdri_scene, tmp_path, cycles_spp=256,  # 1024: 16 s here
            methods=(("PATH", PHOTON_SPP), ("PHOTON", 128)))  # photons leave the map too


def test_background_blender_export_route(tmp_path, monkeypatch, capfd):
    """The route used in the UI (snapshot .blend exported by a child process) renders the same
    image as the in-process export; also prints the time to the first progress report."""
    scene = scenes_bpy.default_scene()
    inproc = scenes_bpy.render(scene, "PHOTON", tmp_path / "a.exr", 16)
    first = capfd.readouterr().out
    monkeypatch.setenv("PHOTON_EXPORT", "subprocess")
    child = scenes_bpy.render(scene, "PHOTON", tmp_path / "b.exr", 16)
    second = capfd.readouterr().out
    for route, out in (("in process", first), ("background Blender", second)):
        timing = [line for line in out.splitlines() if "first progress" in line]
        assert timing, out[-2000:]
        print(f"{route}: {timing[-1].split('Photon: ')[-1]}")
    assert np.array_equal(inproc, child), "the two export routes gave different images"


def test_animation_renders_each_frame(tmp_path):
    """Ctrl+F12: every frame is exported at its own time (the cube moves between frames)."""
    scene = scenes_bpy.default_scene()
    cube = scene.objects["Cube"]
    for frame, x in ((1, -1.0), (2, 1.0)):
        cube.location.x = x
        cube.keyframe_insert("location", frame=frame)
    scene.frame_start, scene.frame_end = 1, 2
    scenes_bpy.render(scene, "PHOTON", tmp_path / "still.exr", 4)  # configures the output
    scene.render.filepath = str(tmp_path / "frame_####")
    scene.render.use_file_extension = True
    bpy.ops.render.render(animation=True)
    frames = [scenes_bpy.read_exr(tmp_path / f"frame_{f:04d}.exr") for f in (1, 2)]
    left, right = (float(img[:, :32].mean() - img[:, 32:].mean()) for img in frames)
    assert left > 0 > right, f"cube not where it should be: {left:.4f}, {right:.4f}"
