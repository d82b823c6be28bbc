"""The two volume scenes of tests/blender/test_volumes.py at 64 x 64, for timing Photon's methods
against Cycles (docs/bench/volumes.md).

- `glass_fog`: a diffuse 6 m floor, a 5 m box of Volume Scatter (density 0.2, Surface unlinked)
  standing on it, a glass sphere (Glass BSDF, roughness 0, IOR 1.45, radius 0.6 m, at height
  1.2 m) inside the fog, and a 0.6 m square area light of 300 W at height 3.5 m facing down;
  black world. The glass focuses the light on the floor; at 0 Volume bounces neither renderer
  shows that caustic in the fog itself (a camera path does not go on from a scattering).
- `god_rays`: a 4 x 4 x 2.5 m room of one-sided thin walls (Principled, base colour 0.7,
  roughness 1) with a 1.2 x 1 m window in the wall x = -2, a 5 W/m^2 sun through it, and a
  3.9 m cube of haze (Volume Scatter, density 0.15) filling the room; the camera inside sees
  the shaft of light; black world.

- `vdb_smoke`: a 256³ OpenVDB smoke grid Blender bakes (`baked_smoke_vdb`) as a Volume object
  (Principled Volume, Density 6) under a sun: the memory and load time of a large grid.

Volume bounces stay at Blender's default, 0. tests/blender/test_volumes.py builds its scenes
with the functions here.

Usage:  .venv/bin/python scenes/blender/volume_scenes.py OUT_DIR
writes OUT_DIR/{glass_fog,god_rays,vdb_smoke}.blend (for scenes/blender/cycles_time.py) and
OUT_DIR/{glass_fog,god_rays,vdb_smoke}.glb, exported through the add-on (for `photon bench`;
the smoke's .vdb stays in OUT_DIR/vdb_smoke_bake, where the .glb names it).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parents[1]))

import bpy  # noqa: E402

import common  # noqa: E402

SIZE = 64


def floor_scene(size, world=0.05, camera=((0.0, -4.0, 3.0), (53.0, 0.0, 0.0))):
    """A fresh `size` x `size` scene: a diffuse 6 m floor, a 45-degree camera (`camera`: its
    location and rotation in degrees; by default looking down at the origin) and a white world
    of strength `world`."""
    scene = common.reset_scene(size, size)
    background = scene.world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    background.inputs["Strength"].default_value = world
    floor = common.principled("Floor", (0.8, 0.8, 0.8), roughness=1.0)
    common.quad("Floor", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], floor)
    common.camera("Camera", camera[0], camera[1], 45.0)
    return scene


def sun(strength=3.0, rotation=(30.0, 10.0, 40.0)):
    """A sun of `strength` W/m² turned by `rotation` (degrees)."""
    common.light("Sun", "SUN", (0, 0, 5), rotation, energy=strength)


def shader_material(name, kind, socket, **inputs):
    """A material of one shader node `kind` (a bl_idname) with `inputs` set, into the Material
    Output's `socket` (Surface or Volume; the other unlinked). Returns (material, node)."""
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    node = tree.nodes.new(kind)
    for key, value in inputs.items():
        node.inputs[key].default_value = value
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs[socket])
    return mat, node


def volume_material(name, kind, **inputs):
    """A material with only a Volume (`shader_material` into the Volume socket)."""
    return shader_material(name, kind, "Volume", **inputs)


def cube(name, material, size, location):
    s = size / 2
    verts = [(-s, -s, -s), (s, -s, -s), (s, s, -s), (-s, s, -s),
             (-s, -s, s), (s, -s, s), (s, s, s), (-s, s, s)]
    faces = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    return common.mesh_object(name, verts, faces, material, location)


def sphere(name, material, radius, location):
    """A smooth UV sphere."""
    bpy.ops.mesh.primitive_uv_sphere_add(radius=radius, location=location, segments=48,
                                         ring_count=24)
    obj = bpy.context.active_object
    obj.name = name
    obj.data.materials.append(material)
    bpy.ops.object.shade_smooth()
    return obj


