"""Motion blur as Cycles renders it (PHOTON_camera and PHOTON_object "motion"): a camera, and
objects, sliding, turning and growing while the shutter is open, their poses at the shutter's
opening, middle and closing exported, each sample taking a moment within it; moving objects of
any material (glass, emissive, a node tree) and Geometry Nodes instances under a moving object.
Rendered by Cycles and by Photon through the add-on at 48x32: mean within 2 % and relMSE <=
0.01, and further from the unblurred image.
"""

import math

import bpy
from bpy_extras.anim_utils import action_get_channelbag_for_slot

import pytest

import common
import scenes_bpy
from cycles_compare import compare
from helpers import rel_mse


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def fcurves(animation_data):
    """The F-curves of the action animating `animation_data` (its slot's channel bag: Blender 5
    no longer has Action.fcurves)."""
    bag = action_get_channelbag_for_slot(animation_data.action, animation_data.action_slot)
    return bag.fcurves


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
    for fcurve in fcurves(camera.animation_data):
        for key in fcurve.keyframe_points:
            key.interpolation = "LINEAR"
    scene.frame_set(1, subframe=0.5)
    scene.render.use_motion_blur = True
    scene.render.motion_blur_shutter = 0.5
    scene.render.motion_blur_position = position
    return scene


def compare_blurred(name, scene, tmp_path, glint=None):
    """`compare` (leaving out pixels above `glint` if given), then check that Photon's image
    without motion blur is more than 3 times further from Cycles' blurred one."""
    img, ref = compare(name, scene, tmp_path, glint=glint)
    scene.render.use_motion_blur = False
    still = scenes_bpy.render(scene, "PHOTON", tmp_path / "still.exr", 256)
    if glint is not None:
        # The pixels `compare` left out (and those black in both): 0 here too.
        still[(img.max(axis=-1) == 0.0) & (ref.max(axis=-1) == 0.0)] = 0.0
    away = rel_mse(still, ref)
    print(f"{name}: unblurred against Cycles' blurred image: relMSE {away:.5f}")
    assert away > 3 * rel_mse(img, ref), away


@pytest.mark.slow
@pytest.mark.parametrize("position", ["CENTER", "START"])
def test_camera_motion_blur(tmp_path, position):
    scene = sliding_camera_scene(position)
    compare_blurred(f"camera motion blur ({position.lower()})", scene, tmp_path)


def test_deforming_curves_are_named_by_the_preflight():
    """With motion blur on, a curve object whose shape keys are animated is named (only
    meshes' deformation is blurred); a mesh with animated shape keys and keyframed transforms,
    the camera's and a box's, are not (they are blurred)."""
    from blender_addon import preflight
    scene = sliding_camera_scene("CENTER")
    box = scene.objects["Box1"]
    box.keyframe_insert("location", frame=1)
    box.shape_key_add(name="Basis")
    box.shape_key_add(name="Taller").keyframe_insert("value", frame=1)
    assert preflight.unsupported_features(scene, scene.objects) == []
    curve = bpy.data.objects.new("Wire", bpy.data.curves.new("Wire", "CURVE"))
    curve.data.splines.new("POLY").points.add(1)
    scene.collection.objects.link(curve)
    curve.shape_key_add(name="Basis")
    curve.shape_key_add(name="Bent").keyframe_insert("value", frame=1)
    messages = preflight.unsupported_features(scene, scene.objects)
    assert len(messages) == 1 and "'Wire'" in messages[0] and "motion blur" in messages[0]
    scene.render.use_motion_blur = False
    assert preflight.unsupported_features(scene, scene.objects) == []


@pytest.mark.slow
@pytest.mark.parametrize("position", ["CENTER", "END"])
def test_object_motion_blur(tmp_path, position):
    """A still camera; the middle box slides 2 m sideways and turns 60° per frame, the left one
    grows by half: both blurred over the shutter as Cycles blurs them."""
    scene = sliding_camera_scene(position)
    camera = scene.objects["Camera"]
    camera.animation_data_clear()
    camera.location.x, camera.rotation_euler.z = 0.0, 0.0
    slide = [(1, "location", (1.0, 0.5, 0.0)), (2, "location", (-1.0, 0.5, 0.0)),
             (1, "rotation_euler", (0.0, 0.0, 0.0)),
             (2, "rotation_euler", (0.0, 0.0, math.radians(60.0)))]
    grow = [(1, "scale", (1.0, 1.0, 1.0)), (2, "scale", (1.5, 1.5, 1.5))]
    for name, keys in (("Box1", slide), ("Box0", grow)):
        box = scene.objects[name]
        for frame, path, value in keys:
            setattr(box, path, value)
            box.keyframe_insert(path, frame=frame)
        for fcurve in fcurves(box.animation_data):
            for key in fcurve.keyframe_points:
                key.interpolation = "LINEAR"
    scene.frame_set(1, subframe=0.5)
    compare_blurred(f"object motion blur ({position.lower()})", scene, tmp_path)


