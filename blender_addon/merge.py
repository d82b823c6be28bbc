"""Merging the images of one frame rendered in parts on several machines, as Cycles' Merge
Images (`bpy.ops.cycles.merge_images`, after Blender's `intern/cycles/session/merge.cpp`).

Each machine renders the same frame with its own Sample Offset (Render › Sampling, Cycles'
`scene.cycles.sample_offset`, which Photon reads) and saves it as an OpenEXR Multilayer file;
the engine records the samples each render holds in the file's metadata (`photon.samples`,
such as "0-16 seed 1"). `photon.merge_images` runs `photon merge` on those
files: every pass averaged by the files' sample counts, which gives the image one machine
would have rendered with all the samples. Parts rendered with Denoise on are refused (their
Combined is denoised): render them noisy, merge, then denoise the merged file (for example
with the compositor's Denoise node fed its Denoising Albedo and Denoising Normal passes).
"""

from pathlib import Path

import bpy
from bpy.props import CollectionProperty, StringProperty

from . import properties, runner

ADDON_DIR = Path(__file__).resolve().parent


class PHOTON_OT_merge_images(bpy.types.Operator):
    """Merge OpenEXR Multilayer renders of one frame made with different Sample Offsets into
    the image of all their samples"""

    bl_idname = "photon.merge_images"
    bl_label = "Merge Images"
    bl_options = {"REGISTER"}

    directory: StringProperty(subtype="DIR_PATH", options={"HIDDEN", "SKIP_SAVE"})
    files: CollectionProperty(type=bpy.types.OperatorFileListElement,
                              options={"HIDDEN", "SKIP_SAVE"})
    filter_glob: StringProperty(default="*.exr", options={"HIDDEN"})
    output_filepath: StringProperty(
        name="Output", subtype="FILE_PATH",
        description="The merged OpenEXR file (may be one of the inputs)")

    def inputs(self) -> list[Path]:
        folder = Path(bpy.path.abspath(self.directory))
        return [folder / f.name for f in self.files if f.name]

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def draw(self, context):
        self.layout.prop(self, "output_filepath")

    def execute(self, context):
        inputs = self.inputs()
        if len(inputs) < 2:
            self.report({"ERROR"}, "Photon: select at least two images to merge")
            return {"CANCELLED"}
        output = self.output_filepath or str(inputs[0].with_name("merged.exr"))
        output = Path(bpy.path.abspath(output))
        try:
            binary = runner.find_binary(properties.preference_binary(context), ADDON_DIR)
            runner.run(runner.merge_command(binary, output, inputs), what="photon merge")
        except runner.PhotonError as exc:
            self.report({"ERROR"}, f"Photon: {exc}")
            return {"CANCELLED"}
        self.report({"INFO"}, f"Photon: merged {len(inputs)} images into {output}")
        return {"FINISHED"}


def register():
    bpy.utils.register_class(PHOTON_OT_merge_images)


def unregister():
    bpy.utils.unregister_class(PHOTON_OT_merge_images)