def bake_volume(folder, build):
    """Bakes the geometry a Geometry Nodes group makes (`build(group)` adds its nodes and
    returns the output socket) to disk in `folder` with a Bake node and returns the path of
    the one OpenVDB file Blender writes. Starts from and leaves an empty scene."""
    import glob
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_cube_add()
    obj = bpy.context.object
    modifier = obj.modifiers.new("Bake", "NODES")
    group = bpy.data.node_groups.new("Bake", "GeometryNodeTree")
    group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    bake = group.nodes.new("GeometryNodeBake")
    if len(bake.bake_items) == 0:  # Blender 5 adds a Bake node without its Geometry item
        bake.bake_items.new("GEOMETRY", "Geometry")
    output = group.nodes.new("NodeGroupOutput")
    group.links.new(build(group), bake.inputs[0])
    group.links.new(bake.outputs[0], output.inputs[0])
    modifier.node_group = group
    bpy.context.view_layer.update()
    settings = modifier.bakes[0]
    settings.bake_mode = "STILL"
    settings.bake_target = "DISK"
    settings.use_custom_path = True
    settings.directory = str(folder)
    bpy.ops.object.geometry_node_bake_single(session_uid=obj.id_data.session_uid,
                                             modifier_name=modifier.name,
                                             bake_id=settings.bake_id)
    found = glob.glob(str(Path(folder) / "blobs" / "*.vdb"))
    assert len(found) == 1, found
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return found[0]


def soft_ball(group, radius, position=None):
    """Nodes in Geometry Nodes `group` making max(0, 1 − |p| / `radius`) of the position p
    (`position`: a Position node's, a new one by default); returns their output socket."""
    nodes, links = group.nodes, group.links
    if position is None:
        position = nodes.new("GeometryNodeInputPosition")
    length = nodes.new("ShaderNodeVectorMath")
    length.operation = "LENGTH"
    links.new(position.outputs[0], length.inputs[0])
    ball = nodes.new("ShaderNodeMapRange")
    ball.inputs["From Max"].default_value = radius
    ball.inputs["To Min"].default_value = 1.0
    ball.inputs["To Max"].default_value = 0.0
    links.new(length.outputs["Value"], ball.inputs["Value"])
    return ball.outputs["Result"]


def baked_smoke_vdb(folder, resolution=12):
    """Bakes a Geometry Nodes Volume Cube over [-1, 1]³ (`resolution` voxels a side) to an
    OpenVDB file in `folder` and returns its path: its "density" grid a soft ball,
    max(0, 1 − |p| / 0.9), times a Noise Texture. Leaves an empty scene behind."""

    def build(group):
        nodes, links = group.nodes, group.links
        position = nodes.new("GeometryNodeInputPosition")
        ball = soft_ball(group, 0.9, position)
        noise = nodes.new("ShaderNodeTexNoise")
        noise.inputs["Scale"].default_value = 1.5
        links.new(position.outputs[0], noise.inputs["Vector"])
        times = nodes.new("ShaderNodeMath")
        times.operation = "MULTIPLY"
        links.new(ball, times.inputs[0])
        links.new(noise.outputs["Fac"], times.inputs[1])
        volume_cube = nodes.new("GeometryNodeVolumeCube")
        for axis in "XYZ":
            volume_cube.inputs[f"Resolution {axis}"].default_value = resolution
        links.new(times.outputs[0], volume_cube.inputs["Density"])
        return volume_cube.outputs[0]

    return bake_volume(folder, build)


def openvdb_module():
    """The `openvdb` Python module bpy ships (in its own site-packages, off sys.path)."""
    version = "%d.%d" % bpy.app.version[:2]
    top = bpy.__file__[: bpy.__file__.index(f"/{version}/")]
    root = Path(top) / version / "python" / "lib" / "python3.11" / "site-packages"
    if str(root) not in sys.path:
        sys.path.append(str(root))
    import openvdb
    return openvdb


