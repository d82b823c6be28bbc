"""Image helpers shared by the reference scripts (scenes/blender/) and the tests (tests/blender/).

No bpy here: reading and writing linear OpenEXR files with the `OpenEXR` PyPI package,
the relMSE metric of README.md, and masks for "the lit region" of an image.
Images are numpy float32 arrays of shape (height, width, channels), row 0 = top row.
"""

from __future__ import annotations

import numpy as np

try:
    import OpenEXR
except ImportError as exc:  # pragma: no cover - reported clearly to the caller
    raise ImportError(
        "the OpenEXR Python package is missing: run tests/setup_python.sh "
        "and use <repo>/.venv/bin/python"
    ) from exc


def read_exr(path, channels=("R", "G", "B")) -> np.ndarray:
    """Read the named channels of a single-part scanline/tiled EXR as float32 (H, W, C).

    Channel names are matched exactly, then by their last dot-separated component
    (so 'ViewLayer.Combined.R' also answers 'R'). Raises ValueError naming what is missing.
    """
    with OpenEXR.File(str(path), separate_channels=True) as f:
        found = f.channels()
        planes = []
        for name in channels:
            key = name if name in found else next(
                (k for k in found if k.split(".")[-1] == name), None)
            if key is None:
                raise ValueError(f"{path}: no channel {name!r} (channels: {sorted(found)})")
            planes.append(np.asarray(found[key].pixels, dtype=np.float32))
    return np.stack(planes, axis=-1)


def write_exr(path, image: np.ndarray, names=None) -> None:
    """Write a float32 (H, W, C) image as a ZIP-compressed scanline EXR with channels R, G, B[, A]."""
    image = np.ascontiguousarray(image, dtype=np.float32)
    if names is None:
        names = "RGBA"[: image.shape[2]]
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    chans = {n: np.ascontiguousarray(image[:, :, i]) for i, n in enumerate(names)}
    with OpenEXR.File(header, chans) as f:
        f.write(str(path))


def rel_mse(image: np.ndarray, reference: np.ndarray) -> float:
    """relMSE = mean((I - R)^2 / (R^2 + 0.01)) over pixels and channels (README.md)."""
    if image.shape != reference.shape:
        raise ValueError(f"shape mismatch: image {image.shape} vs reference {reference.shape}")
    i = image.astype(np.float64)
    r = reference.astype(np.float64)
    return float(np.mean((i - r) ** 2 / (r * r + 0.01)))


def luminance(image: np.ndarray) -> np.ndarray:
    """Rec.709 luminance of an (H, W, >=3) image."""
    return 0.2126 * image[..., 0] + 0.7152 * image[..., 1] + 0.0722 * image[..., 2]


def erode(mask: np.ndarray, pixels: int) -> np.ndarray:
    """Shrink a boolean mask by `pixels` (8-neighbourhood); pixels outside the image count as False."""
    m = mask.copy()
    for _ in range(pixels):
        p = np.pad(m, 1, constant_values=False)
        out = np.ones_like(m)
        for dy in (0, 1, 2):
            for dx in (0, 1, 2):
                out &= p[dy:dy + m.shape[0], dx:dx + m.shape[1]]
        m = out
    return m


def lit_mask(reference: np.ndarray, fraction: float = 0.05, margin: int = 2) -> np.ndarray:
    """Pixels of the reference brighter than `fraction` x its maximum luminance, eroded by `margin`
    pixels so that pixel-filter differences at the edge of a lit region do not count."""
    lum = luminance(reference)
    return erode(lum > fraction * float(lum.max()), margin)
