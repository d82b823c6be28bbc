"""True displacement against Cycles through the add-on (path tracer): the Material Output's
Displacement moves the mesh's vertices when the scene is built (src/scene/displace.rs), by
the material's displacement method as Cycles renders it.

- a plane subdivided by a Subdivision Surface modifier (Simple), a Noise texture into a
  Displacement node (world space), lit by a low sun so the relief casts shadows, method
  "Displacement Only" (flat faces take their displaced face's normal) and "Displacement and
  Bump" (the bump of the same displacement over the moved surface);
- a smooth-shaded UV sphere under a non-uniform object scale, the Displacement node in object
  space (the displacement scales with the object), "Displacement Only": the vertex normals are
  computed again from the displaced faces;
- "Displacement and Bump" on that sphere (the bump's slope taken in object space), and on a
  flat-shaded icosphere (whose faces Blender 5's Cycles shades smooth under the bump);
- a grid of two materials, one displaced: the vertices on their border move once, for both;
- one such sphere's mesh shared by two objects of different transforms (instances);
- a Noise texture's colour into a Vector Displacement node in object space on the subdivided
  plane under a non-uniform scale.

48x48, Photon 256 spp against Cycles' 1024; mean within 1 % of Cycles', relMSE over 4x4-pixel
blocks <= 1e-3 (cycles_compare's pixel relMSE bound loosened to what single pixels' noise
needs).
"""

import math

import bpy
import pytest

import common
from cycles_compare import compare
from helpers import rel_mse
from test_volumes import block_means

SIZE = 48
MEAN_TOL = 0.01
BLOCK_RELMSE_MAX = 1e-3


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def matches_cycles(name, scene, tmp_path, spp=256):
    img, ref = compare(name, scene, tmp_path, photon_spp=spp, cycles_spp=4 * spp,
                       mean_tol=MEAN_TOL, relmse_max=0.05)
    blocks = rel_mse(block_means(img), block_means(ref))
    print(f"{name}: 4x4-block relMSE {blocks:.6f}")
    assert blocks <= BLOCK_RELMSE_MAX, f"{name}: 4x4-block relMSE {blocks:.6f}"


def displaced_material(name, method, space, noise_scale, height_scale):
    """A grey Diffuse BSDF whose Material Output's Displacement is a Displacement node in
    `space` over a Noise texture (Generated coordinates), displacement method `method`."""
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    if hasattr(mat, "displacement_method"):
        mat.displacement_method = method
    else:
        mat.cycles.displacement_method = method
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.remove(nodes["Principled BSDF"])
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    noise = nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = noise_scale
    noise.inputs["Detail"].default_value = 1.0
    displacement = nodes.new("ShaderNodeDisplacement")
    displacement.space = space
    displacement.inputs["Scale"].default_value = height_scale
    output = nodes["Material Output"]
    links.new(diffuse.outputs["BSDF"], output.inputs["Surface"])
    links.new(noise.outputs["Fac"], displacement.inputs["Height"])
    links.new(displacement.outputs["Displacement"], output.inputs["Displacement"])
    return mat


def dim_world(scene):
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bg.inputs["Strength"].default_value = 0.05


def plane_under_a_low_sun(mat, size):
    """A plane of `size` with `mat`, subdivided 6 times by a Simple Subdivision Surface, seen
    from above at an angle and lit by a sun 15 degrees above the horizon."""
    bpy.ops.mesh.primitive_plane_add(size=size)
    plane = bpy.context.active_object
    plane.data.materials.append(mat)
    subdivision = plane.modifiers.new("Subdivision", "SUBSURF")
    subdivision.subdivision_type = "SIMPLE"
    subdivision.levels = subdivision.render_levels = 6
    common.camera("Camera", (0.0, -3.6, 3.0), (50.0, 0.0, 0.0), 45.0)
    common.light("Sun", "SUN", (0, 0, 5), (75.0, 0.0, 35.0), energy=3.0, angle=0.02)
    return plane


@pytest.mark.slow
@pytest.mark.parametrize("method", ["DISPLACEMENT", "BOTH"])
def test_noise_relief_on_a_subdivided_plane_under_a_low_sun(tmp_path, method):
    scene = common.reset_scene(SIZE, SIZE)
    dim_world(scene)
    mat = displaced_material(f"Relief {method}", method, "WORLD", 3.0, 1.0)
    plane_under_a_low_sun(mat, 3.0)
    matches_cycles(f"relief {method.lower()}", scene, tmp_path)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["DISPLACEMENT", "BOTH"])
def test_object_space_relief_on_a_scaled_smooth_sphere(tmp_path, method):
    scene = common.reset_scene(SIZE, SIZE)
    dim_world(scene)
    mat = displaced_material(f"Scaled relief {method}", method, "OBJECT", 3.0, 0.5)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=96, ring_count=48, radius=1.0)
    sphere = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    sphere.data.materials.append(mat)
    sphere.scale = (1.3, 0.9, 0.7)
    sphere.rotation_euler = (math.radians(15.0), 0.0, math.radians(25.0))
    common.camera("Camera", (0.0, -5.0, 1.5), (75.0, 0.0, 0.0), 40.0)
    common.light("Sun", "SUN", (0, 0, 5), (60.0, 0.0, 60.0), energy=2.0, angle=0.02)
    matches_cycles(f"scaled sphere relief {method.lower()}", scene, tmp_path)


