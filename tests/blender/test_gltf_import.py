"""glTF files from other tools, as a new user brings them to `photon render`: each file is
written here (`Gltf`, a small glTF 2.0 writer with PNG textures encoded here too), imported by
Blender's glTF importer (`bpy.ops.import_scene.gltf`) and rendered by Cycles, and rendered by
`photon render --camera Camera`; the mean must agree within 1 % and the relMSE of 4x4-pixel block
means (which leaves out both renderers' pixel noise) be at most 0.01, at 48x48 pixels.

Every file starts from `stage()`: a grey floor, a camera looking down at it from 3 m up and 4 m
back, and a directional light of 2000 lux from the upper left, the only light (black world);
each test adds the object it is about and says what it shows.
"""

from __future__ import annotations

import json
import math
import struct
import subprocess
import zlib
from pathlib import Path

import numpy as np
import pytest

from helpers import photon_binary, read_exr, rel_mse
import reference_cache

MEAN_TOL = 0.01
BLOCK_RELMSE_MAX = 0.01


def png_bytes(rgba: np.ndarray) -> bytes:
    """An 8-bit RGBA PNG of `rgba` (H, W, 4) uint8, row 0 at the top."""
    height, width, _ = rgba.shape
    raw = b"".join(b"\0" + rgba[y].astype(np.uint8).tobytes() for y in range(height))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))

    header = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw))
            + chunk(b"IEND", b""))


