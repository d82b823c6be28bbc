"""pytest configuration for tests/blender: make helpers.py and scenes/blender/refimage.py importable.

Run with the project venv: `.venv/bin/python -m pytest tests/blender` (create it with
tests/setup_python.sh). Tests that render need $PHOTON_BINARY; without it they fail, never skip.

Tests marked `slow` render Cycles references or take more than about 10 s; `-m "not slow"`
leaves them out for a quick check, and tests/run runs them all, in two pytest-xdist workers
(`-n 2 --dist loadfile`: each file's tests in one worker, each worker with its own temporary
directory and Cycles references).
"""

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parents[1] / "scenes" / "blender"))


import pytest  # noqa: E402


def pytest_configure(config):
    config.addinivalue_line(
        "markers", "slow: renders Cycles references or takes more than about 10 s (deselect "
        "with -m \"not slow\")")


@pytest.fixture(scope="session")
def photon_addon():
    """The add-on registered from the source folder (blender_addon/) for the whole test run, and
    unregistered at the end: a still-registered Python RenderEngine makes the bpy module hang at
    interpreter exit."""
    import bpy  # noqa: F401 - imported here so the runner tests need no bpy
    sys.path.insert(0, str(HERE.parents[1]))
    import blender_addon
    blender_addon.register()
    yield blender_addon
    blender_addon.unregister()


@pytest.fixture(scope="session", autouse=True)
def shared_cycles_references(tmp_path_factory):
    """The folder where reference_cache.py keeps each Cycles reference for the test run."""
    import reference_cache
    reference_cache.folder = tmp_path_factory.mktemp("cycles_references")
    yield reference_cache.folder
    reference_cache.folder = None


@pytest.fixture
def binary_env():
    """$PHOTON_BINARY checked to be a usable executable (fails the test otherwise)."""
    from helpers import photon_binary
    return photon_binary()
