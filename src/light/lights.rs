//! The light list: every emitter of a scene (emissive triangles, emitting instances, point,
//! spot and sun lights, the world background), the distributions that pick one, `sample` (a
//! direction towards a light, for next-event estimation) and the matching densities for
//! multiple importance sampling (Veach 1997, ch. 9).
//!
//! An instance of an emitting prototype mesh is one light: a triangle of the prototype is
//! picked in proportion to its object-space area, and the point drawn on it is placed where the
//! instance is at the ray's (or photon's) moment, so moving emitters are sampled where they
//! are; the density is the picking probability over the triangle's area at that moment.
//!
//! A world of one constant colour is left out of the light samples that are weighed by MIS
//! against BSDF sampling, as Cycles leaves it out ("Background MIS has been disabled" in
//! `LightManager::test_enabled_lights`, unless the background varies or portals exist): BSDF
//! sampling finds a uniform sky as well as a uniform light sample does on a diffuse surface, far
//! better on a glossy one, and never wastes a direction below the horizon, so the light samples
//! all go to the lights that need them (the sun). A light sample without a BSDF counterpart
//! (`mis` false: the photon method's direct light without gather rays) still draws from every
//! light.

use super::emission::{
    emitter_point_at, placed_area, sample_emitter_point, spread_factor, triangle_areas,
    EmitterSample, SpreadWindow,
};
use super::environment::{sun_disk_radiance, EnvironmentLight};
use super::lamps::{sample_punctual_light, LampSet};
use super::linking::{hit_links, scene_is_linked};
use super::selection::{LocalSelection, Reach};
use super::source::{LightSample, LightSource, Receiver};
use crate::accel::{Accel, Hit, Ray, Visibility};
use crate::interaction::{LightPoint, SurfaceHit};
use crate::math::{luminance, Frame, Mat3, Vec2, Vec3};
use crate::sampling::{
    square_to_uniform_cone, square_to_uniform_sphere, uniform_cone_pdf, Distribution1D,
    UNIFORM_SPHERE_PDF,
};
use crate::scene::{Light, LightLinks, Scene};
use crate::shader::RayPath;
use std::f32::consts::PI;

/// All emitters of a scene and the distribution that picks one.
pub struct Lights {
    pub sources: Vec<LightSource>,
    /// Picks the light of a sample weighed by MIS against BSDF sampling: every light but a
    /// constant world (module header). The densities MIS reads (`triangle_pdf`, `lamps_met`,
    /// `escaped`) are this one's.
    select: Distribution1D,
    /// Picks the light of a sample without MIS, from every light; `None` when that is `select`.
    select_all: Option<Distribution1D>,
    /// With few lights, `select`'s weights turned into each light's irradiance at the shading
    /// point (`super::selection`): samples weighed by MIS pick half by it, half by `select`.
    local: Option<LocalSelection>,
    /// For each mesh, the index of its first triangle light (triangle lights are contiguous).
    mesh_first_light: Vec<Option<u32>>,
    /// For each instance, its light (`LightSource::Instance`) when its prototype emits; empty
    /// when none does.
    instance_light: Vec<Option<u32>>,
    /// For each prototype, the distribution that picks one of its triangles (by object-space
    /// area) when its material emits.
    prototype_triangles: Vec<Option<Distribution1D>>,
    /// Some light can be met by a ray: an emitting mesh, the world, a sun with a disk or a lamp
    /// seen by scattered rays (checked per camera sample by the photon method, so kept, not
    /// searched).
    hittable: bool,
    /// The lamps rays can meet (point and spot lights with a radius, `lamps_met`).
    lamps: LampSet,
    world: Option<u32>,
    environment: Option<EnvironmentLight>,
    /// The suns' sources, and whether camera rays see their discs.
    suns: Vec<(u32, bool)>,
    scene_center: Vec3,
    scene_radius: f32,
    /// Some material lets shadow rays through where its node tree gives a Transparent BSDF:
    /// shadow rays then evaluate the surfaces they meet (`direct::shadow_transmittance`).
    pub transparent_shadows: bool,
    /// Each source's light linking as an emitter (Blender's light and shadow linking), index
    /// for index; empty when the scene links nothing. A light of a blocker set is left to light
    /// sampling alone (rays do not meet it), its shadow rays passing what is not in the set.
    links: Vec<LightLinks>,
}

