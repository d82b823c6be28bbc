//! The scene-level extensions: `PHOTON_world` (a constant colour, an equirectangular EXR or
//! Blender's Nishita, Multiple Scattering, Preetham or Hosek-Wilkie sky baked into a map, the
//! Nishita and Multiple Scattering skies' sun discs as lights;
//! mixes of them; what camera rays see) and `PHOTON_render` (resolution, transparent film,
//! pixel filter).

use super::container::Loader;
use super::extensions::{
    BackgroundLayer, BackgroundSource, EnvironmentTexture, RenderExtension, SkyModel, SkyTexture,
    WorldExtension,
};
use crate::color_space::WorkingSpace;
use crate::error::Result;
use crate::math::Vec3;
use crate::scene::sky::{NishitaSky, SunDisc};
use crate::scene::sky_hosek::HosekSky;
use crate::scene::sky_multiple_scattering::MultipleScatteringSky;
use crate::scene::sky_preetham::PreethamSky;
use crate::scene::{Background, Environment, Light, SceneRenderSettings, Volume};

/// Width of the environment map a sky is baked into (height half of it): 0.35° pixels, each
/// the mean of 3 × 3 lookups of the sky's own table.
pub(super) const SKY_MAP_WIDTH: u32 = 1024;

impl Loader {
    /// Blender's Environment Texture: the EXR beside the glTF file, × `strength`.
    fn load_environment(&self, env: &EnvironmentTexture, strength: f32) -> Result<Environment> {
        let object = "scene PHOTON_world environment";
        let uri = &env.uri;
        let file = self.resolve_file(uri, object)?;
        if !file.is_file() {
            return Err(self.err(
                object,
                format!("environment image '{uri}' not found ({})", file.display()),
            ));
        }
        let (width, height, rgba) = crate::image_io::read_exr_rgba(&file).map_err(|e| {
            self.err(
                object,
                format!("cannot read environment image '{uri}' as OpenEXR: {e}"),
            )
        })?;
        let mut pixels = Vec::with_capacity(rgba.len());
        for [r, g, b, _] in rgba {
            let c = Vec3::new(r, g, b) * strength;
            if !c.is_finite() {
                return Err(self.err(
                    object,
                    format!("environment image '{uri}' holds NaN or infinite values"),
                ));
            }
            pixels.push(c.max(Vec3::ZERO));
        }
        Ok(Environment {
            width,
            height,
            pixels: pixels.into(),
            to_map: env.rotation * Environment::Y_UP_TO_Z_UP,
            closest: env.closest,
        })
    }

    /// A background of PHOTON_world (the world's own, or what camera rays see): its layers,
    /// each a constant colour, an environment image or a sky × its strength, summed. Several
    /// maps are resampled onto one (the finest) with the constant colours added. Returns the
    /// background and the suns of its skies.
    fn read_background(&self, layers: &[BackgroundLayer]) -> Result<(Background, Vec<Light>)> {
        let mut color = Vec3::ZERO;
        let mut maps = Vec::new();
        let mut suns = Vec::new();
        for layer in layers {
            match &layer.source {
                BackgroundSource::Environment(env) => {
                    maps.push(self.load_environment(env, layer.strength)?)
                }
                BackgroundSource::Sky(sky) => {
                    let (map, sun) = bake_sky(
                        sky,
                        layer.strength,
                        self.scene.render_settings.working_space,
                    );
                    maps.push(map);
                    suns.extend(sun);
                }
                BackgroundSource::Color(c) => color += *c * layer.strength,
            }
        }
        let environment = match maps.len() {
            0 => None,
            1 => maps.pop().map(|mut map| {
                if color != Vec3::ZERO {
                    map.pixels = map.pixels.iter().map(|&p| p + color).collect();
                }
                map
            }),
            _ => {
                let finest = maps
                    .iter()
                    .max_by_key(|m| m.width * m.height)
                    .expect("a map");
                let to_map = Environment::Y_UP_TO_Z_UP;
                let back = to_map.transpose();
                let (w, h) = (finest.width, finest.height);
                let mut sum = Environment::bake(w, h, to_map, 1, |d| {
                    let dir = back * d;
                    maps.iter().map(|m| m.radiance(dir)).sum::<Vec3>() + color
                });
                sum.pixels = sum.pixels.iter().map(|p| p.max(Vec3::ZERO)).collect();
                Some(sum)
            }
        };
        Ok((Background { color, environment }, suns))
    }

