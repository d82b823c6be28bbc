"""The Rendered viewport's session: the `photon view` process, the views sent to it, the latest
image it wrote, and a new process when the scene is exported again.

No bpy here (as runner.py), so tests drive it without a window. The engine (engine.py) calls
`view_request` to turn Blender's viewport matrices into a request, `ViewSession.show` with it
on every redraw (only a changed view is sent: the renderer then drops the image it was working
on and starts on the new view), `ViewSession.rescene` when the depsgraph reports a change other
than the view (the export runs in a thread, then a new renderer starts on the new scene and is
sent the current view; the engine runs one export at a time, marking the session `stale` for
changes made meanwhile), `ViewSession.latest` to get an image not drawn yet, and
`ViewSession.close` when the viewport leaves Rendered mode or the engine is freed.

The renderer's protocol (its README section "Interactive rendering"): a JSON request per line
on stdin; JSON events on stderr; each image replaces one file: a 24-byte header (`PHVW`,
width, height, samples per pixel as little-endian u32, the request id as u64), then RGBA
float32 rows from the bottom up, as a GPU texture is filled. Coordinates: Blender's world is
Z-up, the exported glTF Y-up (x, z, -y), so the view's camera-to-world matrix is converted.
"""

from __future__ import annotations

import collections
import dataclasses
import json
import math
import os
import queue
import struct
import subprocess
import threading
import time
from pathlib import Path

import numpy as np

from . import runner

HEADER = struct.Struct("<4sIIIQ")
MAGIC = b"PHVW"
# Blender's world (Z up) to the exported glTF's (Y up): (x, y, z) -> (x, z, -y).
Z_UP_TO_Y_UP = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0],
                         [0.0, 0.0, 0.0, 1.0]])
# Object types whose transform changes nothing in the exported scene seen from the viewport.
VIEW_ONLY_OBJECTS = ("CAMERA",)


@dataclasses.dataclass
class Frame:
    """One image of the renderer: `pixels` holds width × height × 4 float32, bottom row first."""

    request: int
    width: int
    height: int
    spp: int
    pixels: np.ndarray


def view_request(view_matrix, window_matrix, width: int, height: int) -> dict:
    """The `photon view` request (without its id) for a viewport of `width` × `height` pixels
    whose world-to-view matrix and projection matrix (Blender's `region_data.view_matrix` and
    `window_matrix`, rows of 4) are given. Perspective or orthographic is read from the
    projection's last row; the field of view (or the half-height), the lens shift (an offset
    of the view window, as in a camera view) and the clip planes from its entries."""
    view = np.array(view_matrix, dtype=float).reshape(4, 4)
    p = np.array(window_matrix, dtype=float).reshape(4, 4)
    to_world = np.linalg.inv(view)
    perspective = abs(p[3][3]) < 0.5
    if perspective:
        near, far = p[2][3] / (p[2][2] - 1.0), p[2][3] / (p[2][2] + 1.0)
        request = {"projection": "perspective", "yfov": 2.0 * math.atan(1.0 / p[1][1]),
                   "shift": [p[0][2] * p[1][1] / (2.0 * p[0][0]), p[1][2] / 2.0]}
    else:
        depth = -2.0 / p[2][2]
        near = (-p[2][3] * depth - depth) / 2.0
        far = near + depth
        request = {"projection": "orthographic", "ymag": 1.0 / p[1][1],
                   "shift": [-p[0][3] / p[0][0] * p[1][1] / 2.0, -p[1][3] / 2.0]}
        if near < 0.0:
            # Blender's orthographic view clips in front of and behind its eye: start the rays
            # on the near plane by moving the eye back along its view axis.
            back = np.eye(4)
            back[2][3] = -near  # the near plane lies at z = -near in the eye's frame
            to_world = to_world @ back
            near, far = 0.0, far - near
    world = Z_UP_TO_Y_UP @ to_world
    world[3] = (0.0, 0.0, 0.0, 1.0)  # exactly, whatever the inverse's rounding
    request.update(width=int(width), height=int(height),
                   camera_to_world=[float(v) for v in world.reshape(16)],
                   clip=[max(float(near), 0.0), float(far)])
    return request