@pytest.mark.slow
def test_displacement_and_bump_on_a_flat_shaded_icosphere(tmp_path):
    """"Displacement and Bump" on a flat-shaded icosphere: Blender 4's Cycles shades each
    displaced face by its own normal under the bump, Blender 5's shades the faces smooth (by
    the vertex normals from before the displacement) under the bump."""
    scene = common.reset_scene(SIZE, SIZE)
    dim_world(scene)
    mat = displaced_material("Faceted relief", "BOTH", "OBJECT", 3.0, 0.5)
    bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=3, radius=1.0)
    bpy.context.active_object.data.materials.append(mat)
    common.camera("Camera", (0.0, -5.0, 1.5), (75.0, 0.0, 0.0), 40.0)
    common.light("Sun", "SUN", (0, 0, 5), (60.0, 0.0, 60.0), energy=2.0, angle=0.02)
    matches_cycles("faceted sphere relief both", scene, tmp_path)


@pytest.mark.slow
def test_one_displaced_mesh_shared_by_two_objects_of_different_transforms(tmp_path):
    """A smooth UV sphere's mesh shared by two objects (a linked duplicate: one mesh, placed
    twice), moved and scaled differently, object-space displacement: the mesh is displaced
    once and both copies show the relief, stretched with each object."""
    scene = common.reset_scene(SIZE, SIZE)
    dim_world(scene)
    mat = displaced_material("Shared relief", "DISPLACEMENT", "OBJECT", 3.0, 0.4)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=0.8,
                                         location=(-1.1, 0.0, 0.0))
    first = bpy.context.active_object
    bpy.ops.object.shade_smooth()
    first.data.materials.append(mat)
    second = common.link(bpy.data.objects.new("Second", first.data))
    second.location = (1.1, 0.0, 0.1)
    second.rotation_euler = (0.0, math.radians(30.0), math.radians(90.0))
    second.scale = (1.0, 1.3, 0.8)
    common.camera("Camera", (0.0, -6.0, 1.5), (78.0, 0.0, 0.0), 40.0)
    common.light("Sun", "SUN", (0, 0, 5), (60.0, 0.0, 60.0), energy=2.0, angle=0.02)
    matches_cycles("shared sphere relief", scene, tmp_path)


@pytest.mark.slow
def test_vertices_on_a_border_between_a_displaced_and_a_plain_material(tmp_path):
    """A 64 x 64 grid whose faces on the right take a plain material and those on the left a
    displaced one: the vertices they share move once, by the displaced material, and the
    plain faces beside them stretch up to them (one Blender mesh, two glTF primitives)."""
    scene = common.reset_scene(SIZE, SIZE)
    dim_world(scene)
    displaced = displaced_material("Border relief", "DISPLACEMENT", "WORLD", 3.0, 1.0)
    plain = common.principled("Plain", (0.5, 0.6, 0.8), roughness=1.0)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=64, y_subdivisions=64, size=3.0)
    grid = bpy.context.active_object
    grid.data.materials.append(displaced)
    grid.data.materials.append(plain)
    for polygon in grid.data.polygons:
        polygon.material_index = 1 if polygon.center.x > 0.2 else 0
    common.camera("Camera", (0.0, -3.6, 3.0), (50.0, 0.0, 0.0), 45.0)
    common.light("Sun", "SUN", (0, 0, 5), (75.0, 0.0, 35.0), energy=3.0, angle=0.02)
    matches_cycles("border relief", scene, tmp_path)


@pytest.mark.slow
def test_object_space_vector_displacement_of_a_noise_colour_on_a_scaled_plane(tmp_path):
    """A Noise texture's Color (minus 0.5) into a Vector Displacement node in object space, on
    the subdivided plane scaled 1.5x along its x: the vertices move sideways too, stretched
    with the object."""
    scene = common.reset_scene(SIZE, SIZE)
    dim_world(scene)
    mat = displaced_material("Vector relief", "DISPLACEMENT", "OBJECT", 3.0, 1.0)
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    vector = nodes.new("ShaderNodeVectorDisplacement")
    vector.space = "OBJECT"
    vector.inputs["Midlevel"].default_value = 0.5
    vector.inputs["Scale"].default_value = 0.6
    links.new(nodes["Noise Texture"].outputs["Color"], vector.inputs["Vector"])
    links.new(vector.outputs["Displacement"], nodes["Material Output"].inputs["Displacement"])
    plane = plane_under_a_low_sun(mat, 2.0)
    plane.scale = (1.5, 1.0, 1.0)
    matches_cycles("vector relief", scene, tmp_path)


def test_preflight_names_adaptive_subdivision_not_true_displacement():
    """Displacement Only and Displacement and Bump are rendered (nothing named); Cycles'
    adaptive subdivision (its dicing rate) is not, and is named."""
    from blender_addon import preflight

    scene = common.reset_scene(SIZE, SIZE)
    for method in ("DISPLACEMENT", "BOTH"):
        bpy.ops.mesh.primitive_plane_add(size=2.0)
        plane = bpy.context.active_object
        plane.name = f"Plane {method}"
        plane.data.materials.append(displaced_material(method, method, "WORLD", 3.0, 0.5))
        plane.modifiers.new("Subdivision", "SUBSURF")
    messages = preflight.unsupported_features(scene, list(scene.objects))
    assert not [m for m in messages if "displace" in m.lower()], messages
    plane = bpy.data.objects["Plane BOTH"]
    cycles = getattr(plane, "cycles", None)
    if cycles is not None and hasattr(cycles, "use_adaptive_subdivision"):
        cycles.use_adaptive_subdivision = True
    else:
        plane.modifiers["Subdivision"].use_adaptive_subdivision = True
    messages = preflight.unsupported_features(scene, list(scene.objects))
    named = [m for m in messages if "adaptive subdivision" in m]
    assert len(named) == 1 and "'Plane BOTH'" in named[0], messages