def stripes(width=16, height=16, period=4) -> np.ndarray:
    """Vertical stripes: `period` columns of warm red then `period` of pale blue-grey."""
    rgba = np.zeros((height, width, 4), np.uint8)
    for x in range(width):
        rgba[:, x] = (220, 60, 30, 255) if (x // period) % 2 == 0 else (70, 110, 200, 255)
    return rgba


def quat_look(direction) -> list[float]:
    """The rotation (x, y, z, w) turning glTF's −Z (cameras, lights) towards `direction`,
    keeping +Y up."""
    d = np.asarray(direction, float)
    d /= np.linalg.norm(d)
    yaw = math.atan2(-d[0], -d[2])
    pitch = math.asin(d[1])
    qy = np.array([0.0, math.sin(yaw / 2), 0.0, math.cos(yaw / 2)])
    qx = np.array([math.sin(pitch / 2), 0.0, 0.0, math.cos(pitch / 2)])
    return quat_mul(qy, qx).tolist()


def quat_mul(a, b) -> np.ndarray:
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return np.array([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz])


class Gltf:
    """A glTF document under construction with one binary buffer."""

    def __init__(self):
        self.json = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": []}],
                     "nodes": [], "meshes": [], "accessors": [], "bufferViews": [],
                     "materials": []}
        self.bin = bytearray()

    def push(self, key: str, item) -> int:
        self.json.setdefault(key, []).append(item)
        return len(self.json[key]) - 1

    def use(self, extension: str, required: bool = False):
        used = self.json.setdefault("extensionsUsed", [])
        if extension not in used:
            used.append(extension)
        if required:
            req = self.json.setdefault("extensionsRequired", [])
            if extension not in req:
                req.append(extension)

    def view(self, data: bytes) -> int:
        while len(self.bin) % 4:
            self.bin.append(0)
        offset = len(self.bin)
        self.bin.extend(data)
        return self.push("bufferViews", {"buffer": 0, "byteOffset": offset,
                                         "byteLength": len(data)})

    def accessor(self, values, kind: str, component: int = 5126, normalized: bool = False,
                 bounds: bool = False) -> int:
        """An accessor of `values` (a flat list) of glTF `kind` and component type."""
        fmt = {5120: "b", 5121: "B", 5122: "h", 5123: "H", 5125: "I", 5126: "f"}[component]
        width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}[kind]
        data = struct.pack(f"<{len(values)}{fmt}", *values)
        accessor = {"bufferView": self.view(data), "componentType": component,
                    "count": len(values) // width, "type": kind}
        if normalized:
            accessor["normalized"] = True
        if bounds:
            cols = np.asarray(values, float).reshape(-1, width)
            accessor["min"] = cols.min(axis=0).tolist()
            accessor["max"] = cols.max(axis=0).tolist()
        return self.push("accessors", accessor)

    def mesh(self, name, positions, normals, indices, material=None, uvs=None,
             extra=None) -> int:
        attributes = {"POSITION": self.accessor(positions, "VEC3", bounds=True),
                      "NORMAL": self.accessor(normals, "VEC3")}
        if uvs is not None:
            attributes["TEXCOORD_0"] = self.accessor(uvs, "VEC2")
        primitive = {"attributes": attributes, "indices": self.accessor(indices, "SCALAR", 5125)}
        if material is not None:
            primitive["material"] = material
        primitive.update(extra or {})
        return self.push("meshes", {"name": name, "primitives": [primitive]})

    def quad(self, name, half: float, material=None, extra=None) -> int:
        """A square of side 2·half in the XY plane facing +Z, UVs (0, 0) at its upper left."""
        h = half
        positions = [-h, -h, 0, h, -h, 0, h, h, 0, -h, h, 0]
        uvs = [0, 1, 1, 1, 1, 0, 0, 0]
        return self.mesh(name, positions, [0, 0, 1] * 4, [0, 1, 2, 0, 2, 3], material, uvs,
                         extra)

    def box(self, name, half: float, material=None) -> int:
        """A cube of side 2·half centred on the origin, with flat normals."""
        positions, normals, indices = [], [], []
        for axis in range(3):
            for sign in (-1.0, 1.0):
                n = [0.0, 0.0, 0.0]
                n[axis] = sign
                u, v = [(axis + 1) % 3, (axis + 2) % 3]
                base = len(positions) // 3
                for a, b in [(-1, -1), (1, -1), (1, 1), (-1, 1)]:
                    p = [0.0, 0.0, 0.0]
                    p[axis], p[u], p[v] = sign * half, a * half, b * half
                    positions += p
                    normals += n
                quad = [0, 1, 2, 0, 2, 3] if sign > 0 else [0, 2, 1, 0, 3, 2]
                indices += [base + i for i in quad]
        return self.mesh(name, positions, normals, indices, material)

    def node(self, node: dict, root: bool = True) -> int:
        index = self.push("nodes", node)
        if root:
            self.json["scenes"][0]["nodes"].append(index)
        return index

    def material(self, material: dict) -> int:
        return self.push("materials", material)

    def texture(self, rgba: np.ndarray, sampler: dict | None = None) -> int:
        image = self.push("images", {"bufferView": self.view(png_bytes(rgba)),
                                     "mimeType": "image/png"})
        texture = {"source": image}
        if sampler is not None:
            texture["sampler"] = self.push("samplers", sampler)
        return self.push("textures", texture)

    def camera(self, position, target, yfov=0.7):
        index = self.push("cameras", {"name": "Camera", "type": "perspective", "perspective":
                                      {"yfov": yfov, "aspectRatio": 1.0, "znear": 0.05}})
        direction = np.subtract(target, position)
        self.node({"name": "Camera", "camera": index, "translation": list(position),
                   "rotation": quat_look(direction)})

    def sun(self, direction, lux: float):
        self.use("KHR_lights_punctual")
        lights = self.json.setdefault("extensions", {}).setdefault(
            "KHR_lights_punctual", {"lights": []})["lights"]
        lights.append({"type": "directional", "intensity": lux, "color": [1.0, 1.0, 1.0]})
        self.node({"name": "Sun", "rotation": quat_look(direction),
                   "extensions": {"KHR_lights_punctual": {"light": len(lights) - 1}}})

    def write(self, path: Path) -> Path:
        doc = dict(self.json)
        doc["buffers"] = [{"byteLength": len(self.bin)}]
        if not doc["materials"]:
            del doc["materials"]
        text = json.dumps(doc).encode()
        text += b" " * (-len(text) % 4)
        blob = bytes(self.bin) + b"\0" * (-len(self.bin) % 4)
        total = 12 + 8 + len(text) + 8 + len(blob)
        path.write_bytes(struct.pack("<4sII", b"glTF", 2, total)
                         + struct.pack("<I4s", len(text), b"JSON") + text
                         + struct.pack("<I4s", len(blob), b"BIN\0") + blob)
        return path


def stage() -> Gltf:
    """A grey floor (8 m square, at y = 0), the camera 4 m up and 4 m back looking at the
    origin, and a sun of 2000 lux (about 2.9 W/m²) from the upper left."""
    doc = Gltf()
    grey = doc.material({"name": "Floor", "pbrMetallicRoughness":
                         {"baseColorFactor": [0.6, 0.6, 0.6, 1.0], "metallicFactor": 0.0,
                          "roughnessFactor": 1.0}})
    floor = doc.quad("Floor", 4.0, grey)
    # The quad faces +Z; turned −90° about X it faces +Y.
    doc.node({"name": "Floor", "mesh": floor,
              "rotation": [-math.sin(math.pi / 4), 0.0, 0.0, math.cos(math.pi / 4)]})
    doc.camera((0.0, 3.0, 4.0), (0.0, 0.4, 0.0))
    doc.sun((0.5, -1.0, -0.4), 2000.0)
    return doc


def render_cycles(path: Path, out: Path, size: int, samples: int,
                  frame: int | None = None) -> np.ndarray:
    """Blender's import of the glTF file `path` rendered by Cycles (RGB, row 0 at the top), at
    `frame` when given."""
    import bpy

    import common

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=str(path))
    scene = bpy.context.scene
    scene.camera = next(o for o in scene.objects if o.type == "CAMERA")
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    if frame is not None:
        scene.frame_set(frame)
    scene.render.engine = "CYCLES"
    common.configure_cycles(scene, samples, seed=1, threads=2)
    scene.render.filepath = str(out)
    scene.render.use_file_extension = False

    def render():
        bpy.ops.render.render(write_still=True)
        return read_exr(out)

    # One render per test of what its cases import alike (reference_cache.py).
    return reference_cache.cached_render(render, out)[0]


