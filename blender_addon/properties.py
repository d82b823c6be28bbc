"""Settings: the per-scene render settings (`scene.photon`) and the add-on preferences.

The settings mirror `runner.RenderSettings` one to one (same names, same defaults), which
`runner.settings_arguments` turns into the renderer's flags. The defaults render the
factory-default scene well with no changes: the renderer's planner picks the method, the
"default" quality preset picks the samples and photon counts.
"""

import dataclasses

import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty,
                       StringProperty)

from .runner import RenderSettings, animated_seed

D = RenderSettings()


class PhotonRenderSettings(bpy.types.PropertyGroup):
    method: EnumProperty(
        name="Method", description="Rendering algorithm", default=D.method.upper(),
        items=[("AUTO", "Auto", "The renderer's planner chooses from the scene (photon "
                "mapping when light can be focused into caustics, else path tracing)"),
               ("PATH", "Path Tracing", "Unbiased path tracing (the reference)"),
               ("PHOTON", "Photon Mapping", "Photon maps with final gathering (Jensen)")])
    quality: EnumProperty(
        name="Quality", description="Preset for the samples per pixel and the photon counts",
        default=D.quality.upper(),
        items=[("PREVIEW", "Preview", "16 samples, a quarter of the photons: a quick look"),
               ("DEFAULT", "Default", "64 samples, the default photon counts"),
               ("FINAL", "Final", "256 samples, four times the photons: final frames")])
    samples: IntProperty(
        name="Samples", description="Samples per pixel (0: from the quality preset, or as many "
        "as the time limit allows)", default=D.samples, min=0, soft_max=4096, max=1_000_000)
    viewport_samples: IntProperty(
        name="Viewport Samples", description="Samples per pixel of the Rendered viewport, "
        "which shows them as they come (as Cycles' Viewport samples)", default=32, min=1,
        soft_max=4096, max=1_000_000)
    time_limit: FloatProperty(
        name="Time Limit", description="Stop adding samples after this time (0: no limit)",
        default=D.time_limit, min=0.0, soft_max=3600.0, subtype="TIME_ABSOLUTE")
    max_bounces: IntProperty(
        name="Max Bounces", description="Maximum number of bounces of a light path "
        "(Russian roulette ends most paths earlier)", default=D.max_bounces, min=0, max=1024)
    seed: IntProperty(
        name="Seed", description="Random seed: the same seed gives the same image",
        default=D.seed, min=0)
    threads: IntProperty(
        name="Threads", description="Render threads (0: one per core)", default=D.threads, min=0,
        max=1024)
    custom_photons: BoolProperty(
        name="Custom Photon Counts", description="Use the photon counts below instead of the "
        "quality preset's", default=D.custom_photons)
    photons: IntProperty(
        name="Global Photons", description="Photons emitted for the global photon map",
        default=D.photons, min=1, soft_max=10_000_000)
    caustic_photons: IntProperty(
        name="Caustic Photons", description="Photons emitted for the caustic map (0: no "
        "caustic map)", default=D.caustic_photons, min=0, soft_max=10_000_000)
    gather_rays: IntProperty(
        name="Final Gather Rays", description="Final-gather rays per shading point (0: read "
        "the global photon map directly)", default=D.gather_rays, min=0, soft_max=256)
    irradiance_cache: EnumProperty(
        name="Irradiance Cache", description="Cache and interpolate indirect diffuse light "
        "(Ward's irradiance cache) in photon mapping", default=D.irradiance_cache.upper(),
        items=[("DEFAULT", "Renderer Default", "Let the renderer decide"),
               ("ON", "On", "Use the irradiance cache"),
               ("OFF", "Off", "Final-gather at every shading point")])
    use_denoising: BoolProperty(
        name="Denoise", description="Denoise the final render with OpenImageDenoise (the "
        "library Blender ships), guided by the albedo and normal of the first surface; the "
        "noisy image is kept in the Noisy Image pass", default=False)
    denoising_prefilter: EnumProperty(
        name="Prefilter", description="How the albedo and normal guides are prefiltered, as "
        "Cycles' setting of that name", default="ACCURATE",
        items=[("NONE", "None", "No prefiltering: the guides are taken as noise-free"),
               ("FAST", "Fast", "The guides are denoised together with the image"),
               ("ACCURATE", "Accurate", "The guides are denoised first, then the image")])
    ic_accuracy: FloatProperty(
        name="Cache Accuracy", description="Irradiance-cache accuracy (Ward's a): smaller is "
        "more accurate, with more records", default=D.ic_accuracy, min=0.01, max=1.0,
        precision=3)


