//! The scene-level extensions: `PHOTON_world` (a constant colour, an equirectangular EXR or
//! Blender's Nishita sky baked into a map, with its sun as a light; mixes of them; what camera
//! rays see) and `PHOTON_render` (resolution, transparent film, pixel filter).

use super::container::{json_vec3, Loader};
use crate::error::{Error, Result};
use crate::film::{FilterKind, FilterSettings};
use crate::math::{Mat3, Vec3};
use crate::scene::sky::{NishitaSettings, NishitaSky};
use crate::scene::{Background, Environment, Light, SceneRenderSettings};
use serde_json::Value;

/// Width of the environment map a sky is baked into (height half of it): 0.35° pixels, each
/// the mean of 3 × 3 lookups of the sky's own table.
pub(super) const SKY_MAP_WIDTH: u32 = 1024;

impl Loader {
    /// The `environment` of PHOTON_world: an EXR beside the glTF file, × `strength`.
    pub(super) fn load_environment(&self, env: &Value, strength: f32) -> Result<Environment> {
        let object = "scene PHOTON_world environment";
        let uri = env
            .get("uri")
            .and_then(Value::as_str)
            .ok_or_else(|| self.err(object, "'uri' (the environment image) is missing"))?;
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
        let closest = match env.get("interpolation").and_then(Value::as_str) {
            None | Some("linear") => false,
            Some("closest") => true,
            Some(other) => {
                return Err(self.err(
                    object,
                    format!("unknown interpolation '{other}' (linear or closest)"),
                ))
            }
        };
        let euler = self.mapping_rotation(env, object)?;
        Ok(Environment {
            width,
            height,
            pixels: pixels.into(),
            to_map: euler * Environment::Y_UP_TO_Z_UP,
            closest,
        })
    }

    /// The `sky` of a PHOTON_world background: Blender's Sky Texture (Nishita) baked × `strength`
    /// into an environment map, and its sun disc as a sun light (in scene directions).
    pub(super) fn load_sky(
        &self,
        sky: &Value,
        strength: f32,
    ) -> Result<(Environment, Option<Light>)> {
        let object = "scene PHOTON_world sky";
        match sky.get("type").and_then(Value::as_str) {
            None | Some("NISHITA") => {}
            Some(other) => {
                return Err(self.err(object, format!("unknown sky type '{other}' (NISHITA)")))
            }
        }
        let defaults = NishitaSettings::default();
        let number = |key: &str, default: f32, valid: fn(f32) -> bool| -> Result<f32> {
            match sky.get(key) {
                None => Ok(default),
                Some(v) => v
                    .as_f64()
                    .map(|x| x as f32)
                    .filter(|&x| x.is_finite() && valid(x))
                    .ok_or_else(|| self.err(object, format!("'{key}' is out of range: {v}"))),
            }
        };
        let any = |_: f32| true;
        let non_negative = |x: f32| x >= 0.0;
        let settings = NishitaSettings {
            sun_elevation: number("sun_elevation", defaults.sun_elevation, any)?,
            sun_rotation: number("sun_rotation", defaults.sun_rotation, any)?,
            sun_size: number("sun_size", defaults.sun_size, |x| {
                (0.0..=std::f32::consts::PI).contains(&x)
            })?,
            sun_intensity: number("sun_intensity", defaults.sun_intensity, non_negative)?,
            sun_disc: sky
                .get("sun_disc")
                .and_then(Value::as_bool)
                .unwrap_or(defaults.sun_disc),
            altitude: number("altitude", defaults.altitude, any)?,
            air: number("air", defaults.air, non_negative)?,
            dust: number("dust", defaults.dust, non_negative)?,
            ozone: number("ozone", defaults.ozone, non_negative)?,
        };
        let rotation = self.mapping_rotation(sky, object)?;
        let to_map = rotation * Environment::Y_UP_TO_Z_UP;
        let model = NishitaSky::new(&settings);
        let map = Environment::bake(SKY_MAP_WIDTH, SKY_MAP_WIDTH / 2, to_map, 3, |d| {
            model.sky_radiance(d) * strength
        });
        let sun = model.sun().map(|sun| Light::Sun {
            direction: -(to_map.transpose() * sun.direction),
            irradiance: sun.irradiance * strength,
            angle: sun.angle,
        });
        Ok((map, sun))
    }

