//! Fresnel reflectance: the exact dielectric formula (unpolarised light, Born & Wolf §1.5), the
//! IOR ↔ F0 conversions, Cycles' "real curve" generalised Schlick used by the Principled BSDF
//! for tinted dielectrics, and the F82-tint conductor model (Hoffman 2019, "Fresnel Equations
//! Considered Harmful"; Kutz et al. 2021, "Novel aspects of the Adobe Standard Material") that
//! Blender 4.x uses for metals.

use crate::math::Vec3;

/// Reflectance at normal incidence of an interface with relative IOR `eta`.
pub fn f0_from_ior(eta: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// The relative IOR whose normal-incidence reflectance is `f0` (inverse of `f0_from_ior` for
/// eta ≥ 1). `f0` is clamped below 1 so the result stays finite.
pub fn ior_from_f0(f0: f32) -> f32 {
    let s = f0.clamp(0.0, 0.9999).sqrt();
    (1.0 + s) / (1.0 - s)
}

/// Exact dielectric Fresnel reflectance for light arriving at cosine `cos_i` (≥ 0, measured on
/// the incident side) on an interface with `eta` = η_transmitted / η_incident. Returns 1 on total
/// internal reflection.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let f = 0.5 * (r_s * r_s + r_p * r_p);
    if f.is_finite() {
        f.min(1.0)
    } else {
        1.0
    }
}

/// Where the exact Fresnel curve sits between its normal-incidence value and 1: Cycles' way of
/// tinting a dielectric (F = mix(f0·tint, 1, s)) while keeping the real angular shape.
pub fn fresnel_blend_factor(cos_i: f32, eta: f32) -> f32 {
    let f0 = f0_from_ior(eta);
    let f = fresnel_dielectric(cos_i, eta);
    if f0 >= 1.0 {
        return 1.0;
    }
    ((f - f0) / (1.0 - f0)).clamp(0.0, 1.0)
}

/// Schlick's Fresnel with a per-channel F0 and Hoffman's F82 tint correction:
/// F(μ) = F0 + (1 − F0)(1 − μ)⁵ − b·μ(1 − μ)⁶, with b chosen so that at μ = 1/7 (≈ 82°) the value
/// is the plain Schlick value times the tint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct F82Tint {
    pub f0: Vec3,
    pub b: Vec3,
}

impl F82Tint {
    pub fn new(f0: Vec3, tint: Vec3) -> Self {
        let (f0, schlick_82, p6_over_7) = Self::at_82(f0);
        let tint = tint.clamp(Vec3::ZERO, Vec3::ONE);
        F82Tint {
            f0,
            b: schlick_82 * (Vec3::ONE - tint) / p6_over_7,
        }
    }

    /// `f0` clamped to [0, 1], the plain Schlick value at μ = 1/7 (≈ 82°) and μ(1 − μ)⁶ there.
    fn at_82(f0: Vec3) -> (Vec3, Vec3, f32) {
        let f0 = f0.clamp(Vec3::ZERO, Vec3::ONE);
        // At μ = 1/7: (1 − μ)⁵ = (6/7)⁵ and μ(1 − μ)⁶ = (6/7)⁶ / 7.
        let one_minus = 6.0f32 / 7.0;
        let p5 = one_minus.powi(5);
        let p6_over_7 = one_minus.powi(6) / 7.0;
        (f0, f0 + (Vec3::ONE - f0) * p5, p6_over_7)
    }

    /// The model through `f0` and the value `f82` at μ = 1/7 (Blender 5's film over a metal
    /// takes the metal's edge anew against the film).
    pub fn from_f82(f0: Vec3, f82: Vec3) -> Self {
        let (f0, schlick_82, p6_over_7) = Self::at_82(f0);
        F82Tint {
            f0,
            b: (schlick_82 - f82) / p6_over_7,
        }
    }

    pub fn eval(&self, cos_i: f32) -> Vec3 {
        let mu = cos_i.clamp(0.0, 1.0);
        let m = 1.0 - mu;
        let m5 = m * m * m * m * m;
        (self.f0 + (Vec3::ONE - self.f0) * m5 - self.b * (mu * m5 * m)).clamp(Vec3::ZERO, Vec3::ONE)
    }

    /// Cosine-weighted hemispherical average 2∫F(μ)μ dμ, in closed form
    /// (2∫(1−μ)⁵μ dμ = 1/21, 2∫μ²(1−μ)⁶ dμ = 1/126).
    pub fn average(&self) -> Vec3 {
        (self.f0 + (Vec3::ONE - self.f0) / 21.0 - self.b / 126.0).clamp(Vec3::ZERO, Vec3::ONE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_fresnel_limits() {
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        assert_eq!(fresnel_dielectric(0.0, 1.5), 1.0);
        assert_eq!(fresnel_dielectric(0.5, 1.0), 0.0);
        // Beyond the critical angle from inside glass.
        assert_eq!(fresnel_dielectric(0.3, 1.0 / 1.5), 1.0);
        assert!((ior_from_f0(f0_from_ior(1.45)) - 1.45).abs() < 1e-4);
    }

    #[test]
    fn f82_tint_hits_its_targets() {
        let f0 = Vec3::new(0.9, 0.6, 0.3);
        let tint = Vec3::new(1.0, 0.5, 0.2);
        let f = F82Tint::new(f0, tint);
        assert!((f.eval(1.0) - f0).length() < 1e-6);
        let plain = F82Tint::new(f0, Vec3::ONE);
        let mu = 1.0 / 7.0;
        assert!((f.eval(mu) - plain.eval(mu) * tint).length() < 1e-5);
        // The closed-form average against a midpoint sum.
        let n = 20000;
        let mut sum = Vec3::ZERO;
        for i in 0..n {
            let mu = (i as f32 + 0.5) / n as f32;
            sum += f.eval(mu) * mu;
        }
        assert!((sum * 2.0 / n as f32 - f.average()).length() < 1e-4);
    }
}
