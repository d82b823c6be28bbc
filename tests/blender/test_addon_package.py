"""blender_addon/build_zip.py: the extension zip holds the manifest (with this platform), the
add-on's modules and the binary as an executable bin/photon. The source folder and the zip pass
Blender's own extension validator (`blender --command extension validate`), which is stricter
than Install from Disk, run two ways: through the bundled extensions add-on's command-line
handler (what `--command` calls, from bpy) and as Blender's standalone CLI script
`blender_ext.py validate`. The zip made by Blender's own `extension build` (build_zip.py
--blender-ext) holds the same files and passes too.
"""

import importlib.util
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

from addon import ADDON_DIR, fake_binary

# What `blender --command extension validate PATH` runs, called from bpy as a module (which has
# no `--command`): the bundled extensions add-on's command-line handler, with Blender's tag list.
VALIDATE = """
import sys
import bpy
from bl_pkg import bl_extension_cli
sys.exit(bl_extension_cli.cli_extension_handler(["validate", sys.argv[1]]))
"""


def blender_ext_script():
    """Blender's extensions CLI script inside the bpy module (found without importing bpy)."""
    spec = importlib.util.find_spec("bpy")
    assert spec is not None and spec.origin, "bpy is not installed in this Python"
    found = sorted(Path(spec.origin).parent.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    assert found, f"no blender_ext.py under {Path(spec.origin).parent}"
    return found[-1]


def validate(path, how="handler") -> tuple[int, str]:
    """Exit code and output of Blender's extension validator on a folder or a zip: through the
    extensions add-on's handler ("handler") or the standalone blender_ext.py ("cli")."""
    if how == "handler":
        command = [sys.executable, "-c", VALIDATE, str(path)]
    else:
        command = [sys.executable, str(blender_ext_script()), "validate", str(path)]
    proc = subprocess.run(command, capture_output=True, text=True, timeout=300,
                          stdin=subprocess.DEVNULL)
    return proc.returncode, proc.stdout + proc.stderr


def load_build_zip():
    spec = importlib.util.spec_from_file_location("photon_build_zip", ADDON_DIR / "build_zip.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_zip_contents(tmp_path):
    build_zip = load_build_zip()
    binary = fake_binary(tmp_path / "photon", "sys.exit(0)\n")
    target = build_zip.build(binary, tmp_path / "dist")
    with zipfile.ZipFile(target) as z:
        names = set(z.namelist())
        manifest = tomllib.loads(z.read("blender_manifest.toml").decode())
        mode = z.getinfo("bin/photon").external_attr >> 16
    assert {"__init__.py", "engine.py", "export.py", "node_tree.py", "points_curves.py",
            "preflight.py", "runner.py", "properties.py", "ui.py", "bin/photon"} <= names
    assert manifest["id"] == "photon_render"
    assert manifest["blender_version_min"] == "4.2.0"
    assert manifest["platforms"] == [build_zip.blender_platform()]
    assert mode & 0o111, oct(mode)
    assert target.name.endswith(build_zip.blender_platform().replace("-", "_") + ".zip")


HOW = ["handler", "cli"]
# A permission text over 64 characters, as the manifest had before.
LONG_TEXT = "Export the scene to a temporary folder, run the photon renderer and read its image"


@pytest.mark.parametrize("how", HOW)
def test_blender_validator_accepts_the_source_folder(how):
    code, output = validate(ADDON_DIR, how)
    assert code == 0 and "Success" in output, output


@pytest.mark.parametrize("how", HOW)
def test_blender_validator_accepts_the_built_zip(tmp_path, how):
    binary = fake_binary(tmp_path / "photon", "sys.exit(0)\n")
    target = load_build_zip().build(binary, tmp_path / "dist")
    code, output = validate(target, how)
    assert code == 0 and "Success" in output, output


def test_blender_extension_build_makes_the_same_package(tmp_path):
    """Blender's own `extension build` (blender_ext.py build) accepts the staged package and
    its zip holds what build_zip.py writes itself, the binary executable; the validator
    accepts the result."""
    build_zip = load_build_zip()
    binary = fake_binary(tmp_path / "photon", "sys.exit(0)\n")
    ours = build_zip.build(binary, tmp_path / "ours")
    blenders = build_zip.build(binary, tmp_path / "blender", blender_ext_script())
    assert blenders.name == ours.name
    with zipfile.ZipFile(ours) as a, zipfile.ZipFile(blenders) as b:
        assert sorted(a.namelist()) == sorted(b.namelist()), (a.namelist(), b.namelist())
        for name in a.namelist():
            assert a.read(name) == b.read(name), name
        mode = b.getinfo("bin/photon").external_attr >> 16
        manifest = tomllib.loads(b.read("blender_manifest.toml").decode())
    assert mode & 0o111, oct(mode)
    assert manifest["platforms"] == [build_zip.blender_platform()]
    for how in HOW:
        code, output = validate(blenders, how)
        assert code == 0 and "Success" in output, output


def test_blender_extension_build_refusal_fails_the_build(tmp_path, monkeypatch):
    """When Blender's builder refuses the manifest, build_zip.py stops with its message."""
    build_zip = load_build_zip()
    folder = tmp_path / "addon"
    shutil.copytree(ADDON_DIR, folder, ignore=shutil.ignore_patterns("__pycache__"))
    manifest = folder / "blender_manifest.toml"
    text = manifest.read_text()
    manifest.write_text(text.replace(tomllib.loads(text)["permissions"]["files"], LONG_TEXT))
    monkeypatch.setattr(build_zip, "HERE", folder)
    binary = fake_binary(tmp_path / "photon", "sys.exit(0)\n")
    with pytest.raises(SystemExit) as refused:
        build_zip.build(binary, tmp_path / "dist", blender_ext_script())
    assert "no longer than 64 characters" in str(refused.value), refused.value


@pytest.mark.parametrize("how", HOW)
def test_blender_validator_is_strict(tmp_path, how):
    """The validator really runs: a permission text over 64 characters (as the manifest had
    before) is refused."""
    folder = tmp_path / "photon_render"
    shutil.copytree(ADDON_DIR, folder, ignore=shutil.ignore_patterns("__pycache__"))
    manifest = folder / "blender_manifest.toml"
    text = manifest.read_text()
    manifest.write_text(text.replace(tomllib.loads(text)["permissions"]["files"], LONG_TEXT))
    code, output = validate(folder, how)
    assert code != 0, output
    assert "no longer than 64 characters" in output, output
