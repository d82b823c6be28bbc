"""Material, world and light previews (`bl_use_preview`) render with Photon.

Blender renders a preview in a job thread on its own preview scene; the add-on writes that
scene with preview.py and runs the renderer. Here previews are started as the Material, World
and Light tabs start them, with `bpy.ops.ed.lib_id_generate_preview()` on the material, world
or light, and read back from `preview.image_pixels_float` (display values: the scene's view
transform, set to Standard so they are the sRGB encoding of the render). $PHOTON_BINARY is
wrapped by a script that runs it and keeps a copy of each run's scene and image, so the tests
check that the preview's pixels are Photon's image, that they follow the material's colour
(plain, textured, or through the fallback values of a tree Photon does not evaluate), that
every preview shape and light type renders, and that a material's preview agrees with Cycles'.

The writer itself is checked on the factory scene (cube, point light, camera): written by
preview.write_scene from the depsgraph and rendered with the renderer, it must match the F12
render of the same scene (Blender's glTF exporter); and its cameras must be the glTF
exporter's for every sensor fit and image orientation.
"""

from __future__ import annotations

import json
import time

import bpy
import numpy as np
import pytest

import scenes_bpy
from addon import fake_binary
from helpers import photon_binary, rel_mse
from refimage import read_exr

PREVIEW_TIMEOUT = 60.0

# Runs the real renderer, then copies the scene file and the image of the run to a new folder
# of $PHOTON_CAPTURE (numbered in order), with the command line.
CAPTURING_RENDERER = """
import shutil, subprocess
code = subprocess.call([os.environ["PHOTON_REAL_BINARY"], *sys.argv[1:]])
capture = os.environ["PHOTON_CAPTURE"]
run = os.path.join(capture, str(len(os.listdir(capture))))
os.makedirs(run)
json.dump(sys.argv[1:], open(os.path.join(run, "command.json"), "w"))
shutil.copy(sys.argv[2], run)
output = sys.argv[sys.argv.index("-o") + 1]
if os.path.exists(output):
    shutil.copy(output, os.path.join(run, "render.exr"))
sys.exit(code)
"""


@pytest.fixture
def captured(photon_addon, tmp_path, monkeypatch):
    """The folder receiving a copy of every renderer run; the factory scene with Photon as its
    engine and the Standard view transform."""
    real = photon_binary()
    folder = tmp_path / "captured"
    folder.mkdir()
    wrapper = fake_binary(tmp_path / "bin" / "photon", CAPTURING_RENDERER)
    monkeypatch.setenv("PHOTON_BINARY", str(wrapper))
    monkeypatch.setenv("PHOTON_REAL_BINARY", str(real))
    monkeypatch.setenv("PHOTON_CAPTURE", str(folder))
    bpy.ops.wm.read_factory_settings()
    scene = bpy.context.scene
    scene.render.engine = "PHOTON"
    scene.view_settings.view_transform = "Standard"
    return folder


def preview_pixels(id_block) -> np.ndarray:
    """Render `id_block`'s preview with the scene's engine and return its pixels (H, W, RGBA
    display values, row 0 = top)."""
    with bpy.context.temp_override(id=id_block):
        result = bpy.ops.ed.lib_id_generate_preview()
    assert result == {"FINISHED"}, result
    preview = id_block.preview
    # The preview job never ends without an event loop (bpy.app.is_job_running stays true):
    # the preview is done when its pixels are filled and stay the same for two polls.
    deadline = time.monotonic() + PREVIEW_TIMEOUT
    previous = None
    while time.monotonic() < deadline:
        width, height = preview.image_size
        pixels = np.empty(width * height * 4, dtype=np.float32)
        preview.image_pixels_float.foreach_get(pixels)
        if pixels.size and pixels.max() > 0 and previous is not None \
                and np.array_equal(pixels, previous):
            return pixels.reshape(height, width, 4)[::-1]
        previous = pixels
        time.sleep(0.2)
    pytest.fail(f"no preview of {id_block.name} after {PREVIEW_TIMEOUT:.0f} s")


def generate_preview(id_block, captured) -> tuple[np.ndarray, dict]:
    """`preview_pixels` of `id_block` with Photon, and the one renderer run it made:
    {"command": [...], "image": (H, W, RGBA)}."""
    pixels = preview_pixels(id_block)
    runs = sorted(captured.iterdir(), key=lambda p: int(p.name))
    assert len(runs) == 1, f"expected one renderer run for the preview, got {len(runs)}"
    run = runs[0]
    command = json.loads((run / "command.json").read_text())
    assert (run / "render.exr").is_file(), f"the renderer wrote no image: {command}"
    image = read_exr(run / "render.exr", ("R", "G", "B", "A"))
    run.rename(captured.parent / f"done_{id_block.name}")  # the next preview's is then alone
    return pixels, {"command": command, "image": image}


def srgb(linear: np.ndarray) -> np.ndarray:
    linear = np.clip(linear, 0.0, 1.0)
    return np.where(linear <= 0.0031308, 12.92 * linear,
                    1.055 * np.power(linear, 1.0 / 2.4) - 0.055)


