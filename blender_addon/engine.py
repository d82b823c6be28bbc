"""The render engine "Photon": export the scene, run the photon binary, load its image.

A thin `RenderEngine`: export and process handling live in export.py and runner.py; material,
world and light previews (`is_preview`, on Blender's preview scene, in a job thread where the
glTF exporter cannot run) are written by preview.py and path traced quickly. Nothing is
dropped silently: before exporting, every feature the export cannot carry (preflight.py), then
every warning of the glTF exporter (from either export route) and of the renderer, is reported
as a WARNING (Blender's info log; the console in background mode), and the final status line
counts them. Every failure the user can act on (no binary, no camera, export failure, renderer
error, unreadable image) ends as one `report({'ERROR'}, ...)` with the renderer's own message,
never a traceback and never a silently black image (in `blender -b` such a report also makes
Blender exit non-zero). With Denoise on, the loaded image is denoised (denoise.py) before
Blender gets it; a missing denoiser is a warning. Esc (`test_break`) stops the child within a
second; the temporary folder is always removed. The Rendered viewport (`view_update`,
`view_draw`) keeps a viewport.py session per viewport: the scene exported as F12 exports it in
the UI, `photon view` rendering the viewport's view, its images drawn as GPU textures through
Blender's display transform.
"""

import atexit
import dataclasses
import shutil
import tempfile
import time
import traceback
from pathlib import Path

import bpy

from . import denoise, export, preflight, preview, properties, runner, viewport

ADDON_DIR = Path(__file__).resolve().parent

# Material, world and light previews: a quick path-traced image (its noise is what a preview of
# that size tolerates; the preview scene's small area lights need no photon maps).
PREVIEW_SETTINGS = runner.RenderSettings(method="path", quality="preview", samples=16,
                                         max_bounces=8)

# Share of the progress bar given to each stage of the renderer's progress protocol.
STAGES = {"export": (0.0, 0.05), "load": (0.05, 0.1), "build": (0.1, 0.15), "render": (0.15, 1.0)}


