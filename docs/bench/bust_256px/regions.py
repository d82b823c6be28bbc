"""relMSE and mean of an image against a reference over the whole image and over regions named
by a Photon render with light-path passes (`--exr-layer V --passes`): the translucent pixels
(non-zero Subsurface pass, less a 1-pixel rim) and the rest, each split by channel.

Usage: .venv/bin/python docs/bench/bust_256px/regions.py IMAGE.exr REF.exr MASK.exr
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scenes" / "blender"))
import numpy as np  # noqa: E402
from refimage import read_exr, rel_mse  # noqa: E402


def erode(m: np.ndarray) -> np.ndarray:
    """`m` less its one-pixel rim (the silhouette mixes the bust with what is behind it)."""
    e = m.copy()
    e[1:] &= m[:-1]
    e[:-1] &= m[1:]
    e[:, 1:] &= m[:, :-1]
    e[:, :-1] &= m[:, 1:]
    return e


def line(name: str, img: np.ndarray, ref: np.ndarray, where: np.ndarray) -> str:
    a, b = img[where], ref[where]
    rgb = " ".join(f"{a[:, c].mean() / b[:, c].mean() - 1:+.2%}" for c in range(3))
    return (f"{name:>12} ({where.sum():5d} px) relMSE {rel_mse(a[None], b[None]):.5f} "
            f"mean {a.mean() / b.mean() - 1:+.2%} RGB {rgb}")


def combined(path: str) -> np.ndarray:
    """The image of `path`: its Combined layer when it has passes."""
    try:
        return read_exr(path, ("V.Combined.R", "V.Combined.G", "V.Combined.B"))
    except ValueError:
        return read_exr(path)


def main() -> None:
    img, ref = combined(sys.argv[1]), combined(sys.argv[2])
    sss = read_exr(sys.argv[3], ("V.Subsurface.R", "V.Subsurface.G", "V.Subsurface.B"))
    translucent = sss.sum(axis=2) > 1e-4
    inner = erode(translucent)
    rest = erode(~translucent)
    everything = np.ones(translucent.shape, bool)
    for name, where in (("all", everything), ("translucent", inner), ("rest", rest)):
        print(line(name, img, ref, where))


if __name__ == "__main__":
    main()
