#!/usr/bin/env python3
"""Render the gallery: every gallery scene with `--method auto`, the Cornell box's seed views,
and a table of method, photon counts, render time, threads and relMSE against a path-traced
reference. Writes docs/gallery/*.png and docs/gallery/README.md (linked from the README).

The relMSE column compares a 64 × 64 auto render (same settings as the gallery image, at the
small size) with a 64 × 64 reference: path-traced with `--reference-spp` samples, or for scenes
with caustics of small lights by the photon method with `--photon-reference-spp` samples (see
SCENES), cached in target/gallery-references (keyed by the scene file's hash, the sample count
and the method).

Usage: python3 scenes/gallery/render_gallery.py [--photon target/release/photon] [--width 256]
           [--quality default] [--reference-spp 4096] [--photon-reference-spp 1024]
           [--only NAME ...]
Standard library only. Takes a while (tens of minutes on 2 cores, mostly the references).
"""

import argparse
import hashlib
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OUT = os.path.join(ROOT, "docs", "gallery")
REFS = os.path.join(ROOT, "target", "gallery-references")

# (name, file, caption, reference method): scenes with caustics of small lights, which the
# path tracer does not resolve, are judged against the photon method without the cache and
# with a million global and caustic photons per generation (consistent, like `photon bench
# --reference-method photon`); the others against the path tracer.
SCENES = [
    ("cornell_box", "scenes/cornell_box.glb", "Cornell box with two diffuse boxes", "path"),
    ("cornell_spheres", "scenes/gallery/cornell_spheres.glb",
     "Cornell box, glass and mirror spheres", "photon"),
    ("glass_caustic", "scenes/glass_caustic.glb", "Caustic from a glass sphere", "photon"),
    ("glossy_caustic", "scenes/gallery/glossy_caustic.glb", "Caustic on a glossy floor", "photon"),
    ("metal_ring", "scenes/gallery/metal_ring.glb", "Metal ring: the cardioid caustic", "photon"),
    ("cognac_glass", "scenes/gallery/cognac_glass.glb", "Cognac glass with liquid", "photon"),
    ("sphereflake", "scenes/gallery/sphereflake.glb", "Sphereflake", "photon"),
    ("glass_cube", "scenes/gallery/glass_cube.glb", "Glass cube caustic", "photon"),
    ("fractal_cornell", "scenes/gallery/fractal_cornell.glb", "Fractal Cornell box", "path"),
    ("interior", "scenes/gallery/interior.glb", "Sunlit interior with a pool outside", "photon"),
    ("interior_2pm", "scenes/gallery/interior_2pm.glb",
     "The same room under Blender's Nishita sky, 2 pm", "photon"),
    ("interior_7pm", "scenes/gallery/interior_7pm.glb",
     "The same room under Blender's Nishita sky, 7 pm", "photon"),
    ("translucent_bust", "scenes/gallery/translucent_bust.glb", "Translucent marble bust", "path"),
]

# Global and caustic photons per generation of a photon-method reference.
REFERENCE_PHOTONS = "1000000"

# The Cornell box views the seed shows: (file name, caption, extra arguments).
CORNELL_VIEWS = [
    ("cornell_direct", "Direct illumination only", ["--method", "path", "--max-depth", "1"]),
    ("cornell_gi", "Global illumination (photon map + final gather)", ["--method", "photon"]),
    ("cornell_global_k8", "Global photon map, 8 photons per estimate",
     ["--method", "photon-global", "--k", "8"]),
    ("cornell_global_k256", "Global photon map, 256 photons per estimate",
     ["--method", "photon-global", "--k", "256"]),
    ("cornell_photons", "Photon positions", ["--method", "photons", "--photons", "20000"]),
    ("cornell_irradiance", "Irradiance view: the cached indirect irradiance",
     ["--method", "ic-irradiance"]),
    ("cornell_records_a02", "Irradiance-cache records, accuracy 0.2",
     ["--method", "ic-records", "--ic-accuracy", "0.2"]),
    ("cornell_records_a01", "Irradiance-cache records, accuracy 0.1",
     ["--method", "ic-records", "--ic-accuracy", "0.1"]),
]


def run(photon, args):
    """Run `photon render ... --progress json`; return the parsed JSON progress lines."""
    cmd = [photon, "render"] + args + ["--progress", "json"]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    if proc.returncode != 0:
        sys.exit("failed: %s\n%s" % (" ".join(cmd), proc.stderr))
    lines = []
    for line in proc.stderr.splitlines():
        try:
            lines.append(json.loads(line))
        except ValueError:
            pass
    return lines


def stats(lines, stage):
    for line in reversed(lines):
        if line.get("stage") == stage and "stats" in line:
            return line["stats"]
    return {}


def relmse(photon, image, reference):
    proc = subprocess.run([photon, "compare", image, reference], cwd=ROOT, capture_output=True,
                          text=True, check=True)
    full = trimmed = None
    for line in proc.stdout.splitlines():
        if line.startswith("relMSE without"):
            trimmed = float(line.split()[-1])
        elif line.startswith("relMSE"):
            full = float(line.split()[1])
    if full is None or trimmed is None:
        raise RuntimeError(proc.stdout)
    return full, trimmed


