"""Translucent objects (Principled BSDF, Subsurface Method Random Walk, Blender's default)
against Cycles' random walk through the add-on: Photon walks the same medium
(`src/integrator/random_walk.rs`), so the images agree without the dipole's bias.

Every scene is 32x32 with a coloured Subsurface Radius (1.0, 0.4, 0.2), rendered by the path
tracer and by the photon method (which walks from its camera paths and shades the exit with
its final gather), compared with `cycles_compare.compare`: mean within 2 % and a relMSE bound
about 3x the error measured at these sample counts (Cycles 1024 spp), which is noise:

- a box on a grey floor under a slanting sun and a dim world (closed mesh, light leaving by
  its shadowed faces), Photon 256 spp: path +0.04 %, relMSE 0.0011; photon -0.26 %, 0.0010;
- a smooth sphere under a point light (curved surface, the walk's exits all round), Photon 256
  spp: path +0.43 %, relMSE 0.0010; photon +1.41 %, 0.0010;
- a thin slab (4 cm, 1-5 mean free paths) lit only from below by an area light, seen from
  above: only light that walked through the slab reaches the camera. Photon 1024 spp: path
  +0.12 %, relMSE 0.0092 (at 256 spp 0.027: the error falls with Photon's samples, so it is
  noise, the walk through being the noisiest light here).
"""

import bpy
import pytest

import common
from cycles_compare import compare

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s

SIZE = 32
RADIUS = (1.0, 0.4, 0.2)


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def translucent(name, colour, scale, *, roughness=0.5):
    """A Principled BSDF with Subsurface Weight 1, Random Walk, the coloured radius."""
    mat = common.principled(name, colour, roughness=roughness)
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.subsurface_method = "RANDOM_WALK"
    bsdf.inputs["Subsurface Weight"].default_value = 1.0
    bsdf.inputs["Subsurface Radius"].default_value = RADIUS
    bsdf.inputs["Subsurface Scale"].default_value = scale
    return mat


def grey_world(scene, level):
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (level, level, level, 1.0)
    bg.inputs["Strength"].default_value = 1.0


@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_box_on_a_floor_under_a_sun(tmp_path, method):
    scene = common.reset_scene(SIZE, SIZE)
    grey_world(scene, 0.05)
    floor = common.principled("Floor", (0.5, 0.5, 0.5), roughness=1.0)
    common.quad("Floor", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], floor)
    common.box("Box", (1.0, 1.0, 1.0), translucent("Wax", (0.9, 0.7, 0.5), 0.1), (0, 0, 0), 30.0)
    common.light("Sun", "SUN", (0, 0, 5), (50.0, 0.0, 40.0), energy=3.0)
    common.camera("Camera", (0.0, -3.6, 2.4), (62.0, 0.0, 0.0), 40.0)
    compare(f"random-walk box {method.lower()}", scene, tmp_path, photon_spp=256,
            cycles_spp=1024, method=method, relmse_max=0.003)


@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_sphere_under_a_point_light(tmp_path, method):
    scene = common.reset_scene(SIZE, SIZE)
    grey_world(scene, 0.08)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=1.0)
    sphere = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    sphere.data.materials.append(translucent("Jade", (0.5, 0.8, 0.6), 0.2))
    common.camera("Camera", (0.0, -3.4, 0.4), (83.0, 0.0, 0.0), 40.0)
    common.light("Lamp", "POINT", (-2.0, 1.5, 2.5), energy=400.0, shadow_soft_size=0.4)
    compare(f"random-walk sphere {method.lower()}", scene, tmp_path, photon_spp=256,
            cycles_spp=1024, method=method, relmse_max=0.003)


@pytest.mark.parametrize("method", ["PATH", "PHOTON"])
def test_thin_slab_lit_from_below(tmp_path, method):
    scene = common.reset_scene(SIZE, SIZE)
    slab = translucent("Leaf", (0.8, 0.8, 0.8), 0.5, roughness=0.3)
    common.box("Slab", (2.0, 2.0, 0.04), slab, (0, 0, 0), 0.0)
    common.light("Area", "AREA", (0.3, 0.0, -0.8), (180.0, 0.0, 0.0), energy=60.0, size=1.5)
    common.camera("Camera", (0.0, 0.0, 3.0), (0.0, 0.0, 0.0), 36.0)
    compare(f"random-walk thin slab {method.lower()}", scene, tmp_path, photon_spp=1024,
            cycles_spp=1024, method=method, relmse_max=0.025)
