//! Photon tracing, the first half of photon mapping: photon emission and tracing (Jensen 2001,
//! "Realistic Image Synthesis Using Photon Mapping", ch. 5). Photons leave the lights in proportion to their power, scatter with the same
//! BSDFs as camera paths, survive by Russian roulette on the sampled weight (so stored powers stay
//! nearly equal) and are stored at every hit on a surface that is not specular.
//!
//! Emission, per light kind (Φ is the light's flux, p its selection probability, N the number of
//! photons emitted; a photon carries Φ/(p·N), or the exact per-sample flux for varying emitters):
//! - emissive triangle: a uniform point, a cosine-distributed direction, Le(x)·π·A·sides;
//!   two-sided emitters pick a side with probability ½;
//! - point light: uniform sphere, 4π·I;
//! - spot light: uniform within the outer cone, I·smoothstep falloff / cone pdf (as light.rs);
//! - sun: parallel rays from a disc of the scene's bounding radius R, facing the sun (soft suns
//!   jitter the direction within their cone), E·πR²;
//! - world: a direction as `Lights::sample_world` draws it (uniform for a constant colour, by
//!   importance for an environment map), then a disc of radius R outside the scene facing it,
//!   L(ω)·πR²/pdf(ω);
//! - emitting medium: a point where it emits, a uniform direction, 4π·ε(x)/pdf(x)
//!   (`super::volume_emitters`).
//!
//! Global and subsurface photons of the sun, the world and point and spot lights may be guided
//! (`super::guide`): drawn where they reach what the render reads, their power divided by that
//! density.
//!
//! Caustic photons are aimed (Jensen's projection maps, with bounding spheres): only photons
//! whose first hit is a specular surface can start a caustic path, so caustic photon tracing draws
//! directions (for the sun and the world, ray positions) towards the specular meshes' bounding
//! spheres (`Targets`) and divides the power by that density instead. On glass_caustic this
//! stores 441 677 of 500 000 emitted caustic photons instead of 25 600.

use super::guide::{EmissionGuide, ReadRegion};
use super::volume_emitters::{volume_emitters, VolumeEmitter};
use crate::accel::{Ray, Visibility, FRAME_TIME};
use crate::bsdf::{BsdfSample, PathFilter};
use crate::error::{Error, Result};
use crate::integrator::classify::{is_specular, stores_photons};
use crate::integrator::media::MediumStack;
use crate::integrator::shading::{transmittance, LightPathFilter, PathHistory, Shading};
use crate::integrator::walk::Clamp;
use crate::integrator::Context;
use crate::interaction::{offset_origin, LightPoint, SurfaceHit};
use crate::light::{smoothstep, spread_factor, EmitterSample, LightSource, Receiver};
use crate::math::{luminance, max_component, Frame, Vec2, Vec3};
use crate::medium::{fly, transmittance as medium_transmittance, Flight};
use crate::photon_map::Photon;
use crate::progress::{Progress, ProgressEvent};
use crate::rng::{Rng, Sampler};
use crate::sampling::{
    power_heuristic, square_to_cosine_hemisphere, square_to_disk, square_to_uniform_cone,
    square_to_uniform_sphere, uniform_cone_pdf, Distribution1D,
};
use crate::scene::{instance_bounds, Bounds, Scene};
use crate::subsurface::Sample;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::sync::atomic::{AtomicU64, Ordering};

/// Photons per work item of `trace_photons` (a batch has its own random stream).
const BATCH: u32 = 4096;

/// One emitted photon.
pub struct Emitted {
    /// Its first ray.
    pub ray: Ray,
    /// Its power, before dividing by the photon count.
    pub power: Vec3,
    /// The light it left: an index into `Lights::sources`; `None` for an emitting medium.
    pub light: Option<usize>,
    /// The media where it leaves, when the emitter found them (else the walk finds them).
    media: Option<MediumStack>,
    /// The radiance a camera path's ray meets at the emitter where the photon leaves, along
    /// the photon's first ray (infinite for lights no ray meets: a point light of no radius,
    /// a sun of no angle); what Blender's Clamp Indirect weighs a caustic path's contribution
    /// by (`caustic_clamp`). `None` for an emitting medium.
    radiance: Option<Vec3>,
}

impl Emitted {
    /// Whether it left an emitting medium (its first vertex is in the medium, which no light
    /// sample of the camera paths draws from).
    fn left_a_medium(&self) -> bool {
        self.light.is_none()
    }
}

/// The lights and the emitting media as photon sources, chosen in proportion to their flux
/// (luminance): the first `Lights::sources.len()` choices are the lights.
pub struct Emitters {
    select: Distribution1D,
    volumes: Vec<VolumeEmitter>,
    center: Vec3,
    radius: f32,
    /// Where caustic photons are aimed; `None` when no mesh is specular.
    targets: Option<Targets>,
    /// Some instance moves while the shutter is open: each photon takes a moment within it.
    motion: bool,
    /// Where unaimed photons of the sun, the world and point and spot lights leave
    /// (`super::guide`); `None`: uniformly.
    guide: Option<EmissionGuide>,
}

/// RGB flux of a light (for textured emitters, of the emission factor).
fn light_flux(ctx: &Context, source: &LightSource, radius: f32) -> Vec3 {
    match *source {
        LightSource::Triangle {
            mesh,
            area,
            two_sided,
            ..
        } => {
            let m = &ctx.scene.meshes[mesh as usize];
            let sides = if two_sided { 2.0 } else { 1.0 };
            ctx.scene.materials[m.material as usize].emission * (PI * area * sides)
        }
        LightSource::Instance {
            instance,
            area,
            two_sided,
        } => {
            let prototype = ctx.scene.instances[instance as usize].prototype;
            let m = &ctx.scene.prototypes[prototype as usize];
            let sides = if two_sided { 2.0 } else { 1.0 };
            ctx.scene.materials[m.material as usize].emission * (PI * area * sides)
        }
        LightSource::Point { intensity, .. } => intensity * (4.0 * PI),
        LightSource::Spot {
            intensity,
            cos_outer,
            ..
        } => intensity * (2.0 * PI * (1.0 - cos_outer.clamp(-1.0, 1.0))),
        LightSource::Sun { irradiance, .. } => irradiance * (PI * radius * radius),
        LightSource::World { radiance } => radiance * (4.0 * PI * PI * radius * radius),
    }
}

