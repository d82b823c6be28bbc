"""User interface: Photon's own panels (render settings, film, passes) and Photon added to an
explicit list of Blender's built-in panels whose settings Photon uses.

Blender's panels list the engines they serve in `COMPAT_ENGINES`; a panel shows for Photon only
if its class is named in `BUILTIN_PANELS` below (as Cycles and BlendLuxCore list theirs). What
Photon ignores is left out, so it does not show: EEVEE's and Cycles' render settings, Simplify,
Freestyle, Grease Pencil render settings, stereoscopy, light probes,
the light's EEVEE shadow settings, object shading and ray visibility, AOVs, Cryptomatte and the
Particles tab (not listed yet, though the export carries particles rendered as objects or
collections and hair strands; the pre-flight report warns about the rest). Motion blur has
Photon's own panel: Photon blurs the camera's and objects' motion and meshes' deformation.
Photon's passes (Depth, Normal, Denoising Data and the light passes) have their own View Layer
panel.
A name missing from the running Blender is skipped (panels are renamed between versions).
"""

import bpy

ENGINE = "PHOTON"

# Blender's panels Photon is added to, by Properties tab (and the editors that reuse them).
BUILTIN_PANELS = {
    "render": """
        RENDER_PT_color_management RENDER_PT_color_management_display_settings
        RENDER_PT_color_management_curves RENDER_PT_color_management_white_balance
        RENDER_PT_color_management_working_space RENDER_PT_color_management_advanced
    """,
    "output": """
        RENDER_PT_format RENDER_PT_frame_range RENDER_PT_time_stretching RENDER_PT_output
        RENDER_PT_output_color_management RENDER_PT_output_pixel_density RENDER_PT_encoding
        RENDER_PT_encoding_video RENDER_PT_encoding_audio RENDER_PT_post_processing
        RENDER_PT_stamp RENDER_PT_stamp_note RENDER_PT_stamp_burn
    """,
    "view_layer": """
        VIEWLAYER_PT_layer
    """,
    "object": """
        OBJECT_PT_visibility OBJECT_PT_custom_props
    """,
    "material": """
        EEVEE_MATERIAL_PT_context_material EEVEE_MATERIAL_PT_surface MATERIAL_PT_preview
        MATERIAL_PT_animation MATERIAL_PT_custom_props
    """,
    "world": """
        WORLD_PT_context_world EEVEE_WORLD_PT_surface WORLD_PT_animation WORLD_PT_custom_props
    """,
    "camera": """
        CAMERA_PT_presets CAMERA_PT_safe_areas_presets DATA_PT_context_camera DATA_PT_lens
        DATA_PT_camera DATA_PT_camera_safe_areas DATA_PT_camera_safe_areas_center_cut
        DATA_PT_camera_background_image DATA_PT_camera_display
        DATA_PT_camera_display_composition_guides DATA_PT_camera_animation
        DATA_PT_custom_props_camera DATA_PT_camera_dof DATA_PT_camera_dof_aperture
    """,
    "light": """
        DATA_PT_context_light DATA_PT_preview DATA_PT_EEVEE_light NODE_DATA_PT_EEVEE_light
        DATA_PT_spot DATA_PT_light_animation DATA_PT_custom_props_light
    """,
    # Geometry data: what the export writes, edited the same way for every engine.
    "mesh": """
        DATA_PT_context_mesh DATA_PT_vertex_groups DATA_PT_shape_keys DATA_PT_uv_texture
        DATA_PT_vertex_colors DATA_PT_mesh_attributes DATA_PT_customdata DATA_PT_texture_space
        DATA_PT_remesh DATA_PT_mesh_animation DATA_PT_custom_props_mesh
    """,
    "curves, point clouds, volumes, speakers": """
        DATA_PT_context_curves DATA_PT_curves_surface DATA_PT_CURVES_attributes
        DATA_PT_curves_animation DATA_PT_custom_props_curves DATA_PT_context_pointcloud
        DATA_PT_pointcloud_attributes DATA_PT_custom_props_pointcloud DATA_PT_context_volume
        DATA_PT_volume_file DATA_PT_volume_grids DATA_PT_volume_viewport_display
        DATA_PT_volume_viewport_display_slicing DATA_PT_volume_animation
        DATA_PT_custom_props_volume DATA_PT_context_speaker DATA_PT_speaker DATA_PT_distance
        DATA_PT_cone DATA_PT_speaker_animation DATA_PT_custom_props_speaker
    """,
    # Textures (for modifiers, brushes, force fields).
    "texture": """
        TEXTURE_PT_context TEXTURE_PT_node TEXTURE_PT_preview TEXTURE_PT_image
        TEXTURE_PT_image_settings TEXTURE_PT_image_sampling TEXTURE_PT_image_alpha
        TEXTURE_PT_image_mapping TEXTURE_PT_image_mapping_crop TEXTURE_PT_mapping
        TEXTURE_PT_influence TEXTURE_PT_colors TEXTURE_PT_colors_ramp TEXTURE_PT_blend
        TEXTURE_PT_clouds TEXTURE_PT_distortednoise TEXTURE_PT_magic TEXTURE_PT_marble
        TEXTURE_PT_musgrave TEXTURE_PT_stucci TEXTURE_PT_voronoi
        TEXTURE_PT_voronoi_feature_weights TEXTURE_PT_wood TEXTURE_PT_custom_props
    """,
    # Simulations change the geometry the export writes.
    "physics": """
        PHYSICS_PT_add PHYSICS_PT_field PHYSICS_PT_field_settings PHYSICS_PT_field_settings_kink
        PHYSICS_PT_field_settings_texture_select PHYSICS_PT_field_falloff
        PHYSICS_PT_field_falloff_angular PHYSICS_PT_field_falloff_radial PHYSICS_PT_collision
        PHYSICS_PT_collision_particle PHYSICS_PT_collision_softbody
        PHYSICS_PT_cloth PHYSICS_PT_cloth_physical_properties PHYSICS_PT_cloth_stiffness
        PHYSICS_PT_cloth_damping PHYSICS_PT_cloth_internal_springs PHYSICS_PT_cloth_pressure
        PHYSICS_PT_cloth_cache PHYSICS_PT_cloth_shape PHYSICS_PT_cloth_collision
        PHYSICS_PT_cloth_object_collision PHYSICS_PT_cloth_self_collision
        PHYSICS_PT_cloth_property_weights PHYSICS_PT_cloth_field_weights
        PHYSICS_PT_softbody PHYSICS_PT_softbody_object PHYSICS_PT_softbody_simulation
        PHYSICS_PT_softbody_cache PHYSICS_PT_softbody_goal PHYSICS_PT_softbody_goal_strengths
        PHYSICS_PT_softbody_goal_settings PHYSICS_PT_softbody_edge
        PHYSICS_PT_softbody_edge_aerodynamics PHYSICS_PT_softbody_edge_stiffness
        PHYSICS_PT_softbody_collision PHYSICS_PT_softbody_solver
        PHYSICS_PT_softbody_solver_diagnostics PHYSICS_PT_softbody_solver_helpers
        PHYSICS_PT_softbody_field_weights
        PHYSICS_PT_rigid_body PHYSICS_PT_rigid_body_settings PHYSICS_PT_rigid_body_collisions
        PHYSICS_PT_rigid_body_collisions_surface PHYSICS_PT_rigid_body_collisions_sensitivity
        PHYSICS_PT_rigid_body_collisions_collections PHYSICS_PT_rigid_body_dynamics
        PHYSICS_PT_rigid_body_dynamics_deactivation PHYSICS_PT_rigid_body_constraint
        PHYSICS_PT_rigid_body_constraint_settings PHYSICS_PT_rigid_body_constraint_objects
        PHYSICS_PT_rigid_body_constraint_override_iterations
        PHYSICS_PT_rigid_body_constraint_limits PHYSICS_PT_rigid_body_constraint_limits_linear
        PHYSICS_PT_rigid_body_constraint_limits_angular PHYSICS_PT_rigid_body_constraint_motor
        PHYSICS_PT_rigid_body_constraint_motor_angular
        PHYSICS_PT_rigid_body_constraint_motor_linear PHYSICS_PT_rigid_body_constraint_springs
        PHYSICS_PT_rigid_body_constraint_springs_angular
        PHYSICS_PT_rigid_body_constraint_springs_linear
        PHYSICS_PT_dynamic_paint PHYSICS_PT_dynamic_paint_settings PHYSICS_PT_dp_surface_canvas
        PHYSICS_PT_dp_surface_canvas_paint_dry PHYSICS_PT_dp_surface_canvas_paint_dissolve
        PHYSICS_PT_dp_canvas_output PHYSICS_PT_dp_canvas_output_paintmaps
        PHYSICS_PT_dp_canvas_output_wetmaps PHYSICS_PT_dp_canvas_initial_color
        PHYSICS_PT_dp_effects PHYSICS_PT_dp_effects_spread PHYSICS_PT_dp_effects_drip
        PHYSICS_PT_dp_effects_drip_weights PHYSICS_PT_dp_effects_shrink PHYSICS_PT_dp_cache
        PHYSICS_PT_dp_brush_source PHYSICS_PT_dp_brush_source_color_ramp
        PHYSICS_PT_dp_brush_velocity PHYSICS_PT_dp_brush_velocity_color_ramp
        PHYSICS_PT_dp_brush_velocity_smudge PHYSICS_PT_dp_brush_wave
        PHYSICS_PT_fluid PHYSICS_PT_settings PHYSICS_PT_borders PHYSICS_PT_smoke
        PHYSICS_PT_smoke_dissolve PHYSICS_PT_fire PHYSICS_PT_liquid PHYSICS_PT_flow_source
        PHYSICS_PT_flow_initial_velocity PHYSICS_PT_flow_texture PHYSICS_PT_adaptive_domain
        PHYSICS_PT_noise PHYSICS_PT_mesh PHYSICS_PT_particles PHYSICS_PT_viscosity
        PHYSICS_PT_diffusion PHYSICS_PT_guide PHYSICS_PT_collections PHYSICS_PT_cache
        PHYSICS_PT_export PHYSICS_PT_field_weights
    """,
}


