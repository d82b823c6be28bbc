"""Baked smoke and fire of Blender fluid domains (Mantaflow), for tests/blender/test_fluid.py
and docs/bench/volumes.md "Fluid domains".

`bake_gas(folder, ...)` builds a small gas domain over a flow object (Quick Smoke / Quick Fire
style: a cube emitting smoke or fire into a 2 m domain), bakes it with `bpy.ops.fluid.bake_all`
into `folder` and leaves the scene at the last baked frame. `smoke_material` and
`fire_material` are the Principled Volume materials Blender's Quick Smoke and Quick Fire give
the domain (density from the "density" grid; fire: Blackbody Intensity 1 on the "temperature"
Cycles makes from the flame).

bpy built as a Python module registers Mantaflow's Python classes without their base classes
(a LevelsetGrid has no `setConst`, so every simulation step fails): `mantaflow_bases()` gives
them back before a bake. Blender itself does not need it.

Usage:  .venv/bin/python scenes/blender/fluid_scenes.py OUT_DIR
bakes a smoke and a fire domain (32 cells a side, 12 frames, 64 x 64 px) and writes
OUT_DIR/{fluid_smoke,fluid_fire}.blend and .glb exported through the add-on (for `photon
render` and `photon bench`; the bakes stay in OUT_DIR/*_cache, which the .glb names).
"""

from __future__ import annotations

import ctypes
import os
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parents[1]))

import bpy  # noqa: E402

import common  # noqa: E402

# Each Mantaflow class (by its Python type name) and its base class, as Mantaflow declares them.
MANTAFLOW_BASES = {
    "GridBase": "PbClass", "Grid_Real": "GridBase", "Grid_Vec3": "GridBase",
    "Grid_int": "GridBase", "LevelsetGrid": "Grid_Real", "MACGrid": "Grid_Vec3",
    "FlagGrid": "Grid_int", "Grid4dBase": "PbClass", "Grid4d_Real": "Grid4dBase",
    "Grid4d_Vec3": "Grid4dBase", "Grid4d_Vec4": "Grid4dBase", "Grid4d_int": "Grid4dBase",
    "MeshDataBase": "PbClass", "MeshDataImpl_Real": "MeshDataBase",
    "MeshDataImpl_Vec3": "MeshDataBase", "MeshDataImpl_int": "MeshDataBase",
    "ParticleDataBase": "PbClass", "ParticleDataImpl_Real": "ParticleDataBase",
    "ParticleDataImpl_Vec3": "ParticleDataBase", "ParticleDataImpl_int": "ParticleDataBase",
    "ParticleBase": "PbClass", "ParticleSystem_BasicParticleData": "ParticleBase",
    "ParticleSystem_ParticleIndexData": "ParticleBase",
    "ParticleSystem_TurbulenceParticleData": "ParticleBase",
    "ParticleSystem_VortexParticleData": "ParticleBase",
    "BasicParticleSystem": "ParticleSystem_BasicParticleData",
    "ParticleIndexSystem": "ParticleSystem_ParticleIndexData",
    "TurbulenceParticleSystem": "ParticleSystem_TurbulenceParticleData",
    "VortexParticleSystem": "ParticleSystem_VortexParticleData",
    "Shape": "PbClass", "Box": "Shape", "Cylinder": "Shape", "Sphere": "Shape",
    "Slope": "Shape", "NullShape": "Shape", "Solver": "PbClass", "Mesh": "PbClass",
    "VortexSheetMesh": "Mesh", "NoiseField": "PbClass", "MovingObstacle": "PbClass",
    "Timings": "PbClass",
}
# Offsets of tp_base, tp_bases and tp_mro in CPython 3.11's PyTypeObject (64-bit).
TP_BASE, TP_BASES, TP_MRO = 256, 336, 344
# The tuples the patched types point to, kept alive.
_KEPT = []


def mantaflow_bases():
    """Gives Mantaflow's Python classes their base classes when bpy registered them without
    (bpy as a module); nothing when they have them."""
    import manta
    types = {v.__name__: v for v in vars(manta).values() if isinstance(v, type)}
    root = types["PbClass"]
    if ctypes.c_void_p.from_address(id(root) + TP_MRO).value != id(root.__mro__):
        return  # not the layout this expects
    for name, base in MANTAFLOW_BASES.items():
        kind = types.get(name)
        if kind is None or base not in types or len(kind.__mro__) > 2:
            continue
        chain, at = [kind], name
        while at in MANTAFLOW_BASES:
            at = MANTAFLOW_BASES[at]
            chain.append(types[at])
        mro, bases = (*chain, object), (types[base],)
        _KEPT.extend([mro, bases])
        ctypes.c_void_p.from_address(id(kind) + TP_BASE).value = id(types[base])
        ctypes.c_void_p.from_address(id(kind) + TP_BASES).value = id(bases)
        ctypes.c_void_p.from_address(id(kind) + TP_MRO).value = id(mro)
        ctypes.pythonapi.PyType_Modified(ctypes.py_object(kind))