impl Emitters {
    pub fn new(ctx: &Context) -> Emitters {
        let (center, radius) = ctx.lights.scene_sphere();
        let volumes = volume_emitters(ctx);
        let lights = ctx.lights.sources.iter();
        let power: Vec<f32> = lights
            .map(|s| luminance(light_flux(ctx, s, radius)))
            .chain(volumes.iter().map(|v| luminance(v.flux())))
            .collect();
        Emitters {
            select: Distribution1D::new(&power),
            volumes,
            center,
            radius,
            targets: Targets::new(ctx),
            motion: ctx.scene.has_motion(),
            guide: None,
        }
    }

    /// The emitters with their photons guided towards what the camera's paths meet in an
    /// image of aspect ratio `aspect` (`super::guide`); uniform where that gains nothing.
    pub fn guided(ctx: &Context, aspect: f32, seed: u64) -> Emitters {
        let mut emitters = Emitters::new(ctx);
        let guidable = ctx.lights.sources.iter().any(|s| {
            !matches!(
                s,
                LightSource::Triangle { .. } | LightSource::Instance { .. }
            )
        });
        if guidable {
            if let Some(region) = ReadRegion::new(ctx, aspect, seed) {
                let shares: Vec<f32> = (0..ctx.lights.sources.len())
                    .map(|i| emitters.select.pmf(i))
                    .collect();
                let trace = |light, u1, u2, rng: &mut Rng, out: &mut Vec<(Vec3, Vec3, f32)>| {
                    let Some(e) = emitters.emit_with(ctx, light, None, (0.5, u1, u2), rng) else {
                        return;
                    };
                    let reached = |s: &Shading, power: Vec3, _, _| {
                        out.push((s.sh.p, s.ng, luminance(power)));
                        true
                    };
                    walk_photon(ctx, &e, ctx.max_depth, rng, reached, None);
                };
                emitters.guide = EmissionGuide::new(ctx, &region, &shares, seed, trace);
            }
        }
        emitters
    }

    /// Whether some light's photons are guided.
    pub fn is_guided(&self) -> bool {
        self.guide.is_some()
    }

    /// True when some mesh is specular, so caustic photons have somewhere to go.
    pub fn has_caustic_targets(&self) -> bool {
        self.targets.is_some()
    }

    /// Total emitted flux (RGB) as the photons carry it (the emitting media's as their pilots
    /// estimate it), for tests and statistics.
    pub fn total_flux(&self, ctx: &Context) -> Vec3 {
        let lights = ctx.lights.sources.iter();
        let lights: Vec3 = lights.map(|s| light_flux(ctx, s, self.radius)).sum();
        lights + self.volumes.iter().map(|v| v.flux()).sum::<Vec3>()
    }

    /// Emit one photon. `aimed` photons (for the caustic map) leave only towards the specular
    /// meshes' bounding spheres (the parallel rays of the sun and the world: through them), and
    /// their power divides by that density instead.
    pub fn emit(&self, ctx: &Context, aimed: bool, rng: &mut Rng) -> Option<Emitted> {
        let aim = if aimed { self.targets.as_ref() } else { None };
        let (index, pmf, u_pick) = self.select.sample_remapped(rng.uniform())?;
        let (mut u1, mut u2) = (rng.uniform2(), rng.uniform2());
        if let Some(volume) = index
            .checked_sub(ctx.lights.sources.len())
            .and_then(|k| self.volumes.get(k))
        {
            let time = self.moment(rng);
            let (ray, power, media) = volume.emit(ctx, (u_pick, u1, rng.uniform()), u2, time)?;
            let e = Emitted {
                ray,
                power: power / pmf,
                light: None,
                media: Some(media),
                radiance: None,
            };
            return (e.power.is_finite() && max_component(e.power) > 0.0).then_some(e);
        }
        let mut density = 1.0;
        if let (None, Some(guide)) = (aim, &self.guide) {
            if let Some(warped) = guide.sample(index, u1, u2) {
                (u1, u2, density) = warped?;
            }
        }
        let mut e = self.emit_with(ctx, index, aim, (u_pick, u1, u2), rng)?;
        e.power /= pmf * density;
        (e.power.is_finite() && max_component(e.power) > 0.0).then_some(e)
    }

    /// The moment a photon leaves at: drawn only with motion, so that still scenes keep their
    /// photon streams.
    fn moment(&self, rng: &mut Rng) -> f32 {
        if self.motion {
            rng.uniform()
        } else {
            FRAME_TIME
        }
    }