def builtin_panel_names() -> list[str]:
    """Every name in `BUILTIN_PANELS`, in order."""
    return [name for names in BUILTIN_PANELS.values() for name in names.split()]


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
        col.prop(settings, "viewport_samples")
        col.prop(settings, "time_limit")
        # Blender's Noise Threshold, Cycles' settings, which Photon reads
        # (properties.adaptive_sampling).
        cycles = getattr(context.scene, "cycles", None)
        if cycles is not None:
            col.prop(cycles, "use_adaptive_sampling", text="Noise Threshold")
            sub = col.column()
            sub.active = cycles.use_adaptive_sampling
            sub.prop(cycles, "adaptive_threshold", text="Threshold")
            sub.prop(cycles, "adaptive_min_samples", text="Min Samples")
        col.prop(settings, "max_bounces")
        col.prop(settings, "seed")
        if cycles is not None:
            col.prop(cycles, "use_animated_seed", text="Animated Seed")
            # Cycles' Sample Offset, which Photon reads (properties.sample_offset): one frame
            # split across machines, their images merged by photon.merge_images.
            col.prop(cycles, "sample_offset", text="Sample Offset")
            col.operator("photon.merge_images", icon="IMAGE_DATA")
        col.prop(settings, "threads")


class RENDER_PT_photon_denoise(PhotonPanel, bpy.types.Panel):
    """Render › Sampling › Denoise, as Cycles': OpenImageDenoise on the final render."""
    bl_label = "Denoise"
    bl_parent_id = "RENDER_PT_photon_sampling"
    bl_options = {"DEFAULT_CLOSED"}

    def draw_header(self, context):
        self.layout.prop(context.scene.photon, "use_denoising", text="")

    def draw(self, context):
        settings = context.scene.photon
        col = _split(self.layout)
        col.active = settings.use_denoising
        col.label(text="OpenImageDenoise, with albedo and normal")
        col.prop(settings, "denoising_prefilter")