    /// The working colour space of `PHOTON_render` (before anything else of the file is read).
    pub(super) fn read_working_space(&mut self, gltf_scene: &gltf::Scene) -> Result<()> {
        if let Some(render) = gltf_scene.extension_value("PHOTON_render") {
            let render = RenderExtension::read(render)
                .map_err(|e| self.invalid("scene PHOTON_render", e))?;
            self.scene.render_settings.working_space = render.working_space;
        }
        Ok(())
    }

    /// `PHOTON_world` and `PHOTON_render` of the scene.
    pub(super) fn read_scene_extensions(&mut self, gltf_scene: &gltf::Scene) -> Result<()> {
        if let Some(world) = gltf_scene.extension_value("PHOTON_world") {
            let object = "scene PHOTON_world";
            let world = WorldExtension::read(world).map_err(|e| self.invalid(object, e))?;
            let (background, suns) = self.read_background(&world.background)?;
            self.scene.world.background = background;
            self.scene.lights.extend(suns);
            if let Some(tree) = &world.volume {
                let mut warnings = Vec::new();
                let program =
                    crate::shader::compile(tree, self.scene.textures.len(), &mut warnings)
                        .map_err(|m| self.err(format!("{object} volume"), m))?;
                for w in warnings {
                    self.scene.warnings.push(format!("the world's volume: {w}"));
                }
                self.scene.world.volume = Volume::of(program);
            }
            if let Some(camera) = &world.camera {
                // A sky's sun disc seen only by the camera is not drawn (see the README).
                let (seen, _suns) = self.read_background(camera)?;
                self.scene.world.camera_background = Some(seen);
            }
        }
        if let Some(render) = gltf_scene.extension_value("PHOTON_render") {
            let object = "scene PHOTON_render";
            let render = RenderExtension::read(render).map_err(|e| self.invalid(object, e))?;
            self.scene.render_settings = SceneRenderSettings {
                width: render.width,
                height: render.height,
                transparent_film: render.film_transparent,
                filter: render.filter,
                volume_bounces: render.volume_bounces,
                clamp_direct: render.clamp_direct,
                clamp_indirect: render.clamp_indirect,
                reflective_caustics_off: !render.caustics_reflective,
                refractive_caustics_off: !render.caustics_refractive,
                filter_glossy: render.filter_glossy,
                working_space: render.working_space,
            };
        }
        Ok(())
    }
}

/// Blender's Sky Texture baked × `strength` into an environment map, and a Nishita or Multiple
/// Scattering sky's sun disc as a sun light (in scene directions), in the working colour space
/// `space`.
fn bake_sky(sky: &SkyTexture, strength: f32, space: WorkingSpace) -> (Environment, Option<Light>) {
    let to_map = sky.rotation * Environment::Y_UP_TO_Z_UP;
    let bake = |radiance: &(dyn Fn(Vec3) -> Vec3 + Sync)| {
        Environment::bake(SKY_MAP_WIDTH, SKY_MAP_WIDTH / 2, to_map, 3, |d| {
            space.convert_rec709(radiance(d)) * strength
        })
    };
    let as_light = |sun: SunDisc| Light::Sun {
        direction: -(to_map.transpose() * sun.direction),
        irradiance: space.convert_rec709(sun.irradiance) * strength,
        angle: sun.angle,
        camera: true,
    };
    let settings = match sky.model {
        SkyModel::Nishita(settings) => settings,
        SkyModel::MultipleScattering(settings) => {
            let model = MultipleScatteringSky::new(&settings);
            return (bake(&|d| model.sky_radiance(d)), model.sun().map(as_light));
        }
        SkyModel::Preetham {
            sun_direction,
            turbidity,
        } => {
            let model = PreethamSky::new(sun_direction, turbidity);
            return (bake(&|d| model.radiance(d)), None);
        }
        SkyModel::HosekWilkie {
            sun_direction,
            turbidity,
            ground_albedo,
        } => {
            let model = HosekSky::new(sun_direction, turbidity, ground_albedo);
            return (bake(&|d| model.radiance(d)), None);
        }
    };
    let model = NishitaSky::new(&settings);
    let map = bake(&|d| model.sky_radiance(d));
    (map, model.sun().map(as_light))
}
