"""Record Blender's own Noise and Voronoi values at chosen points, for the pattern tests of
`src/shader/tests.rs` (`blender_noise_at_chosen_points`, `blender_voronoi_at_chosen_points`).

Blender's geometry nodes evaluate the same Noise and Voronoi Texture definitions as Cycles'
shader nodes (BLI_noise, ported from Cycles' kernel): a mesh whose vertices are the chosen
points gets a Geometry Nodes modifier that stores each texture's outputs at its position, and
the evaluated mesh's attributes are written to tests/data/blender_patterns.json.

Usage:  .venv/bin/python scenes/blender/record_patterns.py
"""

from __future__ import annotations

import json
from pathlib import Path

import bpy

# Near the origin, negative, on cell walls, -0, large (Voronoi) and past Noise's period
# (100000, where Cycles takes fmod).
POINTS = [
    (0.1, 0.2, 0.3), (-0.37, 1.91, -2.6), (3.0, -4.0, 5.0), (-0.0, 0.0, -0.5),
    (12.25, -7.5, 0.125), (41.7, 93.2, -18.9), (-250.3, 17.77, 999.9),
    (1.0e5 + 12.3, -3.4, 7.7), (-2.5e5 - 0.3, 4.2e5 + 0.6, 1.1),
]

NOISE = [  # (dimensions, detail, roughness, lacunarity, distortion, normalize)
    ("3D", 2.0, 0.5, 2.0, 0.0, True),
    ("3D", 3.5, 0.6, 2.3, 1.5, False),
    ("2D", 1.0, 0.5, 2.0, 0.0, True),
]

VORONOI = [  # (dimensions, feature, metric, randomness, detail, smoothness, exponent)
    ("3D", "F1", "EUCLIDEAN", 1.0, 0.0, 1.0, 0.5),
    ("3D", "F1", "MANHATTAN", 0.6, 0.0, 1.0, 0.5),
    ("3D", "F1", "CHEBYCHEV", 1.0, 0.0, 1.0, 0.5),
    ("3D", "F1", "MINKOWSKI", 1.0, 0.0, 1.0, 1.5),
    ("2D", "F1", "EUCLIDEAN", 1.0, 0.0, 1.0, 0.5),
    ("3D", "F2", "EUCLIDEAN", 1.0, 0.0, 1.0, 0.5),
    ("3D", "SMOOTH_F1", "EUCLIDEAN", 1.0, 0.0, 0.6, 0.5),
    ("3D", "F1", "EUCLIDEAN", 1.0, 2.5, 1.0, 0.5),
]


def evaluate(build):
    """Values per point of the attributes `build(tree, position)` stores."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    mesh = bpy.data.meshes.new("Points")
    mesh.from_pydata(POINTS, [], [])
    obj = bpy.data.objects.new("Points", mesh)
    bpy.context.scene.collection.objects.link(obj)
    tree = bpy.data.node_groups.new("Record", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    group_in = tree.nodes.new("NodeGroupInput")
    group_out = tree.nodes.new("NodeGroupOutput")
    position = tree.nodes.new("GeometryNodeInputPosition").outputs["Position"]
    geometry = group_in.outputs["Geometry"]
    names = []
    for name, socket, kind in build(tree, position):
        store = tree.nodes.new("GeometryNodeStoreNamedAttribute")
        store.data_type = kind
        store.domain = "POINT"
        store.inputs["Name"].default_value = name
        tree.links.new(geometry, store.inputs["Geometry"])
        tree.links.new(socket, store.inputs["Value"])
        geometry = store.outputs["Geometry"]
        names.append((name, kind))
    tree.links.new(geometry, group_out.inputs["Geometry"])
    modifier = obj.modifiers.new("Record", "NODES")
    modifier.node_group = tree
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    out = {}
    for name, kind in names:
        data = evaluated.attributes[name].data
        out[name] = [tuple(d.vector) if kind == "FLOAT_VECTOR" else
                     tuple(d.color)[:3] if kind == "FLOAT_COLOR" else d.value for d in data]
    return out


def noise(tree, position):
    for k, (dims, detail, rough, lac, dist, normalize) in enumerate(NOISE):
        n = tree.nodes.new("ShaderNodeTexNoise")
        n.noise_dimensions = dims
        n.normalize = normalize
        n.inputs["Scale"].default_value = 1.0
        n.inputs["Detail"].default_value = detail
        n.inputs["Roughness"].default_value = rough
        n.inputs["Lacunarity"].default_value = lac
        n.inputs["Distortion"].default_value = dist
        tree.links.new(position, n.inputs["Vector"])
        yield f"fac{k}", n.outputs["Fac"], "FLOAT"
        yield f"col{k}", n.outputs["Color"], "FLOAT_COLOR"


def voronoi(tree, position):
    for k, (dims, feature, metric, rand, detail, smooth, exponent) in enumerate(VORONOI):
        v = tree.nodes.new("ShaderNodeTexVoronoi")
        v.voronoi_dimensions = dims
        v.feature = feature
        v.distance = metric
        v.normalize = False
        values = {"Scale": 1.0, "Randomness": rand, "Detail": detail, "Smoothness": smooth,
                  "Exponent": exponent}
        for name, value in values.items():
            # Sockets a feature or metric does not use are not declared.
            if name in v.inputs:
                v.inputs[name].default_value = value
        tree.links.new(position, v.inputs["Vector"])
        yield f"dist{k}", v.outputs["Distance"], "FLOAT"
        yield f"col{k}", v.outputs["Color"], "FLOAT_COLOR"
        yield f"pos{k}", v.outputs["Position"], "FLOAT_VECTOR"


def main(out: Path):
    noise_values = evaluate(noise)
    voronoi_values = evaluate(voronoi)
    doc = {
        "blender": bpy.app.version_string,
        "points": POINTS,
        "noise": [dict(zip(("dimensions", "detail", "roughness", "lacunarity", "distortion",
                            "normalize"), n),
                       fac=noise_values[f"fac{k}"], color=noise_values[f"col{k}"])
                  for k, n in enumerate(NOISE)],
        "voronoi": [dict(zip(("dimensions", "feature", "metric", "randomness", "detail",
                              "smoothness", "exponent"), v),
                         distance=voronoi_values[f"dist{k}"],
                         color=voronoi_values[f"col{k}"],
                         position=voronoi_values[f"pos{k}"])
                    for k, v in enumerate(VORONOI)],
    }
    out.write_text(json.dumps(doc, indent=1) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main(Path(__file__).resolve().parents[2] / "tests" / "data" / "blender_patterns.json")
