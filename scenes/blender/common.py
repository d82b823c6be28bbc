"""Shared bpy helpers for building the Cycles reference scenes in scenes/blender/.

Everything here runs inside the venv's python with `import bpy` (Blender 4.5 as a module):
reset to factory settings, make meshes / Principled materials / lights / camera, export with
Blender's glTF exporter (the call recommended in shared/reference/blender-gltf-crates.md),
configure Cycles for a converged, unclamped reference and render to a linear EXR.

`make_reference(...)` ties it together for one scene: export the .glb, render the reference
twice with different seeds, store the mean of the two renders as <name>.exr and write a JSON
sidecar with the settings, the timings and the measured noise.
"""

from __future__ import annotations

import json
import math
import os
import struct
import sys
import tempfile
import time
from pathlib import Path

import bpy
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import refimage  # noqa: E402

# ---------------------------------------------------------------------------------------------
# Scene construction
# ---------------------------------------------------------------------------------------------


def reset_scene(width: int, height: int):
    """Factory settings with an empty scene, Cycles, the given resolution and a black world."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.render.resolution_x = width
    scene.render.resolution_y = height
    scene.render.resolution_percentage = 100
    scene.render.pixel_aspect_x = 1.0
    scene.render.pixel_aspect_y = 1.0
    world = bpy.data.worlds.new("World")
    if bpy.app.version < (5, 0, 0):  # always on (and deprecated) in Blender 5
        world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bg.inputs["Strength"].default_value = 0.0
    scene.world = world
    return scene


def link(obj):
    bpy.context.scene.collection.objects.link(obj)
    return obj


def mesh_object(name, verts, faces, material, location=(0, 0, 0), rotation=(0, 0, 0)):
    """A mesh object from vertex and face lists (faces are vertex-index tuples)."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(v) for v in verts], [], [tuple(f) for f in faces])
    mesh.validate()
    mesh.update()
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    obj.rotation_euler = rotation
    return link(obj)


def quad(name, corners, material):
    """One quad; corners in counter-clockwise order seen from the side the normal points to."""
    return mesh_object(name, corners, [(0, 1, 2, 3)], material)


def box(name, size, material, location, rotation_z_deg):
    """An axis-aligned box of size (sx, sy, sz) standing on its base at `location`, turned about Z."""
    sx, sy, sz = (s / 2 for s in size)
    verts = [(-sx, -sy, 0), (sx, -sy, 0), (sx, sy, 0), (-sx, sy, 0),
             (-sx, -sy, 2 * sz), (sx, -sy, 2 * sz), (sx, sy, 2 * sz), (-sx, sy, 2 * sz)]
    faces = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    return mesh_object(name, verts, faces, material, location,
                       (0.0, 0.0, math.radians(rotation_z_deg)))


def principled(name, base_color, *, roughness=None, specular_ior_level=None,
               emission_color=None, emission_strength=None):
    """A node material with Blender's default Principled BSDF; only the given inputs are changed.

    Returns the material; `principled_values(mat)` reads back what Cycles will use.
    """
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):  # always on (and deprecated) in Blender 5
        mat.use_nodes = True
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*base_color, 1.0)
    if roughness is not None:
        bsdf.inputs["Roughness"].default_value = roughness
    if specular_ior_level is not None:
        bsdf.inputs["Specular IOR Level"].default_value = specular_ior_level
    if emission_color is not None:
        bsdf.inputs["Emission Color"].default_value = (*emission_color, 1.0)
    if emission_strength is not None:
        bsdf.inputs["Emission Strength"].default_value = emission_strength
    return mat


def principled_values(mat) -> dict:
    """The Principled inputs that matter for these scenes, read back from the node."""
    bsdf = mat.node_tree.nodes["Principled BSDF"]

    def val(name):
        v = bsdf.inputs[name].default_value
        try:
            return [round(float(x), 6) for x in v][:3]
        except TypeError:
            return round(float(v), 6)

    return {k: val(k) for k in ("Base Color", "Metallic", "Roughness", "IOR", "Specular IOR Level",
                                "Specular Tint", "Diffuse Roughness", "Emission Color",
                                "Emission Strength", "Coat Weight", "Sheen Weight",
                                "Transmission Weight", "Subsurface Weight")
            if k in bsdf.inputs}


