"""Blender's shadow catcher (Object > Visibility > Shadow Catcher) with a transparent film,
against Cycles' Combined pass through the add-on.

A diffuse sphere on a floor that is a shadow catcher, under a sun and a dim world, 64x64, path
tracer 512 spp against Cycles 1024 spp: where the floor is seen the image is transparent but
for the sphere's shadow (alpha 1 - the light the floor keeps, colour 0), the sphere as usual.
Colour and alpha each match (mean within 1 % of Cycles', 4x4-block relMSE of RGBA at most
0.001); rendered as an ordinary floor (the export's shadow_catcher removed) they do not.

Cycles' Shadow Catcher pass (View Layer > Passes > Shadow Catcher: the light the catcher keeps
of what it receives without the other objects, over white by the pixel's alpha) of the same
scene matches too (mean within 1 %, 4x4-block relMSE at most 0.001; before Photon wrote it,
Blender left it black), and is white without a catcher.
"""

from contextlib import contextmanager

import numpy as np
import pytest

import common
import scenes_bpy
from helpers import rel_mse
from refimage import read_exr
from test_clamp import SIZE, blocks, sphere

MEAN_TOL = 0.01
BLOCK_RELMSE_MAX = 0.001


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def catcher_scene():
    scene = common.reset_scene(SIZE, SIZE)
    floor = common.principled("Floor", (0.8, 0.8, 0.8), roughness=1.0)
    catcher = common.quad("Floor", [(-4, -4, 0), (4, -4, 0), (4, 4, 0), (-4, 4, 0)], floor)
    catcher.is_shadow_catcher = True
    red = common.principled("Red", (0.8, 0.2, 0.1), roughness=0.5)
    sphere("Sphere", red, (0.0, 0.0, 0.5))
    common.light("Sun", "SUN", (0, 0, 5), (40.0, 0.0, 30.0), energy=3.0, angle=0.05)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.2, 0.25, 0.3, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    common.camera("Camera", (0.0, -3.6, 2.4), (58.0, 0.0, 0.0), 40.0)
    return scene


@contextmanager
def transparent_film():
    """Renders configured by `common.configure_cycles` with a transparent film, RGBA."""
    configure = common.configure_cycles

    def transparent(scene, samples, seed, threads):
        settings = configure(scene, samples, seed, threads)
        scene.render.film_transparent = True
        scene.render.image_settings.color_mode = "RGBA"
        return settings

    common.configure_cycles = transparent
    try:
        yield
    finally:
        common.configure_cycles = configure


def render_rgba(scene, engine, path, samples):
    """`scenes_bpy.render` with a transparent film, RGBA."""
    with transparent_film():
        scenes_bpy.render(scene, engine, path, samples)
    return read_exr(path, ("R", "G", "B", "A"))


def shadow_catcher_pass(scene, engine, path, samples):
    """The view layer's Shadow Catcher pass (H x W x RGB), rendered with a transparent film."""
    with transparent_film():
        channels = scenes_bpy.render_layers(scene, engine, path, samples)
    name = f"{scene.view_layers[0].name}.Shadow Catcher"
    planes = [np.asarray(channels[f"{name}.{c}"]).reshape(SIZE, SIZE) for c in "RGB"]
    return np.stack(planes, axis=-1)


def render_photon_without_catcher(scene, path, samples):
    from blender_addon import export

    extension = export.visibility_extension

    def without(obj):
        data = extension(obj)
        data.pop("shadow_catcher", None)
        return data

    export.visibility_extension = without
    try:
        return render_rgba(scene, "PHOTON", path, samples)
    finally:
        export.visibility_extension = extension


def agreement(img, ref):
    colour = float(img[..., :3].mean() / ref[..., :3].mean()) - 1.0
    alpha = float(img[..., 3].mean() / ref[..., 3].mean()) - 1.0
    return colour, alpha, rel_mse(blocks(img), blocks(ref))


@pytest.mark.slow
def test_shadow_catcher_matches_cycles(tmp_path):
    scene = catcher_scene()
    ref = render_rgba(scene, "CYCLES", tmp_path / "cycles.exr", 1024)
    scene.photon.method = "PATH"
    img = render_rgba(scene, "PHOTON", tmp_path / "photon.exr", 512)
    plain = render_photon_without_catcher(scene, tmp_path / "plain.exr", 512)
    assert np.isfinite(img).all()
    colour, alpha, err = agreement(img, ref)
    colour_off, alpha_off, err_off = agreement(plain, ref)
    msg = (f"shadow catcher: colour mean {img[..., :3].mean():.5f} vs cycles "
           f"{ref[..., :3].mean():.5f} ({100 * colour:+.2f} %), alpha mean "
           f"{img[..., 3].mean():.5f} vs {ref[..., 3].mean():.5f} ({100 * alpha:+.2f} %), "
           f"4x4-block relMSE {err:.5f}; as a plain floor {100 * colour_off:+.2f} %, "
           f"{100 * alpha_off:+.2f} %, {err_off:.5f}")
    print(msg)
    assert abs(colour) <= MEAN_TOL and abs(alpha) <= MEAN_TOL, msg
    assert err <= BLOCK_RELMSE_MAX, msg
    assert abs(colour_off) > MEAN_TOL or err_off > BLOCK_RELMSE_MAX, msg


@pytest.mark.slow
def test_shadow_catcher_pass_matches_cycles(tmp_path):
    scene = catcher_scene()
    scene.view_layers[0].cycles.use_pass_shadow_catcher = True
    scene.photon.method = "PATH"
    ref = shadow_catcher_pass(scene, "CYCLES", tmp_path / "cycles.exr", 1024)
    img = shadow_catcher_pass(scene, "PHOTON", tmp_path / "photon.exr", 512)
    assert np.isfinite(img).all()
    mean = float(img.mean() / ref.mean()) - 1.0
    err = rel_mse(blocks(img), blocks(ref))
    msg = (f"shadow catcher pass: mean {img.mean():.5f} vs cycles {ref.mean():.5f} "
           f"({100 * mean:+.2f} %), min {img.min():.4f} vs {ref.min():.4f}, 4x4-block relMSE "
           f"{err:.5f}")
    print(msg)
    assert abs(mean) <= MEAN_TOL, msg
    assert err <= BLOCK_RELMSE_MAX, msg
    # Without a shadow catcher the pass is white, as Cycles leaves it (the file has none).
    scene.objects["Floor"].is_shadow_catcher = False
    white = shadow_catcher_pass(scene, "PHOTON", tmp_path / "plain.exr", 4)
    assert (white == 1.0).all(), (white.min(), white.max())
