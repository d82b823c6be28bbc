#!/usr/bin/env bash
# Create or refresh the Python virtual environment used by the Blender-side tests and the
# scripts in scenes/blender/: <repo>/.venv with Blender 4.5 LTS as a module (bpy, includes
# Cycles), pytest with pytest-xdist (tests/run runs the Blender tests in two worker processes),
# numpy and an OpenEXR reader.
#
# Idempotent: if the venv already holds the pinned packages it does nothing but report them.
# Works from nothing on a fresh machine (needs python3.11 and access to PyPI).
# Fails loudly (non-zero exit, message on stderr) on any error.
#
# Environment:
#   PYTHON   interpreter used to create the venv (default: python3.11, else python3)
#   VENV     venv location (default: <repo>/.venv)
set -euo pipefail

REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${VENV:-$REPO/.venv}"

# bpy 4.5 wheels are built for CPython 3.11 only.
if [[ -z "${PYTHON:-}" ]]; then
    if command -v python3.11 >/dev/null 2>&1; then PYTHON=python3.11; else PYTHON=python3; fi
fi

# Pins. bpy==4.5.* is Blender 4.5 LTS; the others are loose lower bounds.
PACKAGES=("bpy==4.5.*" "pytest>=7" "pytest-xdist>=3" "numpy>=1.24" "OpenEXR>=3.2")

die() { echo "setup_python.sh: ERROR: $*" >&2; exit 1; }
log() { echo "setup_python.sh: $*"; }

# Check in the venv that every pinned package is importable at the right version.
check_venv() {
    "$VENV/bin/python" - <<'EOF' 2>/dev/null
import importlib.metadata as md, sys
ok = md.version("bpy").startswith("4.5.")
for name in ("pytest", "pytest-xdist", "numpy", "OpenEXR"):
    md.version(name)
import numpy, OpenEXR, xdist  # noqa: F401  (bpy itself is slow to import; checked by metadata only)
sys.exit(0 if ok else 1)
EOF
}

if [[ -x "$VENV/bin/python" ]] && check_venv; then
    log "venv at $VENV already has ${PACKAGES[*]}; nothing to do"
    "$VENV/bin/python" -c 'import importlib.metadata as m; print("setup_python.sh:", ", ".join(f"{p} {m.version(p)}" for p in ("bpy","pytest","pytest-xdist","numpy","OpenEXR")))'
    exit 0
fi

command -v "$PYTHON" >/dev/null 2>&1 || die "no Python interpreter '$PYTHON' found (bpy 4.5 needs CPython 3.11)"
PYVER="$("$PYTHON" -c 'import sys; print("%d.%d" % sys.version_info[:2])')"
[[ "$PYVER" == "3.11" ]] || die "$PYTHON is Python $PYVER; bpy 4.5 wheels exist only for CPython 3.11 (set PYTHON=...)"

if [[ ! -x "$VENV/bin/python" ]]; then
    log "creating venv at $VENV with $PYTHON ($PYVER)"
    "$PYTHON" -m venv "$VENV" || die "python -m venv failed (on Debian: apt-get install python3.11-venv)"
else
    log "venv at $VENV exists but lacks some packages; installing into it"
fi

T0=$(date +%s)
log "upgrading pip"
"$VENV/bin/python" -m pip install --quiet --upgrade pip || die "pip upgrade failed"
log "installing ${PACKAGES[*]} (bpy is a ~350 MB download)"
"$VENV/bin/python" -m pip install --progress-bar off "${PACKAGES[@]}" || die "pip install failed"

check_venv || die "packages installed but the check failed (run $VENV/bin/python -c 'import OpenEXR, numpy')"
log "smoke test: import bpy and check Cycles is available"
"$VENV/bin/python" - <<'EOF' || die "bpy smoke test failed"
import sys
import bpy
scene = bpy.context.scene
scene.render.engine = "CYCLES"
if scene.render.engine != "CYCLES":
    sys.exit("Cycles is not available in this bpy build")
print("setup_python.sh: bpy", bpy.app.version_string, "imported; Cycles available")
sys.stdout.flush()
EOF
log "done in $(( $(date +%s) - T0 )) s; venv size $(du -sh "$VENV" | cut -f1)"