def assert_preview_is_photons_image(pixels, run):
    """The preview holds the renderer's image: the sRGB encoding of its colour, its alpha."""
    command, image = run["command"], run["image"]
    assert command[0] == "render" and command[1].endswith("scene.gltf"), command
    assert command[command.index("--method") + 1] == "path", command
    assert pixels.shape == image.shape, (pixels.shape, image.shape)
    # Where the coverage is partial, Blender converts the premultiplied colour its own way.
    whole = (image[:, :, 3] > 0.999) | (image[:, :, 3] < 0.001)
    colour = np.abs(pixels[whole, :3] - srgb(image[whole, :3]))
    alpha = np.abs(pixels[:, :, 3] - image[:, :, 3])
    print(f"preview vs sRGB(Photon): mean |colour| {colour.mean():.5f} on {whole.mean():.2f} of the pixels")
    assert colour.mean() < 0.002 and alpha.max() < 0.01, \
        f"preview differs from Photon's image: mean |colour| {colour.mean():.4f}, " \
        f"max |alpha| {alpha.max():.4f}"


def test_material_preview_renders_with_photon(captured):
    colours = {"Red": (0.8, 0.05, 0.05, 1.0), "Blue": (0.05, 0.05, 0.8, 1.0)}
    means = {}
    for name, colour in colours.items():
        material = bpy.data.materials.new(name)
        material.use_nodes = True
        material.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = colour
        pixels, run = generate_preview(material, captured)
        assert_preview_is_photons_image(pixels, run)
        sphere = pixels[:, :, 3] > 0.99  # the floor is hidden from the camera: alpha 0
        assert 0.1 < sphere.mean() < 0.9, f"sphere covers {sphere.mean():.2f} of the preview"
        means[name] = pixels[sphere, :3].mean(axis=0)
        print(f"{name}: preview {pixels.shape[1]}x{pixels.shape[0]}, sphere mean RGB "
              f"{np.round(means[name], 3).tolist()}")
    red, blue = means["Red"], means["Blue"]
    assert red[0] > 2 * red[2] and blue[2] > 2 * blue[0], means


@pytest.mark.parametrize("shape", ["FLAT", "CUBE", "HAIR", "SHADERBALL", "CLOTH", "FLUID"])
def test_every_preview_shape_renders(captured, shape):
    """The other preview shapes (the shader ball holds curves and text): Photon's image, with
    the shape covering part of it."""
    material = bpy.data.materials.new(shape)
    material.use_nodes = True
    material.preview_render_type = shape
    pixels, run = generate_preview(material, captured)
    assert_preview_is_photons_image(pixels, run)
    coverage = float((pixels[:, :, 3] > 0.5).mean())
    assert coverage > 0.1, f"{shape}: the shape covers {coverage:.2f} of the preview"


@pytest.mark.slow
def test_material_preview_matches_cycles(captured):
    """Photon's preview of a red material next to Cycles' (the preview scene's own Cycles
    settings): Blender's preview scene (its lights, camera and the floor hidden from the
    camera) is written as Cycles renders it."""
    material = bpy.data.materials.new("Red")
    material.use_nodes = True
    material.node_tree.nodes["Principled BSDF"].inputs["Base Color"].default_value = \
        (0.8, 0.05, 0.05, 1.0)
    photon, _run = generate_preview(material, captured)
    bpy.context.scene.render.engine = "CYCLES"
    started = time.perf_counter()
    cycles = preview_pixels(material)
    seconds = time.perf_counter() - started
    difference = np.abs(photon - cycles).mean(axis=(0, 1))
    ratio = photon[:, :, :3].mean() / cycles[:, :, :3].mean()
    print(f"material preview, photon vs cycles ({seconds:.1f} s): mean ratio {ratio:.4f} "
          f"(display values), mean |difference| RGBA {np.round(difference, 4).tolist()}")
    assert abs(ratio - 1.0) < 0.04 and difference.max() < 0.03, (ratio, difference)


def test_image_textured_material_preview(captured, tmp_path):
    """An Image Texture (a PNG file) into the Base Color: the node tree's image is written
    beside the preview scene and read, so the sphere shows the texture's green where the
    Principled BSDF's own Base Color is grey."""
    path = tmp_path / "green.png"
    image = bpy.data.images.new("Green", 4, 4)
    image.pixels.foreach_set(np.tile([0.05, 0.8, 0.05, 1.0], 16).astype(np.float32))
    image.filepath_raw, image.file_format = str(path), "PNG"
    image.save()
    image.source = "FILE"
    material = bpy.data.materials.new("Textured")
    material.use_nodes = True
    tree = material.node_tree
    texture = tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    tree.links.new(texture.outputs["Color"], tree.nodes["Principled BSDF"].inputs["Base Color"])
    pixels, run = generate_preview(material, captured)
    assert_preview_is_photons_image(pixels, run)
    sphere = pixels[pixels[:, :, 3] > 0.99, :3].mean(axis=0)
    assert sphere[1] > 1.5 * sphere[0] and sphere[1] > 1.5 * sphere[2], sphere


