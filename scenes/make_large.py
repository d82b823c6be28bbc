#!/usr/bin/env python3
"""Write a large scene for throughput and start-up measurements (not committed: it is big).

A rolling terrain (a displaced grid) with a field of tessellated spheres on it, a sun and a
camera looking across it: about `--triangles` triangles in all (default 1 million), half in the
terrain and half in the spheres. Standard library only; deterministic.

Usage: python3 scenes/make_large.py OUT.glb [--triangles N]
"""

import argparse
import json
import math
import struct
import sys
from array import array

sys.path.insert(0, __import__("os").path.dirname(__file__))
from build_scenes import LUMENS_PER_WATT, look_at  # noqa: E402


def terrain(n, size):
    """An n × n cell height field of side `size`: 2n² triangles."""
    pos, nrm, idx = array("f"), array("f"), array("I")
    h = lambda x, z: 0.4 * math.sin(0.7 * x) * math.cos(0.5 * z) + 0.1 * math.sin(3.1 * x + 1.7 * z)
    step = size / n
    for j in range(n + 1):
        for i in range(n + 1):
            x, z = -0.5 * size + i * step, -0.5 * size + j * step
            e = 1e-3
            dx = (h(x + e, z) - h(x - e, z)) / (2 * e)
            dz = (h(x, z + e) - h(x, z - e)) / (2 * e)
            ln = math.sqrt(dx * dx + 1 + dz * dz)
            pos.extend((x, h(x, z), z))
            nrm.extend((-dx / ln, 1 / ln, -dz / ln))
    row = n + 1
    for j in range(n):
        for i in range(n):
            a = j * row + i
            idx.extend((a, a + row, a + 1, a + 1, a + row, a + row + 1))
    return pos, nrm, idx


def spheres(count, tris_each, size, base):
    """`count` spheres of about `tris_each` triangles on a jittered grid."""
    stacks = max(4, int(math.sqrt(tris_each / 2)))
    slices = max(4, tris_each // (2 * stacks))
    pos, nrm, idx = array("f"), array("f"), array("I")
    side = int(math.ceil(math.sqrt(count)))
    for s in range(count):
        gx, gz = s % side, s // side
        cx = -0.4 * size + 0.8 * size * (gx + 0.5) / side
        cz = -0.4 * size + 0.8 * size * (gz + 0.5) / side
        r = 0.15 + 0.1 * ((s * 7919) % 13) / 13
        cy = 0.6 + r
        first = base + len(pos) // 3
        for k in range(stacks + 1):
            th = math.pi * k / stacks
            for l in range(slices + 1):
                ph = 2 * math.pi * l / slices
                n = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
                pos.extend((cx + r * n[0], cy + r * n[1], cz + r * n[2]))
                nrm.extend(n)
        row = slices + 1
        for k in range(stacks):
            for l in range(slices):
                a = first - base + k * row + l
                idx.extend((a, a + 1, a + row, a + 1, a + row + 1, a + row))
    return pos, nrm, idx


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--triangles", type=int, default=1_000_000)
    args = ap.parse_args()
    size = 20.0
    n = int(math.sqrt(args.triangles / 4))
    t_pos, t_nrm, t_idx = terrain(n, size)
    s_pos, s_nrm, s_idx = spheres(256, args.triangles // 2 // 256, size, 0)
    meshes, views, accessors, blob = [], [], [], bytearray()

    def add(data, target, comp, kind, count, minmax=None):
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data) * 4,
                      "target": target})
        acc = {"bufferView": len(views) - 1, "componentType": comp, "count": count, "type": kind}
        if minmax:
            acc["min"], acc["max"] = minmax
        accessors.append(acc)
        blob.extend(data.tobytes())
        return len(accessors) - 1

    for name, (p, nr, ix), mat in (("terrain", (t_pos, t_nrm, t_idx), 0),
                                   ("spheres", (s_pos, s_nrm, s_idx), 1)):
        xs, ys, zs = p[0::3], p[1::3], p[2::3]
        mm = ([min(xs), min(ys), min(zs)], [max(xs), max(ys), max(zs)])
        pa = add(p, 34962, 5126, "VEC3", len(p) // 3, mm)
        na = add(nr, 34962, 5126, "VEC3", len(nr) // 3)
        ia = add(ix, 34963, 5125, "SCALAR", len(ix))
        meshes.append({"name": name, "primitives": [
            {"attributes": {"POSITION": pa, "NORMAL": na}, "indices": ia, "material": mat}]})
    eye, target = [0.0, 4.0, 11.0], [0.0, 0.5, 0.0]
    sun_dir = [-0.4, -1.0, -0.3]
    gltf = {
        "asset": {"version": "2.0", "generator": "Photon scenes/make_large.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "directional", "intensity": 3.0 * LUMENS_PER_WATT, "name": "Sun"}]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"name": "terrain", "mesh": 0},
            {"name": "spheres", "mesh": 1},
            {"name": "Camera", "camera": 0, "translation": eye, "rotation": look_at(eye, target)},
            {"name": "Sun", "extensions": {"KHR_lights_punctual": {"light": 0}},
             "rotation": look_at([0, 0, 0], sun_dir)},
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.1}}],
        "materials": [
            {"name": "ground", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.45, 0.35, 1],
                                                         "metallicFactor": 0, "roughnessFactor": 1}},
            {"name": "rock", "pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.65, 1],
                                                       "metallicFactor": 0, "roughnessFactor": 0.6}},
        ],
        "meshes": meshes,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(blob)}],
    }
    js = json.dumps(gltf, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    blob += b"\0" * (-len(blob) % 4)
    total = 12 + 8 + len(js) + 8 + len(blob)
    with open(args.out, "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, total))
        f.write(struct.pack("<I4s", len(js), b"JSON") + js)
        f.write(struct.pack("<I4s", len(blob), b"BIN\0") + bytes(blob))
    print(f"{args.out}: {len(t_idx) // 3 + len(s_idx) // 3} triangles")


if __name__ == "__main__":
    main()
