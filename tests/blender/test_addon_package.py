"""blender_addon/build_zip.py: the extension zip holds the manifest (with this platform), the
add-on's modules and the binary as an executable bin/photon. No bpy needed.
"""

import importlib.util
import tomllib
import zipfile

from addon import ADDON_DIR, fake_binary


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
    assert {"__init__.py", "engine.py", "export.py", "runner.py", "properties.py", "ui.py",
            "bin/photon"} <= names
    assert manifest["id"] == "photon_render"
    assert manifest["blender_version_min"] == "4.2.0"
    assert manifest["platforms"] == [build_zip.blender_platform()]
    assert mode & 0o111, oct(mode)
    assert target.name.endswith(build_zip.blender_platform().replace("-", "_") + ".zip")
