//! The isotropic GGX (Trowbridge–Reitz) microfacet distribution: normal distribution D, Smith
//! masking Λ / G1 and height-correlated masking-shadowing G2 (Heitz 2014, "Understanding the
//! Masking-Shadowing Function in Microfacet-Based BRDFs", eqs. 72 and 99), and sampling of the
//! distribution of visible normals (Heitz 2018, "Sampling the GGX Distribution of Visible
//! Normals", JCGT 7(4)). Walter et al. 2007 ("Microfacet Models for Refraction through Rough
//! Surfaces") give the reflection and refraction Jacobians used by the lobes.
//!
//! All functions work in the local frame (normal = +Z) with `w.z > 0` for the direction that
//! the visible normals are seen from. `alpha` is GGX α = roughness².

use crate::math::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

/// Smallest α used on the rough path; below it the microfacet lobes become delta lobes.
pub const MIN_ALPHA: f32 = 1e-4;

/// GGX normal distribution D(h) (zero for normals facing down).
pub fn ggx_d(alpha: f32, h: Vec3) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let cos2 = h.z * h.z;
    let t = 1.0 + (a2 - 1.0) * cos2;
    a2 * FRAC_1_PI / (t * t)
}

/// Smith Λ(w) for GGX; infinite at grazing incidence (so G1 = 0 there).
pub fn ggx_lambda(alpha: f32, w: Vec3) -> f32 {
    let cos2 = w.z * w.z;
    if cos2 <= 0.0 {
        return f32::INFINITY;
    }
    let tan2 = ((w.x * w.x + w.y * w.y) / cos2).max(0.0);
    0.5 * ((1.0 + alpha * alpha * tan2).sqrt() - 1.0)
}

/// Smith masking G1(w).
pub fn ggx_g1(alpha: f32, w: Vec3) -> f32 {
    1.0 / (1.0 + ggx_lambda(alpha, w))
}

/// Height-correlated masking-shadowing G2(wo, wi).
pub fn ggx_g2(alpha: f32, wo: Vec3, wi: Vec3) -> f32 {
    1.0 / (1.0 + ggx_lambda(alpha, wo) + ggx_lambda(alpha, wi))
}

/// Sample a microfacet normal from the distribution of normals visible from `wo` (`wo.z > 0`).
pub fn sample_ggx_vndf(alpha: f32, wo: Vec3, u: [f32; 2]) -> Vec3 {
    // Stretch the view so the distribution becomes the hemisphere of radius 1.
    let v = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let len2 = v.x * v.x + v.y * v.y;
    let t1 = if len2 > 1e-12 {
        Vec3::new(-v.y, v.x, 0.0) / len2.sqrt()
    } else {
        Vec3::X
    };
    let t2 = v.cross(t1);
    // Uniform point on the disk, squeezed into the visible part of the projected hemisphere.
    let r = u[0].sqrt();
    let phi = 2.0 * PI * u[1];
    let p1 = r * phi.cos();
    let mut p2 = r * phi.sin();
    let s = 0.5 * (1.0 + v.z);
    p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
    let n = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * v;
    // Unstretch.
    Vec3::new(alpha * n.x, alpha * n.y, n.z.max(1e-7)).normalize()
}

/// Density of `sample_ggx_vndf` over microfacet normals: G1(wo)·max(0, wo·h)·D(h) / wo.z.
pub fn ggx_vndf_pdf(alpha: f32, wo: Vec3, h: Vec3) -> f32 {
    let cos_oh = wo.dot(h);
    if cos_oh <= 0.0 || wo.z <= 0.0 {
        return 0.0;
    }
    ggx_g1(alpha, wo) * cos_oh * ggx_d(alpha, h) / wo.z
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ D(h) cos θh dω = 1 (projected microfacet area equals the macro-surface area).
    #[test]
    fn ggx_d_is_normalised() {
        for &alpha in &[0.05f32, 0.3, 1.0] {
            let n = 4000;
            let mut sum = 0.0f64;
            // Integrate over cos θ with substitution for the peak: uniform in θ.
            for i in 0..n {
                let theta = (i as f32 + 0.5) / n as f32 * std::f32::consts::FRAC_PI_2;
                let h = Vec3::new(theta.sin(), 0.0, theta.cos());
                sum += (ggx_d(alpha, h) * h.z * theta.sin()) as f64;
            }
            let integral =
                sum * (std::f64::consts::FRAC_PI_2 / n as f64) * 2.0 * std::f64::consts::PI;
            assert!((integral - 1.0).abs() < 1e-3, "alpha {alpha}: {integral}");
        }
    }
}