class PhotonRenderEngine(bpy.types.RenderEngine):
    bl_idname = "PHOTON"
    bl_label = "Photon"
    bl_use_preview = True
    bl_use_postprocess = True
    bl_use_shading_nodes_custom = False
    # Material Preview only (Blender reads the flag for that mode alone): EEVEE there, as for
    # Cycles; Rendered mode draws Photon's own image (view_update, view_draw).
    bl_use_eevee_viewport = True

    def update_render_passes(self, scene=None, renderlayer=None):
        """Passes the renderer writes: Combined always; Depth, Normal, the denoising data (so
        the compositor's Denoise node can use them) and the light passes (which add up to
        Combined) when the view layer asks for them. With Denoise on, Combined is the denoised
        image, "Noisy Image" (Cycles' name) the renderer's, and the denoising data the guides
        the denoiser read."""
        self.register_pass(scene, renderlayer, "Combined", 4, "RGBA", "COLOR")
        if renderlayer.use_pass_z:
            self.register_pass(scene, renderlayer, "Depth", 1, "Z", "VALUE")
        if renderlayer.use_pass_normal:
            self.register_pass(scene, renderlayer, "Normal", 3, "XYZ", "VECTOR")
        denoising = getattr(getattr(scene, "photon", None), "use_denoising", False)
        if denoising:
            self.register_pass(scene, renderlayer, "Noisy Image", 4, "RGBA", "COLOR")
        if renderlayer.photon.use_pass_denoising_data or denoising:
            self.register_pass(scene, renderlayer, "Denoising Normal", 3, "XYZ", "VECTOR")
            self.register_pass(scene, renderlayer, "Denoising Albedo", 3, "RGB", "COLOR")
        for name in properties.enabled_light_passes(renderlayer):
            self.register_pass(scene, renderlayer, name, 3, "RGB", "COLOR")
        if properties.shadow_catcher_pass(renderlayer):
            self.register_pass(scene, renderlayer, "Shadow Catcher", 3, "RGB", "COLOR")

    def render(self, depsgraph):
        self.timings = {"start": time.perf_counter()}
        self.warnings = []
        try:
            if self.is_preview:
                self._render_preview(depsgraph)
            else:
                self._render(depsgraph)
        except runner.Cancelled:
            self.update_stats("", "Photon: cancelled")
        except (runner.PhotonError, export.ExportError) as exc:
            self.report({"ERROR"}, f"Photon: {exc}")
        except Exception as exc:  # noqa: BLE001 - a bug in the add-on: say so, log the trace
            traceback.print_exc()
            self.report({"ERROR"}, f"Photon add-on internal error: {exc!r} (trace in the console)")

    def _render(self, depsgraph):
        scene = depsgraph.scene
        view_layer = depsgraph.view_layer
        settings = scene.photon
        if scene.camera is None:
            raise runner.PhotonError("the scene has no active camera")
        binary = runner.find_binary(properties.preference_binary(bpy.context), ADDON_DIR)
        width, height = self.resolution_x, self.resolution_y
        # Render Region: the renderer renders only that window of the full-frame camera and
        # Blender places it into the frame (or crops to it).
        region = None
        r = scene.render
        if r.use_border:
            region = runner.border_region(width, height, r.border_min_x, r.border_max_x,
                                          r.border_min_y, r.border_max_y)
        objects, view_layer = depsgraph.objects, depsgraph.view_layer
        for message in preflight.unsupported_features(scene, objects, view_layer):
            self._warn(message)
        offset, adaptive = properties.sample_offset(scene), properties.adaptive_sampling(scene)
        if offset > 0 and adaptive is not None:
            raise runner.PhotonError(
                "Sample Offset needs Noise Threshold off: with adaptive sampling, which pixels "
                "stop depends on the samples before the offset (turn it off on every machine "
                "rendering a part of the frame)")
        self._progress("export", 0.0, "exporting scene")
        with runner.temporary_folder() as folder:
            glb, exr = folder / "scene.glb", folder / "render.exr"
            self._export(scene, folder, glb)
            self.timings["exported"] = time.perf_counter()
            command = runner.render_command(
                binary, glb, exr, width=width, height=height,
                settings=dataclasses.replace(properties.render_settings(settings),
                                             seed=properties.frame_seed(scene)),
                camera=scene.camera.name,
                view_layer=view_layer.name, region=region,
                passes=bool(properties.enabled_light_passes(view_layer)),
                adaptive=adaptive, sample_offset=offset)
            stats = runner.run(command, self._on_event, self.test_break)
            if region:
                width, height = region[2] - region[0], region[3] - region[1]
            self._load(exr, view_layer.name, width, height,
                       denoising=settings if settings.use_denoising else None)
        line = f"Photon: {summary(stats)}; {self._timing_summary()}"
        if self.warnings:
            count = len(self.warnings)
            line += f"; {count} warning{'s' if count > 1 else ''} (see the Info editor)"
        self._final_stats(line)

    def _render_preview(self, depsgraph):
        """A material, world or light preview: Blender's preview scene written by preview.py
        (the glTF exporter cannot run in the preview job), rendered with PREVIEW_SETTINGS. No
        pre-flight report here: the F12 render of the scene gives it."""
        scene, layer = depsgraph.scene, depsgraph.view_layer.name
        if scene.camera is None:
            raise runner.PhotonError("the preview scene has no camera")
        binary = runner.find_binary(properties.preference_binary(bpy.context), ADDON_DIR)
        width, height = self.resolution_x, self.resolution_y
        with runner.temporary_folder() as folder:
            gltf, exr = preview.write_scene(depsgraph, folder), folder / "render.exr"
            command = runner.render_command(binary, gltf, exr, width=width, height=height,
                                            settings=PREVIEW_SETTINGS, camera=scene.camera.name,
                                            view_layer=layer)
            runner.run(command, None, self.test_break)
            self._load(exr, layer, width, height)

    def _final_stats(self, line):
        """Show the final status line. Blender 4 also prints it in background mode (render farm
        logs show it); Blender 5 no longer does, so there it is printed here."""
        self.update_stats("", line)
        if bpy.app.background and bpy.app.version >= (5, 0, 0):
            print(line, flush=True)

    def _warn(self, message):
        """Report `message` as a WARNING once per render."""
        if message not in self.warnings:
            self.warnings.append(message)
            self.report({"WARNING"}, f"Photon: {message}")

    def _export(self, scene, folder, glb):
        if export.export_route() == "inprocess":
            for message in export.export_in_process(glb, __package__):
                self._warn(message)
            return
        if self.is_animation:
            server = ANIMATION_EXPORT.server(scene)
            try:
                server.request({"frame": scene.frame_current, "subframe": scene.frame_subframe,
                                "glb": str(glb)}, "exported", self._on_export_event,
                               self.test_break)
            except (runner.PhotonError, runner.Cancelled):
                ANIMATION_EXPORT.close()
                raise
        else:
            snapshot = folder / "snapshot.blend"
            export.write_snapshot(scene, snapshot)
            runner.run(export.child_command(snapshot, glb, export.scripts_may_run()),
                       self._on_export_event, self.test_break,
                       what="glTF export (background Blender)", cwd=str(folder))
        if not glb.is_file():
            raise export.ExportError(f"the background Blender export wrote no {glb.name}")

    def _on_export_event(self, event):
        """The background Blender's export prints only warnings as progress events."""
        if "warning" in event:
            self._warn(str(event["warning"]))

    def _on_event(self, event):
        self.timings.setdefault("first_progress", time.perf_counter())
        if "warning" in event:
            self._warn(str(event["warning"]))
            return
        stage = str(event.get("stage", ""))
        if stage == "done":
            self.update_progress(1.0)
            return
        fraction = event.get("fraction")
        self._progress(stage, fraction if isinstance(fraction, (int, float)) else 0.0,
                       str(event.get("message", "")))

    def _progress(self, stage, fraction, message):
        lo, hi = STAGES.get(stage, (0.0, 1.0))
        self.update_progress(lo + (hi - lo) * min(max(fraction, 0.0), 1.0))
        self.update_stats("", f"Photon: {stage} {100 * fraction:.0f}% {message}".rstrip())

    def _load(self, exr, layer_name, width, height, denoising=None):
        """Fill the render result from the EXR, after checking that Blender's loader will find
        the channels (it loads nothing, silently, when the names do not match); with
        `denoising` (the scene's settings), denoise it before handing it to Blender."""
        if not exr.is_file():
            raise runner.PhotonError("the renderer exited normally but wrote no image")
        wanted = f"{layer_name}.Combined.R"
        channels = runner.exr_channels(exr)
        if wanted not in channels:
            raise runner.PhotonError(
                f"the rendered image has no channel '{wanted}' (it has: {', '.join(channels[:8])})")
        result = self.begin_result(0, 0, width, height, layer=layer_name)
        try:
            result.load_from_file(str(exr))
        except RuntimeError as exc:
            self.end_result(result, cancel=True)
            raise runner.PhotonError(f"Blender could not load the rendered image: {exc}") from None
        try:
            # The samples the image holds, kept in the files Blender saves (stamp metadata of
            # the whole render's result, as Cycles stamps its samples) so that renders of parts
            # of one frame can be merged (merge.py).
            for name, value in runner.exr_text_attributes(exr, "photon.").items():
                self.get_result().stamp_data_add_field(name, value)
            catcher = result.layers[0].passes.get("Shadow Catcher")
            if catcher is not None and f"{layer_name}.Shadow Catcher.R" not in channels:
                # No shadow catcher in the scene: Cycles' pass is white (the file has none).
                catcher.rect.foreach_set([1.0] * (width * height * 3))
            if denoising is not None:
                self._denoise(result.layers[0], width, height, denoising)
        finally:
            self.end_result(result)

    def _denoise(self, layer, width, height, settings):
        """Denoise the layer's Combined with OpenImageDenoise (denoise.py), keeping the noisy
        image in "Noisy Image". Without the library, or when it fails, a warning says so and
        Combined stays noisy."""
        self.update_stats("", "Photon: denoising (OpenImageDenoise)")
        start = time.perf_counter()
        lib = None
        try:
            lib = denoise.library(bpy.app.binary_path, Path(bpy.__file__).resolve().parent)
        except denoise.DenoiserMissing as exc:
            self._warn(f"Denoise is on, but the image is not denoised: {exc}")
        try:
            denoise.denoise_layer(lib, layer, width, height,
                                  prefilter=settings.denoising_prefilter,
                                  threads=settings.threads, should_cancel=self.test_break)
        except denoise.DenoiseError as exc:
            self._warn(f"Denoise is on, but the image is not denoised: {exc}")
        except denoise.Cancelled:
            raise runner.Cancelled() from None
        else:
            if lib is not None:
                self.timings["denoise_seconds"] = time.perf_counter() - start


    def _timing_summary(self) -> str:
        """Seconds from the call of render() to the end of the export, to the renderer's first
        progress report, and in total."""
        t = self.timings
        start = t["start"]
        parts = [f"{name} {t[key] - start:.2f} s" for name, key in
                 (("export", "exported"), ("first progress", "first_progress")) if key in t]
        if "denoise_seconds" in t:
            parts.append(f"denoise {t['denoise_seconds']:.2f} s")
        return ", ".join(parts + [f"total {time.perf_counter() - start:.2f} s"])


    # -- the Rendered viewport (viewport.py holds the session) ---------------------------
    def view_update(self, context, depsgraph):
        """The viewport's scene changed (or Rendered mode began): export it again, unless only
        cameras moved, and start a renderer on it; a changed Photon setting does the same."""
        try:
            self._view_update(depsgraph)
        except (runner.PhotonError, export.ExportError) as exc:
            self.update_stats("", f"Photon: {exc}")
        except Exception as exc:  # noqa: BLE001 - a bug in the add-on: say so, log the trace
            traceback.print_exc()
            self.update_stats("", f"Photon add-on internal error: {exc!r}")

    def _view_update(self, depsgraph):
        scene = depsgraph.scene
        args = runner.settings_arguments(properties.viewport_settings(scene.photon))
        session = getattr(self, "_view", None)
        if session is None:
            session = self._view = new_view_session(args)
        elif args == session.settings_args and not session.stale and not viewport.needs_export(
                update_kinds(depsgraph)):
            return
        session.settings_args = args
        if session.exporting():
            # One export at a time (an object dragged updates the depsgraph many times a
            # second): this change is exported when the one running ends (view_draw asks).
            session.stale = True
            return
        session.stale = False
        export_view_scene(scene, session)

    def view_draw(self, context, depsgraph):
        """Send the viewport's view (a changed one restarts the render) and draw the newest
        image, through Blender's display transform; redraw while images are still coming."""
        session = getattr(self, "_view", None)
        if session is None:
            return
        region, view = context.region, context.region_data
        session.show(viewport.view_request([list(r) for r in view.view_matrix],
                                           [list(r) for r in view.window_matrix],
                                           region.width, region.height))
        frame = session.latest()
        if frame is not None:
            self._view_texture = _texture(frame)
            self._view_spp = frame.spp
        texture = getattr(self, "_view_texture", None)
        if texture is not None:
            _draw(self, depsgraph.scene, texture, region.width, region.height)
        if session.errors:
            self.update_stats("", f"Photon: {session.errors[-1]}")
        elif texture is not None:
            self.update_stats("", f"Photon: {getattr(self, '_view_spp', 0)} samples")
        if session.stale and not session.exporting():
            self.tag_update()  # Blender calls view_update, which exports the changes since
        if session.rendering():
            self.tag_redraw()

    def __del__(self):
        """The engine is freed (the viewport left Rendered mode): stop its renderer."""
        try:
            session = getattr(self, "_view", None)
        except ReferenceError:
            return
        if session is not None:
            _close_view(session)


