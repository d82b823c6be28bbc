"""Blender's camera clip start and end against Cycles through the add-on, 32x32: Cycles'
camera rays start on the clip start plane and end on the clip end plane (glTF `znear` and
`zfar`, which Blender's exporter writes). Photon's path tracer at 128 spp against Cycles at
512, mean within 2 % and relMSE <= 0.01 (`cycles_compare.compare`).

- clip start hides a sphere nearer the camera than it;
- clip end hides the far part of a long floor, showing the world there;
- a camera inside fog with clip start 0.5 m (perspective and orthographic): the fog between the camera and the plane is not
  seen, neither its light nor its attenuation.
"""

import bpy
import pytest

import common
from cycles_compare import compare
from volume_scenes import cube, sphere, volume_material

SIZE = 32

pytestmark = pytest.mark.slow


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def scene_with_camera(clip_start, clip_end, location, rotation, floor_size=6.0):
    """A fresh scene: a diffuse square floor of side `floor_size`, a sun, a white world of
    strength 0.3 and the camera with the given clip planes."""
    scene = common.reset_scene(SIZE, SIZE)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.6, 0.8, 1.0, 1.0)
    bg.inputs["Strength"].default_value = 0.3
    s = floor_size / 2
    floor = common.principled("Floor", (0.8, 0.8, 0.8), roughness=1.0)
    common.quad("Floor", [(-s, -s, 0), (s, -s, 0), (s, s, 0), (-s, s, 0)], floor)
    camera = common.camera("Camera", location, rotation, 45.0)
    camera.data.clip_start = clip_start
    camera.data.clip_end = clip_end
    common.light("Sun", "SUN", (0, 0, 5), (30.0, 10.0, 40.0), energy=3.0)
    return scene


def test_clip_start_hides_a_near_sphere(tmp_path):
    s = scene_with_camera(1.0, 100.0, (0.0, -4.0, 3.0), (53.0, 0.0, 0.0))
    red = common.principled("Red", (0.8, 0.1, 0.1), roughness=0.5)
    # 0.7 m in front of the camera, on its axis: nearer than the clip start.
    sphere("Near", red, 0.3, (0.0, -3.44, 2.58))
    compare("clip start", s, tmp_path, photon_spp=128, cycles_spp=512)


def test_clip_end_hides_the_far_floor(tmp_path):
    s = scene_with_camera(0.1, 12.0, (0.0, -20.0, 1.5), (85.0, 0.0, 0.0), floor_size=80.0)
    compare("clip end", s, tmp_path, photon_spp=128, cycles_spp=512)


@pytest.mark.parametrize("kind", ["PERSP", "ORTHO"])
def test_camera_inside_fog_sees_it_from_clip_start(tmp_path, kind):
    s = scene_with_camera(0.5, 100.0, (0.0, -2.0, 1.5), (75.0, 0.0, 0.0))
    s.camera.data.type = kind
    s.camera.data.ortho_scale = 3.0
    mat, _ = volume_material("Fog", "ShaderNodeVolumeScatter", Density=0.5)
    cube("Fog", mat, 5.0, (0.0, 0.0, 2.49))
    common.light("Lamp", "POINT", (1.0, 0.5, 2.5), energy=300.0)
    compare(f"camera in fog {kind.lower()}", s, tmp_path, photon_spp=128, cycles_spp=512)