impl Lights {
    pub fn new(scene: &Scene) -> Self {
        let bounds = scene.bounds();
        let (scene_center, scene_radius) = if bounds.is_empty() {
            (Vec3::ZERO, 1.0)
        } else {
            (bounds.center(), (0.5 * bounds.diagonal()).max(1e-6))
        };
        let mut sources = Vec::new();
        let mut power = Vec::new();
        // For `LocalSelection`: where each light is, and its power over what turns power over
        // squared distance into irradiance.
        let mut reach = Vec::new();
        let mut reach_scale = Vec::new();
        let mut local_possible = true;
        let mut mesh_first_light = vec![None; scene.meshes.len()];
        for (mi, mesh) in scene.meshes.iter().enumerate() {
            let material = &scene.materials[mesh.material as usize];
            if !material.is_emissive() {
                continue;
            }
            mesh_first_light[mi] = Some(sources.len() as u32);
            let sides = if material.double_sided { 2.0 } else { 1.0 };
            for (ti, idx) in mesh.indices.iter().enumerate() {
                let p = idx.map(|i| mesh.positions[i as usize]);
                let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
                let area = if area.is_finite() { area } else { 0.0 };
                sources.push(LightSource::Triangle {
                    mesh: mi as u32,
                    triangle: ti as u32,
                    area,
                    two_sided: material.double_sided,
                });
                power.push(PI * luminance(material.emission) * area * sides);
                let normal = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
                reach.push(Reach::near(&p, (!material.double_sided).then_some(normal)));
                reach_scale.push(1.0 / (PI * sides));
                local_possible &= mesh.deformation.len() <= 1;
            }
        }
        let prototype_triangles: Vec<Option<Distribution1D>> = scene
            .prototypes
            .iter()
            .map(|mesh| {
                scene.materials[mesh.material as usize]
                    .is_emissive()
                    .then(|| Distribution1D::new(&triangle_areas(mesh)))
            })
            .collect();
        let mut instance_light = Vec::new();
        if prototype_triangles.iter().any(Option::is_some) {
            instance_light = vec![None; scene.instances.len()];
            for (i, instance) in scene.instances.iter().enumerate() {
                let prototype = instance.prototype as usize;
                let Some(triangles) = &prototype_triangles[prototype] else {
                    continue;
                };
                let mesh = &scene.prototypes[prototype];
                let material = &scene.materials[mesh.material as usize];
                // The object-space area scaled by the transform's mean areal factor (exact for
                // uniform scale): the share of samples only, never the density.
                let det = Mat3::from(instance.to_world.matrix3).determinant().abs();
                let area = triangles.total() as f32 * det.powf(2.0 / 3.0);
                let area = if area.is_finite() { area } else { 0.0 };
                let sides = if material.double_sided { 2.0 } else { 1.0 };
                instance_light[i] = Some(sources.len() as u32);
                local_possible = false;
                reach.push(Reach::Distant);
                reach_scale.push(0.0);
                sources.push(LightSource::Instance {
                    instance: i as u32,
                    area,
                    two_sided: material.double_sided,
                });
                power.push(PI * luminance(material.emission) * area * sides);
            }
        }
        let mut suns = Vec::new();
        for light in &scene.lights {
            match *light {
                Light::Point {
                    position,
                    intensity,
                    radius,
                    lamp,
                } => {
                    sources.push(LightSource::Point {
                        position,
                        intensity,
                        radius,
                        lamp,
                    });
                    power.push(4.0 * PI * luminance(intensity));
                    reach.push(Reach::sphere(position, radius));
                    reach_scale.push(1.0 / (4.0 * PI));
                }
                Light::Spot {
                    position,
                    direction,
                    intensity,
                    cos_inner,
                    cos_outer,
                    radius,
                    lamp,
                } => {
                    sources.push(LightSource::Spot {
                        position,
                        direction: direction.normalize_or(-Vec3::Z),
                        intensity,
                        cos_inner,
                        cos_outer,
                        radius,
                        lamp,
                    });
                    power.push(4.0 * PI * luminance(intensity));
                    reach.push(Reach::sphere(position, radius));
                    reach_scale.push(1.0 / (4.0 * PI));
                }
                Light::Sun {
                    direction,
                    irradiance,
                    angle,
                    camera,
                } => {
                    suns.push((sources.len() as u32, camera));
                    let half = (0.5 * angle).clamp(0.0, 0.5 * PI);
                    sources.push(LightSource::Sun {
                        to_sun: -direction.normalize_or(-Vec3::Z),
                        irradiance,
                        cos_max: if half > 0.0 { half.cos() } else { 1.0 },
                    });
                    power.push(luminance(irradiance) * PI * scene_radius * scene_radius);
                    reach.push(Reach::Sun {
                        to_sun: -direction.normalize_or(-Vec3::Z),
                        sin_half: half.sin(),
                    });
                    reach_scale.push(1.0 / (PI * scene_radius * scene_radius));
                }
            }
        }
        let mut world = None;
        let background = &scene.world.background;
        let environment = background.environment.as_ref().map(EnvironmentLight::new);
        let radiance = match &environment {
            Some(env) => env.average,
            None => background.color,
        };
        let mut select_all = None;
        if luminance(radiance) > 0.0 {
            world = Some(sources.len() as u32);
            sources.push(LightSource::World { radiance });
            let world_power = PI * PI * luminance(radiance) * scene_radius * scene_radius;
            reach.push(Reach::Distant);
            reach_scale.push(1.0 / (PI * scene_radius * scene_radius));
            if environment.is_some() {
                power.push(world_power);
            } else {
                let mut all = power.clone();
                all.push(world_power);
                select_all = Some(Distribution1D::new(&all));
                power.push(0.0);
            }
        }
        let soft_sun = suns.iter().any(
            |&(s, _)| matches!(sources[s as usize], LightSource::Sun { cos_max, .. } if cos_max < 1.0),
        );
        let emitting_mesh = mesh_first_light.iter().any(Option::is_some)
            || instance_light.iter().any(Option::is_some);
        let transparent_shadows = scene.materials.iter().any(|m| {
            m.nodes
                .as_ref()
                .is_some_and(|program| program.shadow_transparent)
        });
        let lamps = LampSet::new(&sources);
        let links = match scene_is_linked(scene) {
            false => Vec::new(),
            true => {
                // Point, spot and sun sources follow `Scene::lights` in order.
                let mut punctual = scene.light_links.iter().copied();
                sources
                    .iter()
                    .map(|source| match *source {
                        LightSource::Triangle { mesh, .. } => scene.meshes[mesh as usize].links,
                        LightSource::Instance { instance, .. } => {
                            scene.instances[instance as usize].links
                        }
                        LightSource::Point { .. }
                        | LightSource::Spot { .. }
                        | LightSource::Sun { .. } => punctual.next().unwrap_or(LightLinks::NONE),
                        LightSource::World { .. } => LightLinks::NONE,
                    })
                    .collect()
            }
        };
        let local = local_possible
            .then(|| LocalSelection::new(&power, &reach, &reach_scale))
            .flatten();
        Lights {
            transparent_shadows,
            hittable: emitting_mesh || world.is_some() || soft_sun || lamps.seen_by_bounces(),
            lamps,
            sources,
            select: Distribution1D::new(&power),
            select_all,
            local,
            mesh_first_light,
            instance_light,
            prototype_triangles,
            world,
            environment,
            suns,
            scene_center,
            scene_radius,
            links,
        }
    }

