#!/usr/bin/env python3
"""Write Photon's small test scenes as binary glTF (.glb) files next to this script.

Standard library only; the output is deterministic, so re-running gives identical files.
All scenes are Y-up and in metres. Punctual lights use the photometric units Blender's exporter
writes in "Standard" mode (candela and lux at 683 lm/W); Photon's own extensions (PHOTON_world,
PHOTON_light, PHOTON_render) carry what glTF lacks and are documented in docs/gltf_extensions.md.

Usage: python3 scenes/build_scenes.py
"""

import json
import math
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
LUMENS_PER_WATT = 683.0

FLOAT, UNSIGNED_INT = 5126, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963


# ----- small vector helpers -------------------------------------------------------------------

def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def normalize(a):
    length = math.sqrt(sum(x * x for x in a))
    return [x / length for x in a]


def quat_from_axes(right, up, back):
    """Quaternion [x, y, z, w] of the rotation whose matrix columns are right, up, back."""
    m00, m01, m02 = right[0], up[0], back[0]
    m10, m11, m12 = right[1], up[1], back[1]
    m20, m21, m22 = right[2], up[2], back[2]
    trace = m00 + m11 + m22
    if trace > 0:
        s = 0.5 / math.sqrt(trace + 1.0)
        return [(m21 - m12) * s, (m02 - m20) * s, (m10 - m01) * s, 0.25 / s]
    if m00 > m11 and m00 > m22:
        s = 2.0 * math.sqrt(1.0 + m00 - m11 - m22)
        return [0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s]
    if m11 > m22:
        s = 2.0 * math.sqrt(1.0 + m11 - m00 - m22)
        return [(m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s]
    s = 2.0 * math.sqrt(1.0 + m22 - m00 - m11)
    return [(m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s]


def look_at(eye, target):
    """Rotation quaternion of a node at `eye` whose local -Z points at `target` (+Y up)."""
    back = normalize(sub(eye, target))
    right = normalize(cross([0.0, 1.0, 0.0], back))
    up = cross(back, right)
    return quat_from_axes(right, up, back)


def axis_angle(axis, degrees):
    half = math.radians(degrees) / 2
    axis = normalize(axis)
    return [axis[0] * math.sin(half), axis[1] * math.sin(half), axis[2] * math.sin(half),
            math.cos(half)]


def clean(values):
    """Round floats so the JSON text does not depend on the last bits of the arithmetic."""
    return [round(v, 6) for v in values]


# ----- geometry -------------------------------------------------------------------------------

def quad(corners, normal):
    """Two triangles over four corners given counter-clockwise seen from the normal's side."""
    uvs = [[0, 1], [1, 1], [1, 0], [0, 0]]
    return corners, [normal] * 4, uvs, [0, 1, 2, 0, 2, 3]


def cube():
    """A unit cube centred on the origin, outward normals, 24 vertices."""
    positions, normals, uvs, indices = [], [], [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = [0.0, 0.0, 0.0]
            n[axis] = sign
            u = [0.0, 0.0, 0.0]
            u[(axis + 1) % 3] = 1.0
            v = cross(n, u)
            base = len(positions)
            for du, dv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                positions.append([0.5 * n[i] + 0.5 * du * u[i] + 0.5 * dv * v[i] for i in range(3)])
                normals.append(n)
                uvs.append([(du + 1) / 2, (1 - dv) / 2])
            indices += [base, base + 1, base + 2, base, base + 2, base + 3]
    return positions, normals, uvs, indices


def uv_sphere(radius, slices, stacks, inward=False):
    """A UV sphere; `inward` flips normals and winding (for a closed room seen from inside)."""
    positions, normals, uvs, indices = [], [], [], []
    for j in range(stacks + 1):
        theta = math.pi * j / stacks
        for i in range(slices + 1):
            phi = 2 * math.pi * i / slices
            n = [math.sin(theta) * math.cos(phi), math.cos(theta), -math.sin(theta) * math.sin(phi)]
            positions.append([radius * x for x in n])
            normals.append([-x for x in n] if inward else n)
            uvs.append([i / slices, j / stacks])
    row = slices + 1
    for j in range(stacks):
        for i in range(slices):
            a, b = j * row + i, (j + 1) * row + i
            c, d = b + 1, a + 1
            triangles = []
            if j != 0:
                triangles.append((a, b, d))
            if j != stacks - 1:
                triangles.append((d, b, c))
            for t in triangles:
                indices += [t[0], t[2], t[1]] if inward else list(t)
    return positions, normals, uvs, indices


# ----- PNG ------------------------------------------------------------------------------------

def png_rgb(width, height, pixel):
    """Encode an 8-bit RGB PNG; pixel(x, y) returns (r, g, b)."""
    raw = bytearray()
    for y in range(height):
        raw.append(0)  # filter: none
        for x in range(width):
            raw += bytes(pixel(x, y))

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(bytes(raw), 9)) + chunk(b"IEND", b""))


# ----- glTF writer ----------------------------------------------------------------------------

class Gltf:
    """Accumulates a glTF document and its binary buffer, then writes a GLB."""

    def __init__(self):
        self.doc = {
            "asset": {"version": "2.0", "generator": "Photon scenes/build_scenes.py"},
            "scene": 0,
            "scenes": [{"name": "Scene", "nodes": []}],
            "nodes": [], "meshes": [], "materials": [], "accessors": [], "bufferViews": [],
        }
        self.bin = bytearray()
        self.used = set()

    def _list(self, key, item):
        self.doc.setdefault(key, []).append(item)
        return len(self.doc[key]) - 1

    def use(self, extension, required=False):
        self.used.add(extension)
        if required:
            required_list = self.doc.setdefault("extensionsRequired", [])
            if extension not in required_list:
                required_list.append(extension)

    def view(self, data, target=None):
        while len(self.bin) % 4:
            self.bin.append(0)
        view = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        self.bin += data
        return self._list("bufferViews", view)

    def accessor(self, rows, kind):
        width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3}[kind]
        if kind == "SCALAR":
            data = struct.pack("<%dI" % len(rows), *rows)
            view = self.view(data, ELEMENT_ARRAY_BUFFER)
            return self._list("accessors", {"bufferView": view, "componentType": UNSIGNED_INT,
                                            "count": len(rows), "type": kind})
        flat = [float(x) for row in rows for x in row]
        view = self.view(struct.pack("<%df" % len(flat), *flat), ARRAY_BUFFER)
        accessor = {"bufferView": view, "componentType": FLOAT, "count": len(rows), "type": kind}
        if kind == "VEC3":
            accessor["min"] = clean([min(r[i] for r in rows) for i in range(width)])
            accessor["max"] = clean([max(r[i] for r in rows) for i in range(width)])
        return self._list("accessors", accessor)

    def mesh(self, name, geometry, material):
        positions, normals, uvs, indices = geometry
        attributes = {"POSITION": self.accessor(positions, "VEC3"),
                      "NORMAL": self.accessor(normals, "VEC3"),
                      "TEXCOORD_0": self.accessor(uvs, "VEC2")}
        primitive = {"attributes": attributes, "indices": self.accessor(indices, "SCALAR"),
                     "material": material}
        return self._list("meshes", {"name": name, "primitives": [primitive]})

    def material(self, name, base=(0.8, 0.8, 0.8), metallic=0.0, roughness=0.5, emission=None,
                 strength=1.0, lambert=False, extensions=None, base_texture=None,
                 double_sided=True):
        pbr = {"baseColorFactor": clean(list(base) + [1.0]), "metallicFactor": metallic,
               "roughnessFactor": roughness}
        if base_texture is not None:
            pbr["baseColorTexture"] = base_texture
        material = {"name": name, "pbrMetallicRoughness": pbr, "doubleSided": double_sided}
        ext = dict(extensions or {})
        if lambert:
            ext["KHR_materials_specular"] = {"specularFactor": 0.0}
        if emission is not None:
            material["emissiveFactor"] = clean(emission)
            if strength != 1.0:
                ext["KHR_materials_emissive_strength"] = {"emissiveStrength": strength}
        if ext:
            material["extensions"] = ext
            for key in ext:
                self.use(key)
        return self._list("materials", material)

    def node(self, name, mesh=None, translation=None, rotation=None, scale=None, camera=None,
             light=None, photon_light=None):
        node = {"name": name}
        if mesh is not None:
            node["mesh"] = mesh
        if camera is not None:
            node["camera"] = camera
        if translation is not None:
            node["translation"] = clean(translation)
        if rotation is not None:
            node["rotation"] = clean(rotation)
        if scale is not None:
            node["scale"] = clean(scale)
        extensions = {}
        if light is not None:
            extensions["KHR_lights_punctual"] = {"light": light}
        if photon_light is not None:
            extensions["PHOTON_light"] = photon_light
            self.use("PHOTON_light")
        if extensions:
            node["extensions"] = extensions
        index = self._list("nodes", node)
        self.doc["scenes"][0]["nodes"].append(index)
        return index

    def camera(self, name, eye, target, yfov_degrees, aspect):
        camera = self._list("cameras", {"name": name, "type": "perspective", "perspective": {
            "yfov": round(math.radians(yfov_degrees), 6), "aspectRatio": round(aspect, 6),
            "znear": 0.01, "zfar": 1000.0}})
        return self.node(name, camera=camera, translation=eye, rotation=look_at(eye, target))

    def punctual(self, name, kind, color, intensity, position, target=None, spot=None,
                 photon=None):
        """A KHR_lights_punctual light; Blender marks the extension required, so do we."""
        self.use("KHR_lights_punctual", required=True)
        light = {"name": name, "type": kind, "color": clean(color), "intensity": round(intensity, 4)}
        if spot is not None:
            light["spot"] = spot
        lights = self.doc.setdefault("extensions", {}).setdefault(
            "KHR_lights_punctual", {"lights": []})["lights"]
        lights.append(light)
        rotation = look_at(position, target) if target is not None else None
        return self.node(name, translation=position, rotation=rotation, light=len(lights) - 1,
                         photon_light=photon)

    def texture_png(self, name, png, nearest=False):
        image = self._list("images", {"name": name, "mimeType": "image/png",
                                      "bufferView": self.view(png)})
        sampler = {"wrapS": 10497, "wrapT": 10497}
        if nearest:
            sampler.update({"magFilter": 9728, "minFilter": 9728})
        sampler_index = self._list("samplers", sampler)
        return self._list("textures", {"source": image, "sampler": sampler_index})

    def scene_extension(self, name, value):
        self.doc["scenes"][0].setdefault("extensions", {})[name] = value
        self.use(name)

    def write(self, filename):
        while len(self.bin) % 4:
            self.bin.append(0)
        self.doc["buffers"] = [{"byteLength": len(self.bin)}]
        if self.used:
            self.doc["extensionsUsed"] = sorted(self.used)
        text = json.dumps(self.doc, separators=(",", ":"), sort_keys=True).encode()
        text += b" " * (-len(text) % 4)
        total = 12 + 8 + len(text) + 8 + len(self.bin)
        glb = (struct.pack("<4sII", b"glTF", 2, total)
               + struct.pack("<I4s", len(text), b"JSON") + text
               + struct.pack("<I4s", len(self.bin), b"BIN\x00") + bytes(self.bin))
        path = os.path.join(HERE, filename)
        with open(path, "wb") as f:
            f.write(glb)
        print("wrote %s (%d bytes)" % (path, len(glb)))


