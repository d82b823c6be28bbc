//! Pass 1 of photon mapping: photon emission and tracing (Jensen 2000, "Photon tracing"; Jensen
//! 2001, ch. 5). Photons leave the lights in proportion to their power, scatter with the same
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
//! - world: a uniform direction, then a disc of radius R outside the scene facing it,
//!   L·πR²·4π.

use super::{Shading, SPECULAR_ROUGHNESS};
use crate::accel::{Ray, Visibility};
use crate::bsdf::{sample_bsdf, Bsdf};
use crate::integrator::Context;
use crate::interaction::{offset_origin, LightPoint};
use crate::light::{sample_emitter_point, smoothstep, LightSource};
use crate::math::{luminance, max_component, Frame, Vec2, Vec3};
use crate::photon_map::Photon;
use crate::rng::Rng;
use crate::sampling::{
    square_to_cosine_hemisphere, square_to_disk, square_to_uniform_cone, square_to_uniform_sphere,
    uniform_cone_pdf, Distribution1D,
};
use crate::subsurface::Sample;
use std::f32::consts::PI;

/// True when a photon arriving at this surface is stored and the renderer reads photon maps
/// here ("diffuse" in Jensen's L(S|D)*E notation): some lobe is not a delta, and the surface is
/// not a glossy-only one (no Lambertian part and roughness below `SPECULAR_ROUGHNESS`).
pub fn stores_photons(bsdf: &Bsdf, wo_local: Vec3) -> bool {
    bsdf.has_non_delta()
        && (bsdf.roughness() >= SPECULAR_ROUGHNESS
            || bsdf.diffuse_reflectance(wo_local) != Vec3::ZERO)
}

/// The lights as photon sources, chosen in proportion to their flux (luminance).
pub struct Emitters {
    select: Distribution1D,
    center: Vec3,
    radius: f32,
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
        let power: Vec<f32> = ctx
            .lights
            .sources
            .iter()
            .map(|s| luminance(light_flux(ctx, s, radius)))
            .collect();
        Emitters {
            select: Distribution1D::new(&power),
            center,
            radius,
        }
    }

    /// Total emitted flux (RGB) as the photons carry it, for tests and statistics.
    pub fn total_flux(&self, ctx: &Context) -> Vec3 {
        ctx.lights
            .sources
            .iter()
            .map(|s| light_flux(ctx, s, self.radius))
            .sum()
    }

    /// Emit one photon: its first ray and its power (before dividing by the photon count).
    pub fn emit(&self, ctx: &Context, rng: &mut Rng) -> Option<(Ray, Vec3)> {
        let (index, pmf) = self.select.sample(rng.uniform())?;
        let (u1, u2) = (rng.uniform2(), rng.uniform2());
        let ray = |origin, direction| Ray {
            origin,
            direction,
            t_max: f32::INFINITY,
        };
        let (r, power) = match ctx.lights.sources[index] {
            LightSource::Triangle {
                mesh,
                triangle,
                area,
                two_sided,
            } => {
                let emitter = sample_emitter_point(ctx.scene, mesh, triangle, u1);
                let LightPoint {
                    p: q,
                    p_error: q_error,
                    n,
                } = emitter.point;
                if n == Vec3::ZERO {
                    return None;
                }
                let (side, sides) = match (two_sided, rng.uniform() < 0.5) {
                    (true, true) => (-n, 2.0),
                    (true, false) => (n, 2.0),
                    _ => (n, 1.0),
                };
                let dir = Frame::from_normal(side).to_world(square_to_cosine_hemisphere(u2));
                (
                    ray(offset_origin(q, q_error, n, dir), dir),
                    emitter.radiance * (PI * area * sides),
                )
            }
            // Photons leave point and spot lights from their centre whatever their radius: the
            // radius only softens shadows, which the photon maps do not resolve.
            LightSource::Point {
                position,
                intensity,
                ..
            } => (
                ray(position, square_to_uniform_sphere(u1)),
                intensity * (4.0 * PI),
            ),
            LightSource::Spot {
                position,
                direction,
                intensity,
                cos_inner,
                cos_outer,
                ..
            } => {
                let cos_outer = cos_outer.clamp(-1.0, 1.0);
                let dir =
                    Frame::from_normal(direction).to_world(square_to_uniform_cone(u1, cos_outer));
                let falloff = smoothstep(cos_outer, cos_inner, dir.dot(direction));
                (
                    ray(position, dir),
                    intensity * (falloff / uniform_cone_pdf(cos_outer)),
                )
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
                let origin = self.disc_point(&frame, u1);
                (
                    ray(origin, -toward),
                    irradiance * (PI * self.radius * self.radius),
                )
            }
            LightSource::World { radiance } => {
                let toward = square_to_uniform_sphere(u2);
                let origin = self.disc_point(&Frame::from_normal(toward), u1);
                (
                    ray(origin, -toward),
                    radiance * (4.0 * PI * PI * self.radius * self.radius),
                )
            }
        };
        let power = power / pmf;
        (power.is_finite() && max_component(power) > 0.0).then_some((r, power))
    }

    /// A point on the disc of the scene's bounding radius facing `frame.n`, outside the scene.
    fn disc_point(&self, frame: &Frame, u: Vec2) -> Vec3 {
        let d = square_to_disk(u) * self.radius;
        self.center + frame.n * (2.0 * self.radius) + frame.s * d.x + frame.t * d.y
    }
}