def render_photon(path: Path, out: Path, size: int, samples: int,
                  extra: list[str] | None = None) -> np.ndarray:
    """`photon render` of the glTF file `path` through its camera "Camera" (RGB)."""
    cmd = [str(photon_binary()), "render", str(path), "-o", str(out), "--width", str(size),
           "--height", str(size), "--spp", str(samples), "--seed", "1", "--camera", "Camera",
           *(extra or [])]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600,
                          stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, f"{' '.join(cmd)} exited {proc.returncode}:\n{proc.stderr}"
    return read_exr(out)


def block_means(image: np.ndarray, block: int = 4) -> np.ndarray:
    h, w, c = image.shape
    return image[: h - h % block, : w - w % block].reshape(
        h // block, block, w // block, block, c).mean(axis=(1, 3))


def compare_with_blender(path: Path, tmp_path: Path, *, size=48, photon_spp=512,
                         cycles_spp=512, photon_args=None, cycles_path: Path | None = None,
                         frame: int | None = None):
    """Photon's render of `path` against Cycles' render of Blender's import of `cycles_path`
    (default: the same file); asserts the agreement and returns (photon, cycles)."""
    name = path.stem
    ref = render_cycles(cycles_path or path, tmp_path / f"{name}_cycles.exr", size, cycles_spp,
                        frame)
    img = render_photon(path, tmp_path / f"{name}_photon.exr", size, photon_spp, photon_args)
    assert img.shape == ref.shape, (img.shape, ref.shape)
    diff = float(img.mean() / ref.mean()) - 1.0
    err = rel_mse(block_means(img), block_means(ref))
    msg = (f"{name}: mean photon {img.mean():.5f} vs cycles {ref.mean():.5f} "
           f"({100 * diff:+.2f} %), 4x4-block relMSE {err:.5f}")
    print(msg)
    assert abs(diff) <= MEAN_TOL, msg
    assert err <= BLOCK_RELMSE_MAX, msg
    return img, ref


# ----- the files ----------------------------------------------------------------------------

def standing_quad(doc: Gltf, name: str, material: int, extra=None) -> int:
    """A 1.6 m square standing on the floor at the origin, facing the camera."""
    mesh = doc.quad(name, 0.8, material, extra)
    return doc.node({"name": name, "mesh": mesh, "translation": [0.0, 0.8, 0.0]})


@pytest.mark.parametrize("method", ["path", "photon"])
def test_unlit(tmp_path, method):
    """KHR_materials_unlit (required): a standing square whose base colour (a factor times a
    striped texture) is seen by the camera as it is, unshaded; Blender's importer makes it an
    Emission that only camera rays see, so it neither lights the floor nor shadows it."""
    doc = stage()
    doc.use("KHR_materials_unlit", required=True)
    texture = doc.texture(stripes())
    unlit = doc.material({"name": "Unlit", "extensions": {"KHR_materials_unlit": {}},
                          "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.8, 0.6, 1.0],
                                                   "baseColorTexture": {"index": texture}}})
    standing_quad(doc, "Sign", unlit)
    # Both methods: light through the square's Transparent BSDF is direct light (shadow rays
    # pass it), never a caustic photon.
    compare_with_blender(doc.write(tmp_path / "unlit.glb"), tmp_path,
                         photon_args=["--method", method])


