"""pytest configuration for tests/blender: make helpers.py and scenes/blender/refimage.py importable.

Run with the project venv: `.venv/bin/python -m pytest tests/blender` (create it with
tests/setup_python.sh). Tests that render need $PHOTON_BINARY; without it they fail, never skip.
"""

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parents[1] / "scenes" / "blender"))
