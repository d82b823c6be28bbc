//! The GGX (Trowbridge–Reitz) microfacet distribution, isotropic and anisotropic (Heitz 2014
//! §5.2: α_x along the frame's x axis, α_y along y): normal distribution D, Smith
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
    sample_ggx_vndf_aniso(alpha, alpha, wo, u)
}

/// Anisotropic GGX D(h).
pub fn ggx_d_aniso(ax: f32, ay: f32, h: Vec3) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let (x, y) = (h.x / ax, h.y / ay);
    let t = x * x + y * y + h.z * h.z;
    FRAC_1_PI / (ax * ay * t * t)
}

/// Anisotropic Smith Λ(w).
pub fn ggx_lambda_aniso(ax: f32, ay: f32, w: Vec3) -> f32 {
    let cos2 = w.z * w.z;
    if cos2 <= 0.0 {
        return f32::INFINITY;
    }
    let t = ((ax * w.x) * (ax * w.x) + (ay * w.y) * (ay * w.y)) / cos2;
    0.5 * ((1.0 + t.max(0.0)).sqrt() - 1.0)
}

/// Anisotropic height-correlated G2(wo, wi).
pub fn ggx_g2_aniso(ax: f32, ay: f32, wo: Vec3, wi: Vec3) -> f32 {
    1.0 / (1.0 + ggx_lambda_aniso(ax, ay, wo) + ggx_lambda_aniso(ax, ay, wi))
}

/// Density of `sample_ggx_vndf_aniso` over microfacet normals.
pub fn ggx_vndf_pdf_aniso(ax: f32, ay: f32, wo: Vec3, h: Vec3) -> f32 {
    let cos_oh = wo.dot(h);
    if cos_oh <= 0.0 || wo.z <= 0.0 {
        return 0.0;
    }
    cos_oh * ggx_d_aniso(ax, ay, h) / ((1.0 + ggx_lambda_aniso(ax, ay, wo)) * wo.z)
}

/// `sample_ggx_vndf` with α_x ≠ α_y.
pub fn sample_ggx_vndf_aniso(ax: f32, ay: f32, wo: Vec3, u: [f32; 2]) -> Vec3 {
    let alpha = Vec3::new(ax, ay, 1.0);
    // Stretch the view so the distribution becomes the hemisphere of radius 1.
    let v = (wo * alpha).normalize();
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
    Vec3::new(ax * n.x, ay * n.y, n.z.max(1e-7)).normalize()
}

/// Density of `sample_ggx_vndf` over microfacet normals: G1(wo)·max(0, wo·h)·D(h) / wo.z.
pub fn ggx_vndf_pdf(alpha: f32, wo: Vec3, h: Vec3) -> f32 {
    let cos_oh = wo.dot(h);
    if cos_oh <= 0.0 || wo.z <= 0.0 {
        return 0.0;
    }
    ggx_g1(alpha, wo) * cos_oh * ggx_d(alpha, h) / wo.z
}

/// ∫ f over the upper hemisphere by the midpoint rule in (cos θ, φ) on n × 2n cells (for
/// tests of the lobes' normalisation).
#[cfg(test)]
pub(crate) fn hemisphere_integral(n: usize, f: impl Fn(Vec3) -> f32) -> f64 {
    let mut sum = 0.0f64;
    for i in 0..n {
        let z = (i as f32 + 0.5) / n as f32;
        let s = (1.0 - z * z).sqrt();
        for j in 0..2 * n {
            let phi = (j as f32 + 0.5) / (2 * n) as f32 * 2.0 * PI;
            sum += f(Vec3::new(s * phi.cos(), s * phi.sin(), z)) as f64;
        }
    }
    sum / n as f64 * 2.0 * std::f64::consts::PI / (2 * n) as f64
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

    /// The anisotropic functions reduce to the isotropic ones, and D_aniso is normalised.
    #[test]
    fn anisotropic_ggx_is_consistent() {
        let h = Vec3::new(0.3, -0.2, 0.9).normalize();
        let w = Vec3::new(-0.5, 0.4, 0.6).normalize();
        assert!((ggx_d_aniso(0.4, 0.4, h) - ggx_d(0.4, h)).abs() < 1e-4 * ggx_d(0.4, h));
        assert!((ggx_lambda_aniso(0.4, 0.4, w) - ggx_lambda(0.4, w)).abs() < 1e-5);
        let (ax, ay) = (0.6f32, 0.15f32);
        let integral = hemisphere_integral(1000, |w| ggx_d_aniso(ax, ay, w) * w.z);
        assert!((integral - 1.0).abs() < 2e-3, "{integral}");
    }
}
