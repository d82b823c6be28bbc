"""Running the photon binary: finding it, building its command line, polling it, cancelling it.

No bpy here, so this module is tested on its own. The engine calls `find_binary`, then `run`
with two callbacks: `on_event(dict)` for every JSON progress line the renderer prints on stderr
and `should_cancel()` (the engine's `test_break`). `run` polls the child several times a second;
on cancel it terminates the child, waits briefly, then kills it, and raises `Cancelled`. A
non-zero exit raises `PhotonError` whose message is the renderer's own error line (or the tail of
its stderr). `temporary_folder()` gives the folder for the scene and the image, removed always.
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import json
import os
import queue
import shutil
import struct
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

BINARY_NAME = "photon.exe" if sys.platform == "win32" else "photon"
ENV_VAR = "PHOTON_BINARY"
POLL_SECONDS = 0.1
KILL_AFTER_SECONDS = 0.5
TAIL_LINES = 30


class PhotonError(Exception):
    """Something the user must fix or know about; the message is meant to be shown as is."""


class Cancelled(Exception):
    """The user cancelled; the child process has ended."""


def addon_binary(addon_dir: Path) -> Path:
    """Where the packaged binary lives inside the add-on folder."""
    return Path(addon_dir) / "bin" / BINARY_NAME


def find_binary(preference_path: str | None, addon_dir: Path, environ=None) -> Path:
    """The photon executable: the add-on preference, then $PHOTON_BINARY, then the add-on's
    bin/ folder, then `photon` on PATH. A place that is set but unusable is an error (it is never
    skipped silently); nothing found is an error naming every place looked at."""
    environ = os.environ if environ is None else environ
    for origin, value in (("the add-on preferences (Photon > Binary)", preference_path),
                          (f"the {ENV_VAR} environment variable", environ.get(ENV_VAR))):
        if value:
            path = Path(value).expanduser()
            if not _is_executable(path):
                raise PhotonError(
                    f"the photon binary '{path}' set in {origin} is not an executable file")
            return path
    packaged = addon_binary(addon_dir)
    if packaged.is_file() and not _is_executable(packaged):
        _make_executable(packaged)  # zip extraction may drop the executable bit
    if _is_executable(packaged):
        return packaged
    on_path = shutil.which(BINARY_NAME, path=environ.get("PATH", os.defpath))
    if on_path:
        return Path(on_path)
    raise PhotonError(
        "the photon binary was not found. Looked in: "
        "the add-on preferences (Photon > Binary, not set); "
        f"the {ENV_VAR} environment variable (not set); the add-on folder ({packaged}); "
        f"'{BINARY_NAME}' on PATH. Build it with 'cargo build --release' and set one of these.")


def _is_executable(path: Path) -> bool:
    return path.is_file() and os.access(path, os.X_OK)


def _make_executable(path: Path):
    try:
        path.chmod(path.stat().st_mode | 0o111)
    except OSError:
        pass


@dataclasses.dataclass
class RenderSettings:
    """The render settings as plain data, with the add-on's defaults; `scene.photon` (properties.py)
    maps onto it one to one and `settings_arguments` onto the renderer's flags. Zero means "the
    renderer decides" where it says so."""

    method: str = "auto"          # --method auto | path | photon (auto: the renderer's planner)
    quality: str = "default"      # --quality preview | default | final
    samples: int = 0              # --spp; 0: from the quality preset (or as many as --time-limit fits)
    time_limit: float = 0.0       # --time-limit in seconds; 0: none
    max_bounces: int = 32         # --max-depth
    seed: int = 0                 # --seed
    threads: int = 0              # --threads; 0: one per core
    custom_photons: bool = False  # pass the two photon counts below instead of the preset's
    photons: int = 200_000        # --photons (global map)
    caustic_photons: int = 100_000  # --caustic-photons (0 skips the caustic map)
    gather_rays: int = 4          # --gather-rays (final-gather rays per shading point)
    irradiance_cache: str = "default"  # 'default' (the renderer's choice), 'on' or 'off'
    ic_accuracy: float = 0.15     # --ic-accuracy (Ward's a), passed with --irradiance-cache on


