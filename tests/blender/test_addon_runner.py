"""blender_addon/runner.py without bpy: binary lookup order and the missing-binary message,
error messages from a failing renderer, progress parsing, cancellation within a second, the
temporary folder always removed, and reading EXR channel names.
"""

import time

import numpy as np
import pytest

from addon import fake_binary, load_runner

runner = load_runner()
NAME = runner.BINARY_NAME


@pytest.fixture
def places(tmp_path):
    """Four candidate binaries, one per lookup place."""
    made = {}
    for place in ("prefs", "env", "addon", "path"):
        target = (runner.addon_binary(tmp_path / "addon") if place == "addon"
                  else tmp_path / place / NAME)
        made[place] = fake_binary(target, "sys.exit(0)\n")
    return made


def test_lookup_order(places, tmp_path):
    addon_dir = tmp_path / "addon"
    path_env = str(places["path"].parent)
    env = {"PHOTON_BINARY": str(places["env"]), "PATH": path_env}
    assert runner.find_binary(str(places["prefs"]), addon_dir, env) == places["prefs"]
    assert runner.find_binary("", addon_dir, env) == places["env"]
    assert runner.find_binary("", addon_dir, {"PATH": path_env}) == places["addon"]
    assert runner.find_binary(None, tmp_path / "elsewhere", {"PATH": path_env}) == places["path"]


def test_missing_binary_message_names_every_place(tmp_path):
    with pytest.raises(runner.PhotonError) as err:
        runner.find_binary("", tmp_path / "addon", {"PATH": str(tmp_path / "empty")})
    text = str(err.value)
    for place in ("preferences", "PHOTON_BINARY", str(runner.addon_binary(tmp_path / "addon")),
                  "PATH"):
        assert place in text, text


def test_set_but_broken_place_is_an_error(tmp_path, places):
    missing = tmp_path / "nowhere" / NAME
    with pytest.raises(runner.PhotonError, match="preferences.*not an executable"):
        runner.find_binary(str(missing), tmp_path / "addon", {})
    with pytest.raises(runner.PhotonError, match="PHOTON_BINARY.*not an executable"):
        runner.find_binary("", tmp_path / "addon", {"PHOTON_BINARY": str(missing)})


def test_progress_and_stats(tmp_path):
    binary = fake_binary(tmp_path / NAME, """
        emit(stage="load", fraction=0.0, message="loading scene")
        print("not json", file=sys.stderr)
        emit(stage="load", fraction=1.0, warning="material 'X': texture missing")
        emit(stage="render", fraction=0.5, message="tiles")
        emit(stage="done", fraction=1.0, message="wrote", stats={"spp": 4, "rays": 10})
        """)
    events = []
    stats = runner.run([str(binary)], events.append, lambda: False)
    assert [e["stage"] for e in events] == ["load", "load", "render", "done"]
    assert events[1]["warning"].startswith("material")
    assert stats == {"spp": 4, "rays": 10}


def test_error_message_reaches_the_caller(tmp_path):
    binary = fake_binary(tmp_path / NAME, """
        emit(stage="load", fraction=0.0, message="loading scene")
        print("photon: error: scene.glb: node 'Cube': accessor 3 is out of range", file=sys.stderr)
        sys.exit(2)
        """)
    events = []
    with pytest.raises(runner.PhotonError) as err:
        runner.run([str(binary)], events.append, lambda: False)
    text = str(err.value)
    assert "exit code 2, bad input" in text
    assert "scene.glb: node 'Cube': accessor 3 is out of range" in text
    assert events and events[0]["stage"] == "load"


def test_crash_without_message_shows_the_tail(tmp_path):
    binary = fake_binary(tmp_path / NAME, """
        print("thread 'main' panicked at src/x.rs:1", file=sys.stderr)
        sys.exit(101)
        """)
    with pytest.raises(runner.PhotonError, match="(?s)exit code 101.*panicked"):
        runner.run([str(binary)], None, None)


def test_cannot_start(tmp_path):
    with pytest.raises(runner.PhotonError, match="cannot start photon"):
        runner.run([str(tmp_path / "no_such_binary")], None, None)


@pytest.mark.parametrize("ignores_sigterm", [False, True])
def test_cancel_ends_within_a_second_and_leaves_nothing(tmp_path, ignores_sigterm):
    body = """
        if IGNORE:
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
        open(sys.argv[1], "w").write("partial")
        emit(stage="render", fraction=0.1, message="tiles")
        time.sleep(60)
        """.replace("IGNORE", str(ignores_sigterm))
    binary = fake_binary(tmp_path / NAME, body)
    events, folder, elapsed = [], None, None
    with pytest.raises(runner.Cancelled):
        with runner.temporary_folder() as folder:
            out = folder / "render.exr"
            t0 = None

            def cancel():
                nonlocal t0
                if events and t0 is None:
                    t0 = time.perf_counter()
                return t0 is not None

            try:
                runner.run([str(binary), str(out)], events.append, cancel)
            finally:
                elapsed = time.perf_counter() - t0 if t0 else None
    assert elapsed is not None and elapsed < 1.0, f"cancel took {elapsed} s"
    assert not folder.exists(), f"{folder} left behind: {list(folder.iterdir())}"


def test_temporary_folder_removed_on_error():
    with pytest.raises(RuntimeError):
        with runner.temporary_folder() as folder:
            (folder / "scene.glb").write_bytes(b"x")
            raise RuntimeError("boom")
    assert not folder.exists()


def flag_values(cmd):
    """{flag: value} for the `--flag value` pairs of a command line (value None for a bare flag)."""
    out = {}
    for i, arg in enumerate(cmd):
        if arg.startswith("--"):
            nxt = cmd[i + 1] if i + 1 < len(cmd) else None
            out[arg] = None if nxt is None or nxt.startswith("--") else nxt
    return out