def fire_vdb(path, n=20):
    """Writes an OpenVDB file of a small fire to `path`: `n`³ voxels 1/`n` apart, centred on
    the origin, with a "density" grid (a ball, thinning outwards), a "temperature" grid (1.7 at
    the centre, falling to 0 at the ball's edge: times Principled Volume's Temperature in K) and
    a "color" grid (yellow at the top, red at the bottom)."""
    import numpy as np
    vdb = openvdb_module()
    axis = (np.arange(n) + 0.5) / n - 0.5
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    r = np.sqrt(x * x + y * y + z * z) / 0.45
    ball = np.clip(1.0 - r, 0.0, None)
    grids = []
    for name, values in (("density", 4.0 * ball), ("temperature", 1.7 * np.sqrt(ball))):
        grid = vdb.FloatGrid()
        grid.copyFromArray(values.astype(np.float32))
        grid.name = name
        grids.append(grid)
    up = np.clip(z / 0.9 + 0.5, 0.0, 1.0)
    color = np.stack([np.ones_like(up), 0.2 + 0.7 * up, 0.1 * up], axis=-1)
    grid = vdb.Vec3SGrid()
    grid.copyFromArray(color.astype(np.float32))
    grid.name = "color"
    grids.append(grid)
    for grid in grids:
        grid.transform = vdb.createLinearTransform(
            [[1 / n, 0, 0, 0], [0, 1 / n, 0, 0], [0, 0, 1 / n, 0], [-0.5, -0.5, -0.5, 1]])
    vdb.write(str(path), grids=grids)
    return path


def checker_vdb(path, n=4):
    """Writes an OpenVDB file of one "density" grid to `path`: `n`³ voxels half a unit apart
    over [−1, 1]³, each column along z of value (i + 2j) mod 3 — coarse enough that where
    voxel values sit shows at a glance."""
    import numpy as np
    vdb = openvdb_module()
    values = np.zeros((n, n, n), np.float32)
    for i in range(n):
        for j in range(n):
            values[i, j, :] = (i + 2 * j) % 3
    grid = vdb.FloatGrid()
    grid.copyFromArray(values)
    grid.name = "density"
    grid.transform = vdb.createLinearTransform(
        [[2 / n, 0, 0, 0], [0, 2 / n, 0, 0], [0, 0, 2 / n, 0], [-1, -1, -1, 1]])
    vdb.write(str(path), grids=[grid])
    return path


def absorber_from_above(size, ortho_scale):
    """A fresh `size` x `size` scene: a white world of strength 1 seen straight down by an
    orthographic camera (5 m up, `ortho_scale` wide), and a material absorbing 1.5 per unit of
    the "density" grid (a black Principled Volume). Returns (scene, material)."""
    scene = common.reset_scene(size, size)
    background = scene.world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    background.inputs["Strength"].default_value = 1.0
    mat, node = volume_material("Absorbing", "ShaderNodeVolumePrincipled")
    node.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    node.inputs["Density"].default_value = 1.5
    common.camera("Camera", (0.0, 0.0, 5.0), (0.0, 0.0, 0.0), 45.0)
    scene.camera.data.type = "ORTHO"
    scene.camera.data.ortho_scale = ortho_scale
    return scene, mat


def volume_object(name, path, material, location, scale=1.0, rotation_z=0.0):
    """A Volume object showing the OpenVDB file at `path`, with `material` (None: none)."""
    volume = bpy.data.volumes.new(name)
    volume.filepath = str(path)
    obj = bpy.data.objects.new(name, volume)
    obj.location = location
    obj.scale = (scale, scale, scale)
    obj.rotation_euler = (0.0, 0.0, math.radians(rotation_z))
    if material is not None:
        volume.materials.append(material)
    common.link(obj)
    return obj


def glass_fog(size=SIZE):
    scene = common.reset_scene(size, size)
    floor = common.principled("Floor", (0.8, 0.8, 0.8), roughness=1.0)
    common.quad("Floor", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], floor)
    common.camera("Camera", (0.0, -4.0, 3.0), (53.0, 0.0, 0.0), 45.0)
    cube("Fog", volume_material("Fog", "ShaderNodeVolumeScatter", Density=0.2)[0], 5.0,
         (0.0, 0.0, 2.49))
    glass, _ = shader_material("Glass", "ShaderNodeBsdfGlass", "Surface", Roughness=0.0,
                               IOR=1.45)
    sphere("Glass", glass, 0.6, (0.0, 0.0, 1.2))
    common.light("Area", "AREA", (0.0, 0.0, 3.5), (0.0, 0.0, 0.0), energy=300.0, size=0.6)
    return scene