def render_settings(g, width, height):
    g.scene_extension("PHOTON_render", {"width": width, "height": height,
                                        "film_transparent": False})


def floor_quad(half):
    return quad([[-half, 0, half], [half, 0, half], [half, 0, -half], [-half, 0, -half]],
                [0, 1, 0])


# ----- scenes ---------------------------------------------------------------------------------

def cornell_room(g):
    """The Cornell box's room, 5.55 m on a side, open at +Z, lit by an emissive quad under the
    ceiling; returns the white material."""
    s = 2.775  # half size
    h = 2 * s
    white = g.material("White", base=(0.725, 0.71, 0.68), roughness=1.0, lambert=True)
    red = g.material("Red", base=(0.63, 0.065, 0.05), roughness=1.0, lambert=True)
    green = g.material("Green", base=(0.14, 0.45, 0.091), roughness=1.0, lambert=True)
    # One-sided, so it emits only downwards: a double-sided lamp 1 cm under the ceiling would
    # flood that gap with light and make every path that reaches it a firefly.
    light = g.material("Light", base=(0, 0, 0), roughness=1.0, lambert=True,
                       emission=(1.0, 0.706, 0.235), strength=40.0, double_sided=False)
    walls = [
        ("Floor", white, quad([[-s, 0, s], [s, 0, s], [s, 0, -s], [-s, 0, -s]], [0, 1, 0])),
        ("Ceiling", white, quad([[-s, h, -s], [s, h, -s], [s, h, s], [-s, h, s]], [0, -1, 0])),
        ("Back", white, quad([[-s, 0, -s], [s, 0, -s], [s, h, -s], [-s, h, -s]], [0, 0, 1])),
        ("Left", red, quad([[-s, 0, s], [-s, 0, -s], [-s, h, -s], [-s, h, s]], [1, 0, 0])),
        ("Right", green, quad([[s, 0, -s], [s, 0, s], [s, h, s], [s, h, -s]], [-1, 0, 0])),
    ]
    for name, material, geometry in walls:
        g.node(name, mesh=g.mesh(name, geometry, material))
    # The lamp: 1.3 m x 1.05 m just under the ceiling, facing down.
    lx, lz, ly = 0.65, 0.525, h - 0.01
    lamp = quad([[-lx, ly, -lz], [lx, ly, -lz], [lx, ly, lz], [-lx, ly, lz]], [0, -1, 0])
    g.node("Lamp", mesh=g.mesh("Lamp", lamp, light))
    return white