def test_render_command():
    settings = runner.RenderSettings(samples=16, max_bounces=8, seed=3, threads=2)
    cmd = runner.render_command("photon", "s.glb", "o.exr", width=64, height=36,
                                settings=settings, camera="Camera", view_layer="ViewLayer")
    assert cmd[:3] == ["photon", "render", "s.glb"]
    flags = flag_values(cmd)
    for flag, value in (("--width", "64"), ("--height", "36"), ("--spp", "16"),
                        ("--max-depth", "8"), ("--seed", "3"), ("--threads", "2"),
                        ("--progress", "json"), ("--camera", "Camera"),
                        ("--exr-layer", "ViewLayer"), ("--method", "auto"),
                        ("--quality", "default"), ("--gather-rays", "4")):
        assert flags[flag] == value, (flag, cmd)
    assert "--passes" not in cmd
    cmd = runner.render_command("photon", "s.glb", "o.exr", width=64, height=36,
                                settings=settings, view_layer="ViewLayer", passes=True)
    assert "--passes" in cmd


def test_settings_arguments_defaults_leave_choices_to_the_renderer():
    """Zero samples, no time limit, preset photon counts and the default irradiance-cache choice
    are not passed, so the quality preset and the renderer's defaults apply."""
    flags = flag_values(runner.settings_arguments(runner.RenderSettings()))
    for flag in ("--spp", "--time-limit", "--photons", "--caustic-photons",
                 "--irradiance-cache", "--ic-accuracy"):
        assert flag not in flags, flag
    assert flags["--method"] == "auto" and flags["--quality"] == "default"


def test_settings_arguments_map_every_setting():
    settings = runner.RenderSettings(
        method="photon", quality="final", samples=5, time_limit=2.5, max_bounces=7, seed=9,
        threads=3, custom_photons=True, photons=1234, caustic_photons=0, gather_rays=16,
        irradiance_cache="on", ic_accuracy=0.25)
    flags = flag_values(runner.settings_arguments(settings))
    assert flags == {"--method": "photon", "--quality": "final", "--spp": "5",
                     "--time-limit": "2.5", "--max-depth": "7", "--seed": "9", "--threads": "3",
                     "--photons": "1234", "--caustic-photons": "0", "--gather-rays": "16",
                     "--irradiance-cache": "on", "--ic-accuracy": "0.25"}
    off = runner.settings_arguments(runner.RenderSettings(irradiance_cache="off"))
    assert flag_values(off)["--irradiance-cache"] == "off" and "--ic-accuracy" not in off


def test_exr_channels(tmp_path):
    import OpenEXR
    path = tmp_path / "t.exr"
    plane = np.zeros((2, 3), np.float32)
    names = ["ViewLayer.Combined.R", "ViewLayer.Combined.G", "ViewLayer.Depth.Z"]
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
              "photon.samples": "0-4,8-12 seed 7", "other": "x"}
    with OpenEXR.File(header, {n: plane for n in names}) as f:
        f.write(str(path))
    assert sorted(runner.exr_channels(path)) == sorted(names)
    assert runner.exr_text_attributes(path, "photon.") == {
        "photon.samples": "0-4,8-12 seed 7"}
    (tmp_path / "bad.exr").write_bytes(b"not an exr at all")
    with pytest.raises(runner.PhotonError, match="not an OpenEXR"):
        runner.exr_channels(tmp_path / "bad.exr")


SERVER = """
    for line in sys.stdin:
        request = json.loads(line)
        if request["frame"] == 3:
            emit(stage="export", error="frame 3 cannot be exported")
            continue
        if request["frame"] == 4:
            print("error: the server crashed", file=sys.stderr, flush=True)
            sys.exit(1)
        if request["frame"] == 5:
            time.sleep(60)
        emit(stage="export", warning=f"frame {request['frame']}: something dropped")
        emit(stage="export", exported=request["frame"])
"""


def test_server_answers_requests_in_one_process(tmp_path):
    """runner.Server (the background Blender exporting an animation's frames): each request
    gets its answer, warnings go to on_event, an error answer raises PhotonError and the
    server goes on; a crash raises PhotonError with the child's message."""
    server = runner.Server([str(fake_binary(tmp_path / "server", SERVER))], what="export")
    events = []
    try:
        for frame in (1, 2):
            answer = server.request({"frame": frame}, "exported", events.append)
            assert answer["exported"] == frame
        assert [e["warning"] for e in events] == ["frame 1: something dropped",
                                                  "frame 2: something dropped"]
        with pytest.raises(runner.PhotonError, match="frame 3 cannot be exported"):
            server.request({"frame": 3}, "exported")
        assert server.alive()
        assert server.request({"frame": 1}, "exported")["exported"] == 1
        with pytest.raises(runner.PhotonError, match="the server crashed"):
            server.request({"frame": 4}, "exported")
        assert not server.alive()
    finally:
        server.close()


def test_server_cancel_and_close(tmp_path):
    """Cancelling a request ends the child within a second; close() ends an idle child."""
    server = runner.Server([str(fake_binary(tmp_path / "server", SERVER))], what="export")
    t0 = time.monotonic()
    with pytest.raises(runner.Cancelled):
        server.request({"frame": 5}, "exported", None, lambda: time.monotonic() - t0 > 0.3)
    assert time.monotonic() - t0 < 1.5
    assert not server.alive()
    idle = runner.Server([str(fake_binary(tmp_path / "idle", SERVER))], what="export")
    assert idle.alive()
    idle.close()
    assert not idle.alive()