    /// A photon of light `index` placed by the unit-square points `u1` and `u2` (`aim` as in
    /// `emit`; `u_pick` in [0, 1) picks the triangle of an emitting instance), its power before
    /// dividing by the light's selection probability.
    fn emit_with(
        &self,
        ctx: &Context,
        index: usize,
        aim: Option<&Targets>,
        (u_pick, u1, u2): (f32, Vec2, Vec2),
        rng: &mut Rng,
    ) -> Option<Emitted> {
        let time = self.moment(rng);
        let ray = |origin, direction| Ray {
            origin,
            direction,
            t_max: f32::INFINITY,
            time,
        };
        let (r, power, seen) = match ctx.lights.sources[index] {
            LightSource::Triangle { .. } | LightSource::Instance { .. } => {
                let EmitterSample {
                    emitter,
                    area,
                    two_sided,
                    spread,
                } = ctx
                    .lights
                    .sample_emitter(ctx.scene, index, u_pick, u1, time, None)?;
                let LightPoint {
                    p: q,
                    p_error: q_error,
                    n,
                    ..
                } = emitter.point;
                if n == Vec3::ZERO {
                    return None;
                }
                let (side, sides) = match (two_sided, rng.uniform() < 0.5) {
                    (true, true) => (-n, 2.0),
                    (true, false) => (n, 2.0),
                    _ => (n, 1.0),
                };
                let (dir, power) = match (aim, spread) {
                    (None, None) => (
                        Frame::from_normal(side).to_world(square_to_cosine_hemisphere(u2)),
                        emitter.radiance * (PI * area * sides),
                    ),
                    // A spread light: uniform directions in the cone it lights, weighted by
                    // its spread factor.
                    (None, Some(angle)) => {
                        let cos_max = (0.5 * angle).cos().clamp(0.0, 1.0 - 1e-7);
                        let dir =
                            Frame::from_normal(side).to_world(square_to_uniform_cone(u2, cos_max));
                        let cos = dir.dot(side);
                        let weight = spread_factor(spread, cos) * cos / uniform_cone_pdf(cos_max);
                        (dir, emitter.radiance * (weight * area * sides))
                    }
                    (Some(t), _) => {
                        let (dir, pdf) = t.sample_direction(q, rng.uniform(), u2)?;
                        let cos = dir.dot(side);
                        if cos <= 0.0 {
                            return None;
                        }
                        let weight = spread_factor(spread, cos) * cos / pdf;
                        (dir, emitter.radiance * (weight * area * sides))
                    }
                };
                let seen = emitter.radiance * spread_factor(spread, dir.dot(side).abs());
                (ray(offset_origin(q, q_error, n, dir), dir), power, seen)
            }
            // Photons leave point and spot lights from their centre whatever their radius: the
            // radius only softens shadows, which the photon maps do not resolve, and widens a
            // spot's cone (direct light, `Lights::sample`), which the photons leave out.
            LightSource::Point {
                position,
                intensity,
                radius,
                ..
            } => {
                let seen = lamp_radiance(intensity, radius);
                match aim {
                    None => (
                        ray(position, square_to_uniform_sphere(u1)),
                        intensity * (4.0 * PI),
                        seen,
                    ),
                    Some(t) => {
                        let (dir, pdf) = t.sample_direction(position, rng.uniform(), u1)?;
                        (ray(position, dir), intensity / pdf, seen)
                    }
                }
            }
            LightSource::Spot {
                position,
                direction,
                intensity,
                cos_inner,
                cos_outer,
                radius,
                ..
            } => {
                let cos_outer = cos_outer.clamp(-1.0, 1.0);
                let (dir, pdf) = match aim {
                    None => (
                        Frame::from_normal(direction)
                            .to_world(square_to_uniform_cone(u1, cos_outer)),
                        uniform_cone_pdf(cos_outer),
                    ),
                    Some(t) => t.sample_direction(position, rng.uniform(), u1)?,
                };
                let falloff = smoothstep(cos_outer, cos_inner, dir.dot(direction));
                let seen = lamp_radiance(intensity * falloff, radius);
                (ray(position, dir), intensity * (falloff / pdf), seen)
            }
            LightSource::Sun {
                to_sun,
                irradiance,
                cos_max,
            } => {
                let frame = Frame::from_normal(to_sun);
                let toward = if cos_max < 1.0 {
                    frame.to_world(square_to_uniform_cone(u2, cos_max))
                } else {
                    to_sun
                };
                let (origin, area) = self.parallel_origin(toward, aim, u1, rng)?;
                // The sun's disc: its irradiance spread over the solid angle it fills.
                let disc = 2.0 * PI * (1.0 - cos_max);
                let seen = if disc > 0.0 {
                    irradiance / disc
                } else {
                    Vec3::splat(f32::INFINITY)
                };
                (ray(origin, -toward), irradiance * area, seen)
            }
            LightSource::World { .. } => {
                let (toward, radiance, pdf) = ctx.lights.sample_world(u2)?;
                let (origin, area) = self.parallel_origin(toward, aim, u1, rng)?;
                (ray(origin, -toward), radiance * (area / pdf), radiance)
            }
        };
        Some(Emitted {
            ray: r,
            power,
            light: Some(index),
            media: None,
            radiance: Some(seen),
        })
    }

    /// The origin of a ray travelling along −`toward` from outside the scene, and the area
    /// (perpendicular to the ray) it stands for: uniform on the disc of the scene's bounding
    /// radius, or with `aim` on the discs that the targets' spheres cast.
    fn parallel_origin(
        &self,
        toward: Vec3,
        aim: Option<&Targets>,
        u: Vec2,
        rng: &mut Rng,
    ) -> Option<(Vec3, f32)> {
        let frame = Frame::from_normal(toward);
        let (centre, radius) = match aim {
            None => (self.center, self.radius),
            Some(t) => t.spheres[t.pick(rng.uniform())],
        };
        let d = square_to_disk(u) * radius;
        let back = 2.0 * self.radius + (centre - self.center).length();
        let origin = centre + frame.n * back + frame.s * d.x + frame.t * d.y;
        let area = match aim {
            None => PI * radius * radius,
            Some(t) => 1.0 / t.parallel_pdf(origin, toward),
        };
        area.is_finite().then_some((origin, area))
    }
}

/// Bounding spheres of the objects that can start a caustic path (a delta or glossy-only
/// material): Jensen's projection maps, with one sphere per mesh instead of a cell map. Caustic
/// photons are emitted only towards them; a direction is drawn from one sphere's cone, chosen
/// uniformly, and the photon's power divides by the mixture density over all cones (so
/// overlapping spheres stay unbiased). Photons towards anything else could not start a caustic
/// path, so nothing is lost.
struct Targets {
    spheres: Vec<(Vec3, f32)>,
}

/// Whether a material can start a caustic path: specular, and not a volume's boundary (a
/// volume's material is specular only for its transparent surface, which starts none).
fn is_caustic_start(scene: &Scene, material: u32) -> bool {
    is_specular(scene, material) && scene.materials[material as usize].volume.is_none()
}

/// More specular instances than this are aimed at as one sphere around them all: every photon
/// sums the density of every sphere.
const MAX_INSTANCE_TARGETS: usize = 64;