def animate(obj, keys):
    """Linear keys (frame, data path, value) on `obj`."""
    for frame, path, value in keys:
        setattr(obj, path, value)
        obj.keyframe_insert(path, frame=frame)
    for fcurve in fcurves(obj.animation_data):
        for key in fcurve.keyframe_points:
            key.interpolation = "LINEAR"


# The middle box's motion over one frame: 2 m sideways and a 60° turn.
SLIDE = [(1, "location", (1.0, 0.5, 0.0)), (2, "location", (-1.0, 0.5, 0.0)),
         (1, "rotation_euler", (0.0, 0.0, 0.0)),
         (2, "rotation_euler", (0.0, 0.0, math.radians(60.0)))]


def still_camera_scene():
    """`sliding_camera_scene` with the camera kept still, the shutter centred on frame 1.5."""
    scene = sliding_camera_scene("CENTER")
    camera = scene.objects["Camera"]
    camera.animation_data_clear()
    camera.location.x, camera.rotation_euler.z = 0.0, 0.0
    return scene


def glass():
    mat = common.principled("Glass", (1.0, 0.55, 0.25), roughness=0.0)
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Transmission Weight"].default_value = 1.0
    bsdf.inputs["IOR"].default_value = 1.45
    return mat


def emissive():
    return common.principled("Glow", (0.2, 0.2, 0.2), emission_color=(1.0, 0.5, 0.2),
                             emission_strength=6.0)


def checker():
    """A node tree glTF cannot carry: a Checker Texture on the object's Generated coordinates
    (it moves with the object) into the base colour."""
    mat = common.principled("Checker", (0.8, 0.8, 0.8))
    tree = mat.node_tree
    tex = tree.nodes.new("ShaderNodeTexChecker")
    tex.inputs["Scale"].default_value = 3.0
    tex.inputs["Color1"].default_value = (0.9, 0.9, 0.9, 1.0)
    tex.inputs["Color2"].default_value = (0.05, 0.2, 0.8, 1.0)
    coords = tree.nodes.new("ShaderNodeTexCoord")
    tree.links.new(coords.outputs["Generated"], tex.inputs["Vector"])
    tree.links.new(tex.outputs["Color"], tree.nodes["Principled BSDF"].inputs["Base Color"])
    return mat


# The turning glass box shows the sun's disc (0.5°, radiance ~5·10⁴) to a rare camera sample
# (through two faces at an angle, or mirrored): a real path that neither engine converges at
# these samples. Cycles 5.0's reference at seed 1 holds one such sample (a pixel of 5.6, the
# image mean +6 %); at seeds 2-4, and Cycles 4.5's at seeds 1-4, none (every other pixel
# below 0.48, means 0.0589 ± 0.0001). Pixels above 1 in either image are left out.
GLINT = 1.0


@pytest.mark.slow
@pytest.mark.parametrize("material", [glass, emissive, checker])
def test_moving_objects_of_any_material_are_blurred(tmp_path, material):
    """The middle box, glass, emitting or textured by a node tree, slides and turns while the
    shutter is open: blurred as Cycles blurs it (moving emitters lighting the floor where they
    are at each moment)."""
    scene = still_camera_scene()
    box = scene.objects["Box1"]
    box.data.materials[0] = material()
    animate(box, SLIDE)
    scene.frame_set(1, subframe=0.5)
    glint = GLINT if material is glass else None
    compare_blurred(f"moving {material.__name__} box", scene, tmp_path, glint=glint)


def scatter(scene, moving_points=False):
    """A grid whose Geometry Nodes instance a gold box on its points (the box's collection
    disabled for rendering); with `moving_points`, the points rise with the scene time."""
    for name in ("Box0", "Box1", "Box2"):
        bpy.data.objects.remove(scene.objects[name])
    source = bpy.data.collections.new("Source")
    scene.collection.children.link(source)
    source.hide_render = True
    pebble = common.box("Pebble", (0.25, 0.25, 0.5), common.principled("Gold", (0.9, 0.6, 0.1)),
                        (0.0, 0.0, 0.0), 0.0)
    scene.collection.objects.unlink(pebble)
    source.objects.link(pebble)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=3, y_subdivisions=2, size=1.2,
                                    location=(0.0, 0.5, 0.01))
    grid = bpy.context.active_object
    scenes_bpy.instance_on_points(grid, pebble, rise_with_time=moving_points)
    return grid