def needs_export(updates) -> bool:
    """Whether depsgraph updates (id type, object type or None, geometry, shading, transform)
    change the exported scene: anything but a camera's transform does. The viewport's own view
    is no depsgraph update at all."""
    for id_type, object_type, geometry, shading, transform in updates:
        if id_type == "OBJECT" and object_type in VIEW_ONLY_OBJECTS:
            continue
        if geometry or shading or transform:
            return True
    return False


def view_command(binary, glb, image, settings_args) -> list[str]:
    """The `photon view` command line."""
    return [str(binary), "view", str(glb), "-o", str(image), *settings_args, "--progress", "json"]


def image_version(path):
    """What tells one image file from the next (each is a new file renamed into place), or
    None while there is none."""
    try:
        stat = os.stat(path)
    except OSError:
        return None
    return stat.st_ino, stat.st_mtime_ns, stat.st_size


def read_frame(path) -> Frame | None:
    """The image file the renderer wrote last, or None while there is none or it is not whole."""
    try:
        data = Path(path).read_bytes()
    except OSError:
        return None
    if len(data) < HEADER.size:
        return None
    magic, width, height, spp, request = HEADER.unpack_from(data)
    if magic != MAGIC or len(data) != HEADER.size + width * height * 16:
        return None
    pixels = np.frombuffer(data, dtype="<f4", offset=HEADER.size).reshape(height, width, 4)
    return Frame(request, width, height, spp, pixels)