/// Bounding spheres of the instances of specular prototypes (of every place a moving one takes
/// while the shutter is open), or one around them all when there are many.
fn instance_spheres(scene: &Scene) -> Vec<(Vec3, f32)> {
    let specular: Vec<bool> = scene
        .prototypes
        .iter()
        .map(|m| !m.positions.is_empty() && is_caustic_start(scene, m.material))
        .collect();
    let local: Vec<Bounds> = scene.prototypes.iter().map(|m| m.bounds()).collect();
    let boxes: Vec<Bounds> = scene
        .instances
        .iter()
        .filter(|i| specular[i.prototype as usize])
        .map(|i| instance_bounds(i, local[i.prototype as usize]))
        .filter(|b| !b.is_empty())
        .collect();
    let sphere = |b: &Bounds| {
        let centre = b.center();
        let radius = 0.5 * b.diagonal();
        (
            centre,
            radius * 1.001 + 1e-6 * centre.abs().max_element() + 1e-20,
        )
    };
    if boxes.len() <= MAX_INSTANCE_TARGETS {
        return boxes.iter().map(sphere).collect();
    }
    let mut all = Bounds::EMPTY;
    for b in &boxes {
        all.grow(b.min);
        all.grow(b.max);
    }
    vec![sphere(&all)]
}

impl Targets {
    /// The specular meshes' bounding spheres; `None` when there is no specular mesh.
    fn new(ctx: &Context) -> Option<Targets> {
        let scene = ctx.scene;
        let mut spheres: Vec<(Vec3, f32)> = scene
            .meshes
            .iter()
            .filter(|m| !m.positions.is_empty() && is_caustic_start(scene, m.material))
            .map(|m| {
                let (lo, hi) = m.positions.iter().fold(
                    (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
                    |(lo, hi), &p| (lo.min(p), hi.max(p)),
                );
                let centre = 0.5 * (lo + hi);
                let radius = m
                    .positions
                    .iter()
                    .map(|&p| (p - centre).length())
                    .fold(0.0f32, f32::max);
                // A little margin for rounding, and no zero-size sphere.
                (
                    centre,
                    radius * 1.001 + 1e-6 * centre.abs().max_element() + 1e-20,
                )
            })
            .collect();
        spheres.extend(instance_spheres(scene));
        (!spheres.is_empty()).then_some(Targets { spheres })
    }

    fn pick(&self, u: f32) -> usize {
        ((u * self.spheres.len() as f32) as usize).min(self.spheres.len() - 1)
    }

    /// Cosine of the cone that sphere `k` subtends from `x`; −1 (the whole sphere of
    /// directions) when `x` is inside it.
    fn cone(&self, k: usize, x: Vec3) -> (Vec3, f32) {
        let (centre, radius) = self.spheres[k];
        let to = centre - x;
        let d2 = to.length_squared();
        if d2 <= radius * radius {
            return (Vec3::Z, -1.0);
        }
        (to / d2.sqrt(), (1.0 - radius * radius / d2).max(0.0).sqrt())
    }

    /// A direction from `x` towards one sphere and its density (solid angle) over all cones.
    fn sample_direction(&self, x: Vec3, u_pick: f32, u: Vec2) -> Option<(Vec3, f32)> {
        let (axis, cos_max) = self.cone(self.pick(u_pick), x);
        let dir = Frame::from_normal(axis).to_world(square_to_uniform_cone(u, cos_max));
        let pdf = self.direction_pdf(x, dir);
        (pdf > 0.0 && pdf.is_finite()).then_some((dir, pdf))
    }

    fn direction_pdf(&self, x: Vec3, dir: Vec3) -> f32 {
        let sum: f32 = (0..self.spheres.len())
            .map(|k| {
                let (axis, cos_max) = self.cone(k, x);
                if cos_max < 0.0 || dir.dot(axis) >= cos_max {
                    uniform_cone_pdf(cos_max)
                } else {
                    0.0
                }
            })
            .sum();
        sum / self.spheres.len() as f32
    }

    /// Density per unit perpendicular area of a parallel ray through `origin` along
    /// −`toward`: the mixture over the discs the spheres cast.
    fn parallel_pdf(&self, origin: Vec3, toward: Vec3) -> f32 {
        let sum: f32 = self
            .spheres
            .iter()
            .map(|&(centre, radius)| {
                let v = centre - origin;
                let off_axis = v - toward * v.dot(toward);
                if off_axis.length_squared() <= radius * radius {
                    1.0 / (PI * radius * radius)
                } else {
                    0.0
                }
            })
            .sum();
        sum / self.spheres.len() as f32
    }
}

/// Which photon map a photon is traced for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapKind {
    /// Every photon at every storing hit (the global map; caustic photons included and flagged).
    Global,
    /// Only light → specular+ → diffuse photons (the light may be a scattering in a medium
    /// straight from a light); the path ends at the first storing hit.
    Caustic,
}

/// Trace one photon from `ray` with `power` (already divided by the photon count) and append
/// the photons it leaves to `out`.
pub fn trace_photon(
    ctx: &Context,
    emitted: &Emitted,
    map: MapKind,
    max_bounces: u32,
    rng: &mut Rng,
    out: &mut Vec<Photon>,
) {
    walk_photon(
        ctx,
        emitted,
        max_bounces,
        rng,
        |s, power, bounce, caustic| {
            let photon = Photon::new(s.sh.p, power, s.wo, bounce, caustic).with_normal(s.ng);
            match map {
                MapKind::Global => {
                    out.push(photon);
                    true
                }
                MapKind::Caustic => {
                    if caustic {
                        out.push(photon);
                    }
                    false
                }
            }
        },
        None,
    );
}

/// Trace one photon for the volume photon map (`crate::volume_photon_map`) from `ray` with
/// `power`, appending a photon at each of its scatterings in a medium after its first
/// scattering anywhere: light that reaches a medium straight from a light is what the camera
/// paths' light samples along their segments add (`walk::light_scattered_along`).
pub fn trace_volume_photon(
    ctx: &Context,
    emitted: &Emitted,
    max_bounces: u32,
    rng: &mut Rng,
    out: &mut Vec<Photon>,
) {
    let mut keep = |photon| out.push(photon);
    let surfaces = |_: &Shading, _, _, _| true;
    walk_photon(ctx, emitted, max_bounces, rng, surfaces, Some(&mut keep));
}