    /// Whether a ray leaving `from` counts the light of source `index` it meets: the light
    /// lights `from`'s object and is not left to light sampling by shadow linking.
    fn meets(&self, from: Receiver, index: usize) -> bool {
        match self.links.get(index) {
            None => true,
            Some(l) => from.lit_by >> l.receiver_set & 1 == 1 && l.blocker_set == 0,
        }
    }

    /// Whether a ray leaving `from` counts the emission of the surface it hit (`hit`), as
    /// `meets` for lamps.
    pub fn emission_counts(&self, scene: &Scene, from: Receiver, hit: &Hit) -> bool {
        if self.links.is_empty() {
            return true;
        }
        let l = hit_links(scene, hit);
        from.lit_by >> l.receiver_set & 1 == 1 && l.blocker_set == 0
    }

    /// Whether a photon of source `index` leaving along `ray` may go on: false when light
    /// linking keeps that light from the object the photon meets first, where its light
    /// neither lands nor scatters (without media, which the photon could scatter in first).
    pub fn photon_lands(&self, scene: &Scene, accel: &Accel, index: usize, ray: &Ray) -> bool {
        let Some(l) = self.links.get(index) else {
            return true;
        };
        if l.receiver_set == 0 || scene.has_media() {
            return true;
        }
        accel
            .intersect(scene, ray, Visibility::Secondary)
            .is_none_or(|hit| hit_links(scene, &hit).lit_by >> l.receiver_set & 1 == 1)
    }

