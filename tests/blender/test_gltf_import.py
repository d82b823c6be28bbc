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


def render_cycles(path: Path, out: Path, size: int, samples: int) -> np.ndarray:
    """Blender's import of the glTF file `path` rendered by Cycles (RGB, row 0 at the top)."""
    import bpy

    import common

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=str(path))
    scene = bpy.context.scene
    scene.camera = next(o for o in scene.objects if o.type == "CAMERA")
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.engine = "CYCLES"
    common.configure_cycles(scene, samples, seed=1, threads=2)
    scene.render.filepath = str(out)
    scene.render.use_file_extension = False
    bpy.ops.render.render(write_still=True)
    return read_exr(out)


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
                         cycles_spp=512, photon_args=None, cycles_path: Path | None = None):
    """Photon's render of `path` against Cycles' render of Blender's import of `cycles_path`
    (default: the same file); asserts the agreement and returns (photon, cycles)."""
    name = path.stem
    ref = render_cycles(cycles_path or path, tmp_path / f"{name}_cycles.exr", size, cycles_spp)
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


def test_unlit(tmp_path):
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
    # The path tracer: the photon method counts the sun through the square twice (a photon
    # crossing its Transparent BSDF is stored as a caustic, and the shadow ray passes too).
    compare_with_blender(doc.write(tmp_path / "unlit.glb"), tmp_path,
                         photon_args=["--method", "path"])


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
    animated by pointers (channels without a `node`), keyed at 0 s at the file's own values;
    the still render shows those values, as Blender shows frame 1 after importing."""
    doc = stage()
    doc.use("KHR_animation_pointer")
    green = doc.material({"name": "Green", "pbrMetallicRoughness":
                          {"baseColorFactor": [0.1, 0.6, 0.2, 1.0], "metallicFactor": 0.0}})
    box = doc.box("Box", 0.5, green)
    node = doc.node({"name": "Box", "mesh": box, "translation": [0.0, 0.5, 0.0]})
    times = doc.accessor([0.0, 1.0], "SCALAR", bounds=True)
    moves = doc.accessor([0.0, 0.5, 0.0, 1.0, 0.5, 0.0], "VEC3")
    colours = doc.accessor([0.1, 0.6, 0.2, 1.0, 0.9, 0.1, 0.1, 1.0], "VEC4")
    doc.json["animations"] = [{"name": "Pointers", "samplers": [
        {"input": times, "output": moves}, {"input": times, "output": colours}], "channels": [
        {"sampler": 0, "target": {"path": "pointer", "extensions": {"KHR_animation_pointer":
                                  {"pointer": f"/nodes/{node}/translation"}}}},
        {"sampler": 1, "target": {"path": "pointer", "extensions": {"KHR_animation_pointer":
                                  {"pointer": f"/materials/{green}/pbrMetallicRoughness/"
                                              "baseColorFactor"}}}}]}]
    compare_with_blender(doc.write(tmp_path / "pointer.glb"), tmp_path)
