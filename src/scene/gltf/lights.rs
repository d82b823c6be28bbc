//! KHR_lights_punctual lights (photometric units converted by `scene::units`) with Photon's
//! `PHOTON_light` additions: Cycles' power, colour and spot cone, lamp radius and visibility, and
//! area lights (which Blender's exporter drops) built as one-sided emissive meshes.

use super::container::{json_vec3, named, Loader};
use crate::error::Result;
use crate::math::{Mat3, Mat4, Vec3, Vec4};
use crate::scene::{units, Lamp, Light, Material, Mesh};
use serde_json::Value;

/// Segments of the fan that approximates disk and ellipse area lights.
pub(super) const AREA_LIGHT_SEGMENTS: usize = 32;

/// Parameters of a `PHOTON_light` area light.
pub(super) struct AreaLight {
    shape: String,
    size: f32,
    size_y: f32,
    power: f32,
    color: Vec3,
    visible_camera: bool,
    /// Full spread angle in radians; π emits over the whole hemisphere.
    spread: f32,
}

impl Loader {
    pub(super) fn add_lights(&mut self, node: &gltf::Node, world: &Mat4) -> Result<()> {
        let object = named("node", node.index(), node.name());
        let extension = node.extension_value("PHOTON_light");
        let number = |key: &str, default: f32| -> f32 {
            extension
                .and_then(|e| e.get(key))
                .and_then(Value::as_f64)
                .map_or(default, |v| v as f32)
        };
        let position = world.transform_point3(Vec3::ZERO);
        let direction = world
            .transform_vector3(Vec3::NEG_Z)
            .normalize_or(Vec3::NEG_Z);
        if extension
            .and_then(|e| e.get("type"))
            .and_then(Value::as_str)
            == Some("area")
        {
            let area = AreaLight {
                shape: extension
                    .and_then(|e| e.get("shape"))
                    .and_then(Value::as_str)
                    .unwrap_or("SQUARE")
                    .to_string(),
                size: number("size", 1.0),
                size_y: number("size_y", number("size", 1.0)),
                power: number("power", 10.0),
                color: extension
                    .and_then(|e| e.get("color"))
                    .and_then(json_vec3)
                    .unwrap_or(Vec3::ONE),
                visible_camera: extension
                    .and_then(|e| e.get("visible_camera"))
                    .and_then(Value::as_bool)
                    .unwrap_or(false),
                spread: number("spread", std::f32::consts::PI),
            };
            return self.add_area_light(node, world, &area, &object);
        }
        let Some(light) = node.light() else {
            return Ok(());
        };
        let object = format!("{object} PHOTON_light");
        let checked = |key: &str, ok: fn(f32) -> bool| -> Result<Option<f32>> {
            match extension.and_then(|e| e.get(key)) {
                None => Ok(None),
                Some(v) => match v.as_f64().map(|x| x as f32) {
                    Some(x) if x.is_finite() && ok(x) => Ok(Some(x)),
                    _ => Err(self.err(&object, format!("'{key}' is out of range: {v}"))),
                },
            }
        };
        // The extension's colour and power (Cycles' units) replace the photometric values.
        let tint = match extension.and_then(|e| e.get("color")) {
            None => None,
            Some(v) => Some(
                json_vec3(v)
                    .filter(|c| c.is_finite() && c.min_element() >= 0.0)
                    .ok_or_else(|| {
                        self.err(&object, format!("'color' must be three numbers ≥ 0: {v}"))
                    })?,
            ),
        };
        let color = tint.unwrap_or_else(|| Vec3::from(light.color()));
        let power = checked("power", |x| x >= 0.0)?.filter(|_| tint.is_some());
        let intensity = match power {
            Some(watts) => color * units::blender_point_power_to_intensity(watts),
            None => color * units::candela_to_watts_per_sr(light.intensity()),
        };
        let flag = |key: &str, default: bool| -> Result<bool> {
            match extension.and_then(|e| e.get(key)) {
                None => Ok(default),
                Some(v) => v.as_bool().ok_or_else(|| {
                    self.err(&object, format!("'{key}' must be true or false: {v}"))
                }),
            }
        };
        let defaults = Lamp::default();
        let lamp = Lamp {
            soft_falloff: flag("soft_falloff", defaults.soft_falloff)?,
            camera: flag("visible_camera", defaults.camera)?,
            bounces: flag("visible_bounces", defaults.bounces)?,
        };
        let light = match light.kind() {
            gltf::khr_lights_punctual::Kind::Point => Light::Point {
                position,
                intensity,
                radius: number("radius", 0.0),
                lamp,
            },
            gltf::khr_lights_punctual::Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                // Cycles' cone: smoothstep((cos θ − cos(size/2)) / ((1 − cos(size/2)) × blend)).
                let size = checked("spot_size", |x| x > 0.0 && x <= std::f32::consts::PI)?;
                let blend = checked("spot_blend", |x| (0.0..=1.0).contains(&x))?;
                let (cos_inner, cos_outer) = match size {
                    Some(size) => {
                        let cos_outer = (0.5 * size).cos();
                        let blend = blend.unwrap_or(0.0);
                        (cos_outer + (1.0 - cos_outer) * blend, cos_outer)
                    }
                    None => (inner_cone_angle.cos(), outer_cone_angle.cos()),
                };
                Light::Spot {
                    position,
                    direction,
                    intensity,
                    cos_inner,
                    cos_outer,
                    radius: number("radius", 0.0),
                    lamp,
                }
            }
            gltf::khr_lights_punctual::Kind::Directional => {
                let strength = checked("strength", |x| x >= 0.0)?.filter(|_| tint.is_some());
                Light::Sun {
                    direction,
                    irradiance: match strength {
                        Some(e) => color * e,
                        None => color * units::lux_to_watts_per_m2(light.intensity()),
                    },
                    angle: number("angle", 0.0),
                }
            }
        };
        self.scene.lights.push(light);
        Ok(())
    }

    pub(super) fn add_area_light(
        &mut self,
        node: &gltf::Node,
        world: &Mat4,
        light: &AreaLight,
        object: &str,
    ) -> Result<()> {
        let (half_x, half_y) = match light.shape.as_str() {
            "SQUARE" | "DISK" => (0.5 * light.size, 0.5 * light.size),
            "RECTANGLE" | "ELLIPSE" => (0.5 * light.size, 0.5 * light.size_y),
            other => {
                return Err(self.err(
                    format!("{object} PHOTON_light"),
                    format!("unknown area light shape '{other}'"),
                ))
            }
        };
        // Local outline, counter-clockwise seen from −Z, so the winding normal points along −Z.
        let outline: Vec<Vec3> = if matches!(light.shape.as_str(), "SQUARE" | "RECTANGLE") {
            vec![
                Vec3::new(-half_x, -half_y, 0.0),
                Vec3::new(-half_x, half_y, 0.0),
                Vec3::new(half_x, half_y, 0.0),
                Vec3::new(half_x, -half_y, 0.0),
            ]
        } else {
            (0..AREA_LIGHT_SEGMENTS)
                .map(|i| {
                    let phi = -std::f32::consts::TAU * i as f32 / AREA_LIGHT_SEGMENTS as f32;
                    Vec3::new(half_x * phi.cos(), half_y * phi.sin(), 0.0)
                })
                .collect()
        };
        let linear = Mat3::from_mat4(*world);
        let mirrored = linear.determinant() < 0.0;
        let mut positions = vec![world.transform_point3(Vec3::ZERO)];
        positions.extend(outline.iter().map(|&p| world.transform_point3(p)));
        let n = outline.len() as u32;
        let indices: Vec<[u32; 3]> = (0..n)
            .map(|i| {
                let (a, b) = (1 + i, 1 + (i + 1) % n);
                if mirrored {
                    [0, b, a]
                } else {
                    [0, a, b]
                }
            })
            .collect();
        let area: f32 = indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| positions[i as usize]);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum();
        if !(area > 0.0 && area.is_finite()) {
            return Err(self.err(
                format!("{object} PHOTON_light"),
                format!("area light has zero or invalid area ({area})"),
            ));
        }
        let spread = light.spread;
        if !(0.0..=std::f32::consts::PI).contains(&spread) {
            return Err(self.err(
                format!("{object} PHOTON_light"),
                format!("area light spread {spread} is not an angle in [0, π] radians"),
            ));
        }
        let normal = (linear.inverse().transpose() * Vec3::NEG_Z).normalize_or(Vec3::NEG_Z);
        let name = node.name().unwrap_or("area light").to_string();
        let material = Material {
            name: format!("{name} (area light)"),
            base_color: Vec4::new(0.0, 0.0, 0.0, 1.0),
            metallic: 0.0,
            roughness: 1.0,
            specular: 0.0,
            emission: light.color * units::blender_area_power_to_radiance(light.power, area),
            double_sided: false,
            ..Material::default()
        };
        self.scene.materials.push(material);
        self.scene.meshes.push(Mesh {
            name: format!("{name} (area light)"),
            normals: vec![normal; positions.len()],
            positions,
            uvs: Vec::new(),
            extra_uvs: Vec::new(),
            tangents: Vec::new(),
            indices,
            material: (self.scene.materials.len() - 1) as u32,
            camera_visible: light.visible_camera,
            holdout: false,
            // Narrower than a milliradian is a laser nothing would sample; Cycles clamps too.
            emission_spread: (spread < std::f32::consts::PI).then_some(spread.max(1e-3)),
            casts_shadows: true,
            colors: Vec::new(),
            object_space: None,
            deformation: Vec::new(),
        });
        Ok(())
    }
}
