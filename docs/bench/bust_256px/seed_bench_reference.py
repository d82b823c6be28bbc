"""Put a Cycles reference where `photon bench` looks for its cached one, so the bench measures
Photon against Cycles' random walk (and `cycles_time.py --bench-dir` reads the same file).

`photon bench` caches its reference as OUT/refs/KEY.exr with KEY.noise.json, KEY =
`STEM-FNV1A64(scene bytes)-vVERSION-WxH-SPPspp-path` (src/bench.rs, `reference`); a file there
is used as it is. This writes the average of the Cycles renders given (`cycles_reference.py`
leaves them as OUT.sSEED.exr) as RGBA under that key, and the noise of that average estimated
from its two halves as the bench estimates its own (the relMSE of a − b + mean against the mean,
over 4). Run the bench afterwards with the same --width/--height, --reference-spp SPP and
--reference-method path.

Usage: .venv/bin/python docs/bench/bust_256px/seed_bench_reference.py SCENE.glb OUT_DIR SPP \
           RENDER.exr [RENDER.exr ...]
"""
import json
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scenes" / "blender"))
import numpy as np  # noqa: E402
from refimage import read_exr, rel_mse, write_exr  # noqa: E402


def fnv1a(data: bytes) -> int:
    """64-bit FNV-1a, as src/bench.rs hashes the scene file."""
    h = 0xCBF29CE484222325
    for b in data:
        h = ((h ^ b) * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return h


def main() -> None:
    scene, out, spp = Path(sys.argv[1]), Path(sys.argv[2]), int(sys.argv[3])
    renders = [read_exr(p) for p in sys.argv[4:]]
    if len(renders) < 2:
        sys.exit("seed_bench_reference: give at least two renders (two halves)")
    root = Path(__file__).resolve().parents[3]
    version = re.search(r'^version = "([^"]+)"', (root / "Cargo.toml").read_text(), re.M)[1]
    height, width = renders[0].shape[:2]
    key = f"{scene.stem}-{fnv1a(scene.read_bytes()):016x}-v{version}-{width}x{height}-{spp}spp-path"
    k = len(renders) // 2
    a, b = sum(renders[:k]) / k, sum(renders[k:]) / (len(renders) - k)
    mean = sum(renders) / len(renders)
    noise = rel_mse(a - b + 0.5 * (a + b), 0.5 * (a + b)) / 4.0
    refs = out / "refs"
    refs.mkdir(parents=True, exist_ok=True)
    rgba = np.concatenate([mean, np.ones(mean.shape[:2] + (1,), np.float32)], axis=2)
    write_exr(refs / f"{key}.exr", rgba.astype(np.float32))
    (refs / f"{key}.noise.json").write_text(json.dumps({
        "reference_noise_rel_mse": noise, "renders": sys.argv[4:],
        "note": "Cycles random walk (docs/bench/bust_256px/seed_bench_reference.py)"},
        indent=2) + "\n")
    print(f"wrote {refs / key}.exr (noise relMSE {noise:.2e}, mean {mean.mean():.5f})")


if __name__ == "__main__":
    main()