@pytest.mark.slow
def test_moving_geometry_nodes_instances_are_blurred(tmp_path):
    """A Geometry Nodes scatter (boxes instanced on a grid's points) whose object slides and
    turns: its instances move with it."""
    scene = still_camera_scene()
    grid = scatter(scene)
    animate(grid, [(k, path, value if path != "location" else (value[0], 0.5, 0.01))
                   for k, path, value in SLIDE])
    scene.frame_set(1, subframe=0.5)
    compare_blurred("moving geometry nodes instances", scene, tmp_path)


def test_instances_moving_on_their_own_are_named(tmp_path):
    """Instances that move within the shutter relative to the object instancing them (points
    rising with the scene time) are named by the export's warnings: only the instancer's own
    motion is carried."""
    from blender_addon import export
    scene = still_camera_scene()
    scatter(scene, moving_points=True)
    scene.frame_set(1, subframe=0.5)
    warnings = export.export_in_process(tmp_path / "rising.glb", "blender_addon")
    assert any("'Grid'" in w and "on their own" in w for w in warnings), warnings
    scene.render.use_motion_blur = False
    warnings = export.export_in_process(tmp_path / "still.glb", "blender_addon")
    assert not any("on their own" in w for w in warnings), warnings


@pytest.mark.slow
def test_shape_key_deformation_is_blurred(tmp_path):
    """The middle box's shape key, keyed from 0 to 1 over a frame, stretches its top 1.2 m
    sideways and 0.6 m up: the vertices are exported at the shutter's steps and interpolated
    at each sample's moment, as Cycles' deformation blur does."""
    scene = still_camera_scene()
    box = scene.objects["Box1"]
    box.shape_key_add(name="Basis")
    key = box.shape_key_add(name="Lean")
    for vertex in key.data:
        if vertex.co.z > 0.5:
            vertex.co.x += 1.2
            vertex.co.z += 0.6
    for frame, value in ((1, 0.0), (2, 1.0)):
        key.value = value
        key.keyframe_insert("value", frame=frame)
    for fcurve in fcurves(box.data.shape_keys.animation_data):
        for point in fcurve.keyframe_points:
            point.interpolation = "LINEAR"
    scene.frame_set(1, subframe=0.5)
    compare_blurred("shape key deformation", scene, tmp_path)


@pytest.mark.slow
def test_armature_deformation_is_blurred(tmp_path):
    """The middle box's top, bound to a bone that bends 100° about the x axis over a frame:
    an armature deformation blurred over the shutter as Cycles blurs it."""
    scene = still_camera_scene()
    box = scene.objects["Box1"]
    rig = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
    scene.collection.objects.link(rig)
    rig.location = box.location
    bpy.context.view_layer.objects.active = rig
    bpy.ops.object.mode_set(mode="EDIT")
    bone = rig.data.edit_bones.new("Top")
    bone.head, bone.tail = (0.0, 0.0, 0.5), (0.0, 0.0, 1.0)
    bpy.ops.object.mode_set(mode="OBJECT")
    group = box.vertex_groups.new(name="Top")
    group.add([v.index for v in box.data.vertices if v.co.z > 0.5], 1.0, "REPLACE")
    box.modifiers.new("Armature", "ARMATURE").object = rig
    pose = rig.pose.bones["Top"]
    pose.rotation_mode = "XYZ"
    for frame, angle in ((1, 0.0), (2, 100.0)):
        pose.rotation_euler = (math.radians(angle), 0.0, 0.0)
        pose.keyframe_insert("rotation_euler", frame=frame)
    for fcurve in fcurves(rig.animation_data):
        for point in fcurve.keyframe_points:
            point.interpolation = "LINEAR"
    scene.frame_set(1, subframe=0.5)
    compare_blurred("armature deformation", scene, tmp_path)


def test_object_motion_steps_and_switch_are_read(tmp_path):
    """An object's Motion Blur steps (2: five poses over the shutter) and its Motion Blur
    switch (off: exported still), as Cycles reads them."""
    from blender_addon import export
    import json
    import struct
    scene = still_camera_scene()
    for name in ("Box0", "Box1"):
        animate(scene.objects[name], SLIDE)
    scene.objects["Box0"].cycles.motion_steps = 2
    scene.objects["Box1"].cycles.use_motion_blur = False
    scene.frame_set(1, subframe=0.5)
    glb = tmp_path / "steps.glb"
    export.export_in_process(glb, "blender_addon")
    data = glb.read_bytes()
    doc = json.loads(data[20:20 + struct.unpack("<I", data[12:16])[0]])
    motion = {node["name"]: node.get("extensions", {}).get("PHOTON_object", {}).get("motion")
              for node in doc["nodes"]}
    assert len(motion["Box0"]) == 5 and motion["Box1"] is None, motion
