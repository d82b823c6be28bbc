//! KHR_lights_punctual lights (photometric units converted by `scene::units`) with Photon's
//! `PHOTON_light` additions: Cycles' power, colour and spot cone, lamp radius and visibility, and
//! area lights (which Blender's exporter drops) built as one-sided emissive meshes.

use super::container::{named, Loader};
use super::extensions::{AreaLight, AreaShape, LightExtension, PunctualExtension};
use crate::error::Result;
use crate::math::{Mat3, Mat4, Vec3, Vec4};
use crate::scene::{units, Light, LightLinks, Material, Mesh};

/// Segments of the fan that approximates disk and ellipse area lights.
pub(super) const AREA_LIGHT_SEGMENTS: usize = 32;

impl Loader {
    /// The lights of `node` placed by `world`: its KHR_lights_punctual light with what its
    /// `PHOTON_light` (`extension`) adds, or the area light that extension describes.
    pub(super) fn add_lights(
        &mut self,
        node: &gltf::Node,
        world: &Mat4,
        extension: Option<&LightExtension>,
    ) -> Result<()> {
        let object = named("node", node.index(), node.name());
        let position = world.transform_point3(Vec3::ZERO);
        let direction = world
            .transform_vector3(Vec3::NEG_Z)
            .normalize_or(Vec3::NEG_Z);
        let default = PunctualExtension::default();
        let extension = match extension {
            Some(LightExtension::Area(area)) => {
                return self.add_area_light(node, world, area, &object)
            }
            Some(LightExtension::Punctual(punctual)) => punctual,
            None => &default,
        };
        let Some(light) = node.light() else {
            return Ok(());
        };
        // The extension's colour and power (Cycles' units) replace the photometric values.
        let tint = extension.color;
        let color = tint.unwrap_or_else(|| Vec3::from(light.color()));
        let power = extension.power.filter(|_| tint.is_some());
        let intensity = match power {
            Some(watts) => color * units::blender_point_power_to_intensity(watts),
            None => color * units::candela_to_watts_per_sr(light.intensity()),
        };
        let lamp = extension.lamp;
        let light = match light.kind() {
            gltf::khr_lights_punctual::Kind::Point => Light::Point {
                position,
                intensity,
                radius: extension.radius,
                lamp,
            },
            gltf::khr_lights_punctual::Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                // Cycles' cone: smoothstep((cos θ − cos(size/2)) / ((1 − cos(size/2)) × blend)).
                let (cos_inner, cos_outer) = match extension.spot_size {
                    Some(size) => {
                        let cos_outer = (0.5 * size).cos();
                        let blend = extension.spot_blend.unwrap_or(0.0);
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
                    radius: extension.radius,
                    lamp,
                }
            }
            gltf::khr_lights_punctual::Kind::Directional => {
                let strength = extension.strength.filter(|_| tint.is_some());
                Light::Sun {
                    direction,
                    irradiance: match strength {
                        Some(e) => color * e,
                        None => color * units::lux_to_watts_per_m2(light.intensity()),
                    },
                    angle: extension.angle,
                    camera: extension.lamp.camera,
                }
            }
        };
        self.scene.lights.push(light);
        let links = self.node_extensions[node.index()].object.links;
        if links != LightLinks::NONE {
            let lights = self.scene.lights.len();
            self.scene.light_links.resize(lights - 1, LightLinks::NONE);
            self.scene.light_links.push(links);
        }
        Ok(())
    }

    pub(super) fn add_area_light(
        &mut self,
        node: &gltf::Node,
        world: &Mat4,
        light: &AreaLight,
        object: &str,
    ) -> Result<()> {
        let (half_x, half_y) = match light.shape {
            AreaShape::Square | AreaShape::Disk => (0.5 * light.size, 0.5 * light.size),
            AreaShape::Rectangle | AreaShape::Ellipse => (0.5 * light.size, 0.5 * light.size_y),
        };
        // Local outline, counter-clockwise seen from −Z, so the winding normal points along −Z.
        let outline: Vec<Vec3> = if matches!(light.shape, AreaShape::Square | AreaShape::Rectangle)
        {
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
            volume_grids: None,
            links: self.node_extensions[node.index()].object.links,
            shadow_catcher: false,
            object_info: Default::default(),
            node_attributes: Default::default(),
            undisplaced: Vec::new(),
        });
        Ok(())
    }
}
