"""One render-farm task, as a farm manager runs Blender on a worker (`blender -b FILE -f N`),
with the bpy module in place of the Blender executable: open the saved .blend, render frame N
of it through `render(animation=True)` over the range N..N (what `-f N` does), write it to the
scene's output path. The add-on is registered from the source folder (on a worker it is
installed); the binary comes from $PHOTON_BINARY (the per-worker override).

    .venv/bin/python tests/blender/farm_worker.py FILE.blend FRAME OUTPUT_PATTERN

A failed render raises from `bpy.ops.render.render`, so the process exits with code 1 and the
renderer's message on stderr, as `blender -b` exits 1 after a render error report.
"""

import sys
from pathlib import Path


def main(argv):
    blend, frame, output = argv[1], int(argv[2]), argv[3]
    import bpy
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    import blender_addon
    blender_addon.register()
    try:
        bpy.ops.wm.open_mainfile(filepath=blend)
        scene = bpy.context.scene
        scene.frame_start = scene.frame_end = frame
        scene.render.filepath = output
        bpy.ops.render.render(animation=True)
    finally:
        blender_addon.unregister()


if __name__ == "__main__":
    main(sys.argv)
