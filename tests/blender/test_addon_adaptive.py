"""Adaptive sampling through the add-on: Blender's Noise Threshold settings (Render > Sampling,
the Cycles settings `use_adaptive_sampling`, `adaptive_threshold`, `adaptive_min_samples`) reach
the renderer as --adaptive-threshold and --adaptive-min-samples, on by default as in Blender, and
the renderer then takes fewer samples than asked in the pixels that converge. The
factory-default scene at 64x36, rendered with F12 (`bpy.ops.render.render()`); the command and
the renderer's final statistics are recorded around `runner.render_command` and `runner.run`.
"""

import bpy
import pytest

from blender_addon import runner
import scenes_bpy
from helpers import photon_binary

SPP = 64


@pytest.fixture
def scene(photon_addon):
    photon_binary()
    scene = scenes_bpy.default_scene()
    scene.render.engine = "PHOTON"
    scene.photon.samples, scene.photon.seed, scene.photon.method = SPP, 1, "PATH"
    return scene


@pytest.fixture
def recorded(monkeypatch):
    """The command lines the add-on built and the statistics the renderer reported."""
    record = {"commands": [], "stats": []}
    build, run = runner.render_command, runner.run

    def render_command(*args, **kwargs):
        command = build(*args, **kwargs)
        record["commands"].append(command)
        return command

    def run_and_record(command, *args, **kwargs):
        stats = run(command, *args, **kwargs)
        if command in record["commands"]:
            record["stats"].append(stats)
        return stats

    monkeypatch.setattr(runner, "render_command", render_command)
    monkeypatch.setattr(runner, "run", run_and_record)
    return record


def flag(command, name):
    """The value after `name` in `command`, or None when it is absent."""
    return command[command.index(name) + 1] if name in command else None


def render(scene, tmp_path):
    scene.render.filepath = str(tmp_path / "photon.png")
    bpy.ops.render.render(write_still=True)


def test_blender_defaults_turn_it_on(scene, recorded, tmp_path):
    cycles = scene.cycles
    assert cycles.use_adaptive_sampling, "Blender's default should be on"
    render(scene, tmp_path)
    command = recorded["commands"][-1]
    assert flag(command, "--adaptive-threshold") == f"{cycles.adaptive_threshold:g}" == "0.01"
    assert flag(command, "--adaptive-min-samples") == "0"


def test_the_scene_settings_are_passed_and_used(scene, recorded, tmp_path):
    scene.cycles.adaptive_threshold = 0.05
    scene.cycles.adaptive_min_samples = 16
    render(scene, tmp_path)
    command = recorded["commands"][-1]
    assert flag(command, "--adaptive-threshold") == "0.05"
    assert flag(command, "--adaptive-min-samples") == "16"
    stats = recorded["stats"][-1]
    # The world behind the cube converges at the first check: fewer samples than asked.
    assert stats["spp"] == SPP
    assert 16 <= stats["mean_spp"] < 0.9 * SPP, stats


def test_switched_off_it_is_not_passed(scene, recorded, tmp_path):
    scene.cycles.use_adaptive_sampling = False
    render(scene, tmp_path)
    command = recorded["commands"][-1]
    assert "--adaptive-threshold" not in command
    assert recorded["stats"][-1]["mean_spp"] == SPP