/// Whether `trace_volume_photon` can store anything in `scene`: volume photons are kept only
/// where a camera path would continue from a scattering in a medium to gather the light they
/// stand for, which Blender's Volume bounces allow from 1 up, or where they leave an emitting
/// medium (light no light sample finds). At the default of 0 bounces, without emitting media,
/// light samples carry all the light the media scatter towards the camera, and tracing volume
/// photons would only spend time.
pub fn stores_volume_photons(scene: &Scene) -> bool {
    scene.has_media() && (scene.render_settings.volume_bounces > 0 || scene.media_emit())
}

/// Trace one photon for the subsurface samples: at every hit on a translucent surface, the
/// flux entering it (power × subsurface weight × the base's share behind the specular layer,
/// seen from the photon's direction) is appended to `out` with the material index. The photon
/// goes on scattering with the full BSDF (the subsurface part treated as its local, Lambertian
/// limit), so light reaching the object after other bounces is counted too.
pub fn trace_subsurface_photon(
    ctx: &Context,
    emitted: &Emitted,
    max_bounces: u32,
    rng: &mut Rng,
    out: &mut Vec<(u32, Sample)>,
) {
    let reached = |s: &Shading, power: Vec3, _, _| {
        let w = s.surface.subsurface.weight;
        if w > 0.0 {
            let flux = power * (w * s.bsdf.base_transmittance());
            if max_component(flux) > 0.0 {
                let position = s.sh.p;
                out.push((s.sh.material, Sample { position, flux }));
            }
        }
        true
    };
    walk_photon(ctx, emitted, max_bounces, rng, reached, None);
}

/// The photon random walk shared by every photon map and the subsurface samples: `store(shading, power, bounces, caustic)` is
/// called at each hit on a surface that stores photons (`caustic`: only specular bounces so
/// far) and returns whether the walk goes on; `in_medium` is given a photon at each scattering
/// in a medium after the photon's first scattering anywhere (its power as the free flight
/// weighed it, before the phase function's sample).
fn walk_photon(
    ctx: &Context,
    emitted: &Emitted,
    max_bounces: u32,
    rng: &mut Rng,
    mut store: impl FnMut(&Shading, Vec3, u32, bool) -> bool,
    mut in_medium: Option<&mut dyn FnMut(Photon)>,
) {
    let (mut ray, mut power) = (emitted.ray, emitted.power);
    // The product of the scattering weights so far (the path's throughput, without Russian
    // roulette's reweighting), for Clamp Indirect on caustics (`caustic_clamp`).
    let mut throughput = Vec3::ONE;
    let clamp = Clamp::of(ctx.scene);
    // True while every bounce so far was specular (light → S*; the light may be the photon's
    // first scattering in a medium, `lit_by_medium`).
    let mut specular_path = true;
    // Surfaces it scattered from, not counting transparent passes (a volume's boundary, a
    // Transparent BSDF, alpha): light through them alone is direct light, which shadow rays
    // find through them, not a caustic.
    let mut surface_bounces = 0;
    // The photon scattered somewhere (a transparent pass is no scattering): light that did not
    // is what light samples find. Light from an emitting medium is found by no light sample:
    // its photons count from where they leave.
    let mut scattered = emitted.left_a_medium();
    let mut absorption = Vec3::ZERO;
    // Index of refraction of the medium the photon travels through (1: outside any object).
    let mut ior = 1.0f32;
    // The participating media it travels through, and its scatterings in them.
    let mut media = match emitted.media {
        Some(media) => media,
        None => MediumStack::at(ctx, ray.origin, ray.time),
    };
    let mut volume_bounces = 0;
    // Its first scattering was in a medium, straight from the light: from there on the
    // scattering is its light (`specular_path`).
    let mut lit_by_medium = false;
    // The scatterings in media the photon may make (`None` until its first scattering
    // anywhere): as many as a camera path continues from (Blender's Volume bounces), and one
    // more where the photon reaches the medium from a light or leaves an emitting medium
    // (the one a camera path's light sample leaves from, or after which it counts only the
    // emission it meets).
    let limit = ctx.scene.render_settings.volume_bounces;
    let mut volume_allowance = emitted.left_a_medium().then_some(limit + 1);
    // Blender's caustics switches: the lobes a camera path drops straight after a diffuse
    // bounce, and whether the photon's last scattering was by one of them (light a camera path
    // finds only by leaving the next surface diffusely: not stored, and not carried on by a
    // diffuse bounce).
    let dropped = LightPathFilter::of(ctx.scene).after_diffuse();
    let mut arrived_by_dropped = false;
    // Blender's Filter Glossy: every surface a photon scatters from is met by the camera paths
    // that read it after a diffuse bounce at least (the surface where it is read), so the photon
    // scatters by the lobes as those paths see them, blurred (`blurred_by_filter_glossy`).
    let blur = blurred_by_filter_glossy(ctx.scene);
    // The densities with which a camera path at the photon's first surface draws the direction
    // to the photon's light, by its BSDF and by its light sample, when that surface scattered
    // it by a lobe a light sample also reaches (`caustic_clamp`).
    let mut first_vertex_pdfs = None;
    for bounce in 0..=max_bounces {
        let hit = ctx.accel.intersect(ctx.scene, &ray, Visibility::Secondary);
        if !media.is_vacuum(ctx.scene) {
            let reach = hit.map_or(f32::INFINITY, |h| h.t * ray.direction.length());
            let dir = ray.direction.normalize();
            let before = max_component(power);
            let mut emitted = Vec3::ZERO;
            let flight = fly(
                &media.media(ctx),
                ray.origin,
                dir,
                reach,
                &mut power,
                &mut emitted,
                rng,
            );
            match flight {
                Flight::Passed => {}
                Flight::Absorbed => return,
                Flight::Scattered { t, at } => {
                    // Blender's Volume bounces: a camera path continues from that many
                    // scatterings in media, and lights from one more: the scattering its
                    // light sample leaves from, the photon's first if it was in a medium.
                    volume_bounces += 1;
                    if volume_bounces > *volume_allowance.get_or_insert(limit + 1) {
                        return;
                    }
                    let p = ray.origin + dir * t;
                    if let (true, Some(keep)) = (scattered, in_medium.as_deref_mut()) {
                        keep(Photon::new(p, power, -dir, bounce, false));
                    }
                    if bounce == max_bounces {
                        return;
                    }
                    let (wi, f, pdf) = at
                        .phase
                        .sample(dir, [rng.uniform(), rng.uniform(), rng.uniform()]);
                    if !(pdf > 0.0) {
                        return;
                    }
                    power *= f / pdf;
                    // Russian roulette keeps the photon's power nearly constant.
                    let q = (max_component(power) / before).min(1.0);
                    if !(q > 0.0) || rng.uniform() >= q {
                        return;
                    }
                    power /= q;
                    // A scattering straight from a light is where a camera path's light sample in
                    // the medium leaves from, at any Volume bounces: light that goes on from it
                    // through specular surfaces to a diffuse one (fog lit by a lamp, seen
                    // through glass) is found by no light sample from that surface, so it is a
                    // caustic of the medium's light (not clamped: Cycles' light sample there
                    // carries the phase function's share of the light). After any other
                    // scattering the path is no longer specular.
                    if scattered {
                        specular_path = false;
                    } else {
                        lit_by_medium = true;
                    }
                    scattered = true;
                    arrived_by_dropped = false;
                    ray = Ray {
                        origin: p,
                        direction: wi,
                        t_max: f32::INFINITY,
                        time: ray.time,
                    };
                    continue;
                }
            }
        }
        let Some(hit) = hit else {
            return;
        };
        let through = transmittance(absorption, &hit, &ray);
        power *= through;
        throughput *= through;
        let s = Shading::new(ctx, &ray, &hit, false);
        // A Ray Portal BSDF: only camera paths follow it (the planner takes the path tracer).
        if s.surface.portal.is_some() {
            return;
        }
        let storing = stores_photons(&s.bsdf);
        // Inside a medium of index η a photon stands for 1/η² of its flux (`adjoint_scale`).
        let mut stored = if ior == 1.0 {
            power
        } else {
            power * adjoint_scale(ior)
        };
        let caustic = surface_bounces > 0 && specular_path;
        if storing && caustic && clamp.is_on() && !lit_by_medium {
            stored *= caustic_clamp(clamp, &s, throughput, emitted.radiance, first_vertex_pdfs);
        }
        if storing && !arrived_by_dropped && !store(&s, stored, bounce, caustic) {
            return;
        }
        if bounce == max_bounces {
            return;
        }
        let mut s = s;
        if !blur.is_none() {
            s.bsdf = s.bsdf.filtered(blur);
        }
        let Some((bs, wi)) = scatter_photon(&s, rng) else {
            return;
        };
        // Only a caustic photon's clamp reads them: a first surface that stores photons ends
        // the caustic path (a delta lobe aside, which no light sample reaches).
        let may_be_caustic = clamp.is_on() && !storing && !bs.delta;
        if may_be_caustic && !scattered && bs.scattering != crate::bsdf::Scattering::Transparent {
            first_vertex_pdfs = light_sample_pdfs(ctx, &s, &bs, &ray, &media, rng);
        }
        if arrived_by_dropped && bs.scattering == crate::bsdf::Scattering::Diffuse {
            return;
        }
        specular_path &= bs.delta || !storing;
        if bs.scattering != crate::bsdf::Scattering::Transparent {
            arrived_by_dropped = dropped.drops(&s.bsdf, &bs);
            surface_bounces += 1;
            scattered = true;
            volume_allowance.get_or_insert(limit);
        }
        // Russian roulette on the scattering weight keeps the photon's power nearly constant.
        let q = max_component(bs.weight).min(1.0);
        if !(q > 0.0) || rng.uniform() >= q {
            return;
        }
        power *= bs.weight / q;
        throughput *= bs.weight;
        if !power.is_finite() {
            return;
        }
        absorption = s.absorption_after(&bs, wi, absorption);
        ior = s.ior_after(&bs, wi, ior);
        if bs.transmitted {
            let entering = wi.dot(s.sh.ng) < 0.0;
            media = media.crossed(ctx.scene, &hit, s.sh.material, entering);
        }
        ray = s.sh.spawn(wi);
    }
}