def test_fallback_material_preview(captured):
    """A tree with a node Photon does not evaluate (Particle Info into the Base Color) falls
    back to the Principled BSDF's unlinked values: here an orange emission of strength 4,
    which lights the sphere orange (the linked Base Color reads as grey)."""
    material = bpy.data.materials.new("Gabor")
    material.use_nodes = True
    tree = material.node_tree
    bsdf = tree.nodes["Principled BSDF"]
    particles = tree.nodes.new("ShaderNodeParticleInfo")
    tree.links.new(particles.outputs["Random"], bsdf.inputs["Base Color"])
    bsdf.inputs["Emission Color"].default_value = (1.0, 0.3, 0.0, 1.0)
    bsdf.inputs["Emission Strength"].default_value = 4.0
    pixels, run = generate_preview(material, captured)
    assert_preview_is_photons_image(pixels, run)
    gltf = json.loads(next(captured.parent.glob("done_Gabor/scene.gltf")).read_text())
    written = next(m for m in gltf["materials"] if m["name"] == "Gabor")
    assert "PHOTON_material_nodes" not in written.get("extensions", {}), written
    image = run["image"]
    sphere = image[image[:, :, 3] > 0.99, :3].mean(axis=0)
    assert sphere[0] > 3.0 and sphere[0] > 2.5 * sphere[2], sphere


def test_world_preview_renders_with_photon(captured):
    world = bpy.context.scene.world
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.1, 0.4, 0.05, 1.0)
    pixels, run = generate_preview(world, captured)
    assert_preview_is_photons_image(pixels, run)
    expected = srgb(np.array([0.1, 0.4, 0.05]))
    error = np.abs(pixels[:, :, :3] - expected).max()
    assert error < 0.01, f"world preview {pixels[:, :, :3].mean(axis=(0, 1))}, expected {expected}"
    assert (pixels[:, :, 3] == 1.0).all()


@pytest.mark.parametrize("kind", ["POINT", "SPOT", "SUN", "AREA"])
def test_light_preview_renders_with_photon(captured, kind):
    """The light preview (the light over a floor) of every light type: Photon's image, lit."""
    light = bpy.data.lights["Light"]
    light.type = kind
    pixels, run = generate_preview(light, captured)
    assert_preview_is_photons_image(pixels, run)
    lit = float(run["image"][:, :, :3].mean())
    print(f"{kind} light preview: mean {lit:.4f}")
    assert lit > 0.05, f"the {kind} light's preview is dark: mean {lit}"


def test_preview_writer_renders_the_scene_as_the_export(photon_addon, tmp_path):
    """The factory scene through preview.write_scene renders as through the glTF export."""
    from blender_addon import preview, runner
    binary = photon_binary()
    scene = scenes_bpy.default_scene()
    scene.photon.method = "PATH"
    exported = scenes_bpy.render(scene, "PHOTON", tmp_path / "export.exr", 64)
    folder = tmp_path / "written"
    folder.mkdir()
    gltf = preview.write_scene(bpy.context.evaluated_depsgraph_get(), folder)
    command = runner.render_command(
        binary, gltf, folder / "render.exr", width=64, height=36,
        settings=runner.RenderSettings(method="path", samples=64, seed=1), camera="Camera")
    runner.run(command)
    written = read_exr(folder / "render.exr")
    err = rel_mse(written, exported)
    ratio = float(written.mean() / exported.mean())
    print(f"preview writer vs glTF export: mean ratio {ratio:.4f}, relMSE {err:.5f}")
    assert abs(ratio - 1.0) < 0.02 and err < 0.01, (ratio, err)


@pytest.mark.parametrize("kind,resolution,fit", [
    ("PERSP", (640, 360), "AUTO"), ("PERSP", (360, 640), "AUTO"),
    ("PERSP", (640, 360), "VERTICAL"), ("PERSP", (360, 640), "HORIZONTAL"),
    # The exporter maps the orthographic scale onto the longer side whatever the sensor fit
    # (Blender does so for AUTO only): compared under AUTO.
    ("ORTHO", (640, 360), "AUTO"), ("ORTHO", (360, 640), "AUTO")])
def test_camera_field_of_view_is_the_exporters(photon_addon, tmp_path, kind, resolution, fit):
    from blender_addon import preview
    scene = scenes_bpy.default_scene()
    scene.render.resolution_x, scene.render.resolution_y = resolution
    camera = bpy.data.objects["Camera"].data
    camera.type, camera.sensor_fit, camera.sensor_height = kind, fit, 20.0
    path = tmp_path / "camera.gltf"
    bpy.ops.export_scene.gltf(filepath=str(path), export_format="GLTF_SEPARATE",
                              export_cameras=True, use_active_scene=True)
    exported = json.loads(path.read_text())["cameras"][0]
    written = preview.camera_projection(camera, *resolution)
    assert written["type"] == exported["type"], (written, exported)
    for key, value in exported[exported["type"]].items():
        assert written[written["type"]][key] == pytest.approx(value, rel=1e-5), (key, written,
                                                                                  exported)
