"""The Ambient Occlusion and Bevel nodes against Cycles through the add-on (path tracer): the
renderer traces their rays from each shading point (src/shader/ambient_occlusion.rs, bevel.rs).

- Ambient Occlusion's Color into a Diffuse BSDF's colour, on a floor, two walls meeting in a
  corner and a sphere standing on the floor, in a uniform grey world: the surfaces darken
  towards the corner and under the sphere (Distance 1; also Inside and Only Local);
- Bevel's Normal into a cube's Principled BSDF, lit by a sun: its edges are rounded over the
  Radius (0.2 on a 2 m cube), their highlights where Cycles has them.

32x32 (AO, 64 spp against Cycles' 256) and 48x48 (Bevel, 256 against 1024); mean within 1 %
of Cycles', relMSE over 4x4-pixel blocks <= 1e-3 (cycles_compare's pixel relMSE bound
loosened to what single pixels' noise needs).
"""

import math

import bpy
import pytest

import common
from cycles_compare import compare
from helpers import rel_mse
from test_volumes import block_means

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s

MEAN_TOL = 0.01
BLOCK_RELMSE_MAX = 1e-3


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def matches_cycles(name, scene, tmp_path, spp):
    img, ref = compare(name, scene, tmp_path, photon_spp=spp, cycles_spp=4 * spp,
                       mean_tol=MEAN_TOL, relmse_max=0.05)
    blocks = rel_mse(block_means(img), block_means(ref))
    print(f"{name}: 4x4-block relMSE {blocks:.6f}")
    assert blocks <= BLOCK_RELMSE_MAX, f"{name}: 4x4-block relMSE {blocks:.6f}"


def node_material(name):
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    return mat, mat.node_tree


def occlusion_material(inside, only_local):
    """A Diffuse BSDF whose colour is an Ambient Occlusion node's Color (0.8 grey in)."""
    mat, tree = node_material("Occluded")
    nodes = tree.nodes
    nodes.remove(nodes["Principled BSDF"])
    ao = nodes.new("ShaderNodeAmbientOcclusion")
    ao.samples = 16
    ao.inside = inside
    ao.only_local = only_local
    ao.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    ao.inputs["Distance"].default_value = 1.0
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    tree.links.new(ao.outputs["Color"], diffuse.inputs["Color"])
    tree.links.new(diffuse.outputs["BSDF"], nodes["Material Output"].inputs["Surface"])
    return mat


def corner_scene(inside, only_local):
    """A 4 m floor, walls at the back and the left meeting in a corner, and a sphere of
    radius 0.5 on the floor, all of `occlusion_material`, under a uniform grey world."""
    scene = common.reset_scene(32, 32)
    material = occlusion_material(inside, only_local)
    common.quad("Floor", [(-1, -3, 0), (3, -3, 0), (3, 1, 0), (-1, 1, 0)], material)
    common.quad("Back", [(-1, 1, 0), (3, 1, 0), (3, 1, 2), (-1, 1, 2)], material)
    common.quad("Left", [(-1, -3, 0), (-1, 1, 0), (-1, 1, 2), (-1, -3, 2)], material)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=0.5,
                                         location=(0.6, 0.0, 0.5))
    sphere = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    sphere.data.materials.append(material)
    common.camera("Camera", (3.0, -3.5, 2.6), (66.0, 0.0, 38.0), 50.0)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    return scene


@pytest.mark.parametrize("inside, only_local", [(False, False), (False, True), (True, False)])
def test_ambient_occlusion_darkens_a_corner_and_a_sphere_on_a_floor(tmp_path, inside, only_local):
    scene = corner_scene(inside, only_local)
    name = "ao" + (" inside" if inside else "") + (" local" if only_local else "")
    matches_cycles(name, scene, tmp_path, spp=64)


def test_bevel_rounds_the_edges_of_a_cube(tmp_path):
    scene = common.reset_scene(48, 48)
    mat, tree = node_material("Bevelled")
    bsdf = tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.7, 0.5, 0.3, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.3
    bevel = tree.nodes.new("ShaderNodeBevel")
    bevel.samples = 16
    bevel.inputs["Radius"].default_value = 0.2
    tree.links.new(bevel.outputs["Normal"], bsdf.inputs["Normal"])
    bpy.ops.mesh.primitive_cube_add(size=2.0, rotation=(0.0, 0.0, math.radians(20.0)))
    bpy.context.active_object.data.materials.append(mat)
    common.camera("Camera", (4.0, -4.0, 3.2), (60.5, 0.0, 45.0), 38.0)
    common.light("Sun", "SUN", (0, 0, 5), (40.0, 15.0, -60.0), energy=4.0, angle=0.1)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.05, 0.05, 0.05, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    matches_cycles("bevel", scene, tmp_path, spp=256)
