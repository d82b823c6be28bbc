"""The Rendered viewport through the add-on (bpy 4.5 in the background, where nothing can be
drawn): the view request made from Blender's view and projection matrices (checked against the
scene camera's own), the depsgraph updates that make the viewport export again (an object, a
material, a light) and those that do not (a camera, a selection), the engine's `view_update`
and `view_draw` on a stand-in engine, and the session the engine keeps for a viewport — the
scene exported as F12 exports it, `photon view` started on it, a first image of the default
cube, a camera move answered by an image in which the cube has moved, an object move answered
by a new export whose image shows it, the renderer gone after `close`. The latencies are
printed (docs/bench/viewport.md); the bounds asserted leave room for a loaded machine.
"""

import math
import os
import time
import types
from pathlib import Path

import bpy
import numpy as np
import pytest
from mathutils import Matrix, Vector

import scenes_bpy
from helpers import photon_binary

WIDTH, HEIGHT = 96, 54
# Bounds for a loaded two-core machine; the measured values are printed.
FIRST_IMAGE_SECONDS = 30.0
RESTART_SECONDS = 3.0


@pytest.fixture(autouse=True)
def binary(photon_addon):
    return photon_binary()


@pytest.fixture
def modules(photon_addon):
    from blender_addon import engine, viewport
    return engine, viewport


def camera_request(viewport, scene, width=WIDTH, height=HEIGHT, moved=None):
    """The request a viewport looking through the scene camera sends (its view matrix and
    projection as `region_data` holds them in camera view), the eye moved by `moved` (in the
    camera's own axes) if given."""
    camera = scene.camera
    to_world = camera.matrix_world.copy()
    if moved is not None:
        to_world = to_world @ Matrix.Translation(Vector(moved))
    depsgraph = bpy.context.evaluated_depsgraph_get()
    window = camera.calc_matrix_camera(depsgraph, x=width, y=height)
    return viewport.view_request([list(r) for r in to_world.inverted()],
                                 [list(r) for r in window], width, height)


def test_view_request_matches_the_camera(modules):
    _, viewport = modules
    scene = scenes_bpy.default_scene()
    camera = scene.camera
    request = camera_request(viewport, scene)
    assert request["projection"] == "perspective"
    # Sensor fit Auto on a wide image: the horizontal angle is the camera's.
    yfov = 2.0 * math.atan(math.tan(camera.data.angle / 2.0) * HEIGHT / WIDTH)
    assert request["yfov"] == pytest.approx(yfov, rel=1e-5)
    assert request["clip"] == pytest.approx([camera.data.clip_start, camera.data.clip_end],
                                            rel=1e-4)
    assert request["shift"] == pytest.approx([0.0, 0.0], abs=1e-6)
    # glTF is Y-up: Blender's (x, y, z) is (x, z, -y).
    m = np.array(request["camera_to_world"]).reshape(4, 4)
    eye = camera.matrix_world.translation
    assert m[:3, 3] == pytest.approx([eye.x, eye.z, -eye.y], rel=1e-5)
    forward = camera.matrix_world.to_3x3() @ Vector((0, 0, -1))
    assert -m[:3, 2] == pytest.approx([forward.x, forward.z, -forward.y], abs=1e-5)
    # Lens shift: a fraction of the wider side in Blender, of the height in the request.
    camera.data.shift_x, camera.data.shift_y = 0.1, -0.05
    request = camera_request(viewport, scene)
    assert request["shift"] == pytest.approx([0.1 * WIDTH / HEIGHT, -0.05 * WIDTH / HEIGHT],
                                             rel=1e-4)
    camera.data.shift_x = camera.data.shift_y = 0.0
    camera.data.type = "ORTHO"
    camera.data.ortho_scale = 6.0
    request = camera_request(viewport, scene)
    assert request["projection"] == "orthographic"
    assert request["ymag"] == pytest.approx(3.0 * HEIGHT / WIDTH, rel=1e-5)
    assert request["clip"][0] == pytest.approx(camera.data.clip_start, abs=1e-4)
    # An orthographic viewport clips in front of and behind its eye (here from -50 to 50):
    # the eye moves back 50 along its view axis and the rays start there.
    window = Matrix(((0.25, 0, 0, 0), (0, 0.25, 0, 0), (0, 0, -2.0 / 100.0, 0), (0, 0, 0, 1)))
    request = viewport.view_request([list(r) for r in Matrix.Identity(4)],
                                    [list(r) for r in window], 100, 100)
    assert request["projection"] == "orthographic" and request["ymag"] == pytest.approx(4.0)
    assert request["clip"] == pytest.approx([0.0, 100.0])
    # Blender's eye at the origin looking down -Z moved back to z = 50: glTF's y = 50.
    m = np.array(request["camera_to_world"]).reshape(4, 4)
    assert m[:3, 3] == pytest.approx([0.0, 50.0, 0.0])


