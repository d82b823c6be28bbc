"""Scene export: Blender's own glTF exporter plus hooks that write Photon's glTF extensions.

`export_scene` writes the scene being rendered to a .glb. Two routes, one chosen per render:

- in process (Blender running in the background, `-b`, or bpy as a Python module): call
  `bpy.ops.export_scene.gltf` directly from `RenderEngine.render`, which works there;
- in a child Blender (the interactive UI): F12 runs `render()` in a job thread where the exporter,
  which needs a window context, can fail (glTF-Blender-IO issue 1943). The scene is written to a
  temporary .blend with `bpy.data.libraries.write` (context-free, fast) and a background Blender
  (`bpy.app.binary_path -b --factory-startup --python export.py -- SNAPSHOT.blend OUT.glb`)
  opens it and runs the same in-process export.

The environment variable PHOTON_EXPORT=inprocess|subprocess overrides the choice (for tests).

`glTF2ExportUserExtension` (re-exported by the add-on's top-level module, where the exporter
looks for it) writes, always with required=False so that other viewers still open the file:
PHOTON_light on light nodes (point/spot radius, sun angle, area lights, which the exporter drops),
PHOTON_world (background colour x strength) and PHOTON_render (final resolution, transparent
film) on the scene. The fields are documented in the renderer's src/scene/gltf.rs.

This file runs both inside the add-on and as the child's script, so it imports only bpy and the
standard library.
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import bpy

GLTF_EXPORT_ARGS = dict(
    export_format="GLB", export_lights=True, export_cameras=True, export_extras=True,
    export_apply=True, export_current_frame=True, use_renderable=True, export_animations=False,
    use_active_scene=True,
)

# Name under which the child process registers this module so the exporter finds the hook.
CHILD_MODULE = "photon_gltf_export"


class ExportError(Exception):
    """The scene could not be exported; the message is meant for the user."""


# ---------------------------------------------------------------------------------------------
# Hooks
# ---------------------------------------------------------------------------------------------

class glTF2ExportUserExtension:  # noqa: N801 - the name the glTF exporter looks for
    """Hooks called by Blender's glTF exporter (one instance per export)."""

    def __init__(self):
        from io_scene_gltf2.io.com.gltf2_io_extensions import Extension
        self._extension = Extension

    def _add(self, gltf_object, name, data):
        if gltf_object.extensions is None:
            gltf_object.extensions = {}
        gltf_object.extensions[name] = self._extension(name=name, extension=data, required=False)

    def gather_node_hook(self, gltf_node, blender_object, export_settings):
        if blender_object is not None and blender_object.type == "LIGHT":
            data = light_extension(blender_object)
            if data:
                self._add(gltf_node, "PHOTON_light", data)

    def gather_scene_hook(self, gltf_scene, blender_scene, export_settings):
        self._add(gltf_scene, "PHOTON_world", world_extension(blender_scene.world))
        self._add(gltf_scene, "PHOTON_render", render_extension(blender_scene))


def light_extension(obj) -> dict:
    """PHOTON_light for a light object."""
    light = obj.data
    if light.type in ("POINT", "SPOT"):
        return {"radius": float(light.shadow_soft_size)}
    if light.type == "SUN":
        return {"angle": float(light.angle)}
    if light.type != "AREA":
        return {}
    size = float(light.size)
    size_y = float(light.size_y) if light.shape in ("RECTANGLE", "ELLIPSE") else size
    power = float(light.energy) * 2.0 ** float(getattr(light, "exposure", 0.0))
    if not getattr(light, "normalize", True):
        # Without "normalize" Blender's power is per square metre; Photon always normalises.
        area = size * size_y * (math.pi / 4.0 if light.shape in ("DISK", "ELLIPSE") else 1.0)
        power *= area
    return {"type": "area", "shape": light.shape, "size": size, "size_y": size_y,
            "power": power, "color": [float(c) for c in light.color],
            "visible_camera": bool(obj.visible_camera)}