def animated_seed(seed: int, frame: int, subframe: float = 0.0) -> int:
    """A seed for `frame` (and `subframe`) of an animation from the scene's `seed`: a 64-bit
    mix (SplitMix64's finaliser, Steele, Lea & Flood 2014) of the three, so neighbouring frames
    get unrelated seeds and the same frame always the same one."""
    mask = (1 << 64) - 1

    def mix(x):
        x = (x + 0x9E3779B97F4A7C15) & mask
        x = ((x ^ (x >> 30)) * 0xBF58476D1CE4E5B9) & mask
        x = ((x ^ (x >> 27)) * 0x94D049BB133111EB) & mask
        return x ^ (x >> 31)

    value = mix(mix(seed & mask) ^ (frame & mask))
    if subframe:
        value = mix(value ^ round(subframe * (1 << 32)))
    return value


def settings_arguments(settings: RenderSettings) -> list[str]:
    """The `photon render` flags for `settings`. Values that mean "the renderer decides" are left
    out, so the renderer's own defaults and planner apply."""
    s = settings
    args = ["--method", s.method, "--quality", s.quality, "--max-depth", str(s.max_bounces),
            "--seed", str(s.seed), "--threads", str(s.threads), "--gather-rays", str(s.gather_rays)]
    if s.samples > 0:
        args += ["--spp", str(s.samples)]
    if s.time_limit > 0:
        args += ["--time-limit", f"{s.time_limit:g}"]
    if s.custom_photons:
        args += ["--photons", str(s.photons), "--caustic-photons", str(s.caustic_photons)]
    if s.irradiance_cache == "on":
        args += ["--irradiance-cache", "on", "--ic-accuracy", f"{s.ic_accuracy:g}"]
    elif s.irradiance_cache == "off":
        args += ["--irradiance-cache", "off"]
    return args


def render_command(binary, scene, output, *, width, height, settings: RenderSettings,
                   camera=None, view_layer=None, region=None, passes=False,
                   adaptive=None, sample_offset=0) -> list[str]:
    """The `photon render` command line for one frame, with JSON progress on stderr. `region`
    is (x0, y0, x1, y1) in full-frame pixels from the top-left, x1 and y1 exclusive; `passes`
    adds the light passes to the view layer's EXR; `adaptive` is adaptive sampling's (noise
    threshold, min samples), 0 meaning automatic for either, or None for none; `sample_offset`
    the first sample of the pixels' sequence to render (Cycles' Sample Offset)."""
    cmd = [str(binary), "render", str(scene), "-o", str(output),
           "--width", str(width), "--height", str(height), *settings_arguments(settings),
           "--progress", "json"]
    if camera:
        cmd += ["--camera", camera]
    if view_layer:
        cmd += ["--exr-layer", view_layer]
    if region:
        cmd += ["--region", *(str(v) for v in region)]
    if passes and view_layer:
        cmd += ["--passes"]
    if adaptive is not None:
        threshold, min_samples = adaptive
        cmd += ["--adaptive-threshold", f"{threshold:g}", "--adaptive-min-samples",
                str(min_samples)]
    if sample_offset > 0:
        cmd += ["--sample-offset", str(sample_offset)]
    return cmd


def merge_command(binary, output, inputs) -> list[str]:
    """The `photon merge` command line: `inputs` (renders of disjoint sample ranges of one
    frame) averaged by their sample counts into `output`."""
    return [str(binary), "merge", str(output), *(str(p) for p in inputs)]


def border_region(width, height, min_x, max_x, min_y, max_y):
    """Blender's render border (fractions of the frame, origin at the bottom-left) as a pixel
    window (x0, y0, x1, y1) from the top-left, x1 and y1 exclusive; never empty."""
    x0 = min(max(round(min_x * width), 0), width - 1)
    x1 = min(max(round(max_x * width), x0 + 1), width)
    y0 = min(max(round((1.0 - max_y) * height), 0), height - 1)
    y1 = min(max(round((1.0 - min_y) * height), y0 + 1), height)
    return x0, y0, x1, y1


