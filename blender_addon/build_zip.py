"""Build the installable extension zip of the Photon add-on, with the release binary inside.

    python blender_addon/build_zip.py [--binary target/release/photon] [--output dist/]
                                      [--blender-ext PATH/TO/blender_ext.py]

Writes dist/photon_render-<version>-<platform>.zip holding the add-on's Python files, its
manifest (with `platforms` set to this machine's platform, as Blender requires for extensions
that carry a native binary) and the binary as bin/photon (bin/photon.exe on Windows). Install it in
Blender with Edit > Preferences > Get Extensions > Install from Disk. Run
`cargo build --release` first. Standard library only.

With --blender-ext, the zip is made by Blender's own extension builder (`blender --command
extension build`, whose script is `blender_ext.py` in Blender's
scripts/addons_core/bl_pkg/cli/, also inside the bpy module) from a staging folder holding
exactly these files; it validates the manifest as the extensions platform does. Without it
the zip is written here, with the same contents.
"""

from __future__ import annotations

import argparse
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
# The add-on's modules (every .py here but this script) and its README.
FILES = (*sorted(p.name for p in HERE.glob("*.py") if p.name != Path(__file__).name), "README.md")


def blender_platform() -> str:
    """This machine in Blender's platform naming (linux-x64, macos-arm64, windows-x64, ...)."""
    system = {"linux": "linux", "darwin": "macos", "win32": "windows"}.get(sys.platform)
    machine = platform.machine().lower()
    arch = {"x86_64": "x64", "amd64": "x64", "aarch64": "arm64", "arm64": "arm64"}.get(machine)
    if system is None or arch is None:
        raise SystemExit(f"unsupported platform {sys.platform}/{machine}")
    return f"{system}-{arch}"


def manifest_with_platform(text: str, plat: str) -> str:
    """The manifest with `platforms = [plat]` (replacing any existing line)."""
    line = f'platforms = ["{plat}"]'
    if re.search(r"^platforms\s*=", text, flags=re.M):
        return re.sub(r"^platforms\s*=.*$", line, text, flags=re.M)
    return text.replace("\n[permissions]", f"\n{line}\n\n[permissions]", 1)


def build(binary: Path, output: Path, blender_ext: Path | None = None) -> Path:
    if not binary.is_file():
        raise SystemExit(f"no binary at {binary}: run 'cargo build --release' first")
    manifest = (HERE / "blender_manifest.toml").read_text()
    version = re.search(r'^version\s*=\s*"([^"]+)"', manifest, flags=re.M).group(1)
    plat = blender_platform()
    output.mkdir(parents=True, exist_ok=True)
    target = output / f"photon_render-{version}-{plat.replace('-', '_')}.zip"
    binary_name = "bin/photon.exe" if plat.startswith("windows") else "bin/photon"
    if blender_ext is not None:
        return build_with_blender(blender_ext, manifest_with_platform(manifest, plat), binary,
                                  binary_name, target)
    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("blender_manifest.toml", manifest_with_platform(manifest, plat))
        for name in FILES:
            z.write(HERE / name, name)
        info = zipfile.ZipInfo(binary_name)
        info.external_attr = 0o100755 << 16  # a regular file, executable
        info.compress_type = zipfile.ZIP_DEFLATED
        z.writestr(info, binary.read_bytes())
    return target


def build_with_blender(blender_ext: Path, manifest: str, binary: Path, binary_name: str,
                       target: Path) -> Path:
    """Make `target` with Blender's extension builder from a staging folder."""
    with tempfile.TemporaryDirectory(prefix="photon_extension_") as tmp:
        stage = Path(tmp) / "photon_render"
        (stage / binary_name).parent.mkdir(parents=True)
        (stage / "blender_manifest.toml").write_text(manifest)
        for name in FILES:
            shutil.copy2(HERE / name, stage / name)
        shutil.copy2(binary, stage / binary_name)
        (stage / binary_name).chmod(0o755)
        if target.exists():
            target.unlink()
        proc = subprocess.run([sys.executable, str(blender_ext), "build", "--source-dir",
                               str(stage), "--output-filepath", str(target)],
                              capture_output=True, text=True, stdin=subprocess.DEVNULL)
    if proc.returncode != 0 or not target.is_file():
        raise SystemExit(f"Blender's extension build refused the package (exit code "
                         f"{proc.returncode}):\n{proc.stdout}{proc.stderr}")
    return target


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--binary", type=Path, default=REPO / "target" / "release" / "photon")
    parser.add_argument("--output", type=Path, default=REPO / "dist")
    parser.add_argument("--blender-ext", type=Path, default=None,
                        help="Blender's blender_ext.py: build the zip with Blender's builder")
    args = parser.parse_args(argv)
    target = build(args.binary, args.output, args.blender_ext)
    print(f"wrote {target} ({target.stat().st_size / 1e6:.1f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