/// What a photon's flux is multiplied by where it is stored inside a medium of index of
/// refraction `ior` (relative to the outside): 1/η². Refraction is not symmetric (Veach 1997,
/// §5.2): the camera paths' BSDF conserves radiance across an interface (Cycles' convention,
/// `crate::bsdf`), f(wo, wi) = (η_i/η_o)² f(wi, wo) for a transmitted pair, so its adjoint, by
/// which photons must scatter for their density to estimate the radiance camera paths compute,
/// is the sampled weight times (η_from/η_to)² at each crossing. Photons scattered by the
/// camera's BSDF, which conserves their flux, would be η² too bright wherever they are stored
/// inside glass: on a rough slab's faces, on the floor inside the gallery's tilted glass cube,
/// under the cognac glass's foot (docs/bench/photon_method.md, "Photons inside glass"). The
/// factors of a photon's crossings cancel once it is back outside, so the scale is applied to what is stored, from the medium the photon is
/// in (followed as the absorbing medium is, `Shading::ior_after`: one level, no nesting), and
/// photons outside any medium are stored exactly as before.
pub fn adjoint_scale(ior: f32) -> f32 {
    1.0 / (ior * ior)
}

/// Where a photon scattered at `s` goes, and the weight it carries: f(wi, wo)·|cos θi| / pdf
/// for light arriving from `wo` and leaving along `wi` (the adjoint BSDF, Veach 1997, ch. 3),
/// not the camera path's f(wo, wi). They differ where the BSDF is not reciprocal: the
/// Principled diffuse is dimmed by the specular layer's albedo seen from the viewer alone (as
/// in Cycles), so photons scattered with f(wo, wi) took the layer's albedo at the incoming
/// angle instead of the outgoing one: in a window-lit room of Blender's default material the
/// photon method read 1.5 % brighter than Cycles, with Lambertian walls it agreed.
///
/// The BSDF's sampler picks the diffuse lobe by its forward albedo, small for light arriving at
/// grazing angles, while the adjoint diffuse is not: so on surfaces with a diffuse and another
/// lobe, half the photons are sampled by the BSDF and half cosine-distributed, weighted by the
/// mixture density (one-sample MIS with the balance heuristic), which keeps weights bounded.
/// Delta lobes and refraction keep the sampler's weight, which conserves flux across an
/// interface; what a photon inside a medium stands for is scaled where it is stored
/// (`adjoint_scale`).
fn scatter_photon(s: &Shading, rng: &mut Rng) -> Option<(BsdfSample, Vec3)> {
    let diffuse = max_component(s.bsdf.diffuse_reflectance());
    let mixed = diffuse > 0.0 && max_component(s.bsdf.albedo()) > diffuse * (1.0 + 1e-3);
    if !mixed {
        let (bs, wi) = s.sample(rng.uniform(), rng.uniform2())?;
        return Some((bs, wi));
    }
    let wo = s.wo_local;
    let local = if rng.uniform() < 0.5 {
        let d = square_to_cosine_hemisphere(rng.uniform2());
        Vec3::new(d.x, d.y, d.z.copysign(wo.z))
    } else {
        let (mut bs, wi) = s.sample(rng.uniform(), rng.uniform2())?;
        if bs.delta || bs.transmitted {
            bs.weight *= 2.0;
            return Some((bs, wi));
        }
        bs.wi
    };
    let wi = s.frame.to_world(local).normalize();
    if s.opaque && wi.dot(s.ng) <= 0.0 {
        return None;
    }
    let pdf = 0.5 * s.bsdf.pdf(local) + 0.5 * local.z.abs() * (1.0 / PI);
    // f(wi, wo)·|cos θo| seen from `wi`, turned into f(wi, wo)·|cos θi|.
    let reverse = s.bsdf.viewed_from(local).eval(wo) * (local.z / wo.z).abs();
    let weight = reverse / pdf;
    (pdf > 0.0 && weight.is_finite()).then_some((
        BsdfSample {
            wi: local,
            weight,
            pdf,
            delta: false,
            transmitted: false,
            scattering: crate::bsdf::Scattering::Diffuse,
        },
        wi,
    ))
}

