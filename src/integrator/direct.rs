//! Direct light, written once: one light sample with multiple importance sampling (Veach &
//! Guibas 1995, the power heuristic), and the MIS weight of emission that a BSDF-sampled ray
//! meets instead. Every integrator's next-event estimation goes through `sample_direct`.

use super::Context;
use crate::interaction::SurfaceHit;
use crate::math::Vec3;
use crate::rng::Rng;
use crate::sampling::power_heuristic;

/// One light sample from `at`, chosen by the lights' power: `beta` × f × Lᵢ × w / pdf, where
/// `scattering(wi)` gives f (with the cosine) and the BSDF density of the direction towards the
/// light, and w is the power heuristic against that density when `mis` is set (1 for delta
/// lights). Counts the shadow ray in `rays`; zero when the light is blocked or not reached.
pub fn sample_direct(
    ctx: &Context,
    at: &SurfaceHit,
    beta: Vec3,
    mis: bool,
    rng: &mut Rng,
    rays: &mut u32,
    scattering: impl FnOnce(Vec3) -> (Vec3, f32),
) -> Vec3 {
    let (choice, point) = rng.uniform3();
    let Some(ls) = ctx.lights.sample(ctx.scene, at.p, at.time, choice, point) else {
        return Vec3::ZERO;
    };
    if ls.li == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let (f, bsdf_pdf) = scattering(ls.wi);
    if f == Vec3::ZERO {
        return Vec3::ZERO;
    }
    *rays += 1;
    if !ctx.accel.unoccluded(ctx.scene, &at.spawn_to(&ls.target)) {
        return Vec3::ZERO;
    }
    let w = if ls.delta || !mis {
        1.0
    } else {
        power_heuristic(ls.pdf, bsdf_pdf)
    };
    beta * f * ls.li * (w / ls.pdf)
}

/// The scattering vertex a ray left, for the MIS weight of the emission that ray meets.
#[derive(Clone, Copy, Debug)]
pub struct Previous {
    pub p: Vec3,
    /// The BSDF density (solid angle) of the ray's direction.
    pub pdf: f32,
    /// The ray left through a delta lobe, or light sampling did not run there: emission it
    /// meets counts in full.
    pub delta: bool,
}

impl Previous {
    /// Weight of emission the ray meets, which light sampling would have drawn with density
    /// `light_pdf` (solid angle).
    pub fn weight(&self, light_pdf: f32) -> f32 {
        if self.delta {
            1.0
        } else {
            power_heuristic(self.pdf, light_pdf)
        }
    }

    /// Weight of the emission of the surface `hit` the ray met.
    pub fn weight_at(&self, ctx: &Context, hit: &SurfaceHit) -> f32 {
        if self.delta {
            1.0
        } else {
            power_heuristic(self.pdf, ctx.lights.triangle_pdf(ctx.scene, self.p, hit))
        }
    }
}