@contextlib.contextmanager
def temporary_folder():
    """A fresh folder for one render, removed with everything in it however the block ends."""
    folder = tempfile.mkdtemp(prefix="photon_")
    try:
        yield Path(folder)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def run(command, on_event=None, should_cancel=None, *, what="photon", cwd=None,
        poll_seconds=POLL_SECONDS) -> dict:
    """Run `command`, feed its JSON stderr lines to `on_event`, and return the final `stats`
    (empty if it printed none). Raises `Cancelled` when `should_cancel()` turns true and
    `PhotonError` when the process cannot start or exits with a non-zero code."""
    try:
        proc = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE, cwd=cwd)
    except OSError as exc:
        raise PhotonError(f"cannot start {what} ({command[0]}): {exc.strerror or exc}") from None
    lines: queue.Queue = queue.Queue()
    reader = threading.Thread(target=_read_lines, args=(proc.stderr, lines), daemon=True)
    reader.start()
    tail = collections.deque(maxlen=TAIL_LINES)
    stats: dict = {}
    try:
        while True:
            finished = proc.poll() is not None
            if finished:
                reader.join(timeout=2.0)
            _drain(lines, tail, stats, on_event)
            if finished:
                break
            if should_cancel is not None and should_cancel():
                _stop(proc)
                raise Cancelled()
            time.sleep(poll_seconds)
    except BaseException:
        if proc.poll() is None:
            _stop(proc)
        raise
    finally:
        proc.stderr.close()
    if proc.returncode != 0:
        raise PhotonError(_failure_message(what, proc.returncode, tail))
    return stats


class Server:
    """A child process that answers requests: one JSON line on its stdin each, answered by JSON
    progress lines on its stderr, the last one holding `done_key` (or `error`). Used for the
    background Blender that exports every frame of an animation (export.py --serve). It ends
    when its stdin closes (also when this process dies)."""

    def __init__(self, command, *, what="server", cwd=None):
        self.what = what
        try:
            self.proc = subprocess.Popen(command, stdin=subprocess.PIPE,
                                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                         cwd=cwd)
        except OSError as exc:
            raise PhotonError(f"cannot start {what} ({command[0]}): "
                              f"{exc.strerror or exc}") from None
        self.lines: queue.Queue = queue.Queue()
        self.tail = collections.deque(maxlen=TAIL_LINES)
        threading.Thread(target=_read_lines, args=(self.proc.stderr, self.lines),
                         daemon=True).start()

    def alive(self) -> bool:
        return self.proc.poll() is None

    def request(self, message: dict, done_key: str, on_event=None, should_cancel=None, *,
                poll_seconds=POLL_SECONDS) -> dict:
        """Send `message` and return the answer's last event (the one holding `done_key`);
        other events go to `on_event`. Raises PhotonError when the answer is an error or the
        child ends, Cancelled (after ending the child) when `should_cancel()` turns true."""
        try:
            self.proc.stdin.write((json.dumps(message) + "\n").encode())
            self.proc.stdin.flush()
        except OSError:
            pass  # the child has ended: reported below with its output
        while True:
            finished = self.proc.poll() is not None
            while True:
                try:
                    line = self.lines.get(timeout=0.0 if not finished else 0.5)
                except queue.Empty:
                    break
                event = _parse_event(line)
                if event is None:
                    if line.strip():
                        self.tail.append(line)
                    continue
                if done_key in event:
                    return event
                if "error" in event:
                    raise PhotonError(f"{self.what} failed: {event['error']}")
                if on_event is not None:
                    on_event(event)
            if finished:
                code = self.proc.returncode
                raise PhotonError(_failure_message(self.what, code, self.tail))
            if should_cancel is not None and should_cancel():
                self.close()
                raise Cancelled()
            time.sleep(poll_seconds)

    def close(self):
        """End the child: close its stdin (it exits), then terminate or kill it if needed."""
        try:
            self.proc.stdin.close()
        except OSError:
            pass
        try:
            self.proc.wait(timeout=KILL_AFTER_SECONDS)
        except subprocess.TimeoutExpired:
            _stop(self.proc)


