"""Access to the add-on source for the tests: the folder, its runner module without bpy, and
fake photon binaries (small Python scripts) for process-handling tests.
"""

from __future__ import annotations

import importlib.util
import os
import stat
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
ADDON_DIR = REPO / "blender_addon"


def load_runner():
    """blender_addon/runner.py as a standalone module (it imports no bpy)."""
    spec = importlib.util.spec_from_file_location("photon_runner", ADDON_DIR / "runner.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def fake_binary(path: Path, body: str) -> Path:
    """An executable Python script at `path` running `body` (has `sys`, `json`, `time`, `emit`)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    prelude = textwrap.dedent("""\
        import json, os, signal, sys, time
        def emit(**event):
            print(json.dumps(event), file=sys.stderr, flush=True)
        """)
    path.write_text(f"#!{sys.executable}\n" + prelude + textwrap.dedent(body))
    path.chmod(path.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
    return path


def env_without_photon(**extra) -> dict:
    """A copy of the environment with no PHOTON_BINARY and the given overrides."""
    env = {k: v for k, v in os.environ.items() if k != "PHOTON_BINARY"}
    env.update(extra)
    return env
