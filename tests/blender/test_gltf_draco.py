"""`KHR_draco_mesh_compression` files against Blender: each file of tests/data/draco (written by
Blender's own exporter, or by glTF Transform, see its README) is imported by Blender's glTF
importer, which decodes Draco with the Draco library Blender bundles, and rendered by Cycles,
and rendered by `photon render --camera Camera`, which decodes it with Photon's own decoder; the
mean must agree within 1 % and the relMSE of 4x4-pixel block means be at most 0.01, at 48x48
pixels (`test_gltf_import.compare_with_blender`)."""

from pathlib import Path

import pytest

from test_gltf_import import compare_with_blender

DATA = Path(__file__).resolve().parents[1] / "data" / "draco"


@pytest.mark.parametrize("name", ["plain.glb", "level6.glb", "level10.glb", "gltf_transform.glb"])
def test_draco_file_renders_as_blenders_import(tmp_path, name):
    compare_with_blender(DATA / name, tmp_path, photon_args=["--method", "path"])
