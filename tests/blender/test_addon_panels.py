"""Panels: Photon is added to exactly the built-in panels listed in ui.BUILTIN_PANELS (it used to
join ~300 by a name rule, light-probe baking and Cryptomatte included), the panels for settings
Photon ignores stay hidden, unregistering removes Photon from every panel, and Photon's View
Layer panel draws its pass toggles (Depth, Normal, Denoising Data, the light passes) on
properties that exist; the material, light and world previews show.
"""

import types

import bpy

ENGINE = "PHOTON"
# Settings Photon ignores: their panels must not show with Photon.
IGNORED = ["DATA_PT_lightprobe_bake", "DATA_PT_context_lightprobe",
           "VIEWLAYER_PT_layer_passes_cryptomatte", "VIEWLAYER_PT_layer_passes_aov",
           "VIEWLAYER_PT_layer_passes", "RENDER_PT_simplify", "RENDER_PT_freestyle",
           "CYCLES_RENDER_PT_sampling",
           # EEVEE's sampling panel, renamed in Blender 5.
           "RENDER_PT_eevee_sampling" if bpy.app.version >= (5, 0, 0)
           else "RENDER_PT_eevee_next_sampling",
           "DATA_PT_EEVEE_light_shadow", "OBJECT_PT_shading", "PARTICLE_PT_context_particles",
           "MATERIAL_PT_freestyle_line", "RENDER_PT_stereoscopy"]

# Listed panels that a supported Blender version lacks, with the versions that lack them.
PANELS_OF_OTHER_VERSIONS = {
    "RENDER_PT_color_management_display_settings": [(5, 0)],
    "RENDER_PT_color_management_working_space": [(4, 5)],
    "RENDER_PT_color_management_advanced": [(4, 5)],
}


def all_panels():
    """Every registered panel class (subclasses of subclasses too)."""
    found, todo = set(), list(bpy.types.Panel.__subclasses__())
    while todo:
        cls = todo.pop()
        if cls not in found:
            found.add(cls)
            todo.extend(cls.__subclasses__())
    return found


def photon_panels():
    return {cls.__name__ for cls in all_panels()
            if isinstance(getattr(cls, "COMPAT_ENGINES", None), set)
            and ENGINE in cls.COMPAT_ENGINES}


def test_photon_is_in_exactly_the_listed_panels(photon_addon):
    ui = photon_addon.ui
    listed = ui.builtin_panel_names()
    assert len(listed) == len(set(listed)), "a panel is listed twice"
    missing = [name for name in listed if getattr(bpy.types, name, None) is None
               and bpy.app.version[:2] not in PANELS_OF_OTHER_VERSIONS.get(name, [])]
    assert not missing, f"listed panels that Blender {bpy.app.version_string} lacks: {missing}"
    own = {cls.__name__ for cls in ui.classes}
    shown = photon_panels()
    present = {name for name in listed if getattr(bpy.types, name, None) is not None}
    assert shown == present | own, (f"not listed: {sorted(shown - present - own)}; "
                                    f"listed, not shown: {sorted(present - shown)}")
    print(f"{len(shown)} panels show with Photon ({len(own)} its own)")
    for name in IGNORED:
        assert getattr(bpy.types, name, None) is not None, f"{name} no longer exists"
        assert name not in shown, name
    # The settings Photon uses are there.
    for name in ("EEVEE_MATERIAL_PT_surface", "EEVEE_WORLD_PT_surface", "DATA_PT_EEVEE_light",
                 "DATA_PT_lens", "RENDER_PT_format", "RENDER_PT_color_management",
                 "VIEWLAYER_PT_layer", "PHYSICS_PT_cloth", "DATA_PT_camera_dof",
                 # Previews (test_addon_preview.py renders them).
                 "MATERIAL_PT_preview", "DATA_PT_preview", "WORLD_PT_photon_preview"):
        assert name in shown, name


def test_unregister_removes_photon_from_every_panel(photon_addon):
    own = {cls.__name__ for cls in photon_addon.ui.classes}
    photon_addon.unregister()
    try:
        assert photon_panels() - own == set()
    finally:
        photon_addon.register()
    assert "EEVEE_MATERIAL_PT_surface" in photon_panels()


class Recorder:
    """Stands in for a UILayout: records the (data, property, text) of every prop() call."""

    def __init__(self):
        self.props = []
        self.use_property_split = self.use_property_decorate = False

    def column(self, **_):
        return self

    row = column

    def template_preview(self, id_block, **_):
        self.props.append((id_block, "preview", None))

    def prop(self, data, name, text=None, **_):
        assert hasattr(data, name), f"{data!r} has no property {name}"
        self.props.append((data, name, text))


def drawn(panel, context):
    layout = Recorder()
    panel.draw(types.SimpleNamespace(layout=layout), context)
    return [(data, name) for data, name, _ in layout.props]


def test_view_layer_panel_draws_the_pass_toggles(photon_addon):
    ui = photon_addon.ui
    bpy.ops.wm.read_factory_settings()
    scene = bpy.context.scene
    scene.render.engine = ENGINE
    layer = scene.view_layers[0]
    context = types.SimpleNamespace(view_layer=layer, scene=scene, engine=ENGINE)
    for panel in (ui.VIEWLAYER_PT_photon_data_passes, ui.VIEWLAYER_PT_photon_light_passes):
        assert panel.bl_context == "view_layer"
        assert panel.bl_parent_id == "VIEWLAYER_PT_photon_passes"
        assert panel.poll(context)
    assert drawn(ui.VIEWLAYER_PT_photon_data_passes, context) == [
        (layer, "use_pass_z"), (layer, "use_pass_normal"),
        (layer.photon, "use_pass_denoising_data")]
    assert drawn(ui.VIEWLAYER_PT_photon_light_passes, context) == [
        (layer, "use_pass_emit"), (layer, "use_pass_diffuse_direct"),
        (layer, "use_pass_diffuse_indirect"), (layer.cycles, "use_pass_volume_direct"),
        (layer.cycles, "use_pass_volume_indirect"), (layer.photon, "use_pass_caustic"),
        (layer.photon, "use_pass_subsurface")]
    assert drawn(ui.RENDER_PT_photon_film, context) == [
        (scene.render, "film_transparent"), (scene.cycles, "pixel_filter_type"),
        (scene.cycles, "filter_width")]
    scene.cycles.pixel_filter_type = "BOX"
    assert drawn(ui.RENDER_PT_photon_film, context) == [
        (scene.render, "film_transparent"), (scene.cycles, "pixel_filter_type")]
    world_context = types.SimpleNamespace(world=scene.world, engine=ENGINE)
    assert ui.WORLD_PT_photon_preview.poll(world_context)
    assert drawn(ui.WORLD_PT_photon_preview, world_context) == [(scene.world, "preview")]
    # The toggles drive the passes the engine registers.
    layer.use_pass_z = True
    layer.photon.use_pass_denoising_data = True
    registered = []
    fake_engine = types.SimpleNamespace(
        register_pass=lambda s, l, name, *args: registered.append(name))
    photon_addon.engine.PhotonRenderEngine.update_render_passes(fake_engine, scene, layer)
    assert registered == ["Combined", "Depth", "Denoising Normal", "Denoising Albedo"]
    scene.render.engine = "CYCLES"
    assert not ui.VIEWLAYER_PT_photon_passes.poll(
        types.SimpleNamespace(view_layer=layer, scene=scene, engine="CYCLES"))
