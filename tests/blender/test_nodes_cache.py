"""A textured scene by every method that reads node trees at a diffuse bounce:
path tracing, photon mapping (photon tracing, gathering and the irradiance cache read the
floor's tree) and path tracing with the irradiance cache (`--method path-cache`, whose records
are path-traced from points on the textured floor), against Cycles and against each other.

The scene, 32x32: a floor whose Base Color is a Noise through a Color Ramp and a Checker
mixed by a Voronoi distance, two coloured walls and a back wall, lit by a sun slanting in and
a dim world, so much of the image is indirect light the floor's colours tint. Photon renders
the add-on's export of it from the command line (the add-on offers no path-cache method):
each method's mean within 2 % of Cycles' and of the path tracer's, relMSE <= 0.01 against
Cycles.
"""

import subprocess

import bpy
import numpy as np
import pytest

import common
import scenes_bpy
from helpers import photon_binary, read_exr, rel_mse
from test_nodes import node_material

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s

SIZE = 32
METHODS = {"path": 256, "photon": 256, "path-cache": 256}


@pytest.fixture(autouse=True)
def _addon(photon_addon, binary_env):
    return photon_addon


def textured_box():
    floor, tree = node_material("Textured floor")
    bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Roughness"].default_value = 1.0
    noise = tree.nodes.new("ShaderNodeTexNoise")
    noise.inputs["Scale"].default_value = 4.0
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.7, 0.25, 0.1, 1.0)
    ramp.color_ramp.elements[1].color = (0.2, 0.6, 0.3, 1.0)
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = 6.0
    checker.inputs["Color1"].default_value = (0.85, 0.85, 0.8, 1.0)
    checker.inputs["Color2"].default_value = (0.1, 0.1, 0.35, 1.0)
    voronoi = tree.nodes.new("ShaderNodeTexVoronoi")
    voronoi.inputs["Scale"].default_value = 3.0
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    links = tree.links
    links.new(noise.outputs["Fac"], ramp.inputs["Fac"])
    links.new(voronoi.outputs["Distance"], mix.inputs["Factor"])
    links.new(ramp.outputs["Color"], mix.inputs["A"])
    links.new(checker.outputs["Color"], mix.inputs["B"])
    links.new(mix.outputs["Result"], bsdf.inputs["Base Color"])
    links.new(bsdf.outputs["BSDF"], tree.nodes["Material Output"].inputs["Surface"])
    scene = bpy.context.scene
    common.quad("Floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], floor)
    red = common.principled("Red", (0.7, 0.15, 0.1), roughness=1.0)
    green = common.principled("Green", (0.15, 0.6, 0.2), roughness=1.0)
    white = common.principled("White", (0.75, 0.75, 0.75), roughness=1.0)
    common.quad("Left", [(-1, -1, 0), (-1, 1, 0), (-1, 1, 1.5), (-1, -1, 1.5)], red)
    common.quad("Right", [(1, -1, 0), (1, -1, 1.5), (1, 1, 1.5), (1, 1, 0)], green)
    common.quad("Back", [(-1, 1, 0), (1, 1, 0), (1, 1, 1.5), (-1, 1, 1.5)], white)
    common.camera("Camera", (0.0, -2.6, 1.6), (62.0, 0.0, 0.0), 50.0)
    common.light("Sun", "SUN", (0, 0, 5), (35.0, 0.0, 20.0), energy=3.0)
    bg = scene.world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.1, 0.1, 0.12, 1.0)
    bg.inputs["Strength"].default_value = 1.0
    return scene


def render_cli(glb, out, method, spp):
    cmd = [str(photon_binary()), "render", str(glb), "-o", str(out), "--width", str(SIZE),
           "--height", str(SIZE), "--spp", str(spp), "--seed", "1", "--method", method]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600,
                          stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, f"{' '.join(cmd)}\n{proc.stderr[-2000:]}"
    return read_exr(out)[:, :, :3]


def test_textured_box_by_path_photon_and_path_cache(tmp_path):
    from blender_addon import export
    scene = textured_box()
    ref = scenes_bpy.render(scene, "CYCLES", tmp_path / "cycles.exr", 1024)[:, :, :3]
    glb = tmp_path / "scene.glb"
    export.export_in_process(glb, "blender_addon")
    images = {m: render_cli(glb, tmp_path / f"{m}.exr", m, spp) for m, spp in METHODS.items()}
    path_mean = images["path"].mean()
    failures = []
    for method, img in images.items():
        assert img.shape == ref.shape and np.isfinite(img).all()
        to_cycles = float(img.mean() / ref.mean()) - 1.0
        to_path = float(img.mean() / path_mean) - 1.0
        err = rel_mse(img, ref)
        msg = (f"textured box {method}: mean {img.mean():.5f} vs cycles {ref.mean():.5f} "
               f"({100 * to_cycles:+.2f} %), vs path {100 * to_path:+.2f} %, relMSE {err:.5f}")
        print(msg)
        if abs(to_cycles) > 0.02 or abs(to_path) > 0.02 or err > 0.01:
            failures.append(msg)
    assert not failures, failures
