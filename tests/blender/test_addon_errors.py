"""Failures during F12 with Photon end as a clear error from `bpy.ops.render.render()` carrying
the add-on's message, not a Python traceback from inside the add-on, and no image is written:
a missing binary, a scene the renderer rejects (a NaN in the world's environment image), a
renderer that fails, a scene without camera.
"""

import os

import bpy
import numpy as np
import pytest

from addon import fake_binary


@pytest.fixture
def small_scene(photon_addon, tmp_path):
    bpy.ops.wm.read_factory_settings()
    scene = bpy.context.scene
    scene.render.engine = "PHOTON"
    scene.render.resolution_x, scene.render.resolution_y = 32, 18
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.filepath = str(tmp_path / "out.exr")
    scene.render.use_file_extension = False
    scene.photon.samples = 4
    return scene


def render_error(scene, capfd) -> str:
    """Render and return the error text; fails if the render succeeded or raised a traceback."""
    with pytest.raises(RuntimeError) as err:
        bpy.ops.render.render(write_still=True)
    captured = capfd.readouterr()
    assert "Traceback" not in captured.err + captured.out, captured.err[-2000:]
    assert not (scene.render.filepath and os.path.exists(scene.render.filepath))
    return str(err.value)


def test_missing_binary(small_scene, monkeypatch, tmp_path, capfd):
    monkeypatch.delenv("PHOTON_BINARY", raising=False)
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    text = render_error(small_scene, capfd)
    assert "photon binary was not found" in text
    for place in ("preferences", "PHOTON_BINARY", "bin/photon", "PATH"):
        assert place in text, text


def test_binary_set_but_missing(small_scene, monkeypatch, tmp_path, capfd):
    monkeypatch.setenv("PHOTON_BINARY", str(tmp_path / "nowhere" / "photon"))
    text = render_error(small_scene, capfd)
    assert "PHOTON_BINARY" in text and "not an executable" in text, text


def test_broken_scene(small_scene, capfd, binary_env, tmp_path):
    """An environment image with a NaN texel: the add-on writes the world's image as it is
    (PHOTON_world), and the renderer refuses the file as bad input with its own message.
    (A NaN vertex is no use here: the exporter writes it as 0. This used to be a WebP texture,
    which the renderer now reads.)"""
    rgba = np.full((4, 8, 4), 0.5, np.float32)
    rgba[1, 2, 0] = np.nan
    image = bpy.data.images.new("NaNSky", 8, 4, alpha=True, float_buffer=True)
    image.pixels.foreach_set(rgba.ravel())
    image.pack()
    tree = small_scene.world.node_tree
    env = tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = image
    tree.links.new(env.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    text = render_error(small_scene, capfd)
    assert "photon failed (exit code 2, bad input)" in text, text
    assert "NaN or infinite" in text, text


def test_renderer_error_message_is_shown(small_scene, monkeypatch, tmp_path, capfd):
    fake = fake_binary(tmp_path / "photon", """
        emit(stage="load", fraction=0.0, message="loading scene")
        print("photon: error: scene.glb: material 'Material': something is wrong", file=sys.stderr)
        sys.exit(2)
        """)
    monkeypatch.setenv("PHOTON_BINARY", str(fake))
    text = render_error(small_scene, capfd)
    assert "material 'Material': something is wrong" in text, text


def test_renderer_writing_a_plain_rgba_exr_is_an_error(small_scene, monkeypatch, tmp_path, capfd):
    """Blender would load nothing from channels R, G, B, A: say so instead of a black image."""
    fake = fake_binary(tmp_path / "photon", """
        import numpy as np, OpenEXR
        out = sys.argv[sys.argv.index("-o") + 1]
        plane = np.ones((18, 32), np.float32)
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        with OpenEXR.File(header, {c: plane for c in "RGBA"}) as f:
            f.write(out)
        emit(stage="done", fraction=1.0, message="wrote", stats={})
        """)
    monkeypatch.setenv("PHOTON_BINARY", str(fake))
    text = render_error(small_scene, capfd)
    assert "no channel 'ViewLayer.Combined.R'" in text, text


def test_no_camera(small_scene, capfd, binary_env):
    """Blender itself refuses before calling the engine; the engine checks too."""
    small_scene.camera = None
    text = render_error(small_scene, capfd)
    assert "no camera" in text or "no active camera" in text, text


def test_render_region_renders_the_window_of_the_frame(small_scene, tmp_path):
    """With Render Region (no crop) Blender places the window into the full frame; inside it
    the pixels are those of the full render (Photon renders a region as a crop, bit for bit),
    outside it they are empty."""
    import numpy as np
    from refimage import read_exr

    bpy.ops.render.render(write_still=True)
    full = read_exr(small_scene.render.filepath)
    r = small_scene.render
    r.use_border, r.use_crop_to_border = True, False
    r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.25, 0.75, 0.5, 1.0
    r.filepath = str(tmp_path / "region.exr")
    bpy.ops.render.render(write_still=True)
    part = read_exr(r.filepath)
    assert part.shape == full.shape, (part.shape, full.shape)
    # Top half (border y from 0.5 to 1, origin bottom-left), middle half of the columns.
    inside = (slice(0, 9), slice(8, 24))
    assert np.array_equal(part[inside], full[inside])
    assert part[12:, :].max() == 0.0 and part[:, :6].max() == 0.0