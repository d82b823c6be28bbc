"""Writes the Draco test files of tests/data/draco with Blender's own glTF exporter (bpy 4.5,
whose exporter bundles the Draco encoder): one small scene (a smooth UV sphere with UVs, a
subdivided cube with flat faces and vertex colours, a plane with a UV seam, and a mesh of two
materials, so two primitives, over a floor lit by a sun and seen by a camera) exported
uncompressed and Draco-compressed at the levels that
pick each of Draco's mesh encoders and prediction schemes, with and without quantization.

    .venv/bin/python tests/data/draco/make_draco.py

Blender sets Draco's encoding speed to 10 - level: level 0 writes the sequential
connectivity, levels 1-5 Edgebreaker's standard traversal and levels 6-10 its valence
traversal (Blender's default is 6); positions use parallelogram prediction above speed 4 and
constrained multi-parallelogram below, texture coordinates the portable scheme and normals
the geometric-normal scheme below speed 4. Quantization 0 stores an attribute unquantized.
"""

from pathlib import Path

import bpy

OUT = Path(__file__).resolve().parent

# (file stem, compression level, quantization bits for position, normal, texcoord, colour)
VARIANTS = [
    ("level0", 0, (14, 10, 12, 10)),
    ("level3", 3, (14, 10, 12, 10)),
    ("level6", 6, (14, 10, 12, 10)),
    ("level10", 10, (11, 8, 10, 8)),
    ("level6_raw", 6, (0, 0, 0, 0)),
    ("level0_raw", 0, (0, 0, 0, 0)),
]


def build_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=12, ring_count=6, radius=0.6, location=(-1.2, 0, 0.6))
    sphere = bpy.context.active_object
    sphere.name = "Sphere"
    bpy.ops.object.shade_smooth()

    bpy.ops.mesh.primitive_cube_add(size=0.8, location=(0.2, 0.3, 0.4))
    cube = bpy.context.active_object
    cube.name = "Cube"
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.subdivide(number_cuts=1)
    bpy.ops.object.mode_set(mode="OBJECT")
    colours = cube.data.color_attributes.new("Col", "BYTE_COLOR", "CORNER")
    for i, loop in enumerate(cube.data.loops):
        v = cube.data.vertices[loop.vertex_index].co
        colours.data[i].color = (0.5 + v.x, 0.5 + v.y, 0.5 + v.z, 1.0)
    # A material that reads the colours, so the exporter writes COLOR_0 and glTF readers
    # multiply the base colour by it.
    painted = bpy.data.materials.new("Painted")
    painted.use_nodes = True
    tree = painted.node_tree
    attribute = tree.nodes.new("ShaderNodeVertexColor")
    attribute.layer_name = "Col"
    tree.links.new(attribute.outputs["Color"], tree.nodes["Principled BSDF"].inputs["Base Color"])
    cube.data.materials.append(painted)

    bpy.ops.mesh.primitive_grid_add(x_subdivisions=4, y_subdivisions=3, size=1.5, location=(0.5, -1.2, 0))
    plane = bpy.context.active_object
    plane.name = "Plane"

    bpy.ops.mesh.primitive_cylinder_add(vertices=8, radius=0.3, depth=0.8, location=(1.3, 0.8, 0.4))
    cylinder = bpy.context.active_object
    cylinder.name = "TwoMaterials"
    red = bpy.data.materials.new("Red")
    red.diffuse_color = (0.8, 0.1, 0.1, 1)
    blue = bpy.data.materials.new("Blue")
    blue.diffuse_color = (0.1, 0.2, 0.8, 1)
    cylinder.data.materials.append(red)
    cylinder.data.materials.append(blue)
    for poly in cylinder.data.polygons:
        poly.material_index = 1 if abs(poly.normal.z) > 0.5 else 0

    # A floor, a sun and a camera, so the files render.
    bpy.ops.mesh.primitive_plane_add(size=6, location=(0, 0, -0.01))
    bpy.context.active_object.name = "Floor"
    bpy.ops.object.light_add(type="SUN", rotation=(0.6, 0.3, 0.4))
    bpy.context.active_object.data.energy = 3.0
    bpy.ops.object.camera_add(location=(0.5, -5.0, 3.5), rotation=(1.05, 0.0, 0.1))
    bpy.context.scene.camera = bpy.context.active_object


def export(path, level=None, bits=None):
    options = dict(filepath=str(path), export_format="GLB", export_cameras=True,
                   export_lights=True, export_apply=True)
    if level is not None:
        p, n, t, c = bits
        options.update(export_draco_mesh_compression_enable=True,
                       export_draco_mesh_compression_level=level,
                       export_draco_position_quantization=p,
                       export_draco_normal_quantization=n,
                       export_draco_texcoord_quantization=t,
                       export_draco_color_quantization=c,
                       export_draco_generic_quantization=12)
    bpy.ops.export_scene.gltf(**options)


if __name__ == "__main__":
    build_scene()
    export(OUT / "plain.glb")
    for stem, level, bits in VARIANTS:
        export(OUT / f"{stem}.glb", level, bits)