def specular_glossiness_doc(textured: bool) -> Gltf:
    doc = stage()
    doc.use("KHR_materials_pbrSpecularGlossiness", required=True)
    ext = {"diffuseFactor": [0.6, 0.15, 0.1, 1.0], "specularFactor": [0.25, 0.25, 0.2],
           "glossinessFactor": 0.6}
    if textured:
        rgba = stripes()
        rgba[:, :, 3] = np.where(rgba[:, :, 0] > 100, 255, 90)  # glossiness in alpha
        ext["specularGlossinessTexture"] = {"index": doc.texture(rgba)}
        ext["diffuseTexture"] = {"index": doc.texture(stripes(period=2))}
    material = doc.material({"name": "SpecGloss", "extensions":
                             {"KHR_materials_pbrSpecularGlossiness": ext}})
    box = doc.box("Box", 0.6, material)
    doc.node({"name": "Box", "mesh": box, "translation": [0.0, 0.6, 0.0],
              "rotation": quat_look((1.0, 0.0, -1.0))})
    return doc


@pytest.mark.parametrize("textured", [False, True], ids=["factors", "textures"])
def test_specular_glossiness(tmp_path, textured):
    """KHR_materials_pbrSpecularGlossiness (required): a box with a red diffuse colour, a grey
    specular colour and glossiness 0.6 (with `textures`: a striped diffuse texture and a
    specular-glossiness texture whose alpha holds the glossiness), as Blender's importer turns
    it into a Principled BSDF (IOR 1000, the specular colour as Specular Tint, roughness
    1 − glossiness)."""
    doc = specular_glossiness_doc(textured)
    name = "specgloss_textures" if textured else "specgloss"
    compare_with_blender(doc.write(tmp_path / f"{name}.glb"), tmp_path)


def variants_doc(shown: str | None) -> Gltf:
    """A box whose own material is red, with KHR_materials_variants naming "Red" (its own) and
    "Blue"; `shown` replaces its own material by that variant's, as a file without variants."""
    doc = stage()
    red = doc.material({"name": "Red", "pbrMetallicRoughness":
                        {"baseColorFactor": [0.8, 0.1, 0.05, 1.0], "metallicFactor": 0.0}})
    blue = doc.material({"name": "Blue", "pbrMetallicRoughness":
                         {"baseColorFactor": [0.05, 0.2, 0.8, 1.0], "metallicFactor": 0.0,
                          "roughnessFactor": 0.3}})
    if shown is None:
        doc.use("KHR_materials_variants", required=True)
        doc.json["extensions"]["KHR_materials_variants"] = {
            "variants": [{"name": "Red"}, {"name": "Blue"}]}
        mappings = {"extensions": {"KHR_materials_variants": {"mappings": [
            {"material": red, "variants": [0]}, {"material": blue, "variants": [1]}]}}}
        box = doc.box("Box", 0.6, red)
        doc.json["meshes"][box]["primitives"][0].update(mappings)
    else:
        box = doc.box("Box", 0.6, {"Red": red, "Blue": blue}[shown])
    doc.node({"name": "Box", "mesh": box, "translation": [0.0, 0.6, 0.0]})
    return doc


@pytest.mark.parametrize("variant", [None, "Blue"], ids=["default", "blue"])
def test_material_variants(tmp_path, variant):
    """KHR_materials_variants (required): the file's default shows each primitive's own
    material (red), as Blender's importer does; `--variant Blue` shows the blue one, compared
    with Blender's import of the same box given the blue material directly."""
    path = variants_doc(None).write(tmp_path / "variants.glb")
    if variant is None:
        compare_with_blender(path, tmp_path)
    else:
        plain = variants_doc(variant).write(tmp_path / "variant_plain.glb")
        compare_with_blender(path, tmp_path, photon_args=["--variant", variant],
                             cycles_path=plain)