def world_extension(world) -> dict:
    """PHOTON_world: the Background colour and strength feeding the world output, or the world's
    viewport colour when it does not use nodes; black without a world."""
    if world is None:
        return {"color": [0.0, 0.0, 0.0], "strength": 1.0}
    if world.use_nodes and world.node_tree is not None:
        background = _world_background(world.node_tree)
        if background is not None:
            color = background.inputs["Color"].default_value
            strength = background.inputs["Strength"].default_value
            return {"color": [float(c) for c in color[:3]], "strength": float(strength)}
        return {"color": [0.0, 0.0, 0.0], "strength": 1.0}
    return {"color": [float(c) for c in world.color[:3]], "strength": 1.0}


def _world_background(tree):
    outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld"]
    active = [n for n in outputs if n.is_active_output] or outputs
    for out in active:
        surface = out.inputs.get("Surface")
        if surface is not None and surface.is_linked:
            node = surface.links[0].from_node
            if node.bl_idname == "ShaderNodeBackground":
                return node
    return None


def render_extension(scene) -> dict:
    """PHOTON_render: the final image size (resolution x percentage) and transparent film."""
    r = scene.render
    scale = r.resolution_percentage / 100.0
    return {"width": max(1, int(r.resolution_x * scale)),
            "height": max(1, int(r.resolution_y * scale)),
            "film_transparent": bool(r.film_transparent)}


# ---------------------------------------------------------------------------------------------
# Export routes
# ---------------------------------------------------------------------------------------------

def export_route() -> str:
    """'inprocess' in background Blender, 'subprocess' in the UI; PHOTON_EXPORT overrides."""
    forced = os.environ.get("PHOTON_EXPORT", "").strip().lower()
    if forced in ("inprocess", "subprocess"):
        return forced
    return "inprocess" if bpy.app.background else "subprocess"


def export_in_process(glb: Path, hook_module: str):
    """Run Blender's glTF exporter on the current scene. `hook_module` is the name in sys.modules
    that holds `glTF2ExportUserExtension`: the exporter only looks at enabled add-ons, so it is
    listed there for the duration of the export if it is not already."""
    prefs = bpy.context.preferences
    added = None
    if hook_module not in prefs.addons.keys():
        added = prefs.addons.new()
        added.module = hook_module
    try:
        result = bpy.ops.export_scene.gltf(filepath=str(glb), **GLTF_EXPORT_ARGS)
    except Exception as exc:  # the operator raises RuntimeError with Blender's own report
        raise ExportError(f"glTF export failed: {exc}") from None
    finally:
        if added is not None:
            prefs.addons.remove(added)
    if "FINISHED" not in result or not Path(glb).is_file():
        raise ExportError(f"glTF export did not write {glb} ({result})")


def child_command(snapshot: Path, glb: Path) -> list[str]:
    """The command that exports a snapshot .blend in a separate process: Blender itself, or the
    Python interpreter when bpy runs as a module (bpy.app.binary_path is then empty)."""
    script = str(Path(__file__).resolve())
    if bpy.app.binary_path:
        return [bpy.app.binary_path, "-b", "--factory-startup", "--python-exit-code", "1",
                "--python", script,
                "--", str(snapshot), str(glb)]
    return [sys.executable, script, "--", str(snapshot), str(glb)]


def write_snapshot(scene, path: Path):
    """Write `scene` and everything it uses to a .blend, without needing a window context."""
    bpy.data.libraries.write(str(path), {scene}, fake_user=True, path_remap="ABSOLUTE")


def _child_main(argv: list[str]) -> int:
    """Entry point of the child process: open the snapshot, export it."""
    snapshot, glb = argv[argv.index("--") + 1:][:2]
    sys.modules[CHILD_MODULE] = sys.modules[__name__]
    bpy.ops.wm.open_mainfile(filepath=snapshot)
    try:
        export_in_process(Path(glb), CHILD_MODULE)
    except ExportError as exc:
        print(f"photon-export: error: {exc}", file=sys.stderr, flush=True)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(_child_main(sys.argv))