class ViewSession:
    """The renderer behind one Rendered viewport. `binary` is the photon executable,
    `settings_args` its render flags (runner.settings_arguments: method, viewport samples, ...),
    `folder` where the scene and the image live (the caller removes it)."""

    def __init__(self, binary, settings_args, folder):
        self.binary = binary
        self.settings_args = list(settings_args)
        self.folder = Path(folder)
        self.image = self.folder / "view.raw"
        self.proc = None
        self.lines: queue.Queue = queue.Queue()
        self.tail = collections.deque(maxlen=runner.TAIL_LINES)
        self.errors: list[str] = []
        self.view = None          # the latest view asked for (request without id)
        self.request_id = 0       # id of the latest request sent
        self.shown = None         # image_version of the last image `latest` returned
        self.frame = None         # that image
        self.finished = set()     # requests whose last image has been written
        self.exports = 0          # scenes exported (and renderers started)
        self.stale = False        # the scene changed while an export ran: export again after
        self.closed = False       # `close` was called: exports running stop
        # request id -> seconds from sending it to its first, first full-size and last images
        self.timings: dict = {}
        self.announced: list = []  # (request, width, height, spp) of each image, in order
        self._lock = threading.Lock()
        self._export_thread = None
        self._sent_at: dict = {}

    # -- the scene ---------------------------------------------------------------------
    def rescene(self, export, glb):
        """Export the scene again (`export()` writes `glb`, run in a thread; it raises
        runner.PhotonError to report a failure, runner.Cancelled once `closed`) and then start
        a renderer on it; the running renderer keeps drawing the old scene until then. The last
        export asked for wins."""
        self.exports += 1
        number = self.exports

        def work():
            try:
                export()
            except runner.Cancelled:
                return  # the session was closed
            except (runner.PhotonError, OSError) as exc:
                with self._lock:
                    self.errors.append(str(exc))
                return
            with self._lock:
                if number == self.exports:
                    self._start(glb)

        self._export_thread = threading.Thread(target=work, daemon=True)
        self._export_thread.start()

    def wait_exported(self, timeout=None):
        """Wait for the export running (the tests do; the engine never waits)."""
        if self._export_thread is not None:
            self._export_thread.join(timeout)

    def _start(self, glb):
        self._stop()
        self.errors.clear()  # a new scene: the old renderer's and export's errors are past
        command = view_command(self.binary, glb, self.image, self.settings_args)
        try:
            self.proc = subprocess.Popen(command, stdin=subprocess.PIPE,
                                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        except OSError as exc:
            self.errors.append(f"cannot start photon ({command[0]}): {exc.strerror or exc}")
            self.proc = None
            return
        self.lines = queue.Queue()
        threading.Thread(target=runner._read_lines, args=(self.proc.stderr, self.lines),
                         daemon=True).start()
        if self.view is not None:
            self._send(self.view)

    # -- the view ----------------------------------------------------------------------
    def show(self, request: dict):
        """Ask for `request` (from `view_request`) unless it is the view asked for last."""
        with self._lock:
            if request == self.view:
                return
            self.view = dict(request)
            if self.proc is not None:
                self._send(self.view)

    def _send(self, view):
        self.request_id += 1
        self._sent_at[self.request_id] = time.perf_counter()
        line = json.dumps({"id": self.request_id, **view}) + "\n"
        try:
            self.proc.stdin.write(line.encode())
            self.proc.stdin.flush()
        except (OSError, ValueError):
            pass  # the renderer has ended: `poll` reports why

    # -- the images --------------------------------------------------------------------
    def poll(self) -> bool:
        """Read the renderer's events; True when an image was announced since the last call.
        Errors (a bad request, a renderer that ended) are kept in `errors`."""
        announced = False
        with self._lock:
            proc = self.proc
            while True:
                try:
                    line = self.lines.get_nowait()
                except queue.Empty:
                    break
                event = runner._parse_event(line)
                if event is None:
                    if line.strip():
                        self.tail.append(line)
                    continue
                if "error" in event:
                    self.errors.append(str(event["error"]))
                elif event.get("stage") == "image":
                    announced = True
                    request = int(event.get("request", 0))
                    self.announced.append((request, event.get("width"), event.get("height"),
                                           event.get("spp")))
                    sent = self._sent_at.get(request)
                    if sent is not None:
                        seconds = time.perf_counter() - sent
                        timing = self.timings.setdefault(request, {"first": seconds})
                        timing["last"] = seconds
                        if self.view and event.get("width") == self.view.get("width"):
                            timing.setdefault("full", seconds)
                    if event.get("final"):
                        self.finished.add(request)
            if proc is not None and proc.poll() is not None and proc.returncode != 0:
                self.errors.append(runner._failure_message("photon view", proc.returncode,
                                                           self.tail))
                self.proc = None
        return announced

    def latest(self) -> Frame | None:
        """The newest image of the current view not returned before, or None."""
        self.poll()
        version = image_version(self.image)
        if version is None or version == self.shown:
            return None
        frame = read_frame(self.image)
        self.shown = version
        if frame is None or frame.request != self.request_id:
            return None  # an image of a view no longer asked for
        self.frame = frame
        return frame

    def exporting(self) -> bool:
        """Whether an export is running."""
        return self._export_thread is not None and self._export_thread.is_alive()

    def rendering(self) -> bool:
        """Whether more images are to come (the engine keeps redrawing): an export running or
        waiting, or a view whose last image is not in."""
        with self._lock:
            return self.exporting() or self.stale or (
                self.proc is not None and self.request_id > 0
                and self.request_id not in self.finished)

    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    # -- the end -----------------------------------------------------------------------
    def _stop(self):
        proc, self.proc = self.proc, None
        if proc is None:
            return
        try:
            proc.stdin.close()  # the renderer ends when its stdin does
        except OSError:
            pass
        try:
            proc.wait(timeout=runner.KILL_AFTER_SECONDS)
        except subprocess.TimeoutExpired:
            runner._stop(proc)
        proc.stderr.close()

    def close(self):
        """Stop the renderer (no process is left behind) and forget the export running."""
        with self._lock:
            self.closed = True  # an export still running stops and starts no renderer
            self.exports += 1
            self._stop()