/// Which photons a tracing pass keeps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pass {
    /// Every photon at every storing hit (the global map; caustic photons included and flagged).
    Global,
    /// Only light → specular+ → diffuse photons; the path ends at the first storing hit.
    Caustic,
}

/// Trace one photon from `ray` with `power` (already divided by the photon count) and append
/// the photons it leaves to `out`.
pub fn trace_photon(
    ctx: &Context,
    ray: Ray,
    power: Vec3,
    pass: Pass,
    max_bounces: u32,
    rng: &mut Rng,
    out: &mut Vec<Photon>,
) {
    walk_photon(
        ctx,
        ray,
        power,
        max_bounces,
        rng,
        |s, power, bounce, caustic| {
            let photon = Photon::new(s.sh.p, power, s.wo, bounce, caustic).with_normal(s.ng);
            match pass {
                Pass::Global => {
                    out.push(photon);
                    true
                }
                Pass::Caustic => {
                    if caustic {
                        out.push(photon);
                    }
                    false
                }
            }
        },
    );
}

/// Trace one photon for the subsurface samples: at every hit on a translucent surface, the
/// flux entering it (power × subsurface weight × the base's share behind the specular layer,
/// seen from the photon's direction) is appended to `out` with the material index. The photon
/// goes on scattering with the full BSDF (the subsurface part treated as its local, Lambertian
/// limit), so light reaching the object after other bounces is counted too.
pub fn trace_subsurface_photon(
    ctx: &Context,
    ray: Ray,
    power: Vec3,
    max_bounces: u32,
    rng: &mut Rng,
    out: &mut Vec<(u32, Sample)>,
) {
    walk_photon(ctx, ray, power, max_bounces, rng, |s, power, _, _| {
        let w = s.surface.subsurface.weight;
        if w > 0.0 {
            let flux = power * (w * s.bsdf.base_transmittance(s.wo_local));
            if max_component(flux) > 0.0 {
                let position = s.sh.p;
                out.push((s.sh.material, Sample { position, flux }));
            }
        }
        true
    });
}

/// The photon random walk shared by every pass: `store(shading, power, bounces, caustic)` is
/// called at each hit on a surface that stores photons (`caustic`: only specular bounces so
/// far) and returns whether the walk goes on.
fn walk_photon(
    ctx: &Context,
    mut ray: Ray,
    mut power: Vec3,
    max_bounces: u32,
    rng: &mut Rng,
    mut store: impl FnMut(&Shading, Vec3, u32, bool) -> bool,
) {
    // True while every bounce so far was specular (light → S*).
    let mut specular_path = true;
    let mut absorption = Vec3::ZERO;
    for bounce in 0..=max_bounces {
        let Some(hit) = ctx.accel.intersect(ctx.scene, &ray, Visibility::Secondary) else {
            return;
        };
        if absorption != Vec3::ZERO {
            power *= (-absorption * (hit.t * ray.direction.length())).exp();
        }
        let s = Shading::new(ctx, &ray, &hit);
        let storing = stores_photons(&s.bsdf, s.wo_local);
        if storing && !store(&s, power, bounce, bounce > 0 && specular_path) {
            return;
        }
        if bounce == max_bounces {
            return;
        }
        let Some(bs) = sample_bsdf(&s.bsdf, s.wo_local, rng.uniform(), rng.uniform2()) else {
            return;
        };
        let wi = s.frame.to_world(bs.wi).normalize();
        if s.opaque && wi.dot(s.ng) <= 0.0 {
            return;
        }
        specular_path &= bs.delta || !storing;
        // Russian roulette on the scattering weight keeps the photon's power nearly constant.
        let q = max_component(bs.weight).min(1.0);
        if !(q > 0.0) || rng.uniform() >= q {
            return;
        }
        power *= bs.weight / q;
        if !power.is_finite() {
            return;
        }
        absorption = s.absorption_after(&bs, wi, absorption);
        ray = s.sh.spawn(wi);
    }
}
