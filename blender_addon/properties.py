"""Settings: the per-scene render settings (`scene.photon`) and the add-on preferences.

Defaults render the factory-default scene well with no changes; they map one to one onto the
renderer's command line (--spp, --max-depth, --seed, --threads).
"""

import bpy
from bpy.props import IntProperty, PointerProperty, StringProperty


class PhotonRenderSettings(bpy.types.PropertyGroup):
    samples: IntProperty(
        name="Samples", description="Samples per pixel", default=64, min=1, soft_max=4096,
        max=1_000_000)
    max_bounces: IntProperty(
        name="Max Bounces", description="Maximum number of bounces of a light path "
        "(Russian roulette ends most paths earlier)", default=32, min=0, max=1024)
    seed: IntProperty(
        name="Seed", description="Random seed: the same seed gives the same image", default=0,
        min=0)
    threads: IntProperty(
        name="Threads", description="Render threads (0: one per core)", default=0, min=0,
        max=1024)


class PhotonPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    binary_path: StringProperty(
        name="Binary", subtype="FILE_PATH",
        description="The photon executable. Empty: $PHOTON_BINARY, then the one packaged with "
        "the add-on, then 'photon' on PATH")

    def draw(self, context):
        self.layout.prop(self, "binary_path")


def preference_binary(context) -> str:
    """The binary path set in the add-on preferences, or '' (also when the add-on is not listed
    among the enabled add-ons, e.g. registered from source in tests)."""
    addon = context.preferences.addons.get(__package__)
    prefs = getattr(addon, "preferences", None)
    return getattr(prefs, "binary_path", "") or ""


classes = (PhotonRenderSettings, PhotonPreferences)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.photon = PointerProperty(type=PhotonRenderSettings)


def unregister():
    del bpy.types.Scene.photon
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
