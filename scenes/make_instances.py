#!/usr/bin/env python3
"""Write a scene of many instances of one small mesh, for start-up measurements of instancing
(not committed: it is large). A field of unit cubes (12 triangles each, one mesh) on a square
grid, lit by a sun, seen from above at an angle: `--count` nodes (default 999 998, which with
the camera's and the sun's nodes make Photon's limit of a million nodes).

Usage: python3 scenes/make_instances.py OUT.glb [--count N]
Then, for example: photon bench OUT.glb --width 96 --budgets 1 --methods path --reference-spp 4
Standard library only; deterministic.
"""

import argparse
import json
import math
import struct


def cube():
    """Positions and indices of a unit cube centred on the origin: 8 vertices, 12 triangles."""
    pos = [(x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    idx = [i for a, b, c, d in faces for i in (a, b, c, a, c, d)]
    return pos, idx


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--count", type=int, default=999_998)
    args = ap.parse_args()
    pos, idx = cube()
    blob = b"".join(struct.pack("<3f", *p) for p in pos) + struct.pack(f"<{len(idx)}I", *idx)
    side = math.ceil(math.sqrt(args.count))
    nodes = [{"mesh": 0, "translation": [2.0 * (i % side - side / 2), 0.5,
                                         2.0 * (i // side - side / 2)]}
             for i in range(args.count)]
    # Camera: above the field's near edge, looking across it and down.
    pitch = -0.35
    cam_rot = [math.sin(pitch / 2), 0.0, 0.0, math.cos(pitch / 2)]
    nodes.append({"camera": 0, "translation": [0.0, 12.0, side + 10.0], "rotation": cam_rot})
    sun = [math.sin(-0.6), 0.0, 0.0, math.cos(-0.6)]
    nodes.append({"extensions": {"KHR_lights_punctual": {"light": 0}}, "rotation": sun})
    gltf = {
        "asset": {"version": "2.0", "generator": "Photon scenes/make_instances.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "directional", "intensity": 683.0 * 3.0}]}},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "cameras": [{"type": "perspective",
                     "perspective": {"yfov": 0.8, "znear": 0.1, "aspectRatio": 1.5}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1,
                                    "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1],
                                                "metallicFactor": 0, "roughnessFactor": 1}}],
        "buffers": [{"byteLength": len(blob)}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 96},
                        {"buffer": 0, "byteOffset": 96, "byteLength": 4 * len(idx)}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
             "min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5]},
            {"bufferView": 1, "componentType": 5125, "count": len(idx), "type": "SCALAR"},
        ],
    }
    text = json.dumps(gltf, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    blob += b"\0" * (-len(blob) % 4)
    body = (struct.pack("<II", len(text), 0x4E4F534A) + text +
            struct.pack("<II", len(blob), 0x004E4942) + blob)
    with open(args.out, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body)


if __name__ == "__main__":
    main()