def new_view_session(settings_args):
    """A Rendered viewport's session (no renderer yet: `export_view_scene` starts one)."""
    binary = runner.find_binary(properties.preference_binary(bpy.context), ADDON_DIR)
    session = viewport.ViewSession(binary, settings_args,
                                   tempfile.mkdtemp(prefix="photon_view_"))
    VIEW_SESSIONS.append(session)
    return session


def export_view_scene(scene, session):
    """Export `scene` for the viewport as F12 does in the UI (a snapshot .blend here, exported
    by a background Blender in the session's thread: the viewport's drawing never waits for
    it; closing the session stops it), then restart the session's renderer on it."""
    number = session.exports + 1
    snapshot = session.folder / f"snapshot{number}.blend"
    glb = session.folder / f"scene{number}.glb"
    export.write_snapshot(scene, snapshot)
    command = export.child_command(snapshot, glb, export.scripts_may_run())
    session.rescene(lambda: runner.run(command, None, lambda: session.closed,
                                       what="glTF export (background Blender)",
                                       cwd=str(session.folder)), glb)


def update_kinds(depsgraph):
    """The depsgraph's updates as viewport.needs_export reads them."""
    return [(type(u.id).__name__.upper(), getattr(u.id, "type", None), u.is_updated_geometry,
             u.is_updated_shading, u.is_updated_transform) for u in depsgraph.updates]


