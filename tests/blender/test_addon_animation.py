"""Animations render every frame in the frame's evaluated state, as `blender -b file.blend -E
PHOTON -a` (render farms) and Ctrl F12 do: `bpy.ops.render.render(animation=True)` on the
factory-default scene (64x36) whose cube moves (location keyframes), turns (a driver on its Z
rotation reading the frame) and stretches (a shape key whose value is keyframed), next to a
bar whose upper half an armature bends (a pose bone's rotation keyframed), frames 1-3.
Photon through the add-on, in both export routes, writes three images; each matches Cycles'
image of the same frame (mean within 2 %, relMSE <= 0.01) and not Cycles' image of another
frame (so a frame exported in the state of another one fails). The UI route (background
Blender) starts one exporting Blender for the whole animation, which sets each frame itself.
"""

import math

import bpy
import numpy as np
import pytest

import common
import scenes_bpy
from helpers import photon_binary, rel_mse
from refimage import read_exr

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s

PHOTON_SPP = 64
CYCLES_SPP = 256
MEAN_TOL = 0.02
RELMSE_MAX = 0.01
FRAMES = (1, 2, 3)
BAR_COLUMNS = 16


def animated_scene():
    """The factory scene with the cube keyframed (location), driven (rotation) and morphed
    (shape key) over frames 1-3."""
    scene = scenes_bpy.default_scene()
    scene.frame_start, scene.frame_end = FRAMES[0], FRAMES[-1]
    cube = bpy.data.objects["Cube"]
    # Location: keyframes at each frame, linear in between.
    for frame, x in zip(FRAMES, (-0.6, 0.2, 0.9)):
        cube.location.x = x
        cube.keyframe_insert("location", index=0, frame=frame)
    # Rotation about Z by a driver on the frame (a simple expression: no Python needed).
    driver = cube.driver_add("rotation_euler", 2).driver
    driver.type = "SCRIPTED"
    driver.expression = "(frame - 1) * 0.35"
    # A shape key lifting the top face by 1 m, keyframed 0 -> 0.5 -> 1.
    cube.shape_key_add(name="Basis")
    key = cube.shape_key_add(name="Tall")
    for point in key.data:
        if point.co.z > 0:
            point.co.z += 1.0
    for frame, value in zip(FRAMES, (0.0, 0.5, 1.0)):
        key.value = value
        key.keyframe_insert("value", frame=frame)
    add_bent_bar()
    scene.frame_set(FRAMES[0])
    return scene


def add_bent_bar():
    """A 0.4 x 0.4 x 2 m bar at (-2.2, -1.2, 0) (4 segments high) whose upper vertices follow one
    bone of an armature at the bar's middle; the bone turns by 0, 30 and 60 degrees about X."""
    bpy.ops.mesh.primitive_cube_add(location=(-2.2, -1.2, 0.0))
    bar = bpy.context.active_object
    bar.scale = (0.2, 0.2, 1.0)
    bpy.ops.object.transform_apply(scale=True)
    for edge in bar.data.edges:  # cut the four vertical edges so the bar can bend
        a, b = (bar.data.vertices[i].co for i in edge.vertices)
        edge.select = abs(a.z - b.z) > 1.0
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.subdivide(number_cuts=3)
    bpy.ops.object.mode_set(mode="OBJECT")
    group = bar.vertex_groups.new(name="Bone")
    group.add([v.index for v in bar.data.vertices if v.co.z > 0.01], 1.0, "REPLACE")
    bpy.ops.object.armature_add(location=(-2.2, -1.2, 0.0))
    rig = bpy.context.active_object
    modifier = bar.modifiers.new("Armature", "ARMATURE")
    modifier.object = rig
    bone = rig.pose.bones["Bone"]
    bone.rotation_mode = "XYZ"
    for frame, degrees in zip(FRAMES, (0.0, 30.0, 60.0)):
        bone.rotation_euler.x = math.radians(degrees)
        bone.keyframe_insert("rotation_euler", index=0, frame=frame)


def render_animation(scene, engine, folder):
    """Render frames 1-3 with `engine` through `bpy.ops.render.render(animation=True)` into
    `folder`; returns the images by frame."""
    scene.render.engine = engine
    scene.render.filepath = str(folder / "frame_")
    scene.render.use_file_extension = True
    bpy.ops.render.render(animation=True)
    images = {}
    for frame in FRAMES:
        path = folder / f"frame_{frame:04d}.exr"
        assert path.is_file(), f"{engine} wrote no image for frame {frame} ({sorted(folder.iterdir())})"
        images[frame] = read_exr(path)
    return images


@pytest.fixture(scope="module")
def cycles_frames(photon_addon, tmp_path_factory):
    scene = animated_scene()
    common.configure_cycles(scene, CYCLES_SPP, seed=1, threads=scenes_bpy.THREADS)
    return render_animation(scene, "CYCLES", tmp_path_factory.mktemp("cycles"))


@pytest.mark.parametrize("route", ["inprocess", "subprocess"])
def test_animation_renders_each_frame_as_cycles(photon_addon, cycles_frames, tmp_path,
                                                 monkeypatch, route):
    photon_binary()
    monkeypatch.setenv("PHOTON_EXPORT", route)
    scene = animated_scene()
    common.configure_cycles(scene, CYCLES_SPP, seed=1, threads=scenes_bpy.THREADS)
    scene.photon.samples, scene.photon.seed, scene.photon.method = PHOTON_SPP, 1, "PATH"
    starts = photon_addon.engine.ANIMATION_EXPORT.starts
    photon = render_animation(scene, "PHOTON", tmp_path)
    # The UI route starts one background Blender for the whole animation, not one per frame,
    # and it has ended with the render job; in process, none.
    assert photon_addon.engine.ANIMATION_EXPORT.starts - starts == (route == "subprocess")
    assert photon_addon.engine.ANIMATION_EXPORT._server is None
    # The frames really differ (the cube moves, turns and grows by a visible amount).
    assert rel_mse(cycles_frames[1], cycles_frames[3]) > 20 * RELMSE_MAX
    for frame in FRAMES:
        img, ref = photon[frame], cycles_frames[frame]
        assert img.shape == ref.shape == (36, 64, 3)
        assert np.isfinite(img).all()
        err = rel_mse(img, ref)
        diff = float(img.mean() / ref.mean()) - 1.0
        others = {f: rel_mse(img, cycles_frames[f]) for f in FRAMES if f != frame}
        msg = (f"{route}, frame {frame}: mean photon {img.mean():.5f} vs cycles "
               f"{ref.mean():.5f} ({100 * diff:+.2f} %), relMSE {err:.5f}; against Cycles' "
               f"other frames: " + ", ".join(f"{f}: {e:.4f}" for f, e in others.items()))
        print(msg)
        assert abs(diff) <= MEAN_TOL, msg
        assert err <= RELMSE_MAX, msg
        assert min(others.values()) > 5 * err, msg
        # The bar alone (the image's left quarter, where the cube never is) is in the pose of
        # this frame: the armature's deformation is exported per frame.
        bar = rel_mse(img[:, :BAR_COLUMNS], ref[:, :BAR_COLUMNS])
        bar_others = [rel_mse(img[:, :BAR_COLUMNS], cycles_frames[f][:, :BAR_COLUMNS])
                      for f in others]
        msg += f"; bar: relMSE {bar:.4f}, against other frames {min(bar_others):.4f}"
        print(msg)
        assert bar <= RELMSE_MAX, msg
        assert min(bar_others) > 5 * bar, msg
