"""Motion blur: the poses and deformation of the camera and objects over the shutter, as Cycles
samples them.

`shutter_poses_recorded(scene)` steps the scene through the shutter before an export and fills
SHUTTER_POSES (world matrices of the camera and of moving objects) and DEFORM_STEPS (vertex
positions of deforming meshes), which the export's hooks write as "motion" and "deform" of
PHOTON_camera and PHOTON_object. Of the add-on's modules it imports only shared.py: it
runs in the export's child process too.
"""

from __future__ import annotations

import base64
import contextlib
import math

import bpy
import mathutils

try:
    from .shared import GEOMETRY_TYPES, LOG
except ImportError:  # loaded by export.py as a top-level module in the export's child process
    from shared import GEOMETRY_TYPES, LOG

# World matrices over the shutter (the camera's and moving objects'), by object name, while
# `shutter_poses_recorded` runs.
SHUTTER_POSES: dict[str, list[list[float]]] = {}
# Blender (x, y, z) is glTF (x, z, −y).
Z_UP_TO_Y_UP = mathutils.Matrix(((1, 0, 0, 0), (0, 0, 1, 0), (0, -1, 0, 0), (0, 0, 0, 1)))


def shutter_times(scene) -> list[float]:
    """Frame times of the shutter's opening, middle and closing, as Cycles places them: the
    shutter (in frames) centred on the frame, starting or ending at it."""
    r = scene.render
    length = float(r.motion_blur_shutter)
    start = {"START": 0.0, "END": -length}.get(r.motion_blur_position, -0.5 * length)
    frame = scene.frame_current + scene.frame_subframe
    return [frame + start + k * 0.5 * length for k in range(3)]


def instances_in_their_instancers() -> dict:
    """The depsgraph's instances (particles, Geometry Nodes) now: their matrices relative to
    the object instancing them, rounded to 1e-5, by (instancer name, persistent id)."""
    placed = {}
    depsgraph = bpy.context.evaluated_depsgraph_get()
    for instance in depsgraph.object_instances:
        if not instance.is_instance or instance.parent is None:
            continue
        relative = instance.parent.matrix_world.inverted_safe() @ instance.matrix_world
        key = (instance.parent.name, tuple(instance.persistent_id))
        placed[key] = tuple(round(x, 5) for row in relative for x in row)
    return placed


# Deforming meshes' vertex positions over the shutter, by object name, while
# `shutter_poses_recorded` runs: PHOTON_object's "deform".
DEFORM_STEPS: dict[str, dict] = {}


def deforms(obj) -> bool:
    """Whether `obj`'s geometry changes with time: an armature modifier, or shape keys with
    keyframes or drivers."""
    obj = getattr(obj, "original", obj)  # the depsgraph's copy has its shape keys applied
    if any(m.type == "ARMATURE" for m in getattr(obj, "modifiers", ())):
        return True
    keys = getattr(getattr(obj, "data", None), "shape_keys", None)
    data = keys.animation_data if keys is not None else None
    return data is not None and (data.action is not None or len(data.drivers) > 0)


def deform_step_count(obj) -> int:
    """The moments at which Cycles samples `obj`'s motion and deformation: 2^(steps - 1) * 2 + 1
    for the object's motion blur steps (Object > Motion Blur > Steps; 3 by default)."""
    steps = max(1, int(getattr(getattr(obj, "cycles", None), "motion_steps", 1)))
    return (2 << (steps - 1)) + 1


def deforms_with_blur(obj) -> bool:
    """Whether `obj` is a mesh whose deformation (armature, animated shape keys) is blurred:
    Cycles' Object > Motion Blur and its Deformation switch on."""
    cycles = getattr(obj, "cycles", None)
    return (obj.type == "MESH" and deforms(obj)
            and getattr(cycles, "use_motion_blur", True)
            and getattr(cycles, "use_deform_motion", True))


def evaluated_positions(obj) -> str:
    """`obj`'s evaluated mesh vertices now (object space, glTF axes (x, z, -y)) as base64 of
    little-endian float32 triples, as the glTF exporter writes them."""
    import numpy as np
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = evaluated.to_mesh()
    try:
        co = np.empty(3 * len(mesh.vertices), dtype=np.float32)
        mesh.vertices.foreach_get("co", co)
    finally:
        evaluated.to_mesh_clear()
    co = co.reshape(-1, 3)
    gltf = np.stack([co[:, 0], co[:, 2], -co[:, 1]], axis=1).astype("<f4")
    return base64.b64encode(gltf.tobytes()).decode("ascii")