/// Which photons a tracing run emits: its name in progress messages, the tag that separates its
/// random stream from the other runs', and whether its photons are aimed at the specular meshes.
pub struct Stream<'a> {
    pub label: &'a str,
    pub tag: u64,
    pub aimed: bool,
    /// Bytes the run may store (what the memory budget leaves after the earlier runs).
    pub budget_bytes: u64,
    /// Photon `i` of a Sobol run is sample `i` of one Owen-scrambled Sobol sequence (Keller
    /// 1996, "Quasi-Monte Carlo methods in computer graphics: the global illumination problem":
    /// quasi-random walks): its emission and every bounce draw well-spread numbers across
    /// the run's photons, so the maps' density is less noisy than with independent streams.
    pub sampler: Sampler,
}

impl<'a> Stream<'a> {
    /// An unaimed run that may store what `budget_bytes` leaves after the `stored` photons of
    /// the runs before it.
    pub fn unaimed(
        label: &'a str,
        tag: u64,
        budget_bytes: u64,
        stored: usize,
        sampler: Sampler,
    ) -> Stream<'a> {
        let used = (stored * std::mem::size_of::<Photon>()) as u64;
        Stream {
            label,
            tag,
            aimed: false,
            budget_bytes: budget_bytes.saturating_sub(used),
            sampler,
        }
    }
}

/// Trace `count` photons in parallel batches with `trace(emitted, rng, out)` (its power already
/// divided by the count), concatenated in batch order.
pub fn trace_photons<T: Send + Clone>(
    ctx: &Context,
    emitters: &Emitters,
    stream: Stream,
    count: u32,
    seed: u64,
    progress: &Progress,
    trace: impl Fn(&Emitted, &mut Rng, &mut Vec<T>) + Sync,
) -> Result<Vec<T>> {
    let batches = count.div_ceil(BATCH);
    let done = AtomicU64::new(0);
    let stored = AtomicU64::new(0);
    // Batches are joined into one vector at the end: both exist for a moment.
    let bytes_per_item = 2 * std::mem::size_of::<T>() as u64;
    let scale = 1.0 / count.max(1) as f32;
    let parts: Vec<Vec<T>> = (0..batches)
        .into_par_iter()
        .map(|b| {
            progress.check()?;
            let mut random = Rng::for_item(seed ^ stream.tag, b as u64, 0);
            let n = BATCH.min(count - b * BATCH);
            let mut out = Vec::with_capacity(n as usize * 2);
            for i in b * BATCH..b * BATCH + n {
                let mut sobol;
                let rng = match stream.sampler {
                    Sampler::Sobol => {
                        sobol = Rng::sobol(seed, stream.tag, i);
                        &mut sobol
                    }
                    Sampler::Random => &mut random,
                };
                // Light linking: a photon is dropped where its light does not light the
                // object it meets first (emitting media are linked to everything).
                let lands = |e: &Emitted| {
                    e.light.is_none_or(|light| {
                        ctx.lights.photon_lands(ctx.scene, ctx.accel, light, &e.ray)
                    })
                };
                if let Some(mut e) = emitters.emit(ctx, stream.aimed, rng).filter(lands) {
                    e.power *= scale;
                    trace(&e, rng, &mut out);
                }
            }
            // Partial sums never exceed the final count, so whether this fails does not depend
            // on the order the batches finish in.
            let total = stored.fetch_add(out.len() as u64, Ordering::Relaxed) + out.len() as u64;
            if total * bytes_per_item > stream.budget_bytes {
                return Err(Error::Settings(format!(
                    "the {} photons need more than the {} MiB left of the photon memory limit \
                     ({total} stored so far); emit fewer photons or raise --memory-limit",
                    stream.label,
                    stream.budget_bytes >> 20
                )));
            }
            let finished = done.fetch_add(1, Ordering::Relaxed) + 1;
            (progress.report)(&ProgressEvent {
                stage: "photons",
                fraction: finished as f32 / batches as f32,
                message: format!("{} photons: batch {finished}/{batches}", stream.label),
            });
            Ok(out)
        })
        .collect::<Result<_>>()?;
    Ok(parts.concat())
}

