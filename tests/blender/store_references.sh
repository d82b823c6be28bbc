#!/usr/bin/env bash
# Renders every Cycles reference the Blender tests compare with and keeps it in
# tests/data/cycles_references/<Blender version>/ (reference_cache.py), in place of what was kept
# for this version. Run it after a change to a test's scene or settings, or to the add-on's
# Cycles set-up, and commit the folder: the tests then read these files instead of rendering
# Cycles, and render (saying so) any reference that is not there. Arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/../.."
version=$(.venv/bin/python -c 'import bpy; print(".".join(str(v) for v in bpy.app.version))' | tail -n 1)
rm -rf "tests/data/cycles_references/$version"
PHOTON_STORE_REFERENCES=1 PHOTON_BINARY="$PWD/target/release/photon" \
    .venv/bin/python -m pytest tests/blender -q -n "${PHOTON_TEST_WORKERS:-2}" --dist loadfile "$@"
du -sh "tests/data/cycles_references/$version"