    /// Whether a ray can meet a lamp (`lamps_met`).
    pub fn has_lamps(&self) -> bool {
        !self.lamps.is_empty()
    }

    /// Whether the scene links any light or object (`Scene::light_links`, `Mesh::links`).
    pub fn linked(&self) -> bool {
        !self.links.is_empty()
    }

    pub fn is_empty(&self) -> bool {
        self.select.is_empty()
            && self
                .select_all
                .as_ref()
                .is_none_or(Distribution1D::is_empty)
    }

    /// True when a ray can meet some light (an emitting mesh, the world, a sun with a disk, a
    /// lamp seen by scattered rays), so that BSDF sampling can find what light sampling also
    /// does.
    pub fn hittable(&self) -> bool {
        self.hittable
    }

    /// A point far enough along `dir` from `p` to be outside the scene: the end of shadow rays
    /// towards distant lights.
    pub(super) fn far_point(&self, p: Vec3, dir: Vec3) -> LightPoint {
        let reach = 2.0 * (self.scene_radius + (p - self.scene_center).length());
        LightPoint {
            p: p + dir * reach,
            p_error: Vec3::ZERO,
            n: Vec3::ZERO,
            distant: true,
        }
    }

    /// Pick a light with `u_select` and sample a direction towards it from `from`, seen at moment
    /// `time` of the shutter (where moving emitters are then).
    /// `path`: the path at `from`, which an emitter's node tree reads as it is sampled from
    /// there (`RayPath::emission`). `mis`: the sample will be weighed by MIS against BSDF
    /// sampling, which alone finds a constant world (module header); without it every light
    /// may be picked.
    #[allow(clippy::too_many_arguments)]
    pub fn sample(
        &self,
        scene: &Scene,
        from: Receiver,
        path: RayPath,
        time: f32,
        mis: bool,
        u_select: f32,
        u: Vec2,
    ) -> Option<LightSample> {
        let p = from.p;
        let (index, pmf, u_pick) = match (&self.local, &self.select_all, mis) {
            (_, Some(all), false) => all.sample_remapped(u_select)?,
            (Some(local), _, true) => local.sample(from, u_select, &self.select)?,
            _ => self.select.sample_remapped(u_select)?,
        };
        let links = self.links.get(index);
        if links.is_some_and(|l| from.lit_by >> l.receiver_set & 1 == 0) {
            return None;
        }
        let mut s = self.sample_source(scene, index, (p, path), time, u_pick, u)?;
        s.pdf *= pmf;
        if let Some(l) = links.filter(|l| l.blocker_set != 0) {
            s.delta = true;
            s.blockers = l.blocker_set;
        }
        (s.pdf > 0.0 && s.pdf.is_finite()).then_some(s)
    }

