"""Blender's pixel filter (Render > Film > Pixel Filter) through the add-on: a scene of sharp
emissive edges on black, whose pixels differ only by how the filter spreads each edge, rendered
by Cycles and by Photon (F12, `bpy.ops.render.render()`) with the film's Box (1 px) and
Gaussian (3 px) filters. Photon matches Cycles to relMSE 0.01, and rendered with Blender's
default filter instead (what Photon did before it read the film's filter) it is clearly worse.
"""

import bpy
import pytest

import common
import scenes_bpy
from helpers import photon_binary, rel_mse
from refimage import read_exr

pytestmark = pytest.mark.slow  # renders Cycles or takes more than ~10 s

SPP = 256
WIDTH, HEIGHT = 48, 32


def emission(name, strength):
    """A material that only emits white light of `strength`."""
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.clear()
    emit = nodes.new("ShaderNodeEmission")
    emit.inputs["Strength"].default_value = strength
    out = nodes.new("ShaderNodeOutputMaterial")
    mat.node_tree.links.new(emit.outputs["Emission"], out.inputs["Surface"])
    return mat


def edge_scene():
    """Three emissive quads (strengths 1, 2 and 0.5) with edges slanted against the pixel grid,
    on a black world, seen from above by a perspective camera; nothing else lights anything."""
    scene = common.reset_scene(WIDTH, HEIGHT)
    common.quad("Half", [(-9, -9, 0), (0.7, -9, 0), (-0.6, 9, 0), (-9, 9, 0)],
                emission("One", 1.0))
    common.quad("Kite", [(1.0, -0.4, 0.1), (2.2, -1.1, 0.1), (2.6, 0.5, 0.1), (1.3, 0.9, 0.1)],
                emission("Two", 2.0))
    common.quad("Sliver", [(0.9, 1.4, 0.1), (3.0, 1.1, 0.1), (3.1, 1.5, 0.1), (1.0, 1.7, 0.1)],
                emission("Half", 0.5))
    common.camera("Camera", (0.8, 0.0, 5.0), (0.0, 0.0, 3.0), 50.0)
    return scene


def render(scene, engine, path, filter_type, filter_width):
    """The scene rendered by `engine` with the film's pixel filter set so."""
    common.configure_cycles(scene, SPP, seed=1, threads=scenes_bpy.THREADS)
    scene.cycles.pixel_filter_type = filter_type
    scene.cycles.filter_width = filter_width
    scene.render.engine = engine
    if engine == "PHOTON":
        scene.photon.samples, scene.photon.seed, scene.photon.threads = SPP, 1, 0
        scene.photon.method = "PATH"
    scene.render.filepath = str(path)
    scene.render.use_file_extension = False
    bpy.ops.render.render(write_still=True)
    assert path.exists(), f"{engine} wrote no image at {path}"
    return read_exr(path)


@pytest.mark.parametrize("filter_type, filter_width", [("BOX", 1.0), ("GAUSSIAN", 3.0)])
def test_photon_filters_as_cycles_does(photon_addon, tmp_path, filter_type, filter_width):
    photon_binary()
    scene = edge_scene()
    name = f"{filter_type.lower()}{filter_width:g}"
    cycles = render(scene, "CYCLES", tmp_path / f"{name}_cycles.exr", filter_type, filter_width)
    photon = render(scene, "PHOTON", tmp_path / f"{name}_photon.exr", filter_type, filter_width)
    # What Photon rendered before it read the film's filter: Blender's default filter.
    default = render(scene, "PHOTON", tmp_path / f"{name}_default.exr", "BLACKMAN_HARRIS", 1.5)
    edge = (cycles.max(axis=2) > 0.02) & (cycles.max(axis=2) < 0.98)
    assert edge.mean() > 0.05, f"only {edge.mean():.3f} of the pixels see an edge"
    err, ignored = rel_mse(photon, cycles), rel_mse(default, cycles)
    msg = (f"{filter_type} {filter_width} px: relMSE {err:.5f} against Cycles "
           f"(mean {photon.mean():.5f} vs {cycles.mean():.5f}); with the default filter "
           f"instead {ignored:.5f}")
    print(msg)
    assert err <= 0.01, msg
    assert ignored >= 5.0 * err and ignored > 0.01, msg