def cornell_box():
    """The Cornell box with two diffuse boxes."""
    g = Gltf()
    s = 2.775
    white = cornell_room(g)
    # One unit cube mesh, instanced twice with rotation and non-uniform scale.
    box = g.mesh("Box", cube(), white)
    g.node("ShortBox", mesh=box, translation=[0.93, 0.825, 0.7],
           rotation=axis_angle([0, 1, 0], -17), scale=[1.65, 1.65, 1.65])
    g.node("TallBox", mesh=box, translation=[-0.93, 1.65, -0.7],
           rotation=axis_angle([0, 1, 0], 17), scale=[1.65, 3.3, 1.65])
    g.camera("Camera", [0, s, s + 8.0], [0, s, 0], 39.3, 1.0)
    render_settings(g, 256, 256)
    g.write("cornell_box.glb")


def furnace():
    """Inside a closed sphere of albedo 0.5 emitting 0.5 everywhere: radiance is exactly 1."""
    g = Gltf()
    material = g.material("Furnace", base=(0.5, 0.5, 0.5), roughness=1.0, lambert=True,
                          emission=(0.5, 0.5, 0.5))
    g.node("Sphere", mesh=g.mesh("Sphere", uv_sphere(1.0, 48, 24, inward=True), material))
    g.camera("Camera", [0, 0, 0.3], [0, 0, -1], 60.0, 1.0)
    render_settings(g, 128, 128)
    g.write("furnace.glb")