    /// A point on emitting geometry `index` (`LightSource::Triangle` or `Instance`) drawn with
    /// `u` at moment `time`, `u_pick` picking an instance's triangle; `seen_from` as for
    /// `sample_emitter_point`. `None` for other lights and degenerate triangles.
    pub fn sample_emitter(
        &self,
        scene: &Scene,
        index: usize,
        u_pick: f32,
        u: Vec2,
        time: f32,
        seen_from: Option<(Vec3, RayPath)>,
    ) -> Option<EmitterSample> {
        match self.sources[index] {
            LightSource::Triangle {
                mesh,
                triangle,
                area,
                two_sided,
            } => {
                let m = &scene.meshes[mesh as usize];
                (area > 0.0).then(|| EmitterSample {
                    emitter: sample_emitter_point(scene, m, triangle, None, time, u, seen_from),
                    area,
                    two_sided,
                    spread: m.emission_spread,
                })
            }
            LightSource::Instance {
                instance,
                two_sided,
                ..
            } => {
                let instance = &scene.instances[instance as usize];
                let prototype = instance.prototype as usize;
                let (triangle, pmf) = self.prototype_triangles[prototype]
                    .as_ref()?
                    .sample(u_pick)?;
                let m = &scene.prototypes[prototype];
                let to_world = instance.to_world_at(time);
                let area = placed_area(m, triangle as u32, to_world, time);
                let (triangle, placed) = (triangle as u32, Some(to_world));
                let emitter = sample_emitter_point(scene, m, triangle, placed, time, u, seen_from);
                (area > 0.0 && pmf > 0.0).then_some(EmitterSample {
                    emitter,
                    area: area / pmf,
                    two_sided,
                    spread: m.emission_spread,
                })
            }
            _ => None,
        }
    }

    pub(super) fn sample_source(
        &self,
        scene: &Scene,
        index: usize,
        from: (Vec3, RayPath),
        time: f32,
        u_pick: f32,
        u: Vec2,
    ) -> Option<LightSample> {
        let p = from.0;
        match self.sources[index] {
            LightSource::Triangle { .. } | LightSource::Instance { .. } => {
                let EmitterSample {
                    emitter,
                    area,
                    two_sided,
                    spread,
                } = match self.spread_window(scene, index, p, time) {
                    Some((window, mesh, triangle)) => {
                        let b = window.sample(u)?;
                        let m = &scene.meshes[mesh as usize];
                        let point = emitter_point_at(scene, m, triangle, None, time, b, Some(from));
                        EmitterSample {
                            emitter: point,
                            area: window.area(),
                            two_sided: matches!(
                                self.sources[index],
                                LightSource::Triangle {
                                    two_sided: true,
                                    ..
                                }
                            ),
                            spread: m.emission_spread,
                        }
                    }
                    None => self.sample_emitter(scene, index, u_pick, u, time, Some(from))?,
                };
                let (q, n) = (emitter.point.p, emitter.point.n);
                let d = q - p;
                let dist2 = d.length_squared();
                if !(dist2 > 0.0) {
                    return None;
                }
                let wi = d / dist2.sqrt();
                let cos_l = -wi.dot(n);
                if cos_l <= 0.0 && !two_sided {
                    return None;
                }
                let cos_l = cos_l.abs();
                if cos_l <= 0.0 {
                    return None;
                }
                let spread = spread_factor(spread, cos_l);
                if spread <= 0.0 {
                    return None;
                }
                Some(LightSample {
                    li: emitter.radiance * spread,
                    wi,
                    pdf: dist2 / (cos_l * area),
                    delta: false,
                    target: emitter.point,
                    blockers: 0,
                })
            }
            LightSource::Point { .. } | LightSource::Spot { .. } => {
                sample_punctual_light(&self.sources[index], p, u)
            }
            LightSource::Sun {
                to_sun,
                irradiance,
                cos_max,
            } => {
                if cos_max >= 1.0 {
                    return Some(LightSample {
                        li: irradiance,
                        wi: to_sun,
                        pdf: 1.0,
                        delta: true,
                        target: self.far_point(p, to_sun),
                        blockers: 0,
                    });
                }
                let wi = Frame::from_normal(to_sun).to_world(square_to_uniform_cone(u, cos_max));
                Some(LightSample {
                    li: sun_disk_radiance(irradiance, cos_max),
                    wi,
                    pdf: uniform_cone_pdf(cos_max),
                    delta: false,
                    target: self.far_point(p, wi),
                    blockers: 0,
                })
            }
            LightSource::World { .. } => {
                let (wi, li, pdf) = self.sample_world(u)?;
                Some(LightSample {
                    li,
                    wi,
                    pdf,
                    delta: false,
                    target: self.far_point(p, wi),
                    blockers: 0,
                })
            }
        }
    }

