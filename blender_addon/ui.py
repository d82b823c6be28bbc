"""User interface: Photon's Render Properties panel, and Photon added to the built-in panels
(material, light, world, camera, output...) whose settings Photon uses.

Blender's panels list the engines they serve in `COMPAT_ENGINES`. Photon joins every panel that
serves EEVEE and is not EEVEE-specific (its class name does not mention EEVEE), plus the few
EEVEE panels that show engine-independent data (material surface, light, world surface).
"""

import bpy

ENGINE = "PHOTON"
EEVEE_IDS = {"BLENDER_EEVEE_NEXT", "BLENDER_EEVEE"}
SHARED_EEVEE_PANELS = {
    "EEVEE_MATERIAL_PT_context_material", "EEVEE_MATERIAL_PT_surface",
    "EEVEE_MATERIAL_PT_settings", "DATA_PT_EEVEE_light", "EEVEE_WORLD_PT_surface",
}


class PhotonPanel:
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    COMPAT_ENGINES = {ENGINE}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


def _split(layout):
    layout.use_property_split = True
    layout.use_property_decorate = False
    return layout.column()


class RENDER_PT_photon_sampling(PhotonPanel, bpy.types.Panel):
    bl_label = "Sampling"

    def draw(self, context):
        settings = context.scene.photon
        col = _split(self.layout)
        col.prop(settings, "method")
        col.prop(settings, "quality")
        col.prop(settings, "samples")
        col.prop(settings, "time_limit")
        col.prop(settings, "max_bounces")
        col.prop(settings, "seed")
        col.prop(settings, "threads")


class RENDER_PT_photon_photons(PhotonPanel, bpy.types.Panel):
    bl_label = "Photon Mapping"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        settings = context.scene.photon
        col = _split(self.layout)
        col.active = settings.method != "PATH"
        col.prop(settings, "custom_photons")
        sub = col.column()
        sub.active = settings.custom_photons
        sub.prop(settings, "photons")
        sub.prop(settings, "caustic_photons")
        col.prop(settings, "gather_rays")
        col.prop(settings, "irradiance_cache")
        sub = col.column()
        sub.active = settings.irradiance_cache == "ON"
        sub.prop(settings, "ic_accuracy")


def shared_panels():
    """The built-in panels Photon is added to."""
    for panel in bpy.types.Panel.__subclasses__():
        engines = getattr(panel, "COMPAT_ENGINES", None)
        if not isinstance(engines, set) or not engines & EEVEE_IDS:
            continue
        if "eevee" not in panel.__name__.lower() or panel.__name__ in SHARED_EEVEE_PANELS:
            yield panel


class VIEWLAYER_PT_photon_light_passes(PhotonPanel, bpy.types.Panel):
    """The light passes Photon writes: Blender's own toggles where they exist."""
    bl_label = "Light Passes"
    bl_context = "view_layer"

    def draw(self, context):
        layer = context.view_layer
        col = _split(self.layout)
        col.prop(layer, "use_pass_emit", text="Emission")
        col.prop(layer, "use_pass_diffuse_direct", text="Direct")
        col.prop(layer, "use_pass_diffuse_indirect", text="Indirect")
        col.prop(layer.photon, "use_pass_caustic")
        col.prop(layer.photon, "use_pass_subsurface")


classes = (RENDER_PT_photon_sampling, RENDER_PT_photon_photons, VIEWLAYER_PT_photon_light_passes)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    for panel in shared_panels():
        panel.COMPAT_ENGINES.add(ENGINE)


def unregister():
    for panel in bpy.types.Panel.__subclasses__():
        engines = getattr(panel, "COMPAT_ENGINES", None)
        if isinstance(engines, set) and not issubclass(panel, PhotonPanel):
            engines.discard(ENGINE)
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