def god_rays(size=SIZE):
    scene = common.reset_scene(size, size)
    wall = common.principled("Wall", (0.7, 0.7, 0.7), roughness=1.0)
    w, d, h = 2.0, 2.0, 2.5
    common.quad("Floor", [(-w, -d, 0), (w, -d, 0), (w, d, 0), (-w, d, 0)], wall)
    common.quad("Ceiling", [(-w, -d, h), (-w, d, h), (w, d, h), (w, -d, h)], wall)
    common.quad("Back", [(-w, d, 0), (w, d, 0), (w, d, h), (-w, d, h)], wall)
    common.quad("Front", [(-w, -d, 0), (-w, -d, h), (w, -d, h), (w, -d, 0)], wall)
    common.quad("Right", [(w, -d, 0), (w, -d, h), (w, d, h), (w, d, 0)], wall)
    x = -w  # the left wall, around a window 1.2 m wide and 1 m high
    for corners in ([(x, -d, 0), (x, d, 0), (x, d, 0.9), (x, -d, 0.9)],
                    [(x, -d, 1.9), (x, d, 1.9), (x, d, h), (x, -d, h)],
                    [(x, -d, 0.9), (x, -0.6, 0.9), (x, -0.6, 1.9), (x, -d, 1.9)],
                    [(x, 0.6, 0.9), (x, d, 0.9), (x, d, 1.9), (x, 0.6, 1.9)]):
        common.quad("Left", corners, wall)
    cube("Haze", volume_material("Haze", "ShaderNodeVolumeScatter", Density=0.15)[0], 3.9,
         (0.0, 0.0, 1.2))
    common.light("Sun", "SUN", (0, 0, 5), (50.0, 0.0, -90.0), energy=5.0)
    common.camera("Camera", (1.6, -1.6, 1.3), (85.0, 0.0, 45.0), 80.0)
    return scene


def vdb_smoke(out_dir, size=SIZE, resolution=256):
    path = baked_smoke_vdb(Path(out_dir).resolve() / "vdb_smoke_bake", resolution)
    scene = common.reset_scene(size, size)
    mat, node = volume_material("Smoke", "ShaderNodeVolumePrincipled")
    node.inputs["Density"].default_value = 6.0
    volume_object("Smoke", path, mat, (0.0, 0.0, 1.0))
    common.camera("Camera", (0.0, -4.0, 3.0), (53.0, 0.0, 0.0), 45.0)
    common.light("Sun", "SUN", (0, 0, 5), (30.0, 10.0, 40.0), energy=3.0)
    return scene


SCENES = {"glass_fog": glass_fog, "god_rays": god_rays, "vdb_smoke": vdb_smoke}


def save_scenes(out_dir: Path, builds):
    """For each `(name, build)` of `builds`: `build(out_dir)` makes the scene, which is saved as
    OUT_DIR/name.blend and exported through the add-on as OUT_DIR/name.glb."""
    import blender_addon
    from blender_addon import export

    blender_addon.register()
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        for name, build in builds:
            build(out_dir)
            blend = out_dir / f"{name}.blend"
            bpy.ops.wm.save_as_mainfile(filepath=str(blend.resolve()))
            glb = out_dir / f"{name}.glb"
            for warning in export.export_in_process(glb, "blender_addon"):
                print(f"{name}: export warning: {warning}")
            print(f"wrote {blend} and {glb}")
    finally:
        blender_addon.unregister()


def main(out_dir: Path):
    save_scenes(out_dir, [(name, lambda out, build=build: build(out) if build is vdb_smoke else build())
                          for name, build in SCENES.items()])


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(Path(sys.argv[1]))