def principled_volume_material(name, **inputs):
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    tree = mat.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    node = tree.nodes.new("ShaderNodeVolumePrincipled")
    for key, value in inputs.items():
        node.inputs[key].default_value = value
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Volume"])
    return mat, node


def smoke_material():
    """Quick Smoke's: a Principled Volume, density 5 from the "density" grid."""
    return principled_volume_material("Smoke domain", Density=5.0)[0]


def fire_material():
    """Quick Fire's: Quick Smoke's with Blackbody Intensity 1 (the "temperature" attribute,
    from the flame, times 1000 K)."""
    return principled_volume_material("Fire domain", Density=5.0,
                                      **{"Blackbody Intensity": 1.0})[0]


def bake_gas(folder, flow_type="SMOKE", resolution=16, frames=8, location=(0.0, 0.0, 1.1),
             scale=1.0, material=None, noise=False):
    """A 2 m gas domain (at `location`, scaled by `scale`) over a 0.5 m cube emitting
    `flow_type` ("SMOKE", "FIRE" or "BOTH") near its floor, baked over frames 1..`frames` at
    `resolution` cells along its longest side into `folder` (OpenVDB, Blender's defaults);
    the scene is left at frame `frames`; with `noise`, Blender's noise upres (2x) is baked
    too. Returns the domain object. By default the domain's
    bottom is 0.1 m above a floor at height 0: a box face lying in the floor leaves which of
    the two a ray meets first to chance, in Cycles as in Photon."""
    mantaflow_bases()
    scene = bpy.context.scene
    x, y, z = location
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(x, y, z - 0.6 * scale))
    flow_object = bpy.context.object
    flow_object.name = "Flow"
    flow = flow_object.modifiers.new("Fluid", "FLUID")
    flow.fluid_type = "FLOW"
    flow.flow_settings.flow_type = flow_type
    flow.flow_settings.flow_behavior = "INFLOW"
    flow_object.hide_render = True
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=location)
    domain = bpy.context.object
    domain.name = "Domain"
    domain.scale = (scale, scale, scale)
    modifier = domain.modifiers.new("Fluid", "FLUID")
    modifier.fluid_type = "DOMAIN"
    settings = modifier.domain_settings
    settings.domain_type = "GAS"
    settings.resolution_max = resolution
    settings.cache_directory = str(folder)
    settings.cache_frame_start = 1
    settings.cache_frame_end = frames
    settings.cache_type = "ALL"
    settings.use_noise = noise
    domain.data.materials.append(material or smoke_material())
    # Mantaflow's noise writes its wavelet tile (waveletNoiseTile.bin, 24 MiB) to the current
    # folder: bake in the cache's.
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    here = os.getcwd()
    os.chdir(folder)
    try:
        with bpy.context.temp_override(object=domain, active_object=domain,
                                       selected_objects=[domain], scene=scene):
            result = bpy.ops.fluid.bake_all()
    finally:
        os.chdir(here)
    assert "FINISHED" in result, result
    scene.frame_set(frames)
    return domain


def smoke_scene(folder, size=48, flow_type="SMOKE", frames=8, resolution=16):
    """A baked gas domain over a grey floor, lit by a sun, seen from the side and above."""
    scene = common.reset_scene(size, size)
    floor = common.principled("Floor", (0.8, 0.8, 0.8), roughness=1.0)
    common.quad("Floor", [(-3, -3, 0), (3, -3, 0), (3, 3, 0), (-3, 3, 0)], floor)
    material = fire_material() if flow_type != "SMOKE" else smoke_material()
    domain = bake_gas(folder, flow_type, resolution, frames, material=material)
    common.camera("Camera", (0.0, -5.0, 2.5), (75.0, 0.0, 0.0), 45.0)
    common.light("Sun", "SUN", (0, 0, 5), (30.0, 10.0, 40.0), energy=3.0)
    return scene, domain


def main(out_dir: Path):
    from volume_scenes import save_scenes

    def build(flow_type, name):
        return lambda out: smoke_scene((out / f"{name}_cache").resolve(), 64, flow_type, 12, 32)

    try:
        save_scenes(out_dir, [(name, build(flow_type, name))
                              for name, flow_type in (("fluid_smoke", "SMOKE"), ("fluid_fire", "FIRE"))])
    finally:
        # A fluid domain still loaded when the process ends makes bpy's Mantaflow abort it.
        bpy.ops.wm.read_factory_settings(use_empty=True)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(Path(sys.argv[1]))