def test_depsgraph_updates_that_export_again(modules):
    engine, viewport = modules
    scene = scenes_bpy.default_scene()
    bpy.context.view_layer.update()  # the scene's own set-up is no update of the test's
    seen = []

    def record(_scene, depsgraph):
        seen.append(engine.update_kinds(depsgraph))

    bpy.app.handlers.depsgraph_update_post.append(record)
    try:
        def updates(change):
            seen.clear()
            change()
            bpy.context.view_layer.update()
            return [kind for kinds in seen for kind in kinds]

        moved_camera = updates(lambda: setattr(scene.camera, "location",
                                               scene.camera.location + Vector((0.5, 0, 0))))
        assert moved_camera, "moving the camera is a depsgraph update"
        assert not viewport.needs_export(moved_camera), moved_camera
        cube = bpy.data.objects["Cube"]
        selected = updates(lambda: cube.select_set(not cube.select_get()))
        assert not viewport.needs_export(selected), selected
        brighter = updates(lambda: setattr(bpy.data.lights["Light"], "energy", 500.0))
        assert viewport.needs_export(brighter), brighter
        moved_cube = updates(lambda: setattr(cube, "location", (0.5, 0.0, 0.0)))
        assert viewport.needs_export(moved_cube), moved_cube

        def recolour():
            bsdf = cube.active_material.node_tree.nodes["Principled BSDF"]
            bsdf.inputs["Base Color"].default_value = (0.8, 0.1, 0.1, 1.0)

        recoloured = updates(recolour)
        assert viewport.needs_export(recoloured), recoloured
    finally:
        bpy.app.handlers.depsgraph_update_post.remove(record)


def cube_column(frame):
    """The cube's mean column as a fraction of the width: the mean over pixels brighter than
    the grey world."""
    luminance = frame.pixels[..., :3].mean(axis=2)
    columns = np.nonzero(luminance > 0.15)[1]
    assert columns.size > 0, "the cube is in view"
    return (columns.mean() + 0.5) / frame.width


def wait_frame(session, request_id=None, final=False, seconds=FIRST_IMAGE_SECONDS):
    """The next image of the session's current view (of `request_id` if given; the last one
    with `final`), failing with the renderer's errors after `seconds`."""
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        session.latest()
        frame = session.frame
        if frame is not None and (request_id is None or frame.request == request_id):
            if not final or frame.request in session.finished:
                return frame
        if session.errors:
            pytest.fail(f"the session failed: {session.errors}")
        time.sleep(0.01)
    pytest.fail(f"no image within {seconds} s (errors: {session.errors})")


