"""Camera motion blur as Cycles renders it (PHOTON_camera "motion"): a camera sliding and
turning while the shutter is open, its poses at the shutter's opening, middle and closing
exported, each sample taking a moment within it. Rendered by Cycles and by Photon through the
add-on at 48x32: mean within 2 % and relMSE <= 0.01, and further from a still camera's image.
"""

import math

import pytest

import common
import scenes_bpy
from cycles_compare import compare
from helpers import rel_mse


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def sliding_camera_scene(position):
    """White boxes on a dark floor under a sun; the camera slides 0.8 m sideways and turns 6°
    from frame 1 to frame 2 (linear keys), rendered at frame 1.5 with a shutter of 0.5 frames
    placed at `position`."""
    scene = common.reset_scene(48, 32)
    dark = common.principled("Dark", (0.1, 0.1, 0.1))
    white = common.principled("White", (0.9, 0.9, 0.9))
    common.quad("Floor", [(-6, -6, 0), (6, -6, 0), (6, 6, 0), (-6, 6, 0)], dark)
    for i, x in enumerate((-1.2, 0.0, 1.2)):
        common.box(f"Box{i}", (0.3, 0.3, 1.0), white, (x, 0.5 * i, 0.0), 10.0 * i)
    common.light("Sun", "SUN", (0, 0, 5), (30.0, 0.0, 20.0), energy=3.0)
    camera = common.camera("Camera", (-0.4, -5.0, 1.5), (80.0, 0.0, 3.0), 50.0)
    for frame, x, turn in ((1, -0.4, 3.0), (2, 0.4, -3.0)):
        camera.location.x = x
        camera.rotation_euler.z = math.radians(turn)
        camera.keyframe_insert("location", frame=frame)
        camera.keyframe_insert("rotation_euler", frame=frame)
    for fcurve in camera.animation_data.action.fcurves:
        for key in fcurve.keyframe_points:
            key.interpolation = "LINEAR"
    scene.frame_set(1, subframe=0.5)
    scene.render.use_motion_blur = True
    scene.render.motion_blur_shutter = 0.5
    scene.render.motion_blur_position = position
    return scene


@pytest.mark.parametrize("position", ["CENTER", "START"])
def test_camera_motion_blur(tmp_path, position):
    scene = sliding_camera_scene(position)
    img, ref = compare(f"camera motion blur ({position.lower()})", scene, tmp_path)
    scene.render.use_motion_blur = False
    still = scenes_bpy.render(scene, "PHOTON", tmp_path / "still.exr", 256)
    away = rel_mse(still, ref)
    print(f"still camera against Cycles' blurred image: relMSE {away:.5f}")
    assert away > 3 * rel_mse(img, ref), away


def test_moving_objects_are_named_by_the_preflight():
    """With motion blur on, a keyframed object is named (it is not blurred); the camera's own
    keys are not (its motion is)."""
    from blender_addon import preflight
    scene = sliding_camera_scene("CENTER")
    assert preflight.unsupported_features(scene, scene.objects) == []
    box = scene.objects["Box1"]
    box.keyframe_insert("location", frame=1)
    messages = preflight.unsupported_features(scene, scene.objects)
    assert len(messages) == 1 and "'Box1'" in messages[0] and "motion blur" in messages[0]
    scene.render.use_motion_blur = False
    assert preflight.unsupported_features(scene, scene.objects) == []
