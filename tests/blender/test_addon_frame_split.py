"""One frame split across machines, as a farm renders it: the same .blend saved with Cycles'
Sample Offset 0 and 4 (4 samples each) and rendered in separate processes (farm_worker.py, as
`blender -b FILE -f 1` on two workers) to OpenEXR Multilayer files, merged by the add-on's
`photon.merge_images` (which runs `photon merge`), equals the frame rendered with 8 samples in
one process: every pass but Depth and Normal to float rounding (those two where the pixel's
samples hit one surface), and the saved files record the samples
they hold. Sample Offset with Noise Threshold on is refused with a message saying what to do,
and a merge of two renders of the same samples fails with the renderer's message.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

HERE = Path(__file__).resolve().parent
WORKER = HERE / "farm_worker.py"
SPP = 4


def save_part(path: Path, offset: int, samples: int, adaptive: bool = False):
    """The area-light scene (64x36, path tracer, seed 1) saved to `path` with `samples` samples
    from `offset`, frame 1 only, written as OpenEXR Multilayer."""
    import bpy

    import common
    import scenes_bpy

    scene = scenes_bpy.area_light_photon_path(samples)
    scene.cycles.use_adaptive_sampling = adaptive
    scene.cycles.sample_offset = offset
    scene.frame_start = scene.frame_end = 1
    view_layer = scene.view_layers[0]
    view_layer.use_pass_z = view_layer.use_pass_normal = True
    view_layer.use_pass_diffuse_direct = view_layer.use_pass_diffuse_indirect = True
    common.set_multilayer_exr(scene.render.image_settings)
    scene.render.image_settings.color_depth = "32"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))


def run_worker(blend: Path, output: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(WORKER), str(blend), "1", output],
                          capture_output=True, text=True, timeout=600, env=os.environ.copy())


def channels(path: Path) -> tuple[dict[str, np.ndarray], dict]:
    import OpenEXR
    # Blender 4 saves a multilayer file as one part, Blender 5 as a part a pass.
    with OpenEXR.File(str(path), separate_channels=True) as f:
        planes = {name: np.asarray(c.pixels, dtype=np.float32)
                  for part in f.parts for name, c in part.channels.items()}
        header = dict(f.parts[0].header)
    return planes, header


def text(header: dict, key: str) -> str | None:
    value = header.get(key)
    return value.decode() if isinstance(value, bytes) else value


@pytest.mark.slow
def test_parts_rendered_apart_merge_into_the_whole_frame(photon_addon, binary_env, tmp_path):
    import bpy

    outputs = {}
    for name, offset, samples in (("a", 0, SPP), ("b", SPP, SPP), ("whole", 0, 2 * SPP)):
        blend = tmp_path / f"{name}.blend"
        save_part(blend, offset, samples)
        done = run_worker(blend, str(tmp_path / f"{name}_"))
        assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
        outputs[name] = tmp_path / f"{name}_0001.exr"
    for name, ranges in (("a", "0-4"), ("b", "4-8"), ("whole", "0-8")):
        _, header = channels(outputs[name])
        assert text(header, "photon.samples") == f"{ranges} seed 1", (name, sorted(header))

    merged = tmp_path / "merged.exr"
    result = bpy.ops.photon.merge_images(
        directory=str(tmp_path), files=[{"name": outputs["b"].name}, {"name": outputs["a"].name}],
        output_filepath=str(merged))
    assert result == {"FINISHED"}
    got, header = channels(merged)
    want, _ = channels(outputs["whole"])
    assert text(header, "photon.samples") == "0-8 seed 1"
    assert set(got) == set(want)
    combined = [n for n in got if ".Combined." in n]
    assert len(combined) == 4, sorted(got)
    assert {"ViewLayer.Depth.Z", "ViewLayer.Normal.X", "ViewLayer.DiffInd.R"} <= set(got)
    for name, plane in got.items():
        if ".Depth." in name or ".Normal." in name:
            # Exact where every sample of the pixel hit one surface (exr_merge.rs).
            same = np.isclose(plane, want[name], rtol=1e-5, atol=1e-6).mean()
            print(f"{name}: {100 * same:.0f} % of pixels equal")
            assert same > 0.5, name
            continue
        np.testing.assert_allclose(plane, want[name], rtol=1e-5, atol=1e-6, err_msg=name)
    part, _ = channels(outputs["a"])
    difference = max(np.abs(part[n] - want[n]).max() for n in combined)
    print(f"part vs whole: largest Combined difference {difference:.4f}; merged vs whole: "
          f"{max(np.abs(got[n] - want[n]).max() for n in combined):.2e}")
    assert difference > 1e-3  # a part alone is a different (noisier) image

    # The same samples twice: the renderer refuses, the operator reports it.
    with pytest.raises(RuntimeError, match="both hold samples 0-4"):
        bpy.ops.photon.merge_images(
            directory=str(tmp_path), files=[{"name": outputs["a"].name},
                                            {"name": outputs["whole"].name}],
            output_filepath=str(tmp_path / "bad.exr"))
    assert not (tmp_path / "bad.exr").exists()


def test_sample_offset_with_noise_threshold_is_refused(photon_addon, binary_env, tmp_path):
    blend = tmp_path / "adaptive.blend"
    save_part(blend, SPP, SPP, adaptive=True)
    done = run_worker(blend, str(tmp_path / "x_"))
    output = done.stdout + done.stderr
    assert done.returncode != 0, output[-2000:]
    assert "Sample Offset needs Noise Threshold off" in output, output[-2000:]
    assert not (tmp_path / "x_0001.exr").exists()


def test_sample_offset_is_passed_to_the_renderer():
    from addon import load_runner
    runner = load_runner()
    settings = runner.RenderSettings(samples=4)
    command = runner.render_command("photon", "s.glb", "o.exr", width=8, height=8,
                                    settings=settings, sample_offset=12)
    assert command[command.index("--sample-offset") + 1] == "12"
    assert "--sample-offset" not in runner.render_command(
        "photon", "s.glb", "o.exr", width=8, height=8, settings=settings)
    assert runner.merge_command("photon", "m.exr", ["a.exr", "b.exr"]) == [
        "photon", "merge", "m.exr", "a.exr", "b.exr"]