def _texture(frame):
    """A GPU texture holding `frame`'s pixels (already bottom row first)."""
    import gpu
    pixels = frame.pixels.astype("float32").ravel()
    buffer = gpu.types.Buffer("FLOAT", pixels.size, pixels)
    return gpu.types.GPUTexture((frame.width, frame.height), format="RGBA16F", data=buffer)


def _draw(engine, scene, texture, width, height):
    """Draw `texture` over the viewport's region through Blender's display transform."""
    import gpu
    from gpu_extras.presets import draw_texture_2d
    gpu.state.blend_set("ALPHA_PREMULT")
    engine.bind_display_space_shader(scene)
    draw_texture_2d(texture, (0, 0), width, height)
    engine.unbind_display_space_shader()
    gpu.state.blend_set("NONE")


# Sessions of the Rendered viewports open: closed when their engine is freed, when the add-on
# is disabled and when Blender quits.
VIEW_SESSIONS = []


def _close_view(session):
    session.close()
    shutil.rmtree(session.folder, ignore_errors=True)
    if session in VIEW_SESSIONS:
        VIEW_SESSIONS.remove(session)


def close_views():
    for session in list(VIEW_SESSIONS):
        _close_view(session)


atexit.register(close_views)


class AnimationExport:
    """The background Blender that exports every frame of an animation rendered in the UI
    route: started at the animation's first frame on a snapshot of the scene, asked for each
    frame (it sets the frame itself, so its state is the frame's), ended when the render job
    ends (render_complete / render_cancel handlers; a new job's render_init also ends a stale
    one). One Blender start per animation instead of one per frame. `starts` counts them."""

    def __init__(self):
        self._server = None
        self._folder = None
        self.starts = 0

    def server(self, scene) -> "runner.Server":
        if self._server is not None and self._server.alive():
            return self._server
        self.close()
        self._folder = Path(tempfile.mkdtemp(prefix="photon_animation_"))
        snapshot = self._folder / "snapshot.blend"
        export.write_snapshot(scene, snapshot)
        self._server = runner.Server(
            export.child_command(snapshot, None, export.scripts_may_run()),
            what="glTF export (background Blender)", cwd=str(self._folder))
        self.starts += 1
        return self._server

    def close(self, *_args):
        if self._server is not None:
            self._server.close()
            self._server = None
        if self._folder is not None:
            shutil.rmtree(self._folder, ignore_errors=True)
            self._folder = None


ANIMATION_EXPORT = AnimationExport()


@bpy.app.handlers.persistent
def _end_animation_export(*_args):
    ANIMATION_EXPORT.close()


HANDLERS = ("render_init", "render_complete", "render_cancel")


def summary(stats: dict) -> str:
    """One line for the status bar from the renderer's final statistics."""
    if not stats:
        return "done"
    return (f"{stats.get('width')}x{stats.get('height')}, {stats.get('spp')} spp in "
            f"{stats.get('total_seconds', stats.get('render_seconds', 0)):.2f} s, "
            f"{stats.get('mrays_per_second', 0):.1f} "
            f"M rays/s, {stats.get('triangles')} triangles")


classes = (PhotonRenderEngine,)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    for name in HANDLERS:
        getattr(bpy.app.handlers, name).append(_end_animation_export)


def unregister():
    ANIMATION_EXPORT.close()
    close_views()
    for name in HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if _end_animation_export in handlers:
            handlers.remove(_end_animation_export)
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