def materials():
    """Glass, rough metal and default dielectric spheres on a checkered floor under a sun."""
    g = Gltf()
    checker = png_rgb(8, 8, lambda x, y: (230, 230, 230) if (x // 4 + y // 4) % 2 == 0
                      else (40, 40, 40))
    texture = g.texture_png("checker.png", checker, nearest=True)
    g.use("KHR_texture_transform")
    floor = g.material("Checker", base=(1, 1, 1), roughness=0.8, base_texture={
        "index": texture,
        "extensions": {"KHR_texture_transform": {"scale": [4.0, 4.0], "offset": [0.0, 0.0]}}})
    glass = g.material("Glass", base=(1, 1, 1), roughness=0.0, extensions={
        "KHR_materials_transmission": {"transmissionFactor": 1.0},
        "KHR_materials_ior": {"ior": 1.5}})
    metal = g.material("Metal", base=(0.9, 0.64, 0.3), metallic=1.0, roughness=0.3)
    plastic = g.material("Dielectric", base=(0.8, 0.1, 0.1), roughness=0.5)
    g.node("Floor", mesh=g.mesh("Floor", floor_quad(5.0), floor))
    sphere = uv_sphere(0.7, 32, 16)
    for name, material, x in (("GlassSphere", glass, -1.6), ("MetalSphere", metal, 0.0),
                              ("DielectricSphere", plastic, 1.6)):
        g.node(name, mesh=g.mesh(name, sphere, material), translation=[x, 0.7, 0])
    g.punctual("Sun", "directional", [1, 1, 1], 3.0 * LUMENS_PER_WATT, [0, 10, 0],
               target=[-3, 0, -5], photon={"angle": 0.0092})
    g.scene_extension("PHOTON_world", {"color": [0.4, 0.5, 0.7], "strength": 0.5})
    g.camera("Camera", [0, 2.2, 6.0], [0, 0.6, 0], 40.0, 1.0)
    render_settings(g, 256, 256)
    g.write("materials.glb")


def lights():
    """A point, a spot and a rectangular area light over a floor with a cube and a sphere."""
    g = Gltf()
    grey = g.material("Grey", base=(0.6, 0.6, 0.6), roughness=1.0, lambert=True)
    blue = g.material("Blue", base=(0.2, 0.3, 0.8), roughness=0.4)
    g.node("Floor", mesh=g.mesh("Floor", floor_quad(6.0), grey))
    g.node("Cube", mesh=g.mesh("Cube", cube(), grey), translation=[-1.2, 0.5, 0],
           rotation=axis_angle([0, 1, 0], 30))
    g.node("Ball", mesh=g.mesh("Ball", uv_sphere(0.6, 32, 16), blue), translation=[1.2, 0.6, 0])
    # Blender's exporter: intensity = P / (4 pi) * 683 for point and spot lights.
    candela = lambda watts: watts / (4 * math.pi) * LUMENS_PER_WATT
    g.punctual("Point", "point", [1.0, 0.9, 0.8], candela(300.0), [-2.0, 3.0, 2.0],
               photon={"radius": 0.1})
    outer = math.radians(45) / 2
    g.punctual("Spot", "spot", [0.8, 0.9, 1.0], candela(800.0), [2.5, 4.0, 1.5],
               target=[1.2, 0, 0], spot={"innerConeAngle": round(outer * 0.85, 6),
                                         "outerConeAngle": round(outer, 6)},
               photon={"radius": 0.05})
    g.node("Area", translation=[0, 3.5, -1.5], rotation=axis_angle([1, 0, 0], -90),
           photon_light={"type": "area", "shape": "RECTANGLE", "size": 1.0, "size_y": 0.5,
                         "power": 200.0, "color": [1.0, 0.8, 0.6], "visible_camera": True})
    g.camera("Camera", [0, 2.5, 7.0], [0, 0.5, 0], 40.0, 320 / 240)
    render_settings(g, 320, 240)
    g.write("lights.glb")


def glass_caustic():
    """A glass sphere on a diffuse floor under a small square area light: a caustic below it."""
    g = Gltf()
    floor = g.material("Floor", base=(0.8, 0.8, 0.8), roughness=1.0, lambert=True)
    glass = g.material("Glass", base=(1, 1, 1), roughness=0.0, extensions={
        "KHR_materials_transmission": {"transmissionFactor": 1.0},
        "KHR_materials_ior": {"ior": 1.5}})
    g.node("Floor", mesh=g.mesh("Floor", floor_quad(4.0), floor))
    g.node("GlassSphere", mesh=g.mesh("GlassSphere", uv_sphere(1.0, 64, 32), glass),
           translation=[0, 1.0, 0])
    g.node("Lamp", translation=[0.8, 5.0, 0.5], rotation=axis_angle([1, 0, 0], -90),
           photon_light={"type": "area", "shape": "SQUARE", "size": 0.3, "power": 400.0,
                         "color": [1.0, 1.0, 1.0], "visible_camera": False})
    g.camera("Camera", [0, 3.0, 6.0], [0, 0.6, 0], 40.0, 1.0)
    render_settings(g, 256, 256)
    g.write("glass_caustic.glb")


if __name__ == "__main__":
    cornell_box()
    furnace()
    materials()
    lights()
    glass_caustic()
