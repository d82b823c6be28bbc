"""The gallery bust (scenes/gallery/build_gallery.py, `translucent_bust`) rebuilt from a subset
of its parts, to find where Photon's path tracer and photon method part ways: the bust is the
union of four overlapping meshes in one (a lathed dome for the shoulders, an open neck column
running into the dome and the head, an egg for the head, a sphere for the nose), so it has
faces inside the marble. `full` is byte-identical to scenes/gallery/translucent_bust.glb.

Usage: python3 docs/bench/bust_256px/variants.py OUT_DIR
Writes OUT_DIR/{full,egg,dome,dome_egg,dome_neck_egg,egg_nose,full_s02,full_ior1,egg_ior1}.glb
(`_s02`: Subsurface Scale 0.02 instead of 0.08; `_ior1`: subsurface IOR 1.0 instead of 1.4).
"""
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scenes" / "gallery"))
sys.path.insert(0, str(ROOT / "scenes"))
import build_gallery as gallery  # noqa: E402
import build_scenes as bs  # noqa: E402


def main() -> None:
    out = Path(sys.argv[1]).resolve()
    out.mkdir(parents=True, exist_ok=True)
    bs.HERE = str(out)
    every = gallery.BUST_PARTS
    for name, parts, options in (
            ("full", every, {}), ("egg", ["egg"], {}), ("dome", ["dome"], {}),
            ("dome_egg", ["dome", "egg"], {}), ("dome_neck_egg", ["dome", "neck", "egg"], {}),
            ("egg_nose", ["egg", "nose"], {}), ("full_s02", every, {"scale": 0.02}),
            ("full_ior1", every, {"ior": 1.0}), ("egg_ior1", ["egg"], {"ior": 1.0})):
        gallery.bust_scene(parts, **options).write(name + ".glb")


if __name__ == "__main__":
    main()
