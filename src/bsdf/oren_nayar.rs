//! Blender's rough diffuse lobe (the Diffuse BSDF's Roughness and the Principled BSDF's Diffuse
//! Roughness): Yasuhiro Fujii's improved Oren–Nayar model ("A tiny improvement of Oren–Nayar
//! reflectance model", the FON form with the normalisation A = 1 / (π + σ (π/2 − 2/3)),
//! B = σ A) plus the energy-preserving multiple-scattering term of the OpenPBR specification
//! (Portsmouth et al.'s EON), as Cycles combines them (`bsdf_oren_nayar.h`):
//!
//! Per unit lobe weight: f = A + B·s/t + M·(1 − E(μo))·(1 − E(μi)), where s = ωi·ωo − μi μo and
//! t = max(μi, μo) when s > 0 (else 1); E(μ) = A π + B G(μ) is the single-scattering lobe's
//! directional albedo (G Fujii's closed form), E_avg = A π + B (2π − 5.6)/3 its cosine-weighted
//! average, and M = ρ² E_avg / ((1 − E_avg) π (1 − ρ (1 − E_avg))) with ρ the clamped base
//! colour. The lobe's weight (the base colour under the layers above) multiplies f, so the
//! multiple-scattering term scales with ρ³ as in Cycles (OpenPBR writes ρ²); a white surface
//! reflects exactly all the light. Sampled cosine-weighted, as Cycles samples it.

use crate::math::Vec3;
use std::f32::consts::{FRAC_PI_2, PI};

/// Roughness below which the lobe is Lambertian (Cycles' closure weight cutoff).
pub const LAMBERT_BELOW: f32 = 1e-5;

/// The lobe seen from a fixed direction (its view-dependent multiple-scattering factor folded
/// in).
#[derive(Clone, Copy, Debug)]
pub struct OrenNayar {
    a: f32,
    b: f32,
    /// M·(1 − E(μo)) per channel.
    ms: Vec3,
    /// E(μo).
    e_o: f32,
    /// E_avg.
    e_avg: f32,
}

/// Fujii's G(μ): B·G(μ) is the part of the single-scattering albedo at cosine μ that the
/// roughness adds; its small-μ limit where tan θ misbehaves.
fn g(mu: f32) -> f32 {
    if mu < 1e-6 {
        return (FRAC_PI_2 - 2.0 / 3.0) - mu;
    }
    let sin = (1.0 - mu * mu).max(0.0).sqrt();
    let theta = mu.clamp(-1.0, 1.0).acos();
    sin * (theta - 2.0 / 3.0 - sin * mu) + (2.0 / 3.0) * (sin / mu) * (1.0 - sin * sin * sin)
}

impl OrenNayar {
    /// The lobe of roughness `sigma` (clamped to [0, 1]) and albedo `rho` (clamped) seen at
    /// cosine `mu_o`; `None` below `LAMBERT_BELOW` (a Lambertian lobe).
    pub fn new(sigma: f32, rho: Vec3, mu_o: f32) -> Option<OrenNayar> {
        let sigma = if sigma.is_finite() {
            sigma.clamp(0.0, 1.0)
        } else {
            0.0
        };
        if sigma < LAMBERT_BELOW {
            return None;
        }
        let a = 1.0 / (PI + sigma * (FRAC_PI_2 - 2.0 / 3.0));
        let b = sigma * a;
        let rho = rho.clamp(Vec3::ZERO, Vec3::ONE);
        let e_avg = a * PI + ((2.0 * PI - 5.6) / 3.0) * b;
        let m = rho * rho * (e_avg / ((1.0 - e_avg) * PI))
            / (Vec3::ONE - rho * (1.0 - e_avg)).max(Vec3::splat(1e-6));
        let e_o = a * PI + b * g(mu_o.max(0.0));
        Some(OrenNayar {
            a,
            b,
            ms: m * (1.0 - e_o),
            e_o,
            e_avg,
        })
    }

    /// f / weight for unit directions `wo` (the one `new` was given) and `wi` above the surface
    /// (local frame, normal +Z); the cosine not included.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let (mu_i, mu_o) = (wi.z.max(0.0), wo.z.max(0.0));
        let mut t = wi.dot(wo) - mu_i * mu_o;
        if t > 0.0 {
            t /= mu_i.max(mu_o) + f32::MIN_POSITIVE;
        }
        let e_i = self.a * PI + self.b * g(mu_i);
        Vec3::splat(self.a + self.b * t) + self.ms * (1.0 - e_i)
    }

    /// ∫ f / weight · cos θi dωi: the single-scattering albedo E(μo) plus the multiple
    /// scattering's M (1 − E(μo)) π (1 − E_avg).
    pub fn albedo(&self) -> Vec3 {
        Vec3::splat(self.e_o) + self.ms * (PI * (1.0 - self.e_avg))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed forms against quadrature: E(μ) = ∫ f_ss cos dω and E_avg = 2 ∫ E(μ) μ dμ
    /// (Cycles' E_avg is a fit: within 1 %).
    #[test]
    fn albedos_match_quadrature() {
        let lobe = OrenNayar::new(1.0, Vec3::ONE, 0.5).expect("rough");
        let single = |mu_o: f32| {
            let wo = Vec3::new((1.0 - mu_o * mu_o).sqrt(), 0.0, mu_o);
            let n = 400;
            let mut sum = 0.0f64;
            for i in 0..n {
                let mu = (i as f32 + 0.5) / n as f32;
                let sin = (1.0 - mu * mu).sqrt();
                for j in 0..n {
                    let phi = 2.0 * PI * (j as f32 + 0.5) / n as f32;
                    let wi = Vec3::new(sin * phi.cos(), sin * phi.sin(), mu);
                    let no_ms = OrenNayar {
                        ms: Vec3::ZERO,
                        ..lobe
                    };
                    sum += (no_ms.eval(wo, wi).x * mu) as f64;
                }
            }
            (sum * 2.0 * PI as f64 / (n * n) as f64) as f32
        };
        for mu in [0.1f32, 0.5, 0.9] {
            let e = lobe.a * PI + lobe.b * g(mu);
            assert!(
                (single(mu) - e).abs() < 2e-3,
                "μ={mu}: {} vs {e}",
                single(mu)
            );
        }
        let n = 2000;
        let avg: f32 = (0..n)
            .map(|i| {
                let mu = (i as f32 + 0.5) / n as f32;
                2.0 * (lobe.a * PI + lobe.b * g(mu)) * mu / n as f32
            })
            .sum();
        assert!(
            (avg - lobe.e_avg).abs() < 0.01 * avg,
            "{avg} vs {}",
            lobe.e_avg
        );
    }

    #[test]
    fn white_reflects_everything_and_smooth_is_lambert() {
        for mu in [0.05f32, 0.4, 1.0] {
            let white = OrenNayar::new(0.7, Vec3::ONE, mu).expect("rough");
            assert!(
                (white.albedo().x - 1.0).abs() < 1e-5,
                "{:?}",
                white.albedo()
            );
        }
        assert!(OrenNayar::new(0.0, Vec3::ONE, 0.5).is_none());
        assert!(OrenNayar::new(f32::NAN, Vec3::ONE, 0.5).is_none());
    }
}