    /// The rotation of a Mapping node (`"rotation": [x, y, z]`, Blender's Euler XYZ, radians)
    /// applied to directions in Blender's frame before a world texture's lookup.
    pub(super) fn mapping_rotation(&self, texture: &Value, object: &str) -> Result<Mat3> {
        let rotation = match texture.get("rotation") {
            None => Vec3::ZERO,
            Some(v) => json_vec3(v).filter(|r| r.is_finite()).ok_or_else(|| {
                self.err(object, format!("'rotation' must be [x, y, z], found {v}"))
            })?,
        };
        // X first, then Y, then Z.
        Ok(Mat3::from_rotation_z(rotation.z)
            * Mat3::from_rotation_y(rotation.y)
            * Mat3::from_rotation_x(rotation.x))
    }

    /// A background of PHOTON_world (the whole extension, its `camera`, or an entry of `mix`):
    /// a constant colour, an environment image or a sky, each × `strength` × `weight`; a `mix`
    /// sums its entries. Several maps are resampled onto one (the finest) with the constant
    /// colours added. Returns the background and the suns of its skies.
    pub(super) fn read_background(
        &self,
        world: &Value,
        object: &str,
    ) -> Result<(Background, Vec<Light>)> {
        let factor = |layer: &Value, key: &str| -> Result<f32> {
            match layer.get(key) {
                None => Ok(1.0),
                Some(v) => v
                    .as_f64()
                    .map(|x| x as f32)
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| self.err(object, format!("'{key}' must be a number: {v}"))),
            }
        };
        let layers: Vec<&Value> = match world.get("mix") {
            None => vec![world],
            Some(Value::Array(entries)) => entries.iter().collect(),
            Some(v) => return Err(self.err(object, format!("'mix' must be a list, found {v}"))),
        };
        let mut color = Vec3::ZERO;
        let mut maps = Vec::new();
        let mut suns = Vec::new();
        for layer in layers {
            let strength = factor(layer, "strength")? * factor(layer, "weight")?;
            if let Some(env) = layer.get("environment") {
                maps.push(self.load_environment(env, strength)?);
            } else if let Some(sky) = layer.get("sky") {
                let (map, sun) = self.load_sky(sky, strength)?;
                maps.push(map);
                suns.extend(sun);
            } else {
                let c = match layer.get("color") {
                    None => Vec3::ZERO,
                    Some(v) => json_vec3(v).filter(|c| c.is_finite()).ok_or_else(|| {
                        self.err(object, format!("'color' must be [r, g, b], found {v}"))
                    })?,
                };
                color += c * strength;
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

    pub(super) fn read_scene_extensions(&mut self, gltf_scene: &gltf::Scene) -> Result<()> {
        if let Some(world) = gltf_scene.extension_value("PHOTON_world") {
            let (background, suns) = self.read_background(world, "scene PHOTON_world")?;
            self.scene.world.background = background;
            self.scene.lights.extend(suns);
            if let Some(camera) = world.get("camera") {
                // A sky's sun disc seen only by the camera is not drawn (see the README).
                let object = "scene PHOTON_world camera";
                let (seen, _suns) = self.read_background(camera, object)?;
                self.scene.world.camera_background = Some(seen);
            }
        }
        if let Some(render) = gltf_scene.extension_value("PHOTON_render") {
            let dimension = |key: &str| -> Result<Option<u32>> {
                match render.get(key) {
                    None => Ok(None),
                    Some(v) => match v.as_u64().and_then(|v| u32::try_from(v).ok()) {
                        Some(d) if d > 0 => Ok(Some(d)),
                        _ => Err(self.err(
                            "scene PHOTON_render",
                            format!("'{key}' must be a positive integer, found {v}"),
                        )),
                    },
                }
            };
            let filter = match render.get("filter") {
                None => None,
                Some(filter) => Some(self.read_filter(filter)?),
            };
            self.scene.render_settings = SceneRenderSettings {
                width: dimension("width")?,
                height: dimension("height")?,
                transparent_film: render
                    .get("film_transparent")
                    .and_then(Value::as_bool)
                    .unwrap_or(false),
                filter,
            };
        }
        Ok(())
    }

    /// `PHOTON_render`'s `filter`: Cycles' pixel filter type and Blender's width.
    pub(super) fn read_filter(&self, filter: &Value) -> Result<FilterSettings> {
        let object = "scene PHOTON_render filter";
        let name = filter.get("type").and_then(Value::as_str).unwrap_or("");
        let kind = FilterKind::from_name(name).ok_or_else(|| {
            self.err(
                object,
                format!("'type' must be BLACKMAN_HARRIS, GAUSSIAN or BOX, found {name:?}"),
            )
        })?;
        let width = match filter.get("width") {
            None => kind.default_width(),
            Some(w) => w
                .as_f64()
                .ok_or_else(|| self.err(object, format!("'width' must be a number, found {w}")))?
                as f32,
        };
        FilterSettings::new(kind, width).map_err(|e| match e {
            Error::Settings(message) => self.err(object, message),
            e => e,
        })
    }
}