def deformation_recorded(scene, objects) -> dict[str, dict]:
    """PHOTON_object's "deform" of each deforming mesh of `objects`: its vertices at the frame
    and at `deform_step_count` moments evenly spread over the shutter. A mesh whose vertex count
    changes within the shutter is left out, with a warning."""
    deforming = [obj for obj in objects if deforms_with_blur(obj)]
    if not deforming:
        return {}
    times = shutter_times(scene)
    start, end = times[0], times[-1]
    frame, subframe = scene.frame_current, scene.frame_subframe
    steps = {obj.name: [] for obj in deforming}
    counts = {obj.name: deform_step_count(obj) for obj in deforming}
    try:
        for n in sorted(set(counts.values())):
            for k in range(n):
                t = start + (end - start) * k / (n - 1)
                scene.frame_set(math.floor(t), subframe=t - math.floor(t))
                for obj in deforming:
                    if counts[obj.name] == n:
                        steps[obj.name].append(evaluated_positions(obj))
    finally:
        scene.frame_set(frame, subframe=subframe)
    out = {}
    for obj in deforming:
        at_frame = evaluated_positions(obj)
        if len({len(s) for s in steps[obj.name]} | {len(at_frame)}) != 1:
            LOG.warning(f"object '{obj.name}': its deformation is not blurred (its vertex count "
                        f"changes within the shutter)")
            continue
        out[obj.name] = {"frame": at_frame, "steps": steps[obj.name]}
    return out


@contextlib.contextmanager
def shutter_poses_recorded(scene):
    """Within the block, SHUTTER_POSES holds, with Render > Motion Blur on, the world matrices
    (glTF axes, column-major) at `shutter_times` of the scene camera (scale removed) and, at
    their motion steps (`deform_step_count`) evenly spread over the shutter, of every rendered
    object the glTF exporter writes as a mesh with its Motion Blur switch on (Object > Motion
    Blur, as Cycles reads it), for those whose matrices differ;
    PHOTON_camera and PHOTON_object carry them as "motion". DEFORM_STEPS holds the deforming
    meshes' vertices over the shutter (`deformation_recorded`), PHOTON_object's "deform". The
    frame is put back afterwards."""
    if not scene.render.use_motion_blur:
        yield
        return
    objects = [obj for obj in scene.objects
               if obj == scene.camera or (obj.type in GEOMETRY_TYPES and not obj.hide_render
                                          and getattr(obj.cycles, "use_motion_blur", True))]
    # Objects take their own motion steps as in Cycles, the camera three.
    step_counts = {obj.name: 3 if obj == scene.camera else deform_step_count(obj)
                   for obj in objects}
    times = shutter_times(scene)
    frame, subframe = scene.frame_current, scene.frame_subframe
    poses = {obj.name: [] for obj in objects}
    carried = []
    try:
        for n in sorted(set(step_counts.values())):
            for k in range(n):
                t = times[0] + (times[-1] - times[0]) * k / (n - 1)
                scene.frame_set(math.floor(t), subframe=t - math.floor(t))
                carried.append(instances_in_their_instancers())
                for obj in (obj for obj in objects if step_counts[obj.name] == n):
                    # A camera node keeps Blender's camera axes; mesh nodes hold their vertices
                    # in glTF axes, so their matrices change axes on both sides.
                    if obj == scene.camera:
                        m = Z_UP_TO_Y_UP @ obj.matrix_world.normalized()
                    else:
                        m = Z_UP_TO_Y_UP @ obj.matrix_world @ Z_UP_TO_Y_UP.inverted()
                    poses[obj.name].append([float(m[r][c]) for c in range(4)
                                            for r in range(4)])
    finally:
        scene.frame_set(frame, subframe=subframe)
    SHUTTER_POSES.update({name: p for name, p in poses.items() if any(q != p[0] for q in p)})
    DEFORM_STEPS.update(deformation_recorded(scene, objects))
    for name in sorted({name for placed in carried[1:] for (name, _), m in placed.items()
                        if carried[0].get((name, _)) != m}):
        LOG.warning(f"object '{name}': its instances (particles, Geometry Nodes) move within "
                    f"the shutter on their own; only the motion of '{name}' carrying them is "
                    f"blurred")
    try:
        yield
    finally:
        SHUTTER_POSES.clear()
        DEFORM_STEPS.clear()