def camera(name, location, rotation_deg, fov_deg):
    """A perspective camera (field of view along the larger image side), made the scene camera."""
    cam = bpy.data.cameras.new(name)
    cam.lens_unit = "FOV"
    cam.angle = math.radians(fov_deg)
    cam.sensor_fit = "AUTO"
    cam.clip_start = 0.1
    cam.clip_end = 100.0
    obj = link(bpy.data.objects.new(name, cam))
    obj.location = location
    obj.rotation_euler = tuple(math.radians(a) for a in rotation_deg)
    bpy.context.scene.camera = obj
    return obj


def light(name, kind, location, rotation_deg=(0, 0, 0), **props):
    """A light object of type POINT / SUN / SPOT with the given datablock properties."""
    data = bpy.data.lights.new(name, kind)
    for key, value in props.items():
        setattr(data, key, value)
    obj = link(bpy.data.objects.new(name, data))
    obj.location = location
    obj.rotation_euler = tuple(math.radians(a) for a in rotation_deg)
    return obj


# ---------------------------------------------------------------------------------------------
# Export and render
# ---------------------------------------------------------------------------------------------

GLTF_EXPORT_ARGS = dict(
    export_format="GLB", export_lights=True, export_cameras=True, export_extras=True,
    export_apply=True, export_current_frame=True, use_renderable=True, export_animations=False,
)


def export_glb(path: Path):
    """Export the whole scene with Blender's glTF exporter (lighting mode left at its default)."""
    result = bpy.ops.export_scene.gltf(filepath=str(path), **GLTF_EXPORT_ARGS)
    if "FINISHED" not in result:
        raise RuntimeError(f"glTF export to {path} failed: {result}")


def edit_glb_json(glb: Path, edit) -> None:
    """Rewrite the JSON chunk of a .glb in place: `edit(doc)` changes the parsed document (to
    add what Blender's exporter drops, as the add-on's export hooks do)."""
    data = glb.read_bytes()
    (json_len,) = struct.unpack_from("<I", data, 12)
    doc = json.loads(data[20:20 + json_len])
    rest = data[20 + json_len:]
    edit(doc)
    chunk = json.dumps(doc, separators=(",", ":")).encode()
    chunk += b" " * (-len(chunk) % 4)
    body = struct.pack("<II", len(chunk), 0x4E4F534A) + chunk + rest
    glb.write_bytes(struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body)


def add_extension_used(doc: dict, name: str) -> None:
    used = doc.setdefault("extensionsUsed", [])
    if name not in used:
        used.append(name)


def set_multilayer_exr(image_settings):
    """Output a multilayer EXR: Blender 5 chooses it with media_type (OPEN_EXR_MULTILAYER is no
    longer among the plain image formats), Blender 4 with the file format."""
    if hasattr(image_settings, "media_type"):
        image_settings.media_type = "MULTI_LAYER_IMAGE"  # its only file format: multilayer EXR
    else:
        image_settings.file_format = "OPEN_EXR_MULTILAYER"


def configure_cycles(scene, samples: int, seed: int, threads: int):
    """Cycles settings for an unclamped, converged CPU reference. Returns them as a dict."""
    c = scene.cycles
    c.device = "CPU"
    c.samples = samples
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.seed = seed
    c.use_animated_seed = False
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.blur_glossy = 0.0
    c.caustics_reflective = True
    c.caustics_refractive = True
    c.use_light_tree = True
    c.max_bounces = 64
    c.diffuse_bounces = 64
    c.glossy_bounces = 64
    c.transmission_bounces = 64
    c.transparent_max_bounces = 64
    # Volume bounces stay as the scene has them (Blender's default is 0).
    c.pixel_filter_type = "BLACKMAN_HARRIS"
    c.filter_width = 1.5
    c.film_exposure = 1.0
    c.use_auto_tile = False
    scene.render.film_transparent = False
    scene.render.threads_mode = "FIXED"
    scene.render.threads = threads
    scene.render.use_persistent_data = False
    vs = scene.view_settings
    vs.view_transform = "Standard"
    vs.look = "None"
    vs.exposure = 0.0
    vs.gamma = 1.0
    img = scene.render.image_settings
    if hasattr(img, "media_type"):  # Blender 5
        img.media_type = "IMAGE"
    img.file_format = "OPEN_EXR"
    img.color_mode = "RGB"
    img.color_depth = "32"
    img.exr_codec = "ZIP"
    return {
        "device": c.device, "samples": c.samples, "adaptive_sampling": c.use_adaptive_sampling,
        "denoising": c.use_denoising, "sample_clamp_direct": c.sample_clamp_direct,
        "sample_clamp_indirect": c.sample_clamp_indirect, "blur_glossy": c.blur_glossy,
        "caustics_reflective": c.caustics_reflective, "caustics_refractive": c.caustics_refractive,
        "light_tree": c.use_light_tree, "light_sampling_threshold": c.light_sampling_threshold,
        "max_bounces": c.max_bounces, "diffuse_bounces": c.diffuse_bounces,
        "glossy_bounces": c.glossy_bounces, "transmission_bounces": c.transmission_bounces,
        "transparent_max_bounces": c.transparent_max_bounces, "volume_bounces": c.volume_bounces,
        "min_light_bounces (russian roulette)": c.min_light_bounces,
        "min_transparent_bounces": c.min_transparent_bounces,
        "sampling_pattern": c.sampling_pattern,
        "pixel_filter_type": c.pixel_filter_type, "filter_width": c.filter_width,
        "film_transparent": scene.render.film_transparent,
        "view_transform": vs.view_transform, "look": vs.look,
        "threads": scene.render.threads,
        "output": "linear float32 EXR, channels R G B, ZIP, row 0 = top",
    }