    /// Solid-angle density with which `sample` would have chosen the point `hit` on an emissive
    /// triangle, seen from `from` (for MIS when a BSDF-sampled ray hits an emitter).
    pub fn triangle_pdf(&self, scene: &Scene, from: Receiver, hit: &SurfaceHit) -> f32 {
        if hit.hit.instance != crate::accel::NO_INSTANCE {
            return self.instance_triangle_pdf(scene, from, hit);
        }
        let Some(first) = self
            .mesh_first_light
            .get(hit.mesh as usize)
            .copied()
            .flatten()
        else {
            return 0.0;
        };
        let index = (first + hit.triangle) as usize;
        let LightSource::Triangle { area, .. } = self.sources[index] else {
            return 0.0;
        };
        // A spread area light seen from `from` is drawn in its window only.
        let area = match self.spread_window(scene, index, from.p, hit.time) {
            Some((window, ..)) if window.contains(hit.p) => window.area(),
            Some(_) => return 0.0,
            None => area,
        };
        let d = hit.p - from.p;
        let dist2 = d.length_squared();
        let cos_l = (d.normalize_or_zero().dot(hit.ng)).abs();
        if area <= 0.0 || cos_l <= 0.0 {
            return 0.0;
        }
        self.pick_pmf(from, index) * dist2 / (cos_l * area)
    }

    /// The window of emitting triangle `index` (a `LightSource::Triangle` of a mesh with an
    /// area-light spread) that light sampling from `p` draws points in, with the triangle's
    /// mesh and index; `None` where the whole triangle is drawn from.
    fn spread_window(
        &self,
        scene: &Scene,
        index: usize,
        p: Vec3,
        time: f32,
    ) -> Option<(SpreadWindow, u32, u32)> {
        let LightSource::Triangle { mesh, triangle, .. } = self.sources[index] else {
            return None;
        };
        let m = &scene.meshes[mesh as usize];
        let spread = m.emission_spread?;
        let window = SpreadWindow::new(m.triangle_at(triangle, time), p, spread)?;
        Some((window, mesh, triangle))
    }

    /// `triangle_pdf` of a point on an instance: the instance's share, its triangle's, and the
    /// triangle's area where the instance is at the hit's moment.
    pub(super) fn instance_triangle_pdf(
        &self,
        scene: &Scene,
        from: Receiver,
        hit: &SurfaceHit,
    ) -> f32 {
        let Some(index) = self
            .instance_light
            .get(hit.hit.instance as usize)
            .copied()
            .flatten()
        else {
            return 0.0;
        };
        let instance = &scene.instances[hit.hit.instance as usize];
        let Some(triangles) = &self.prototype_triangles[instance.prototype as usize] else {
            return 0.0;
        };
        let mesh = &scene.prototypes[instance.prototype as usize];
        let area = placed_area(mesh, hit.triangle, instance.to_world_at(hit.time), hit.time);
        let d = hit.p - from.p;
        let dist2 = d.length_squared();
        let cos_l = (d.normalize_or_zero().dot(hit.ng)).abs();
        if !(area > 0.0) || cos_l <= 0.0 {
            return 0.0;
        }
        self.pick_pmf(from, index as usize) * triangles.pmf(hit.triangle as usize) * dist2
            / (cos_l * area)
    }