def adaptive_sampling(scene):
    """Blender's adaptive sampling (Render > Sampling > Noise Threshold, the Cycles settings,
    which Photon reads as it reads the pixel filter): (threshold, min samples), 0 meaning
    automatic, or None when it is off. Without the Cycles add-on's settings, Blender's defaults:
    on, threshold 0.01, min samples automatic."""
    cycles = getattr(scene, "cycles", None)
    if not getattr(cycles, "use_adaptive_sampling", True):
        return None
    return (float(getattr(cycles, "adaptive_threshold", 0.01)),
            int(getattr(cycles, "adaptive_min_samples", 0)))


def sample_offset(scene) -> int:
    """Cycles' Sample Offset (Render > Sampling > Advanced, `scene.cycles.sample_offset`), which
    Photon reads as Cycles does: the render takes samples offset .. offset + Samples - 1 of the
    pixels' sequence, so machines rendering disjoint ranges of one frame can merge their images
    (merge.py). 0 without the Cycles settings."""
    return int(getattr(getattr(scene, "cycles", None), "sample_offset", 0))


def frame_seed(scene) -> int:
    """The seed of the frame being rendered: Photon's Seed, or with Cycles' Animated Seed
    (Render > Sampling, `scene.cycles.use_animated_seed`) that seed mixed with the frame and
    subframe, so each frame has its own noise and every frame is still the same wherever and
    in whatever order it is rendered."""
    seed = scene.photon.seed
    if not getattr(getattr(scene, "cycles", None), "use_animated_seed", False):
        return seed
    return animated_seed(seed, scene.frame_current, scene.frame_subframe)


def render_settings(props) -> RenderSettings:
    """`scene.photon` as the plain `runner.RenderSettings` (enum items lower-cased)."""
    values = {}
    for field in dataclasses.fields(RenderSettings):
        value = getattr(props, field.name)
        values[field.name] = value.lower() if isinstance(value, str) else value
    return RenderSettings(**values)


def viewport_settings(props) -> RenderSettings:
    """The Rendered viewport's settings: the render's, at the viewport's samples, without a
    time limit (the viewport keeps adding samples up to its count)."""
    return dataclasses.replace(render_settings(props), samples=props.viewport_samples,
                               time_limit=0.0)


class PhotonViewLayerSettings(bpy.types.PropertyGroup):
    """Passes Blender has no engine-independent view-layer toggle for (`view_layer.photon`)."""
    use_pass_denoising_data: BoolProperty(
        name="Denoising Data", description="Denoising Normal and Denoising Albedo, the "
        "passes the compositor's Denoise node uses", default=False)
    use_pass_caustic: BoolProperty(
        name="Caustic", description="Photon mapping's caustic-map term (light focused by "
        "glass and mirrors onto diffuse surfaces; 0 with path tracing, whose caustics are in "
        "Direct and Indirect)", default=False)
    use_pass_subsurface: BoolProperty(
        name="Subsurface", description="Light that entered a translucent (subsurface) "
        "material", default=False)


# Light passes: (Blender pass name, the view-layer setting that enables it, the object holding
# that setting). Emission, Diffuse Direct and Diffuse Indirect are Blender's own toggles (Photon
# puts all its direct and indirect light from surfaces there, glossy included), Volume Direct
# and Indirect Cycles' (`view_layer.cycles`, with Cycles' pass names); the renderer writes its
# passes under the same names (src/image_io.rs LIGHT_PASS_NAMES; the volume passes only when
# the image has volume light: Blender leaves a pass the file lacks black).
LIGHT_PASSES = (("Emit", "use_pass_emit", None), ("DiffDir", "use_pass_diffuse_direct", None),
                ("DiffInd", "use_pass_diffuse_indirect", None),
                ("VolumeDir", "use_pass_volume_direct", "cycles"),
                ("VolumeInd", "use_pass_volume_indirect", "cycles"),
                ("Caustic", "use_pass_caustic", "photon"),
                ("Subsurface", "use_pass_subsurface", "photon"))


def enabled_light_passes(view_layer) -> list[str]:
    """Names of the light passes enabled on `view_layer`."""
    names = []
    for name, prop, group in LIGHT_PASSES:
        owner = getattr(view_layer, group, None) if group else view_layer
        if getattr(owner, prop, False):
            names.append(name)
    return names


def shadow_catcher_pass(view_layer) -> bool:
    """Whether `view_layer` asks for Cycles' Shadow Catcher pass (the renderer writes it when
    the scene has a shadow catcher; without one it is white, as Cycles leaves it)."""
    return bool(getattr(getattr(view_layer, "cycles", None), "use_pass_shadow_catcher", False))


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


classes = (PhotonRenderSettings, PhotonViewLayerSettings, PhotonPreferences)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.photon = PointerProperty(type=PhotonRenderSettings)
    bpy.types.ViewLayer.photon = PointerProperty(type=PhotonViewLayerSettings)


def unregister():
    del bpy.types.ViewLayer.photon
    del bpy.types.Scene.photon
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