def test_animation_pointer_is_tolerated(tmp_path):
    """KHR_animation_pointer: a box whose translation and a material's base colour are
    animated by pointers (channels without a `node`), held at the file's own values for the
    first second; the still render shows those values, as Blender shows frame 1 after
    importing."""
    doc = stage()
    doc.use("KHR_animation_pointer")
    green = doc.material({"name": "Green", "pbrMetallicRoughness":
                          {"baseColorFactor": [0.1, 0.6, 0.2, 1.0], "metallicFactor": 0.0}})
    box = doc.box("Box", 0.5, green)
    node = doc.node({"name": "Box", "mesh": box, "translation": [0.0, 0.5, 0.0]})
    # Held from 0 to 1 s: Blender shows frame 1, 1/24 s in.
    times = doc.accessor([0.0, 1.0, 2.0], "SCALAR", bounds=True)
    moves = doc.accessor([0.0, 0.5, 0.0] * 2 + [1.0, 0.5, 0.0], "VEC3")
    colours = doc.accessor([0.1, 0.6, 0.2, 1.0] * 2 + [0.9, 0.1, 0.1, 1.0], "VEC4")
    doc.json["animations"] = [{"name": "Pointers", "samplers": [
        {"input": times, "output": moves}, {"input": times, "output": colours}], "channels": [
        {"sampler": 0, "target": {"path": "pointer", "extensions": {"KHR_animation_pointer":
                                  {"pointer": f"/nodes/{node}/translation"}}}},
        {"sampler": 1, "target": {"path": "pointer", "extensions": {"KHR_animation_pointer":
                                  {"pointer": f"/materials/{green}/pbrMetallicRoughness/"
                                              "baseColorFactor"}}}}]}]
    compare_with_blender(doc.write(tmp_path / "pointer.glb"), tmp_path)