def test_rendered_viewport_session(modules):
    engine, viewport = modules
    scene = scenes_bpy.default_scene()
    scene.photon.viewport_samples = 8
    args = engine.runner.settings_arguments(engine.properties.viewport_settings(scene.photon))
    assert args[args.index("--spp") + 1] == "8"
    start = time.perf_counter()
    session = engine.new_view_session(args)
    try:
        engine.export_view_scene(scene, session)
        session.show(camera_request(viewport, scene))
        first = wait_frame(session)
        first_seconds = time.perf_counter() - start
        last = wait_frame(session, final=True)
        assert session.announced[0] == (1, WIDTH // 4, HEIGHT // 4, 1), "a quarter first"
        assert (last.width, last.height, last.spp) == (WIDTH, HEIGHT, 8)
        assert np.isfinite(last.pixels).all()
        centred = cube_column(last)
        assert 0.35 < centred < 0.65, f"the cube in the middle ({centred})"
        pid = session.proc.pid

        # The view moves right: the cube moves left, with no new export.
        moved = time.perf_counter()
        session.show(camera_request(viewport, scene, moved=(1.5, 0.0, 0.0)))
        restart = wait_frame(session, session.request_id)
        restart_seconds = time.perf_counter() - moved
        full = wait_frame(session, session.request_id, final=True)
        full_seconds = time.perf_counter() - moved
        assert session.exports == 1 and session.proc.pid == pid, "a view move exports nothing"
        left = cube_column(full)
        assert left < centred - 0.1, f"the cube moved left ({centred} -> {left})"
        assert cube_column(restart) < centred - 0.1

        # The cube moves (a depsgraph change): the scene is exported again, a new renderer
        # draws the current view, in which the cube is further left.
        bpy.data.objects["Cube"].location = (0.0, -1.5, 0.0)
        bpy.context.view_layer.update()
        exported = time.perf_counter()
        engine.export_view_scene(scene, session)
        session.wait_exported(FIRST_IMAGE_SECONDS)
        assert session.exports == 2 and session.proc.pid != pid
        again = wait_frame(session, session.request_id, final=True)
        export_seconds = time.perf_counter() - exported
        further = cube_column(again)
        assert abs(further - left) > 0.05, f"the moved cube is seen ({left} -> {further})"
        print(f"viewport, default cube {WIDTH}x{HEIGHT}, 8 spp: first image {first_seconds:.2f} s "
              f"after the session started (export included); after a view move first image "
              f"{restart_seconds:.3f} s, 8 spp {full_seconds:.3f} s; after an object move "
              f"(export + new renderer) 8 spp {export_seconds:.2f} s")
        assert first_seconds < FIRST_IMAGE_SECONDS
        assert restart_seconds < RESTART_SECONDS
    finally:
        proc = session.proc
        engine.close_views()
    assert proc is not None and proc.poll() is not None, "the renderer has ended"
    with pytest.raises(ProcessLookupError):
        os.kill(proc.pid, 0)  # waited for: no zombie left
    assert not session.folder.exists()
    assert session not in engine.VIEW_SESSIONS


def test_session_reports_failures_and_recovers(modules, tmp_path, binary):
    """A failed export and a scene the renderer refuses are reported in `errors` with their
    messages (nothing crashes, no image); the next good scene clears them and renders."""
    _, viewport = modules
    from blender_addon import runner
    session = viewport.ViewSession(binary, ["--method", "path", "--spp", "2"], tmp_path)
    cornell = (Path(__file__).resolve().parents[2] / "scenes" / "cornell_box.glb")
    request = {"width": 16, "height": 16, "projection": "perspective", "yfov": 0.686,
               "camera_to_world": [1, 0, 0, 0, 0, 1, 0, 2.775, 0, 0, 1, 10.775, 0, 0, 0, 1]}
    try:
        session.show(request)

        def fail():
            raise runner.PhotonError("glTF export failed: no such thing")

        session.rescene(fail, tmp_path / "never.glb")
        session.wait_exported(FIRST_IMAGE_SECONDS)
        assert session.errors == ["glTF export failed: no such thing"]
        broken = tmp_path / "broken.glb"
        broken.write_bytes(b"not a glb")
        session.rescene(lambda: None, broken)
        session.wait_exported(FIRST_IMAGE_SECONDS)
        end = time.perf_counter() + FIRST_IMAGE_SECONDS
        while not session.errors and time.perf_counter() < end:
            session.poll()
            time.sleep(0.01)
        # The new renderer cleared the export's error; its own failure is reported.
        assert len(session.errors) == 1, session.errors
        assert "photon view failed (exit code 2, bad input)" in session.errors[0], session.errors
        assert session.latest() is None
        session.rescene(lambda: None, cornell)
        session.wait_exported(FIRST_IMAGE_SECONDS)
        assert session.errors == []
        frame = wait_frame(session, final=True)
        assert (frame.width, frame.height, frame.spp) == (16, 16, 2)
    finally:
        session.close()
    assert session.proc is None


class ViewportEngine:
    """The engine's viewport methods on a stand-in for the RenderEngine Blender would make
    (one cannot be made from Python): it records the status lines and the redraws asked for."""

    def __init__(self, engine):
        cls = engine.PhotonRenderEngine
        self.methods = {name: getattr(cls, name) for name in
                        ("view_update", "_view_update", "view_draw", "__del__")}
        self.stats, self.redraws, self.updates_asked = [], 0, 0

    def __getattr__(self, name):
        method = self.__dict__["methods"].get(name)
        if method is None:
            raise AttributeError(name)
        return method.__get__(self)

    def update_stats(self, _stats, info):
        self.stats.append(info)

    def tag_redraw(self):
        self.redraws += 1

    def tag_update(self):
        self.updates_asked += 1


def test_view_update_and_view_draw(modules, monkeypatch):
    """The engine's `view_update` and `view_draw` (the GPU texture and the drawing, which
    background mode cannot do, replaced by recorders): the first update exports and starts a
    renderer, each draw sends the region's view and draws the newest image, redraws are asked
    for until the last image is in, an update without changes exports nothing, a changed
    Viewport Samples restarts the renderer, freeing the engine ends it."""
    engine, viewport = modules
    scene = scenes_bpy.default_scene()
    scene.photon.viewport_samples = 4
    drawn = []
    monkeypatch.setattr(engine, "_texture", lambda frame: frame)
    monkeypatch.setattr(engine, "_draw", lambda _engine, _scene, frame, width, height:
                        drawn.append((frame.request, frame.width, frame.spp, width, height)))
    depsgraph = bpy.context.evaluated_depsgraph_get()
    camera = scene.camera
    region_data = types.SimpleNamespace(
        view_matrix=camera.matrix_world.inverted(),
        window_matrix=camera.calc_matrix_camera(depsgraph, x=WIDTH, y=HEIGHT))
    context = types.SimpleNamespace(region=types.SimpleNamespace(width=WIDTH, height=HEIGHT),
                                    region_data=region_data)
    cls = engine.PhotonRenderEngine
    assert cls.bl_use_eevee_viewport, "Material Preview stays EEVEE's, as with Cycles"
    assert "view_draw" in cls.__dict__ and "view_update" in cls.__dict__
    fake = ViewportEngine(engine)
    fake.view_update(context, depsgraph)
    session = fake._view
    assert session.exports == 1, fake.stats

    def draw_until_done():
        end = time.perf_counter() + FIRST_IMAGE_SECONDS
        while time.perf_counter() < end:
            redraws = fake.redraws
            fake.view_draw(context, depsgraph)
            if drawn and fake.redraws == redraws:
                return  # no redraw asked for: the view's last image is in
            time.sleep(0.01)
        pytest.fail(f"the view did not finish (status: {fake.stats[-3:]})")

    draw_until_done()
    assert drawn[-1] == (session.request_id, WIDTH, 4, WIDTH, HEIGHT), drawn
    assert fake.stats[-1] == "Photon: 4 samples"
    sent = session.request_id
    fake.view_draw(context, depsgraph)
    assert session.request_id == sent, "an unchanged view is not sent again"
    fake.view_update(context, depsgraph)
    assert session.exports == 1, "no change, no export"
    pid = session.proc.pid
    # Two changes while the first one's export runs: one export for both, once it ends.
    scene.photon.viewport_samples = 3
    fake.view_update(context, depsgraph)
    scene.photon.viewport_samples = 2
    fake.view_update(context, depsgraph)
    assert session.exports == 2 and session.stale
    session.wait_exported(FIRST_IMAGE_SECONDS)
    fake.view_draw(context, depsgraph)
    assert fake.updates_asked == 1, "the draw asks Blender for a view_update"
    fake.view_update(context, depsgraph)
    assert session.exports == 3 and not session.stale
    session.wait_exported(FIRST_IMAGE_SECONDS)
    assert session.proc.pid != pid
    draw_until_done()
    assert drawn[-1][2] == 2, drawn
    proc = session.proc
    # Freed while an export runs: the export's background process is stopped too.
    bpy.data.objects["Cube"].location = (0.0, 0.0, 0.5)
    scene.photon.viewport_samples = 1
    fake.view_update(context, depsgraph)
    assert session.exporting()
    fake.__del__()
    assert proc.poll() is not None and session not in engine.VIEW_SESSIONS
    session.wait_exported(2.0)
    assert not session.exporting(), "the export stopped within a poll of its process"
    assert session.proc is None, "no renderer started after the close"


@pytest.mark.slow
@pytest.mark.parametrize("grid", [0, 709], ids=["cube", "million"])
def test_rendered_viewport_latency(modules, grid):
    """Latencies at a common viewport size, 800x450, for the default scene and for it over a
    grid of 1 005 362 triangles: the first image (export included) and the first image after
    a view move, printed for docs/bench/viewport.md."""
    engine, viewport = modules
    width, height = 800, 450
    scene = scenes_bpy.default_scene()
    if grid:
        bpy.ops.mesh.primitive_grid_add(x_subdivisions=grid, y_subdivisions=grid, size=8.0,
                                        location=(0.0, 0.0, -1.0))
    triangles = sum(len(p.vertices) - 2 for o in scene.objects if o.type == "MESH"
                    for p in o.data.polygons)
    scene.photon.viewport_samples = 4
    args = engine.runner.settings_arguments(engine.properties.viewport_settings(scene.photon))
    start = time.perf_counter()
    session = engine.new_view_session(args)
    try:
        engine.export_view_scene(scene, session)
        session.show(camera_request(viewport, scene, width, height))
        wait_frame(session, seconds=300.0)
        first_seconds = time.perf_counter() - start
        wait_frame(session, final=True, seconds=300.0)
        moved = time.perf_counter()
        session.show(camera_request(viewport, scene, width, height, moved=(0.5, 0.0, 0.0)))
        wait_frame(session, session.request_id)
        restart_seconds = time.perf_counter() - moved
        full = wait_frame(session, session.request_id, final=True, seconds=300.0)
        full_seconds = time.perf_counter() - moved
        timing = session.timings[session.request_id]
        print(f"viewport, {triangles} triangles, {width}x{height}, 4 spp: first image "
              f"{first_seconds:.2f} s after the session started (export included); after a view "
              f"move: first image {restart_seconds:.3f} s, first full-size image "
              f"{timing.get('full', float('nan')):.3f} s, 4 spp {full_seconds:.2f} s")
        assert full.spp == 4
        assert restart_seconds < RESTART_SECONDS
    finally:
        engine.close_views()