    /// The lamps (point and spot lights with a radius) `ray` meets before distance `reach`
    /// along it (in units of its direction's length, as `Hit::t` × that length): for each,
    /// `visit(radiance, pdf, distance)` with the radiance arriving along the ray (a spot's cone
    /// evaluated along it, as Cycles does), the density with which light sampling from the
    /// ray's origin draws that direction (with the probability of picking the lamp; for MIS)
    /// and the lamp's distance. `camera`: a camera ray, which sees the lamps Blender shows the
    /// camera; any other ray is one a surface scattered. As in Cycles a lamp is not geometry:
    /// the ray passes through it (Cycles counts a transparent bounce), so every lamp on the way
    /// counts. From inside a sphere lamp a ray meets its far side. `from`: the vertex the ray
    /// left, where the light sample it is weighed against was drawn.
    pub fn lamps_met(
        &self,
        ray: &Ray,
        from: Receiver,
        reach: f32,
        camera: bool,
        mut visit: impl FnMut(Vec3, f32, f32),
    ) {
        self.lamps
            .met(&self.sources, ray, reach, camera, |i, radiance, pdf, t| {
                if self.meets(from, i as usize) {
                    visit(radiance, self.pick_pmf(from, i as usize) * pdf, t)
                }
            });
    }

    /// Radiance of distant emitters (world and soft suns) seen along `dir`, each paired with its
    /// light-sampling density for MIS at `from`, the vertex the ray left: returns (radiance,
    /// pdf) per emitter via `visit`. A `camera` ray misses the discs of suns hidden from the
    /// camera.
    pub fn escaped(
        &self,
        from: Receiver,
        dir: Vec3,
        camera: bool,
        mut visit: impl FnMut(Vec3, f32),
    ) {
        if let Some(w) = self.world {
            let (radiance, pdf) = self.world_radiance(dir);
            visit(radiance, self.pick_pmf(from, w as usize) * pdf);
        }
        for &(s, seen_by_camera) in &self.suns {
            if camera && !seen_by_camera {
                continue;
            }
            if let LightSource::Sun {
                to_sun,
                irradiance,
                cos_max,
            } = self.sources[s as usize]
            {
                if cos_max < 1.0 && dir.dot(to_sun) >= cos_max && self.meets(from, s as usize) {
                    visit(
                        sun_disk_radiance(irradiance, cos_max),
                        self.pick_pmf(from, s as usize) * uniform_cone_pdf(cos_max),
                    );
                }
            }
        }
    }

    /// Probability that a light sample weighed by MIS, drawn from `from`, picks light `index`.
    pub(super) fn pick_pmf(&self, from: Receiver, index: usize) -> f32 {
        match &self.local {
            Some(local) => local.pmf(from, index, &self.select),
            None => self.select.pmf(index),
        }
    }

    /// A direction towards the world background (for light samples and photon emission), the
    /// radiance arriving along it and its solid-angle density, not counting the probability of
    /// choosing the world: the environment map by importance, a constant colour uniformly.
    pub fn sample_world(&self, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        let w = self.world?;
        match &self.environment {
            Some(env) => env.sample(u),
            None => {
                let LightSource::World { radiance } = self.sources[w as usize] else {
                    return None;
                };
                Some((square_to_uniform_sphere(u), radiance, UNIFORM_SPHERE_PDF))
            }
        }
    }

    /// Radiance of the world background along `dir` and the density `sample_world` gives it.
    pub(super) fn world_radiance(&self, dir: Vec3) -> (Vec3, f32) {
        match (&self.environment, self.world) {
            (Some(env), _) => (env.eval(dir), env.pdf(dir)),
            (None, Some(w)) => match self.sources[w as usize] {
                LightSource::World { radiance } => (radiance, UNIFORM_SPHERE_PDF),
                _ => (Vec3::ZERO, 0.0),
            },
            (None, None) => (Vec3::ZERO, 0.0),
        }
    }

    /// Bounding sphere of the scene geometry (centre, radius).
    pub fn scene_sphere(&self) -> (Vec3, f32) {
        (self.scene_center, self.scene_radius)
    }
}
