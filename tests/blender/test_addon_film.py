"""Alpha of the render result as Cycles writes it: 1 in every pixel with an opaque film (the
background included), the geometry coverage only with Film > Transparent (0 where the camera
sees the world). The factory-default scene at 64x36, rendered through `bpy.ops.render.render()`
with Photon and with Cycles, written as RGBA EXR.
"""

import bpy
import numpy as np
import pytest

import common
import scenes_bpy
from helpers import photon_binary
from refimage import read_exr

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s

SPP = 16


@pytest.fixture
def scene(photon_addon):
    photon_binary()
    scene = scenes_bpy.default_scene()
    common.configure_cycles(scene, SPP, seed=1, threads=scenes_bpy.THREADS)
    scene.photon.samples, scene.photon.seed = SPP, 1
    settings = scene.render.image_settings
    settings.file_format, settings.color_mode = "OPEN_EXR", "RGBA"
    scene.render.use_file_extension = False
    return scene


def render_alpha(scene, engine, path):
    """The alpha channel (H, W) of the scene rendered with `engine`."""
    scene.render.engine = engine
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    return read_exr(path, ("R", "G", "B", "A"))[:, :, 3]


def test_opaque_film_gives_alpha_one_everywhere(scene, tmp_path):
    scene.render.film_transparent = False
    cycles = render_alpha(scene, "CYCLES", tmp_path / "cycles.exr")
    photon = render_alpha(scene, "PHOTON", tmp_path / "photon.exr")
    assert photon.shape == cycles.shape == (36, 64)
    assert (cycles == 1.0).all(), "Cycles itself should write alpha 1 with an opaque film"
    background = int((photon < 1.0).sum())
    assert background == 0, (f"{background} of {photon.size} pixels have alpha < 1 "
                             f"(min {photon.min():.3f}) with an opaque film")


def test_transparent_film_gives_coverage(scene, tmp_path):
    scene.render.film_transparent = True
    cycles = render_alpha(scene, "CYCLES", tmp_path / "cycles.exr")
    photon = render_alpha(scene, "PHOTON", tmp_path / "photon.exr")
    # The corners see only the world, the centre sees the cube.
    for corner in (photon[0, 0], photon[0, -1], photon[-1, 0], photon[-1, -1]):
        assert corner == 0.0, photon
    assert photon[18, 32] == 1.0, photon[18, 32]
    assert 0.05 < photon.mean() < 0.95, photon.mean()
    # Same coverage as Cycles, up to the anti-aliased edge pixels.
    diff = np.abs(photon - cycles)
    assert diff.mean() < 0.02, f"mean |alpha photon - alpha cycles| = {diff.mean():.4f}"
