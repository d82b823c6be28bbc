"""Helpers for the tests that compare Photon with the committed Cycles references.

- `reference(name)`: the reference image (H, W, 3 float32, row 0 = top) and its JSON sidecar,
  from scenes/blender/<name>.exr / .json.
- `render_photon(name, ...)`: run `$PHOTON_BINARY render scenes/blender/<name>.glb -o OUT.exr
  --width W --height H --spp N --seed S --threads T` with a timeout and return its RGB image.
  Any problem (PHOTON_BINARY unset or not executable, non-zero exit, timeout, missing or
  malformed output) fails the calling test with a message that includes photon's stderr.
- `block_means(img, size)`: the means of size x size pixel blocks, to compare images whose
  pixels differ by noise or by a sub-pixel shift.
- `rel_mse`, `read_exr`, `lit_mask`, `luminance` come from scenes/blender/refimage.py.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
SCENES = REPO / "scenes" / "blender"
sys.path.insert(0, str(SCENES))
from refimage import erode, lit_mask, luminance, read_exr, rel_mse  # noqa: E402,F401

# Seconds one photon run may take before the test fails (override with PHOTON_TEST_TIMEOUT).
TIMEOUT = float(os.environ.get("PHOTON_TEST_TIMEOUT", "900"))
THREADS = os.cpu_count() or 2


def reference(name: str):
    """(image, sidecar dict) of the committed Cycles reference `name`."""
    exr = SCENES / f"{name}.exr"
    side = SCENES / f"{name}.json"
    for p in (exr, side, SCENES / f"{name}.glb"):
        if not p.exists():
            pytest.fail(f"missing reference file {p}: regenerate with "
                        f".venv/bin/python scenes/blender/make_references.py", pytrace=False)
    return read_exr(exr), json.loads(side.read_text())


def block_means(img: np.ndarray, size: int = 4) -> np.ndarray:
    """The means of `size` x `size` pixel blocks of an (H, W, C) image."""
    h, w = img.shape[0] // size * size, img.shape[1] // size * size
    return img[:h, :w].reshape(h // size, size, w // size, size, -1).mean(axis=(1, 3))


def photon_binary() -> Path:
    """The Photon executable named by $PHOTON_BINARY; fails the test if it is unusable."""
    value = os.environ.get("PHOTON_BINARY")
    if not value:
        pytest.fail("PHOTON_BINARY is not set: build photon (cargo build --release) and set "
                    "PHOTON_BINARY=<repo>/target/release/photon (tests/run does this)",
                    pytrace=False)
    path = Path(value)
    if not path.is_file() or not os.access(path, os.X_OK):
        pytest.fail(f"PHOTON_BINARY={value} is not an executable file", pytrace=False)
    return path


def _tail(text: str, lines: int = 40) -> str:
    return "\n".join(text.strip().splitlines()[-lines:]) or "(empty)"


def render_photon(name: str, width: int, height: int, spp: int, seed: int = 1,
                  threads: int = THREADS, timeout: float = TIMEOUT,
                  extra: list[str] | None = None) -> np.ndarray:
    """Render scenes/blender/<name>.glb with Photon (and the `extra` arguments) and return the
    RGB image (H, W, 3)."""
    binary = photon_binary()
    glb = SCENES / f"{name}.glb"
    with tempfile.TemporaryDirectory(prefix=f"photon_{name}_") as tmp:
        out = Path(tmp) / f"{name}.exr"
        cmd = [str(binary), "render", str(glb), "-o", str(out), "--width", str(width),
               "--height", str(height), "--spp", str(spp), "--seed", str(seed),
               "--threads", str(threads)] + (extra or [])
        t0 = time.perf_counter()
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                                  stdin=subprocess.DEVNULL)
        except subprocess.TimeoutExpired as exc:
            err = exc.stderr.decode(errors="replace") if isinstance(exc.stderr, bytes) else (exc.stderr or "")
            pytest.fail(f"photon timed out after {timeout:.0f} s: {' '.join(cmd)}\n"
                        f"--- stderr (tail) ---\n{_tail(err)}", pytrace=False)
        dt = time.perf_counter() - t0
        if proc.returncode != 0:
            pytest.fail(f"photon exited with code {proc.returncode} after {dt:.1f} s: "
                        f"{' '.join(cmd)}\n--- stderr (tail) ---\n{_tail(proc.stderr)}\n"
                        f"--- stdout (tail) ---\n{_tail(proc.stdout, 10)}", pytrace=False)
        if not out.exists():
            pytest.fail(f"photon exited 0 but wrote no {out}: {' '.join(cmd)}\n"
                        f"--- stderr (tail) ---\n{_tail(proc.stderr)}", pytrace=False)
        try:
            image = read_exr(out, ("R", "G", "B", "A"))
        except Exception as exc:  # noqa: BLE001 - report any decoding problem as a failure
            pytest.fail(f"cannot read photon's output {out} as an RGBA EXR: {exc}", pytrace=False)
    print(f"photon {name}: {width}x{height} {spp} spp in {dt:.1f} s")
    if image.shape[:2] != (height, width):
        pytest.fail(f"photon wrote a {image.shape[1]}x{image.shape[0]} image, "
                    f"asked for {width}x{height}", pytrace=False)
    bad = int((~np.isfinite(image)).sum())
    if bad:
        pytest.fail(f"photon's image has {bad} NaN/Inf values", pytrace=False)
    return image[:, :, :3]


def describe(image: np.ndarray, ref: np.ndarray) -> str:
    """Per-channel means of an image and its reference, for failure messages."""
    m = image.reshape(-1, 3).mean(axis=0)
    r = ref.reshape(-1, 3).mean(axis=0)
    return (f"photon mean RGB {np.round(m, 5).tolist()}, cycles mean RGB {np.round(r, 5).tolist()}, "
            f"ratio {np.round(m / np.maximum(r, 1e-12), 4).tolist()}")


def assert_matches_reference(name: str, spp: int, relmse_max: float, mean_tol: float):
    """Render scenes/blender/<name>.glb at its reference's size and check it against the Cycles
    reference: relMSE at most `relmse_max`, mean within `mean_tol` (relative)."""
    ref, info = reference(name)
    img = render_photon(name, info["width"], info["height"], spp)
    err = rel_mse(img, ref)
    ratio = float(img.mean() / ref.mean())
    msg = (f"{name}: relMSE {err:.5f} (max {relmse_max}); mean ratio {ratio:.4f} "
           f"(tolerance {mean_tol:.0%}); {describe(img, ref)}")
    print(msg)
    assert err <= relmse_max, msg
    assert abs(ratio - 1.0) <= mean_tol, msg