def render_exr(scene, path: Path, seed: int) -> float:
    """Render the scene camera to a linear EXR; returns the wall time in seconds."""
    scene.cycles.seed = seed
    scene.render.filepath = str(path)
    scene.render.use_file_extension = False
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    dt = time.perf_counter() - t0
    if not path.exists():
        raise RuntimeError(f"Cycles render did not write {path}")
    return dt


def make_reference(name: str, out_dir: Path, *, samples: int, seeds=(1, 2), threads=None,
                   extra: dict | None = None, analytic=None, export=export_glb) -> dict:
    """Export <name>.glb (with `export(path)`; Blender's glTF exporter unless told), render the
    reference with two seeds and write <name>.exr (their mean) and <name>.json. Cycles is set up
    before the export, so an export that carries its settings (the add-on's) sees them.
    `analytic(width, height) -> (image, mask)` optionally gives an expected image to check the
    reference against. Returns the sidecar dict."""
    out_dir.mkdir(parents=True, exist_ok=True)
    scene = bpy.context.scene
    threads = threads or os.cpu_count() or 2
    settings = configure_cycles(scene, samples, seeds[0], threads)
    glb = out_dir / f"{name}.glb"
    export(glb)

    renders, times = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds:
            path = Path(tmp) / f"{name}_seed{seed}.exr"
            dt = render_exr(scene, path, seed)
            times.append(round(dt, 2))
            renders.append(refimage.read_exr(path))
            print(f"[{name}] seed {seed}: {samples} spp in {dt:.1f} s", flush=True)
    ref = np.mean(renders, axis=0).astype(np.float32)
    exr = out_dir / f"{name}.exr"
    refimage.write_exr(exr, ref)

    noise = refimage.rel_mse(renders[0], renders[1])
    info = {
        "scene": name,
        "blender": bpy.app.version_string,
        "glb": glb.name, "reference": exr.name,
        "width": scene.render.resolution_x, "height": scene.render.resolution_y,
        "samples_per_render": samples, "seeds": list(seeds),
        "reference_is": f"mean of {len(seeds)} Cycles renders with the seeds above "
                        f"({samples * len(seeds)} spp in total)",
        "render_seconds": times,
        "relmse_between_seeds": noise,
        "estimated_relmse_of_reference": noise / 4.0,
        "mean_rgb": [round(float(x), 6) for x in ref.reshape(-1, 3).mean(axis=0)],
        "mean": float(ref.mean()),
        "gltf_export": GLTF_EXPORT_ARGS,
        "cycles": settings,
    }
    if extra:
        info.update(extra)
    if analytic is not None:
        expected, mask = analytic(scene.render.resolution_x, scene.render.resolution_y)
        got = float(ref[mask].mean())
        want = float(expected[mask].mean())
        info["analytic_check"] = {
            "what": "mean over the masked pixels of the reference vs the analytic radiance at pixel centres",
            "pixels": int(mask.sum()), "cycles": got, "analytic": want, "ratio": got / want,
        }
    (out_dir / f"{name}.json").write_text(json.dumps(info, indent=2) + "\n")
    print(f"[{name}] wrote {glb.name}, {exr.name} ({exr.stat().st_size // 1024} KB); "
          f"relMSE between seeds {noise:.3g}; mean {info['mean_rgb']}", flush=True)
    return info
