"""Where the error of several renderers' renders sits, against one reference.

usage: errmap.py REF.exr OUT_PREFIX NAME=GLOB [NAME=GLOB ...]

Each NAME=GLOB is one renderer's renders of the scene (one per seed, same samples). Prints per
renderer the mean and median relMSE over its renders, the renders holding a pixel above
`SPIKE` (a rare caustic that rules the mean when present) and the mean and median without them,
and the share of the summed per-pixel error in the 10 / 50 / 200 worst pixels. Writes
OUT_PREFIX-NAME.png (the per-pixel relMSE averaged over the renders, square-root scaled) and
OUT_PREFIX-ref.png; with two renderers also OUT_PREFIX-diff.png (red: the first has more
error, blue: the second) and the difference by 16 × 16 block.
"""

import glob
import struct
import sys
import zlib
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scenes" / "blender"))
from refimage import read_exr  # noqa: E402

SPIKE = 300.0


def write_png(path, rgb):
    """An 8-bit RGB PNG of `rgb` (values in [0, 1]), each pixel 3 × 3."""
    rgb = np.kron(np.clip(rgb, 0, 1), np.ones((3, 3, 1)))
    h, w, _ = rgb.shape
    raw = b"".join(b"\0" + (rgb[y] * 255).astype(np.uint8).tobytes() for y in range(h))

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    Path(path).write_bytes(b"\x89PNG\r\n\x1a\n"
                           + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                           + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def main(argv):
    if len(argv) < 3:
        print(__doc__)
        return 2
    ref = read_exr(argv[0]).astype(np.float64)
    prefix = argv[1]
    maps = {}
    for arg in argv[2:]:
        name, pattern = arg.split("=", 1)
        files = sorted(glob.glob(pattern))
        if not files:
            print(f"no renders match {pattern}")
            return 2
        images = [read_exr(f).astype(np.float64) for f in files]
        errors = np.array([((i - ref) ** 2 / (ref * ref + 0.01)).mean(axis=2) for i in images])
        per_render = errors.mean(axis=(1, 2))
        spiked = [f for f, i in zip(files, images) if i.max() > SPIKE]
        clean = np.array([e for e, i in zip(per_render, images) if i.max() <= SPIKE])
        mean_map = errors.mean(axis=0)
        worst = np.sort(mean_map.ravel())[::-1]
        shares = "/".join(f"{worst[:k].sum() / worst.sum():.2f}" for k in (10, 50, 200))
        print(f"{name}: {len(files)} renders, relMSE mean {per_render.mean():.5f} median "
              f"{np.median(per_render):.5f}; {len(spiked)} with a pixel > {SPIKE:g}"
              + (f", without them mean {clean.mean():.5f} median {np.median(clean):.5f}"
                 if len(clean) else "")
              + f"; worst 10/50/200 pixels hold {shares} of the error")
        maps[name] = mean_map
    scale = max(np.percentile(m, 99) for m in maps.values())
    for name, m in maps.items():
        write_png(f"{prefix}-{name}.png", np.repeat(np.sqrt(m / scale)[..., None], 3, axis=2))
    write_png(f"{prefix}-ref.png", ref / (1 + ref))
    if len(maps) == 2:
        (na, a), (nb, b) = maps.items()
        d = a - b
        s = np.percentile(np.abs(d), 99)
        diff = np.zeros(a.shape + (3,))
        diff[..., 0] = np.sqrt(np.clip(d / s, 0, 1))
        diff[..., 2] = np.sqrt(np.clip(-d / s, 0, 1))
        write_png(f"{prefix}-diff.png", diff)
        print(f"{na} minus {nb}, summed per-pixel relMSE by 16 x 16 block / pixels, x 1e4:")
        for y in range(0, a.shape[0], 16):
            print(" ".join(f"{(a[y:y + 16, x:x + 16] - b[y:y + 16, x:x + 16]).sum() / a.size * 1e4:+7.1f}"
                           for x in range(0, a.shape[1], 16)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
