"""Where the Blender tests' time goes: a pytest plugin that writes, for every test, its wall and
CPU seconds (setup, call and teardown; the process's own CPU and that of the children it waited
for, so the Photon processes count) and how much of them were Cycles renders and Photon F12
renders (`bpy.app.handlers.render_pre`/`render_post`: Cycles renders in the Blender process,
Photon's add-on waits for the renderer's process before the render ends).

    PHOTON_TIMING_DIR=/tmp/timing PYTHONPATH=tests/blender \\
        .venv/bin/python -m pytest tests/blender -p time_renders ...
    .venv/bin/python tests/blender/time_renders.py /tmp/timing   # the summary by file

One tab-separated file per process (each pytest-xdist worker writes its own).
"""

from __future__ import annotations

import os
import resource
import sys
import time
from pathlib import Path

import pytest

FIELDS = ("test", "wall", "cpu", "cycles_wall", "cycles_cpu", "photon_wall", "photon_cpu",
          "cycles_renders")


def _cpu() -> float:
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


class _Clock:
    def __init__(self):
        self.render_start = None
        self.test = None

    def pre(self, scene, *_args):
        self.render_start = (scene.render.engine, time.perf_counter(), _cpu())

    def post(self, *_args):
        if self.render_start is None or self.test is None:
            return
        engine, wall, cpu = self.render_start
        self.render_start = None
        name = {"CYCLES": "cycles", "PHOTON": "photon"}.get(engine)
        if name is None:
            return
        self.test[f"{name}_wall"] += time.perf_counter() - wall
        self.test[f"{name}_cpu"] += _cpu() - cpu
        if name == "cycles":
            self.test["cycles_renders"] += 1


_clock = _Clock()
_out = None


def pytest_sessionstart(session):
    global _out
    folder = os.environ.get("PHOTON_TIMING_DIR")
    if not folder:
        return
    Path(folder).mkdir(parents=True, exist_ok=True)
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    if worker == "main" and getattr(session.config.option, "numprocesses", None):
        return  # the xdist controller runs no test
    _out = open(Path(folder) / f"{worker}.tsv", "w")
    _out.write("\t".join(FIELDS) + "\n")
    import bpy

    # Persistent: the tests load factory settings, which drops every other handler.
    @bpy.app.handlers.persistent
    def pre(*args):
        _clock.pre(*args)

    @bpy.app.handlers.persistent
    def post(*args):
        _clock.post(*args)

    bpy.app.handlers.render_pre.append(pre)
    bpy.app.handlers.render_post.append(post)
    bpy.app.handlers.render_cancel.append(post)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    if _out is None:
        yield
        return
    _clock.test = dict.fromkeys(FIELDS[1:], 0)
    wall, cpu = time.perf_counter(), _cpu()
    yield
    row = _clock.test
    row["wall"], row["cpu"] = time.perf_counter() - wall, _cpu() - cpu
    _out.write("\t".join([item.nodeid] + [f"{row[k]:.2f}" for k in FIELDS[1:]]) + "\n")
    _out.flush()
    _clock.test = None


def summary(folder: Path) -> None:
    """Seconds by test file, largest CPU first, and the totals."""
    files: dict[str, list[float]] = {}
    for tsv in sorted(folder.glob("*.tsv")):
        lines = tsv.read_text().splitlines()[1:]
        for line in lines:
            cells = line.split("\t")
            name = cells[0].split("::")[0].rsplit("/", 1)[-1]
            sums = files.setdefault(name, [0.0] * (len(FIELDS) - 1) + [0])
            for k, value in enumerate(cells[1:]):
                sums[k] += float(value)
            sums[-1] += 1
    print("| file | tests | wall s | CPU s | Cycles CPU s | Photon F12 CPU s | Cycles renders |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    total = [0.0] * len(FIELDS)
    for name, s in sorted(files.items(), key=lambda kv: -kv[1][1]):
        print(f"| {name} | {s[-1]} | {s[0]:.0f} | {s[1]:.0f} | {s[3]:.0f} | {s[5]:.0f} "
              f"| {s[6]:.0f} |")
        total = [a + b for a, b in zip(total, s)]
    print(f"| all | {total[-1]:.0f} | {total[0]:.0f} | {total[1]:.0f} | {total[3]:.0f} "
          f"| {total[5]:.0f} | {total[6]:.0f} |")


if __name__ == "__main__":
    summary(Path(sys.argv[1]))