def reference(photon, path, spp, method):
    with open(os.path.join(ROOT, path), "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()[:16]
    ref = os.path.join(REFS, "%s-%d-%s.exr" % (digest, spp, method))
    if not os.path.exists(ref):
        os.makedirs(REFS, exist_ok=True)
        extra = ["--method", "path"]
        if method == "photon":
            extra = ["--method", "photon", "--irradiance-cache", "off", "--photons",
                     REFERENCE_PHOTONS, "--caustic-photons", REFERENCE_PHOTONS]
        run(photon, [path, "--width", "64", "--height", "64", "--spp", str(spp), "--seed", "99",
                     "-o", ref] + extra)
    return ref


def photon_text(p):
    if not p:
        return "none"
    parts = []
    if p.get("global_emitted"):
        parts.append("%dk global" % (p["global_emitted"] // 1000))
    if p.get("caustic_emitted"):
        parts.append("%dk caustic" % (p["caustic_emitted"] // 1000))
    return ", ".join(parts) or "none"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--photon", default=os.path.join(ROOT, "target", "release", "photon"))
    ap.add_argument("--width", type=int, default=256)
    ap.add_argument("--quality", default="default")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--photon-reference-spp", type=int, default=1024)
    ap.add_argument("--only", nargs="*")
    args = ap.parse_args()
    os.makedirs(OUT, exist_ok=True)
    rows = []
    for name, path, caption, reference_method in SCENES:
        if args.only and name not in args.only:
            continue
        common = [path, "--method", "auto", "--quality", args.quality]
        lines = run(args.photon, common + ["--width", str(args.width), "--height",
                                           str(args.width), "-o", os.path.join(OUT, name + ".png")])
        done, photons = stats(lines, "done"), stats(lines, "photons")
        small = os.path.join(REFS, name + "-auto64.exr")
        os.makedirs(REFS, exist_ok=True)
        run(args.photon, common + ["--width", "64", "--height", "64", "-o", small])
        spp = args.reference_spp if reference_method == "path" else args.photon_reference_spp
        ref = reference(args.photon, path, spp, reference_method)
        error, trimmed = relmse(args.photon, small, ref)
        seconds = done.get("render_seconds", 0) + done.get("build_seconds", 0) + \
            photons.get("trace_seconds", 0) + photons.get("kdtree_seconds", 0) + \
            photons.get("irradiance_seconds", 0)
        rows.append((name, caption, done.get("method", "?"), photon_text(photons),
                     done.get("spp"), seconds, done.get("threads"), error, reference_method,
                     trimmed))
        print("%-18s %-8s %6.1f s relMSE %.4f (%.4f without the worst pixels)"
              % (name, rows[-1][2], seconds, error, trimmed))
    # Results of earlier runs (for --only) are kept in results.json.
    results_path = os.path.join(OUT, "results.json")
    previous = {"scenes": [], "views": []}
    if os.path.exists(results_path):
        with open(results_path) as f:
            previous = json.load(f)
    stored = {row[0]: row for row in previous["scenes"]}
    for row in rows:
        stored[row[0]] = list(row)
    order = [scene[0] for scene in SCENES]
    rows = [stored[name] for name in order if name in stored]
    views = previous["views"]
    if not args.only or "cornell_box" in args.only:
        views = []
        for name, caption, extra in CORNELL_VIEWS:
            lines = run(args.photon, ["scenes/cornell_box.glb", "--width", str(args.width),
                                      "--height", str(args.width), "-o",
                                      os.path.join(OUT, name + ".png")] + extra)
            views.append((name, caption, " ".join(extra), stats(lines, "done")))
    with open(results_path, "w") as f:
        json.dump({"scenes": rows, "views": views}, f, indent=1)
    with open(os.path.join(OUT, "README.md"), "w") as f:
        f.write("# Gallery\n\nThe seed's scenes rendered by Photon with `--method auto --quality "
                "%s` at %d × %d, generated by `python3 scenes/gallery/render_gallery.py`. Times "
                "are wall-clock seconds on this machine (photon tracing + BVH + rendering); "
                "relMSE is the same auto render at 64 × 64 against a reference: the "
                "path tracer's at %d spp, or for scenes with caustics of small lights (which the path "
                "tracer does not resolve) the photon method's at %d spp, without the irradiance "
                "cache and with %s global and caustic photons per generation of maps (consistent: it "
                "converges with the samples). The reference column says which. A few pixels "
                "of rare, bright paths (a small lamp seen through glass, which every unbiased "
                "method finds by chance at 64 spp) can rule the relMSE; the next column leaves "
                "out the worst 0.25 %% of the pixels (`photon compare`).\n\n"
                % (args.quality, args.width, args.width, args.reference_spp,
                   args.photon_reference_spp, REFERENCE_PHOTONS))
        f.write("| image | scene | method | photons | spp | time | threads | relMSE | "
                "without the worst pixels | reference |\n")
        f.write("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n")
        for row in rows:
            name, caption, method, photons, spp, seconds, threads, error = row[:8]
            ref_method = row[8] if len(row) > 8 else "path"
            trimmed = "%.4f" % row[9] if len(row) > 9 else "—"
            f.write("| ![%s](%s.png) | %s | %s | %s | %s | %.1f s | %s | %.4f | %s | %s |\n"
                    % (name, name, caption, method, photons, spp, seconds, threads, error,
                       trimmed, ref_method))
        if views:
            f.write("\n## The Cornell box, as the seed shows it\n\n| image | view | arguments "
                    "| time |\n| --- | --- | --- | --- |\n")
            for name, caption, extra, done in views:
                f.write("| ![%s](%s.png) | %s | `%s` | %.1f s |\n"
                        % (name, name, caption, extra, done.get("render_seconds", 0)))
    print("wrote", os.path.join(OUT, "README.md"))


if __name__ == "__main__":
    main()