def test_gpu_instancing(tmp_path):
    """EXT_mesh_gpu_instancing (required): one small box mesh drawn nine times on a 3x3 grid,
    each instance with its own translation, rotation about Y and scale (one mirrored in X),
    the node itself turned and raised; Blender's importer makes each instance an object."""
    doc = stage()
    doc.use("EXT_mesh_gpu_instancing", required=True)
    orange = doc.material({"name": "Orange", "pbrMetallicRoughness":
                           {"baseColorFactor": [0.8, 0.35, 0.1, 1.0], "metallicFactor": 0.0}})
    box = doc.box("Box", 0.25, orange)
    translations, rotations, scales = [], [], []
    for i in range(9):
        x, z = (i % 3 - 1) * 1.1, (i // 3 - 1) * 1.1
        translations += [x, 0.25, z]
        angle = 0.35 * i
        rotations += [0.0, math.sin(angle / 2), 0.0, math.cos(angle / 2)]
        s = 0.7 + 0.1 * i
        scales += [-s if i == 4 else s, s, s]
    attributes = {"TRANSLATION": doc.accessor(translations, "VEC3"),
                  "ROTATION": doc.accessor(rotations, "VEC4"),
                  "SCALE": doc.accessor(scales, "VEC3")}
    doc.node({"name": "Scatter", "mesh": box, "translation": [0.0, 0.05, 0.0],
              "rotation": [0.0, math.sin(0.2), 0.0, math.cos(0.2)],
              "extensions": {"EXT_mesh_gpu_instancing": {"attributes": attributes}}})
    compare_with_blender(doc.write(tmp_path / "instancing.glb"), tmp_path)


@pytest.mark.parametrize("sampler", [
    None,
    {"wrapS": 33648, "wrapT": 33071, "magFilter": 9728},
    {"wrapS": 10497, "wrapT": 33648, "minFilter": 9728, "magFilter": 9729},
], ids=["repeat_linear", "mirror_clamp_nearest", "repeat_mirror_linear"])
def test_texture_transform(tmp_path, sampler):
    """KHR_texture_transform: a standing square with the striped texture offset by (0.1, 0.2),
    turned by 0.4 rad and scaled by (2, 1.5), under three samplers: repeating and bilinear;
    mirrored in s and clamped in t with a nearest magnification filter only (Blender's importer
    then takes the nearest texel); and repeating in s, mirrored in t, nearest minification
    with linear magnification (bilinear, as the importer decides)."""
    doc = stage()
    doc.use("KHR_texture_transform")
    texture = doc.texture(stripes(), sampler)
    transform = {"offset": [0.1, 0.2], "rotation": 0.4, "scale": [2.0, 1.5]}
    material = doc.material({"name": "Striped", "pbrMetallicRoughness": {
        "baseColorTexture": {"index": texture, "extensions":
                             {"KHR_texture_transform": transform}},
        "metallicFactor": 0.0, "roughnessFactor": 0.8}})
    standing_quad(doc, "Sign", material)
    compare_with_blender(doc.write(tmp_path / "texture_transform.glb"), tmp_path)


# The integer POSITION types (glTF component type numbers), each plain and normalized, with the
# largest value each holds.
POSITION_TYPES = [(c, n) for c in (5120, 5121, 5122, 5123) for n in (False, True)]
INTEGER_RANGE = {5120: 127, 5121: 255, 5122: 32767, 5123: 65535}


def test_mesh_quantization(tmp_path):
    """KHR_mesh_quantization (required): eight small textured squares in a row, each with its
    POSITION stored as another integer type (signed and unsigned bytes and shorts, each plain
    and normalized) and dequantized by its node's scale, with NORMAL as normalized signed
    bytes or shorts and TEXCOORD_0 as normalized unsigned bytes or shorts or plain floats."""
    doc = stage()
    doc.use("KHR_mesh_quantization", required=True)
    # Nearest texels: Cycles filters an 8-bit sRGB image's encoded values, Photon's glTF
    # materials its decoded ones, which differ by 1 % in the mean on these minified stripes.
    texture = doc.texture(stripes(period=2), {"magFilter": 9728, "minFilter": 9728})
    material = doc.material({"name": "Tiles", "pbrMetallicRoughness": {
        "baseColorTexture": {"index": texture}, "metallicFactor": 0.0}})
    for i, (component, normalized) in enumerate(POSITION_TYPES):
        full = INTEGER_RANGE[component]
        # The square's side in stored integers (a third of the range), which the node's scale
        # turns into 0.6 m.
        side = full // 3
        stored = side / full if normalized else side
        positions = [0, 0, 0, side, 0, 0, side, side, 0, 0, side, 0]
        n_type, n_full = (5120, 127) if i % 2 == 0 else (5122, 32767)
        normals = [0, 0, n_full] * 4
        uv_type = [5121, 5123, 5126][i % 3]
        uv_full = {5121: 255, 5123: 65535, 5126: 1.0}[uv_type]
        uvs = [0, uv_full, uv_full, uv_full, uv_full, 0, 0, 0]
        attributes = {
            "POSITION": doc.accessor(positions, "VEC3", component, normalized, bounds=True),
            "NORMAL": doc.accessor(normals, "VEC3", n_type, True),
            "TEXCOORD_0": doc.accessor(uvs, "VEC2", uv_type, uv_type != 5126)}
        mesh = doc.push("meshes", {"name": f"Q{i}", "primitives": [{
            "attributes": attributes, "material": material,
            "indices": doc.accessor([0, 1, 2, 0, 2, 3], "SCALAR", 5125)}]})
        doc.node({"name": f"Q{i}", "mesh": mesh, "scale": [0.6 / stored] * 3,
                  "translation": [-1.5 + 0.8 * (i % 4), 0.1 + 0.8 * (i // 4), 0.0]})
    compare_with_blender(doc.write(tmp_path / "quantized.glb"), tmp_path)


def test_sparse_accessor(tmp_path):
    """A sparse accessor: a standing square whose POSITION accessor replaces two of its four
    corners (the top ones, pulled back and apart) through sparse indices and values, and a
    view-less sparse accessor of normals (all zero but the substituted +Z ones)."""
    doc = stage()
    purple = doc.material({"name": "Purple", "pbrMetallicRoughness":
                           {"baseColorFactor": [0.5, 0.2, 0.7, 1.0], "metallicFactor": 0.0}})
    mesh = doc.quad("Sail", 0.8, purple)
    primitive = doc.json["meshes"][mesh]["primitives"][0]
    positions = doc.json["accessors"][primitive["attributes"]["POSITION"]]
    positions["sparse"] = {
        "count": 2,
        "indices": {"bufferView": doc.view(struct.pack("<2H", 2, 3)), "componentType": 5123},
        "values": {"bufferView": doc.view(struct.pack("<6f", 1.2, 0.8, -0.5, -1.1, 0.9,
                                                      -0.3))}}
    positions["min"], positions["max"] = [-1.1, -0.8, -0.5], [1.2, 0.9, 0.0]
    normals = {"componentType": 5126, "count": 4, "type": "VEC3", "sparse": {
        "count": 4,
        "indices": {"bufferView": doc.view(struct.pack("<4B", 0, 1, 2, 3)),
                    "componentType": 5121},
        "values": {"bufferView": doc.view(struct.pack("<12f", *([0.0, 0.0, 1.0] * 4)))}}}
    primitive["attributes"]["NORMAL"] = doc.push("accessors", normals)
    doc.node({"name": "Sail", "mesh": mesh, "translation": [0.0, 0.9, 0.0]})
    compare_with_blender(doc.write(tmp_path / "sparse.glb"), tmp_path)


def tube_doc(animated: bool) -> Gltf:
    """A skinned tube 2 m tall (8 sides, radius 0.25 m, 9 rings) on the floor, bound to two
    joints: "Root" at the origin and its child "Bend" 1 m up, turned 40° about Z, so the
    upper half bends over; rings between 0.6 and 1.4 m blend the two joints. Beside it a
    3x3-vertex square with two morph targets (the middle vertex pushed out, the top edge
    lifted) at the mesh's weights 0.7 and 0.4. With `animated`, one animation (LINEAR keys at
    0, 0.5 and 1 s) turns "Bend" from 0 to 40° to 80°, moves the square and changes its
    weights, and a STEP channel and a CUBICSPLINE channel drive the tube's "Root" rotation
    and the square's scale."""
    doc = stage()
    blue = doc.material({"name": "Blue", "pbrMetallicRoughness":
                         {"baseColorFactor": [0.15, 0.3, 0.8, 1.0], "metallicFactor": 0.0}})
    rings, sides, radius = 9, 8, 0.25
    positions, normals, joints, weights, indices = [], [], [], [], []
    for r in range(rings):
        h = 2.0 * r / (rings - 1)
        upper = min(max((h - 0.6) / 0.8, 0.0), 1.0)
        for s in range(sides):
            a = 2 * math.pi * s / sides
            positions += [radius * math.cos(a), h, radius * math.sin(a)]
            normals += [math.cos(a), 0.0, math.sin(a)]
            joints += [0, 1, 0, 0]
            weights += [1.0 - upper, upper, 0.0, 0.0]
    for r in range(rings - 1):
        for s in range(sides):
            a, b = r * sides + s, r * sides + (s + 1) % sides
            c, d = a + sides, b + sides
            indices += [a, c, b, b, c, d]
    attributes = {"POSITION": doc.accessor(positions, "VEC3", bounds=True),
                  "NORMAL": doc.accessor(normals, "VEC3"),
                  "JOINTS_0": doc.accessor(joints, "VEC4", 5121),
                  "WEIGHTS_0": doc.accessor(weights, "VEC4")}
    tube = doc.push("meshes", {"name": "Tube", "primitives": [{
        "attributes": attributes, "material": blue,
        "indices": doc.accessor(indices, "SCALAR", 5125)}]})
    bend = doc.node({"name": "Bend", "translation": [0.0, 1.0, 0.0],
                     "rotation": [0.0, 0.0, math.sin(math.radians(20)),
                                  math.cos(math.radians(20))]}, root=False)
    root = doc.node({"name": "Root", "translation": [-0.6, 0.0, 0.0], "children": [bend]})
    identity = [1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0]
    down = identity[:13] + [-1.0] + identity[14:]
    inverse_binds = doc.accessor(identity[:12] + [0.6, 0.0, 0.0, 1.0] + down[:12]
                                 + [0.6, -1.0, 0.0, 1.0], "MAT4")
    doc.push("skins", {"joints": [root, bend], "inverseBindMatrices": inverse_binds,
                       "skeleton": root})
    doc.node({"name": "Tube", "mesh": tube, "skin": 0})

    # The morphed square.
    grid = [(x, y) for y in (0, 1, 2) for x in (0, 1, 2)]
    square_positions = [v for x, y in grid for v in (0.5 * x - 0.5, 0.5 * y, 0.0)]
    middle = [v for x, y in grid for v in (0.0, 0.0, 0.5 if (x, y) == (1, 1) else 0.0)]
    top = [v for x, y in grid for v in (0.0, 0.4 if y == 2 else 0.0, 0.0)]
    square_indices = []
    for y in range(2):
        for x in range(2):
            a = 3 * y + x
            square_indices += [a, a + 1, a + 4, a, a + 4, a + 3]
    orange = doc.material({"name": "Orange", "doubleSided": True, "pbrMetallicRoughness":
                           {"baseColorFactor": [0.8, 0.4, 0.1, 1.0], "metallicFactor": 0.0}})
    square = doc.push("meshes", {"name": "Square", "weights": [0.7, 0.4], "primitives": [{
        "attributes": {"POSITION": doc.accessor(square_positions, "VEC3", bounds=True)},
        "targets": [{"POSITION": doc.accessor(middle, "VEC3", bounds=True)},
                    {"POSITION": doc.accessor(top, "VEC3", bounds=True)}],
        "material": orange, "indices": doc.accessor(square_indices, "SCALAR", 5125)}]})
    square_node = doc.node({"name": "Square", "mesh": square, "translation": [0.8, 0.1, 0.3],
                            "rotation": [0.0, math.sin(-0.3), 0.0, math.cos(-0.3)]})
    if animated:
        times = doc.accessor([0.0, 0.5, 1.0], "SCALAR", bounds=True)
        turns = [v for deg in (0, 40, 80) for v in
                 (0.0, 0.0, math.sin(math.radians(deg / 2)), math.cos(math.radians(deg / 2)))]
        moves = [0.8, 0.1, 0.3, 0.7, 0.3, 0.5, 0.9, 0.1, 0.6]
        morphs = [0.0, 0.0, 1.0, 0.2, 0.2, 1.0]
        step_turns = [v for deg in (0, 10, 30) for v in
                      (0.0, math.sin(math.radians(deg / 2)), 0.0, math.cos(math.radians(deg / 2)))]
        # CUBICSPLINE: (in-tangent, value, out-tangent) per key.
        cubic = [0, 0, 0, 1, 1, 1, 0.4, 0.4, 0.4,
                 0.2, 0.2, 0.2, 1.2, 1.2, 1.2, 0, 0, 0,
                 0, 0, 0, 0.9, 0.9, 0.9, 0, 0, 0]
        samplers = [{"input": times, "output": doc.accessor(turns, "VEC4")},
                    {"input": times, "output": doc.accessor(moves, "VEC3")},
                    {"input": times, "output": doc.accessor(morphs, "SCALAR")},
                    {"input": times, "output": doc.accessor(step_turns, "VEC4"),
                     "interpolation": "STEP"},
                    {"input": times, "output": doc.accessor(cubic, "VEC3"),
                     "interpolation": "CUBICSPLINE"}]
        channels = [{"sampler": 0, "target": {"node": bend, "path": "rotation"}},
                    {"sampler": 1, "target": {"node": square_node, "path": "translation"}},
                    {"sampler": 2, "target": {"node": square_node, "path": "weights"}},
                    {"sampler": 3, "target": {"node": root, "path": "rotation"}},
                    {"sampler": 4, "target": {"node": square_node, "path": "scale"}}]
        doc.json["animations"] = [{"name": "Act", "samplers": samplers, "channels": channels}]
    return doc


def test_skin_and_morph_targets(tmp_path):
    """Skins at the joints' node transforms and morph targets at the mesh's default weights
    (`tube_doc`): the tube bends over and the square bulges, as in Blender's import."""
    compare_with_blender(tube_doc(False).write(tmp_path / "skin_morph.glb"), tmp_path)


@pytest.mark.parametrize("seconds", [0.25, 0.75])
def test_time_poses_the_animation(tmp_path, seconds):
    """`--time SECONDS` against Blender at frame SECONDS × 24 (its importer keys glTF time t at
    frame t × fps): the bend, the square's place, scale and weights and the tube's stepped
    turn between keys (`tube_doc(animated=True)`)."""
    path = tube_doc(True).write(tmp_path / "animated.glb")
    compare_with_blender(path, tmp_path, photon_args=["--time", str(seconds)],
                         frame=round(seconds * 24))


def test_mesh_without_material(tmp_path):
    """A box with no material: Blender's importer leaves the object without one and Cycles
    shades it with its default surface (a Diffuse BSDF of colour 0.8), which Photon follows
    rather than glTF's default material (a white rough metal, brighter)."""
    doc = stage()
    box = doc.box("Plain", 0.6)
    doc.node({"name": "Plain", "mesh": box, "translation": [0.0, 0.6, 0.0],
              "rotation": [0.0, math.sin(0.4), 0.0, math.cos(0.4)]})
    compare_with_blender(doc.write(tmp_path / "no_material.glb"), tmp_path)


def test_mesh_without_material_with_vertex_colours(tmp_path):
    """A box with vertex colours (COLOR_0, red and blue corners) and no material: Blender's
    importer gives it a Principled BSDF (roughness 0.5) of the vertex colour, which Photon
    follows (before, it showed Cycles' grey default surface)."""
    doc = stage()
    box = doc.box("Painted", 0.6)
    corners = len(doc.json["accessors"][doc.json["meshes"][box]["primitives"][0]
                                        ["attributes"]["POSITION"]]["count"] * [0])
    colours = []
    for k in range(corners):
        colours += [0.9, 0.1, 0.05, 1.0] if k % 2 else [0.05, 0.2, 0.9, 1.0]
    doc.json["meshes"][box]["primitives"][0]["attributes"]["COLOR_0"] = doc.accessor(
        colours, "VEC4")
    doc.node({"name": "Painted", "mesh": box, "translation": [0.0, 0.6, 0.0],
              "rotation": [0.0, math.sin(0.4), 0.0, math.cos(0.4)]})
    compare_with_blender(doc.write(tmp_path / "vertex_colours.glb"), tmp_path)