class RENDER_PT_photon_light_paths(PhotonPanel, bpy.types.Panel):
    """Cycles' Light Paths settings Photon reads: Clamping and Caustics
    (export.render_extension)."""
    bl_label = "Light Paths"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        cycles = getattr(context.scene, "cycles", None)
        if cycles is None:
            return
        col = _split(self.layout)
        col.prop(cycles, "sample_clamp_direct", text="Clamp Direct")
        col.prop(cycles, "sample_clamp_indirect", text="Clamp Indirect")
        col = _split(self.layout)
        col.prop(cycles, "blur_glossy", text="Filter Glossy")
        col.prop(cycles, "caustics_reflective", text="Reflective Caustics")
        col.prop(cycles, "caustics_refractive", text="Refractive Caustics")


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


class RENDER_PT_photon_film(PhotonPanel, bpy.types.Panel):
    bl_label = "Film"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        col = _split(self.layout)
        col.prop(context.scene.render, "film_transparent", text="Transparent")
        # Cycles' pixel filter, which Photon reads (export.film_filter); the width of a box is
        # always 1 px, as Cycles' own panel shows by hiding it.
        cycles = getattr(context.scene, "cycles", None)
        if cycles is not None:
            col.prop(cycles, "pixel_filter_type", text="Pixel Filter")
            if cycles.pixel_filter_type != "BOX":
                col.prop(cycles, "filter_width", text="Width")


