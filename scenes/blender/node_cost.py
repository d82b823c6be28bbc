"""The node-tree cost benchmark: one scene, exported twice through the add-on, once
with every material a procedural tree of 21 nodes and once with constant Principled materials.

The scene: a 4 m ground plane and three spheres under a sun and a grey-blue sky, seen from
above at an angle so the objects fill the 160 x 160 frame. Each procedural material is Texture
Coordinate → Mapping → Noise, Voronoi, Checker, Wave (with distortion) and Gradient, combined
through a Color Ramp, Math, Map Range, Clamp, Mix, Hue/Saturation, Invert, Gamma,
Bright/Contrast and Separate Color into a Principled BSDF's Base Color and Roughness, and a Bump
of the Noise into its Normal (21 nodes with the Material Output; docs/bench/node_trees.md,
"Node-tree cost"); the constant materials are lone
Principled BSDFs of similar colour and roughness (glTF's path).

Usage:  .venv/bin/python scenes/blender/node_cost.py OUT_DIR
writes OUT_DIR/node_cost_tree.glb and OUT_DIR/node_cost_constant.glb. Then time, alternating:
  photon render OUT_DIR/node_cost_tree.glb -o /tmp/t.exr --width 160 --height 160 --spp 64 \\
      --method path
  photon render OUT_DIR/node_cost_constant.glb -o /tmp/c.exr --width 160 --height 160 \\
      --spp 64 --method path
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

SIZE = 160


def procedural(name: str, hue: float):
    """A material whose Principled BSDF is fed by 19 other nodes (21 with the Material
    Output)."""
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    tree = mat.node_tree
    nodes, links = tree.nodes, tree.links
    bsdf = nodes["Principled BSDF"]
    coords = nodes.new("ShaderNodeTexCoord")
    mapping = nodes.new("ShaderNodeMapping")
    mapping.inputs["Scale"].default_value = (2.0, 2.0, 2.0)
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, 0.3 + hue)
    links.new(coords.outputs["Object"], mapping.inputs["Vector"])
    vec = mapping.outputs["Vector"]

    noise = nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 3.0
    noise.inputs["Detail"].default_value = 2.0
    voronoi = nodes.new("ShaderNodeTexVoronoi")
    voronoi.inputs["Scale"].default_value = 4.0
    checker = nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = 3.0
    wave = nodes.new("ShaderNodeTexWave")
    wave.inputs["Distortion"].default_value = 2.0
    gradient = nodes.new("ShaderNodeTexGradient")
    for tex in (noise, voronoi, checker, wave, gradient):
        links.new(vec, tex.inputs["Vector"])

    ramp = nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.1, 0.2 + hue * 0.3, 0.5, 1.0)
    ramp.color_ramp.elements[1].color = (0.9, 0.7, 0.3 + hue * 0.2, 1.0)
    links.new(noise.outputs["Fac"], ramp.inputs["Fac"])

    multiply = nodes.new("ShaderNodeMath")
    multiply.operation = "MULTIPLY"
    links.new(voronoi.outputs["Distance"], multiply.inputs[0])
    links.new(wave.outputs["Fac"], multiply.inputs[1])
    map_range = nodes.new("ShaderNodeMapRange")
    map_range.inputs["To Min"].default_value = 0.2
    map_range.inputs["To Max"].default_value = 0.8
    links.new(multiply.outputs["Value"], map_range.inputs["Value"])
    clamp = nodes.new("ShaderNodeClamp")
    links.new(map_range.outputs["Result"], clamp.inputs["Value"])

    mix = nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.blend_type = "MIX"
    links.new(gradient.outputs["Fac"], mix.inputs["Factor"])
    links.new(ramp.outputs["Color"], mix.inputs["A"])
    links.new(checker.outputs["Color"], mix.inputs["B"])
    hsv = nodes.new("ShaderNodeHueSaturation")
    hsv.inputs["Hue"].default_value = 0.5 + hue
    links.new(mix.outputs["Result"], hsv.inputs["Color"])
    invert = nodes.new("ShaderNodeInvert")
    invert.inputs["Fac"].default_value = 0.2
    links.new(hsv.outputs["Color"], invert.inputs["Color"])
    separate = nodes.new("ShaderNodeSeparateColor")
    links.new(invert.outputs["Color"], separate.inputs["Color"])
    roughness = nodes.new("ShaderNodeMath")
    roughness.operation = "ADD"
    links.new(clamp.outputs["Result"], roughness.inputs[0])
    links.new(separate.outputs["Red"], roughness.inputs[1])
    roughness.use_clamp = True

    bump = nodes.new("ShaderNodeBump")
    bump.inputs["Distance"].default_value = 0.05
    links.new(noise.outputs["Fac"], bump.inputs["Height"])

    gamma = nodes.new("ShaderNodeGamma")
    gamma.inputs["Gamma"].default_value = 1.2
    links.new(invert.outputs["Color"], gamma.inputs["Color"])
    contrast = nodes.new("ShaderNodeBrightContrast")
    contrast.inputs["Contrast"].default_value = 0.2
    links.new(gamma.outputs["Color"], contrast.inputs["Color"])

    links.new(contrast.outputs["Color"], bsdf.inputs["Base Color"])
    links.new(roughness.outputs["Value"], bsdf.inputs["Roughness"])
    links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
    return mat


def constant(name: str, hue: float):
    return common.principled(name, (0.5, 0.4 + 0.3 * hue, 0.35), roughness=0.5)


def build(make):
    scene = common.reset_scene(SIZE, SIZE)
    ground = make("Ground", 0.0)
    common.quad("Ground", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], ground)
    for i, (x, y) in enumerate([(-0.9, 0.3), (0.6, 0.6), (0.2, -0.8)]):
        bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=0.55,
                                             location=(x, y, 0.55))
        sphere = bpy.context.active_object
        bpy.ops.object.shade_smooth()
        sphere.data.materials.append(make(f"Sphere {i}", 0.2 * (i + 1)))
    common.camera("Camera", (0.0, -4.2, 3.6), (50.0, 0.0, 0.0), 50.0)
    common.light("Sun", "SUN", (0, 0, 5), (35.0, 10.0, 30.0), energy=3.0)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.3, 0.35, 0.45, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    return scene


def main(out_dir: Path):
    import blender_addon
    from blender_addon import export, node_tree

    blender_addon.register()
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
        for label, make in (("tree", procedural), ("constant", constant)):
            scene = build(make)
            trees = [node_tree.material_nodes(m)[0] for m in bpy.data.materials]
            described = [t for t in trees if t is not None]
            if label == "tree":
                assert len(described) == 4, "every procedural tree must be described"
                print(f"{label}: {len(described[0]['nodes'])} nodes per tree")
            else:
                assert not described
            glb = out_dir / f"node_cost_{label}.glb"
            export.export_in_process(glb, "blender_addon")
            print(f"wrote {glb}")
            del scene
    finally:
        blender_addon.unregister()


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(Path(sys.argv[1]))
