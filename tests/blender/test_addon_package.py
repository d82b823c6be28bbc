"""blender_addon/build_zip.py: the extension zip holds the manifest (with this platform), the
add-on's modules and the binary as an executable bin/photon. The source folder and the zip pass
Blender's own extension validator (`blender --command extension validate`), which is stricter
than Install from Disk.
"""

import importlib.util
import shutil
import subprocess
import sys
import tomllib
import zipfile

from addon import ADDON_DIR, fake_binary

# What `blender --command extension validate PATH` runs, called from bpy as a module (which has
# no `--command`): the bundled extensions add-on's command-line handler, with Blender's tag list.
VALIDATE = """
import sys
import bpy
from bl_pkg import bl_extension_cli
sys.exit(bl_extension_cli.cli_extension_handler(["validate", sys.argv[1]]))
"""


def validate(path) -> tuple[int, str]:
    """Exit code and output of Blender's extension validator on a folder or a zip."""
    proc = subprocess.run([sys.executable, "-c", VALIDATE, str(path)], capture_output=True,
                          text=True, timeout=300, stdin=subprocess.DEVNULL)
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
    assert {"__init__.py", "engine.py", "export.py", "node_tree.py", "preflight.py", "runner.py",
            "properties.py", "ui.py", "bin/photon"} <= names
    assert manifest["id"] == "photon_render"
    assert manifest["blender_version_min"] == "4.2.0"
    assert manifest["platforms"] == [build_zip.blender_platform()]
    assert mode & 0o111, oct(mode)
    assert target.name.endswith(build_zip.blender_platform().replace("-", "_") + ".zip")


def test_blender_validator_accepts_the_source_folder():
    code, output = validate(ADDON_DIR)
    assert code == 0 and "Success" in output, output


def test_blender_validator_accepts_the_built_zip(tmp_path):
    binary = fake_binary(tmp_path / "photon", "sys.exit(0)\n")
    target = load_build_zip().build(binary, tmp_path / "dist")
    code, output = validate(target)
    assert code == 0 and "Success" in output, output


def test_blender_validator_is_strict(tmp_path):
    """The validator really runs: a permission text over 64 characters (as the manifest had
    before) is refused."""
    folder = tmp_path / "photon_render"
    shutil.copytree(ADDON_DIR, folder, ignore=shutil.ignore_patterns("__pycache__"))
    manifest = folder / "blender_manifest.toml"
    text = manifest.read_text()
    long_text = "Export the scene to a temporary folder, run the photon renderer and read its image"
    manifest.write_text(text.replace(tomllib.loads(text)["permissions"]["files"], long_text))
    code, output = validate(folder)
    assert code != 0, output
    assert "no longer than 64 characters" in output, output
