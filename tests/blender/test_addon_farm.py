"""Frames rendered on a render farm: each worker a separate process, frames out of order.

A small animation (the red box on a grey floor under an area light, scenes_bpy's, 64x36, 16
spp, no adaptive sampling) whose camera slides 1 mm per frame (frames 1-3): every frame's
input differs, but the picture barely moves, so what changes from frame to frame is the noise.
It is saved as a .blend and rendered twice: in one run (`render(animation=True)`, as `blender
-b -a`) and as a farm manager runs it, one process per frame (farm_worker.py, as `blender -b
FILE -f N`), in the order 3, 1, 2. Both give the same frames bit for bit, with a fixed seed
and with Cycles' Animated Seed on and Denoise on. The flicker (mean |I(f+1) - I(f)| / mean I
over the frame pairs) is printed for a fixed and an animated seed, noisy and denoised
(docs/bench/denoise.md); an animated seed flickers more than a fixed one.

Cycles' Animated Seed (`runner.animated_seed`, no bpy): the same (seed, frame, subframe) always
gives the same 64-bit seed, and neighbouring frames, seeds and subframes different ones.

Failures: a worker whose renderer fails exits non-zero with the renderer's message in its
output, and so does a worker whose $PHOTON_BINARY is not a binary.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from addon import fake_binary, load_runner

HERE = Path(__file__).resolve().parent
WORKER = HERE / "farm_worker.py"
FRAMES = (1, 2, 3)
FARM_ORDER = (3, 1, 2)
SPP = 16
CAMERA_STEP = 0.001  # metres per frame
# (name, Cycles' Animated Seed, Denoise)
MODES = {"fixed seed": (False, False), "animated seed": (True, False),
         "fixed seed, denoised": (False, True), "animated seed, denoised": (True, True)}
FARM_MODES = ("fixed seed", "animated seed, denoised")


def save_animation(path: Path, animated_seed: bool, denoise: bool):
    """The animation, saved to `path` with the given seed and denoise settings."""
    import bpy

    import scenes_bpy

    scene = scenes_bpy.area_light_photon_path(SPP)
    scene.photon.use_denoising = denoise
    scene.cycles.use_animated_seed = animated_seed
    scene.frame_start, scene.frame_end = FRAMES[0], FRAMES[-1]
    camera = scene.camera
    start = camera.location.copy()
    for frame in FRAMES:
        camera.location = start
        camera.location.x += CAMERA_STEP * (frame - 1)
        camera.keyframe_insert("location", frame=frame)
    scene.frame_set(FRAMES[0])
    bpy.ops.wm.save_as_mainfile(filepath=str(path))


def folder_pattern(folder: Path) -> str:
    """An output path that writes frame N as `folder`/000N.exr."""
    return str(folder) + os.sep


def read_frames(folder: Path) -> dict[int, np.ndarray]:
    from refimage import read_exr
    return {frame: read_exr(folder / f"{frame:04d}.exr") for frame in FRAMES}


def run_worker(blend: Path, frame: int, output: str, env=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(WORKER), str(blend), str(frame), output],
                          capture_output=True, text=True, timeout=600,
                          env=env if env is not None else os.environ.copy())


def flicker(frames: dict[int, np.ndarray]) -> float:
    images = [frames[f].astype(np.float64) for f in FRAMES]
    return float(np.mean([np.abs(b - a).mean() / a.mean() for a, b in zip(images, images[1:])]))


def test_animated_seed_depends_on_seed_and_frame_only():
    runner = load_runner()
    seeds = {runner.animated_seed(seed, frame, sub) for seed in (0, 1, 2)
             for frame in (-1, 0, 1, 2, 250) for sub in (0.0, 0.5)}
    assert len(seeds) == 3 * 5 * 2
    assert all(0 <= s < 2 ** 64 for s in seeds)
    assert runner.animated_seed(1, 7) == runner.animated_seed(1, 7, 0.0)
    assert load_runner().animated_seed(1, 7, 0.25) == runner.animated_seed(1, 7, 0.25)


@pytest.mark.slow
def test_farm_frames_equal_one_run(photon_addon, binary_env, tmp_path):
    import bpy

    one_run, farm = {}, {}
    for mode, (animated, denoise) in MODES.items():
        tag = mode.replace(", ", "_").replace(" ", "_")
        blend = tmp_path / f"{tag}.blend"
        save_animation(blend, animated, denoise)
        scene = bpy.context.scene
        scene.render.filepath = folder_pattern(tmp_path / f"{tag}_one_run")
        bpy.ops.render.render(animation=True)
        one_run[mode] = read_frames(tmp_path / f"{tag}_one_run")
        if mode in FARM_MODES:
            for frame in FARM_ORDER:
                done = run_worker(blend, frame, folder_pattern(tmp_path / f"{tag}_farm"))
                assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
            farm[mode] = read_frames(tmp_path / f"{tag}_farm")
    for mode in FARM_MODES:
        for frame in FRAMES:
            assert np.array_equal(farm[mode][frame], one_run[mode][frame]), (mode, frame)
    for mode, frames in one_run.items():
        # The camera moved: no two frames are the same image.
        assert not np.array_equal(frames[1], frames[2]), mode
        print(f"{mode}: flicker {flicker(frames):.4f}")
    assert not np.array_equal(one_run["fixed seed"][2], one_run["animated seed"][2])
    assert flicker(one_run["animated seed"]) > 2 * flicker(one_run["fixed seed"])


def test_a_failing_renderer_fails_the_worker(photon_addon, tmp_path):
    """The renderer exits 2 with its error line: the worker exits non-zero, the message in its
    output, and no image is written."""
    blend = tmp_path / "scene.blend"
    save_animation(blend, False, False)
    broken = fake_binary(tmp_path / "photon", """
        print("error: the scene file is broken (test)", file=sys.stderr)
        sys.exit(2)
        """)
    env = dict(os.environ, PHOTON_BINARY=str(broken))
    done = run_worker(blend, 2, folder_pattern(tmp_path / "out"), env)
    output = done.stdout + done.stderr
    assert done.returncode != 0, output[-2000:]
    assert "the scene file is broken (test)" in output, output[-2000:]
    assert "exit code 2, bad input" in output, output[-2000:]
    assert not (tmp_path / "out" / "0002.exr").exists()


def test_a_bad_binary_override_fails_the_worker(photon_addon, tmp_path):
    blend = tmp_path / "scene.blend"
    save_animation(blend, False, False)
    env = dict(os.environ, PHOTON_BINARY=str(tmp_path / "no_such_photon"))
    done = run_worker(blend, 1, folder_pattern(tmp_path / "out"), env)
    output = done.stdout + done.stderr
    assert done.returncode != 0, output[-2000:]
    assert "PHOTON_BINARY" in output and "no_such_photon" in output, output[-2000:]