class RENDER_PT_photon_motion_blur(PhotonPanel, bpy.types.Panel):
    """Blender's motion blur settings Photon reads: it blurs the camera's and the objects'
    motion and meshes' deformation over the shutter (each object's Motion Blur steps and
    Deformation switch in its Object properties, as in Cycles)."""
    bl_label = "Motion Blur"
    bl_options = {"DEFAULT_CLOSED"}

    def draw_header(self, context):
        self.layout.prop(context.scene.render, "use_motion_blur", text="")

    def draw(self, context):
        render = context.scene.render
        col = _split(self.layout)
        col.active = render.use_motion_blur
        col.prop(render, "motion_blur_position", text="Position")
        col.prop(render, "motion_blur_shutter")


class VIEWLAYER_PT_photon_passes(PhotonPanel, bpy.types.Panel):
    """The passes Photon writes besides Combined."""
    bl_label = "Passes"
    bl_context = "view_layer"

    def draw(self, context):
        pass


class VIEWLAYER_PT_photon_data_passes(PhotonPanel, bpy.types.Panel):
    """Depth and Normal (Blender's own toggles) and the denoising data the compositor's
    Denoise node uses."""
    bl_label = "Data"
    bl_context = "view_layer"
    bl_parent_id = "VIEWLAYER_PT_photon_passes"

    def draw(self, context):
        layer = context.view_layer
        col = _split(self.layout)
        col.prop(layer, "use_pass_z", text="Depth")
        col.prop(layer, "use_pass_normal", text="Normal")
        col.prop(layer.photon, "use_pass_denoising_data")


class VIEWLAYER_PT_photon_light_passes(PhotonPanel, bpy.types.Panel):
    """The light passes Photon writes: Blender's own toggles where they exist."""
    bl_label = "Light"
    bl_context = "view_layer"
    bl_parent_id = "VIEWLAYER_PT_photon_passes"

    def draw(self, context):
        layer = context.view_layer
        col = _split(self.layout)
        col.prop(layer, "use_pass_emit", text="Emission")
        col.prop(layer, "use_pass_diffuse_direct", text="Direct")
        col.prop(layer, "use_pass_diffuse_indirect", text="Indirect")
        cycles = getattr(layer, "cycles", None)  # Cycles' settings, there while Cycles is
        if cycles is not None:
            col.prop(cycles, "use_pass_volume_direct", text="Volume Direct")
            col.prop(cycles, "use_pass_volume_indirect", text="Volume Indirect")
        col.prop(layer.photon, "use_pass_caustic")
        col.prop(layer.photon, "use_pass_subsurface")


class WORLD_PT_photon_preview(PhotonPanel, bpy.types.Panel):
    """The world's preview, rendered by Photon (engine.py, preview.py). Blender's only world
    preview panel is Cycles' own; the material's and the light's (MATERIAL_PT_preview,
    DATA_PT_preview) are listed above."""
    bl_label = "Preview"
    bl_context = "world"
    bl_options = {"DEFAULT_CLOSED"}

    @classmethod
    def poll(cls, context):
        return context.world is not None and super().poll(context)

    def draw(self, context):
        self.layout.template_preview(context.world)


classes = (RENDER_PT_photon_sampling, RENDER_PT_photon_denoise, RENDER_PT_photon_light_paths,
           RENDER_PT_photon_photons, RENDER_PT_photon_film, RENDER_PT_photon_motion_blur, VIEWLAYER_PT_photon_passes,
           VIEWLAYER_PT_photon_data_passes, VIEWLAYER_PT_photon_light_passes,
           WORLD_PT_photon_preview)


def builtin_panels():
    """The classes of `BUILTIN_PANELS` that exist in the running Blender."""
    for name in builtin_panel_names():
        panel = getattr(bpy.types, name, None)
        if panel is not None and isinstance(getattr(panel, "COMPAT_ENGINES", None), set):
            yield panel


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    for panel in builtin_panels():
        panel.COMPAT_ENGINES.add(ENGINE)


def unregister():
    for panel in builtin_panels():
        panel.COMPAT_ENGINES.discard(ENGINE)
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