def _read_lines(stream, lines: queue.Queue):
    for raw in stream:
        lines.put(raw.decode("utf-8", errors="replace").rstrip("\r\n"))


def _drain(lines: queue.Queue, tail, stats: dict, on_event):
    while True:
        try:
            line = lines.get_nowait()
        except queue.Empty:
            return
        event = _parse_event(line)
        if event is None:
            if line.strip():
                tail.append(line)
            continue
        if "warning" in event:
            tail.append(f"warning: {event['warning']}")
        if isinstance(event.get("stats"), dict):
            stats.update(event["stats"])
        if on_event is not None:
            on_event(event)


def _parse_event(line: str):
    if not line.startswith("{"):
        return None
    try:
        event = json.loads(line)
    except ValueError:
        return None
    return event if isinstance(event, dict) and "stage" in event else None


def _stop(proc: subprocess.Popen):
    """Terminate, wait briefly, then kill."""
    proc.terminate()
    try:
        proc.wait(timeout=KILL_AFTER_SECONDS)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


EXIT_MEANING = {1: "internal failure", 2: "bad input", 130: "cancelled"}


def _failure_message(what: str, code: int, tail) -> str:
    errors = [line.split("error:", 1)[1].strip() for line in tail if "error:" in line]
    if code < 0:
        meaning = f"killed by signal {-code}"
    else:
        meaning = f"exit code {code}" + (f", {EXIT_MEANING[code]}" if code in EXIT_MEANING else "")
    if errors:
        return f"{what} failed ({meaning}): " + "; ".join(errors)
    detail = "\n".join(tail) if tail else "(no output)"
    return f"{what} failed ({meaning}). Last output:\n{detail}"


def _exr_header(path) -> dict[str, tuple[str, bytes]]:
    """The attributes of a single-part OpenEXR file's header, name -> (type, raw value), from its
    first 64 KiB (raises PhotonError if the file is not an OpenEXR file)."""
    try:
        with open(path, "rb") as f:
            data = f.read(1 << 16)
    except OSError as exc:
        raise PhotonError(f"cannot read the image {path}: {exc.strerror}") from None
    if len(data) < 8 or struct.unpack_from("<I", data, 0)[0] != 20000630:
        raise PhotonError(f"the image {path} is not an OpenEXR file")
    attributes, pos = {}, 8
    while pos < len(data) and data[pos] != 0:
        name, pos = _cstring(data, pos)
        kind, pos = _cstring(data, pos)
        (size,) = struct.unpack_from("<i", data, pos)
        pos += 4
        attributes[name] = (kind, data[pos:pos + size])
        pos += size
    return attributes


def exr_channels(path) -> list[str]:
    """Channel names in the header of a single-part OpenEXR file (raises PhotonError if the file
    is not one). Used to check the renderer's image before Blender loads it, because Blender's
    loader silently loads nothing when the names do not match."""
    kind, value = _exr_header(path).get("channels", ("", b""))
    if kind != "chlist":
        raise PhotonError(f"the rendered image {path} has no channel list")
    channels, p = [], 0
    while p < len(value) and value[p] != 0:
        chan, p = _cstring(value, p)
        channels.append(chan)
        p += 16
    return channels


def exr_text_attributes(path, prefix: str = "") -> dict[str, str]:
    """The text attributes of an OpenEXR file's header whose names start with `prefix`: the
    renderer's samples (`photon.samples`: "0-16 seed 1")."""
    return {name: value.decode("utf-8", errors="replace")
            for name, (kind, value) in _exr_header(path).items()
            if kind == "string" and name.startswith(prefix)}


def _cstring(data: bytes, pos: int):
    end = data.index(b"\0", pos)
    return data[pos:end].decode("utf-8", errors="replace"), end + 1