/// The share of a caustic photon that Blender's Clamp Indirect leaves (`walk::Clamp`): Cycles
/// finds a caustic by a path from the camera that leaves the diffuse surface by its BSDF,
/// passes the specular surfaces and meets the emitter, and clamps that path's contribution,
/// the surface's reflectance × the specular chain's `throughput` × the emitter's `radiance`
/// there, to the limit (a camera seeing the surface directly). Cycles' clamped contribution
/// is the photon's times the share this returns, so the caustic estimate keeps what Cycles'
/// clamped caustic keeps on average (nothing of a sun's or a small lamp's caustic at the
/// default limit, 10). `radiance` `None` (an emitting medium): no clamp.
///
/// Where the photon's first surface scattered it by a lobe that is not a delta (rough glass,
/// or smooth glass as Filter Glossy blurs it), the camera path also finds the light by its
/// light sample there, and Cycles clamps each of the two contributions apart, each weighted by
/// the power heuristic: `first_vertex_pdfs`, the BSDF's and the light sample's densities of
/// the direction to the light there, give each strategy its share of the path and the
/// contribution it would have made (the BSDF's: the path's, × its weight; the light sample's:
/// the path's × p_bsdf / p_light × its shadow ray's transmittance, × its weight: a camera path
/// through scattering media without scattering carries no transmittance, a shadow ray does).
fn caustic_clamp(
    clamp: Clamp,
    s: &Shading,
    throughput: Vec3,
    radiance: Option<Vec3>,
    first_vertex_pdfs: Option<(f32, f32, Vec3)>,
) -> f32 {
    let Some(radiance) = radiance else {
        return 1.0;
    };
    let reflectance = s.bsdf.diffuse_reflectance();
    let contribution = reflectance * throughput * radiance;
    // A channel that carries nothing carries nothing of an infinite radiance either.
    let contribution = Vec3::select(contribution.is_nan_mask(), Vec3::ZERO, contribution);
    let sum = contribution.abs().element_sum();
    if !sum.is_finite() {
        // A light no ray meets: no path from the camera finds its caustic.
        return 0.0;
    }
    if !(sum > 0.0) {
        return 1.0;
    }
    let kept = |c: Vec3| {
        let sum = c.abs().element_sum();
        if sum > 0.0 {
            clamp.apply(c, false).abs().element_sum() / sum
        } else {
            1.0
        }
    };
    match first_vertex_pdfs {
        Some((p_bsdf, p_light, through)) if p_light > 0.0 && p_bsdf > 0.0 => {
            let w_bsdf = power_heuristic(p_bsdf, p_light);
            let w_light = 1.0 - w_bsdf;
            w_bsdf * kept(contribution * w_bsdf)
                + w_light * kept(contribution * through * (w_light * p_bsdf / p_light))
        }
        _ => kept(contribution),
    }
}

/// The filter Blender's Filter Glossy applies to the surfaces a photon scatters from: the blur
/// of a camera path after a diffuse bounce of the largest density a cosine-distributed
/// direction has (`PathHistory::GATHER`); the caustics switches are left to the walk.
fn blurred_by_filter_glossy(scene: &Scene) -> PathFilter {
    PathFilter {
        drop_reflection: false,
        drop_refraction: false,
        min_alpha: LightPathFilter::of(scene).at(PathHistory::GATHER).min_alpha,
    }
}

/// At the first surface `s` a photon met straight from its light, along `ray`, and scattered by
/// the sample `bs`: the densities (solid angle) with which a camera path arriving along the
/// photon's new direction draws the direction back to the light, by `s`'s BSDF and by a light
/// sample, and the transmittance of the `media` the light sample's shadow ray crosses (an
/// estimate); `None` where no light sample finds that light that way (light linking aside).
fn light_sample_pdfs(
    ctx: &Context,
    s: &Shading,
    bs: &BsdfSample,
    ray: &Ray,
    media: &MediumStack,
    rng: &mut Rng,
) -> Option<(f32, f32, Vec3)> {
    let p_bsdf = s.bsdf.viewed_from(bs.wi).pdf(s.wo_local);
    if !(p_bsdf > 0.0) {
        return None;
    }
    let from = Receiver::at(s.sh.p);
    let back = s.sh.spawn(-ray.direction.normalize());
    let hit = ctx.accel.intersect(ctx.scene, &back, Visibility::Secondary);
    let mut p_light = 0.0;
    let reach = hit.map_or(f32::INFINITY, |h| h.t * back.direction.length());
    ctx.lights
        .lamps_met(&back, from, reach, false, |l, pdf, _| {
            if l != Vec3::ZERO {
                p_light += pdf;
            }
        });
    match hit {
        Some(h) => {
            let sh = SurfaceHit::new(ctx.scene, &back, &h);
            p_light += ctx.lights.triangle_pdf(ctx.scene, from, &sh);
        }
        None => ctx.lights.escaped(from, back.direction, false, |l, pdf| {
            if l != Vec3::ZERO {
                p_light += pdf;
            }
        }),
    }
    if !(p_light > 0.0) {
        return None;
    }
    let through = match media.is_vacuum(ctx.scene) {
        true => Vec3::ONE,
        false => medium_transmittance(&media.media(ctx), back.origin, back.direction, reach, rng),
    };
    Some((p_bsdf, p_light, through))
}

/// The radiance a ray meets on a point or spot lamp of `intensity` and `radius` (a sphere of
/// radiance I/(πr²), `light::lamps`); infinite for a point light of no radius.
fn lamp_radiance(intensity: Vec3, radius: f32) -> Vec3 {
    if radius > 0.0 {
        intensity / (PI * radius * radius)
    } else {
        Vec3::splat(f32::INFINITY)
    }
}
