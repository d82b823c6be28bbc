//! Hair fibres: Blender's Principled Hair BSDF, Chiang model (Chiang, Bitterli, Tappan &
//! Burley 2016, "A Practical and Controllable Hair and Fur Model for Production Path
//! Tracing", after d'Eon et al. 2011's longitudinal lobes and Marschner et al. 2003's R, TT and
//! TRT paths), and Blender's older Hair BSDF (one Gaussian-like reflection or transmission lobe
//! around the fibre, as Cycles' `bsdf_hair`).
//!
//! Frame: the shading frame's x axis is the fibre's tangent (root to tip), z the fibre's
//! normal at the point (`crate::interaction::SurfaceHit::fibre_tangent`). θ is the longitudinal angle
//! (sin θ = ω·x), φ the azimuth around the fibre. The offset h ∈ [−1, 1] across the fibre
//! follows from the view: h = sin γ_o, γ_o the angle between the normal and the view
//! projected on the normal plane, with the sign convention of Cycles' curves (h = −ω_o,y / |ω_o
//! projected|), so a round fibre seen across its width meets every h once.
//!
//! Chiang's model: each path p (R, TT, TRT) scatters as A_p(h) · M_p(θ_i, θ_o) · N_p(φ) and
//! the residual (TRRT and beyond) as A_3 · M_3 / (2π); f·|cos θ| (what `eval` returns) is
//! their sum. M_p is d'Eon's longitudinal lobe of variance v_p (v_R from the roughness and
//! the Coat, v_TT = v/4, v_TRT = v_res = 4v) around −θ_o, shifted by the cuticle tilt
//! (2α, −α, −4α); N_p a logistic of scale s (from the radial roughness) trimmed to [−π, π],
//! centred on Marschner's azimuthal deflection Δφ_p = 2pγ_t − 2γ_o + pπ. A_p follow from the
//! Fresnel reflectance at the entry and the absorption along the chord, exp(−σ 2cos γ_t /
//! cos θ_t) (σ per unit diameter). With no absorption, A_0 + A_1 + A_2 + A_3 = 1 and the
//! lobes are normalised: the fibre conserves energy exactly.
//!
//! The tilted lobes are M_p(θ') cos θ'/cos θ_i, θ' the untilted angle: with the tilt's
//! Jacobian each stays normalised, so the fibre conserves energy with any tilt. (Cycles
//! evaluates M_p(θ') alone, which its sampling, the same as here, does not follow: its
//! sampled paths see the lobes as here, its light samples without the Jacobian; the two
//! differ by tan θ · sin(kα), under 4 % within 60° of the fibre's normal plane for the
//! default 2° tilt. Without the Jacobian, the weight of a sample near the fibre's pole is
//! unbounded.)
//!
//! Sampling picks p by A_p's luminance, θ by inverting M_p (d'Eon et al. 2011) then tilting,
//! φ by inverting the trimmed logistic (or uniformly for the residual). The density `eval`
//! returns is that procedure's exactly, but where the tilt carries a sample past the fibre's
//! pole, within a few α of it; the sample's weight is A_p's mixture over the choice.

use crate::math::{luminance, Vec2, Vec3};
use crate::shader::Hair;
use std::f32::consts::{FRAC_PI_2, PI, TAU};

/// Roughnesses below this are clamped to it (Cycles' limits).
const MIN_ROUGHNESS: f32 = 0.001;

/// A fibre's scattering, from its closure.
#[derive(Clone, Copy, Debug)]
pub enum HairBsdf {
    Chiang(Chiang),
    Gaussian(Gaussian),
}

/// Chiang et al.'s fibre: longitudinal variances of R, TT, TRT and the residual, the
/// logistic's scale, the cuticle tilt α, the IOR and the absorption per unit diameter.
#[derive(Clone, Copy, Debug)]
pub struct Chiang {
    variance: [f32; 4],
    scale: f32,
    tilt: f32,
    eta: f32,
    sigma: Vec3,
}

/// Blender's Hair BSDF: one lobe, reflection or transmission, of widths `roughness_u`
/// (longitudinal) and `roughness_v` (azimuthal), its highlight shifted by `offset`.
#[derive(Clone, Copy, Debug)]
pub struct Gaussian {
    transmission: bool,
    offset: f32,
    roughness_u: f32,
    roughness_v: f32,
}

/// Chiang et al.'s map from a perceptual roughness to d'Eon's longitudinal variance.
fn longitudinal_variance(roughness: f32) -> f32 {
    let b = roughness;
    (0.726 * b + 0.812 * b * b + 3.7 * b.powi(20)).powi(2)
}

/// Chiang et al.'s map from the radial roughness to the logistic's scale.
fn azimuthal_scale(roughness: f32) -> f32 {
    let b = roughness;
    (0.265 * b + 1.194 * b * b + 5.372 * b.powi(22)) * (PI / 8.0).sqrt()
}

impl HairBsdf {
    pub fn new(closure: &Hair) -> HairBsdf {
        let clean = |v: f32, lo: f32, hi: f32| if v.is_finite() { v.clamp(lo, hi) } else { lo };
        match *closure {
            Hair::Chiang {
                sigma,
                roughness,
                radial_roughness,
                coat,
                ior,
                tilt,
            } => {
                let v = clean(roughness, MIN_ROUGHNESS, 1.0);
                let primary = clean((1.0 - clean(coat, 0.0, 1.0)) * v, MIN_ROUGHNESS, 1.0);
                let v_all = longitudinal_variance(v);
                HairBsdf::Chiang(Chiang {
                    variance: [
                        longitudinal_variance(primary),
                        0.25 * v_all,
                        4.0 * v_all,
                        4.0 * v_all,
                    ],
                    scale: azimuthal_scale(clean(radial_roughness, MIN_ROUGHNESS, 1.0)),
                    tilt: clean(tilt, -FRAC_PI_2, FRAC_PI_2),
                    eta: if ior.is_finite() && ior > 1e-3 {
                        ior
                    } else {
                        1.55
                    },
                    sigma: Vec3::new(
                        clean(sigma.x, 0.0, 1e4),
                        clean(sigma.y, 0.0, 1e4),
                        clean(sigma.z, 0.0, 1e4),
                    ),
                })
            }
            Hair::Gaussian {
                transmission,
                offset,
                roughness_u,
                roughness_v,
                ..
            } => HairBsdf::Gaussian(Gaussian {
                transmission,
                // Cycles turns the node's Offset around.
                offset: -clean(offset, -FRAC_PI_2, FRAC_PI_2),
                roughness_u: clean(roughness_u, MIN_ROUGHNESS, 1.0),
                roughness_v: clean(roughness_v, MIN_ROUGHNESS, 1.0),
            }),
        }
    }

    /// The fibre seen from `wo` (local frame, unit); `None` when `wo` runs along the fibre.
    pub fn viewed_from(&self, wo: Vec3) -> Option<ViewedHair> {
        let r = (wo.y * wo.y + wo.z * wo.z).sqrt();
        if !(r > 1e-6) {
            return None;
        }
        // Cycles' curve frame: Y ⟂ the fibre and the view, Z = X × Y (in the view's normal
        // plane, pointing away from the viewer).
        let y_axis = Vec3::new(0.0, -wo.z, wo.y) / r;
        let z_axis = Vec3::new(0.0, -wo.y, -wo.z) / r;
        let sin_theta_o = wo.x.clamp(-1.0, 1.0);
        let cos_theta_o = (1.0 - sin_theta_o * sin_theta_o).max(0.0).sqrt();
        let h = (-wo.y / r).clamp(-1.0, 1.0);
        let lobes = match self {
            HairBsdf::Chiang(c) => Lobes::Chiang(ChiangView::new(c, sin_theta_o, cos_theta_o, h)),
            HairBsdf::Gaussian(g) => Lobes::Gaussian(*g),
        };
        Some(ViewedHair {
            y_axis,
            z_axis,
            sin_theta_o,
            cos_theta_o,
            lobes,
        })
    }

    /// The fibre as Blender's Filter Glossy widens it (`crate::bsdf::PathFilter`): Chiang's
    /// longitudinal variance (the TT, TRT and residual lobes' base), the R lobe's and the
    /// logistic's scale each at least `least`, which Cycles compares with them as they are;
    /// Blender's older Hair BSDF is left as it is, as in Cycles.
    pub fn widened(self, least: f32) -> HairBsdf {
        match self {
            HairBsdf::Chiang(mut c) => {
                let v = (0.25 * c.variance[2]).max(least);
                c.variance = [c.variance[0].max(least), 0.25 * v, 4.0 * v, 4.0 * v];
                c.scale = c.scale.max(least);
                HairBsdf::Chiang(c)
            }
            HairBsdf::Gaussian(g) => HairBsdf::Gaussian(g),
        }
    }

    /// Perceptual roughness of the narrowest lobe (for the photon method's classification).
    pub fn roughness(&self) -> f32 {
        match self {
            HairBsdf::Chiang(c) => c.variance[0].sqrt().sqrt(),
            HairBsdf::Gaussian(g) => g.roughness_u,
        }
    }
}

#[derive(Clone, Copy, Debug)]
enum Lobes {
    Chiang(ChiangView),
    Gaussian(Gaussian),
}

/// What Chiang's lobes hold for one view.
#[derive(Clone, Copy, Debug)]
struct ChiangView {
    fibre: Chiang,
    gamma_o: f32,
    gamma_t: f32,
    /// A_p: R, TT, TRT and the residual.
    attenuation: [Vec3; 4],
    /// The probability of sampling each path (A_p's luminance, normalised).
    choice: [f32; 4],
}

impl ChiangView {
    fn new(fibre: &Chiang, sin_theta_o: f32, cos_theta_o: f32, h: f32) -> ChiangView {
        let eta = fibre.eta;
        let gamma_o = h.asin();
        let sin_theta_t = sin_theta_o / eta;
        let cos_theta_t = (1.0 - sin_theta_t * sin_theta_t).max(1e-8).sqrt();
        let sin_gamma_t = (h * cos_theta_o
            / (eta * eta - sin_theta_o * sin_theta_o).max(1e-8).sqrt())
        .clamp(-1.0, 1.0);
        let gamma_t = sin_gamma_t.asin();
        let cos_gamma_t = (1.0 - sin_gamma_t * sin_gamma_t).max(0.0).sqrt();
        let chord = 2.0 * cos_gamma_t / cos_theta_t;
        let through = Vec3::new(
            (-fibre.sigma.x * chord).exp(),
            (-fibre.sigma.y * chord).exp(),
            (-fibre.sigma.z * chord).exp(),
        );
        let cos_gamma_o = (1.0 - h * h).max(0.0).sqrt();
        let f = super::fresnel::fresnel_dielectric(cos_theta_o * cos_gamma_o, eta);
        let tt = (1.0 - f) * (1.0 - f) * through;
        let trt = tt * through * f;
        let reflected_inside = through * f;
        let rest = trt
            * Vec3::new(
                residual_ratio(reflected_inside.x),
                residual_ratio(reflected_inside.y),
                residual_ratio(reflected_inside.z),
            );
        let attenuation = [Vec3::splat(f), tt, trt, rest];
        let energy = attenuation.map(|a| luminance(a).max(0.0));
        let total: f32 = energy.iter().sum();
        let choice = if total > 0.0 {
            energy.map(|e| e / total)
        } else {
            [1.0, 0.0, 0.0, 0.0]
        };
        ChiangView {
            fibre: *fibre,
            gamma_o,
            gamma_t,
            attenuation,
            choice,
        }
    }

    /// The tilt of path p's longitudinal lobe: R towards the root by 2α, TT and TRT towards
    /// the tip by α and 4α.
    fn tilt(&self, p: usize) -> f32 {
        let a = self.fibre.tilt;
        match p {
            0 => 2.0 * a,
            1 => -a,
            _ => -4.0 * a,
        }
    }

    /// f·|cos θ| and the sampling density at (sin θ_i, cos θ_i, φ = φ_i − φ_o).
    fn eval_and_pdf(
        &self,
        sin_o: f32,
        cos_o: f32,
        sin_i: f32,
        cos_i: f32,
        phi: f32,
    ) -> (Vec3, f32) {
        let mut f = Vec3::ZERO;
        let mut pdf = 0.0;
        for p in 0..3 {
            // θ' = θ_i + tilt: the untilted angle M_p is read at.
            let (st, ct) = self.tilt(p).sin_cos();
            let sin_u = sin_i * ct + cos_i * st;
            let cos_u = (cos_i * ct - sin_i * st).abs();
            let m = longitudinal(sin_u, cos_u, sin_o, cos_o, self.fibre.variance[p]);
            let n = trimmed_logistic(
                wrap_angle(phi - azimuthal_shift(p, self.gamma_o, self.gamma_t)),
                self.fibre.scale,
            );
            // The tilt's Jacobian: M_p is normalised over the untilted angle.
            let jacobian = if cos_i > 0.0 { cos_u / cos_i } else { 0.0 };
            f += self.attenuation[p] * (m * n * jacobian);
            pdf += self.choice[p] * m * n * jacobian;
        }
        let m = longitudinal(sin_i, cos_i, sin_o, cos_o, self.fibre.variance[3]);
        let n = 1.0 / TAU;
        f += self.attenuation[3] * (m * n);
        pdf += self.choice[3] * m * n;
        (f, pdf)
    }

    /// A sampled (sin θ_i, cos θ_i, φ) from `u_lobe` (picks the path, then, rescaled, the
    /// longitudinal angle) and `u`.
    fn sample(&self, sin_o: f32, cos_o: f32, u_lobe: f32, u: Vec2) -> (f32, f32, f32) {
        let mut rest = u_lobe;
        let mut p = 3;
        for (k, &c) in self.choice.iter().enumerate().take(3) {
            if rest < c {
                p = k;
                break;
            }
            rest -= c;
        }
        let c = self.choice[p].max(1e-12);
        let w = (rest / c).clamp(1e-5, 1.0);
        // d'Eon et al.'s exact inversion of M_p around −θ_o.
        let v = self.fibre.variance[p];
        let fac = 1.0 + v * (w + (1.0 - w) * (-2.0 / v).exp()).ln();
        let fac = fac.clamp(-1.0, 1.0);
        let sin_u = -fac * sin_o + (1.0 - fac * fac).max(0.0).sqrt() * (TAU * u.y).cos() * cos_o;
        let sin_u = sin_u.clamp(-1.0, 1.0);
        let cos_u = (1.0 - sin_u * sin_u).max(0.0).sqrt();
        let (sin_i, cos_i) = if p < 3 {
            let (st, ct) = self.tilt(p).sin_cos();
            (sin_u * ct - cos_u * st, (cos_u * ct + sin_u * st).abs())
        } else {
            (sin_u, cos_u)
        };
        let phi = if p < 3 {
            azimuthal_shift(p, self.gamma_o, self.gamma_t)
                + sample_trimmed_logistic(u.x, self.fibre.scale)
        } else {
            TAU * u.x
        };
        (sin_i, cos_i, phi)
    }
}

/// T f / (1 − T f): the residual's sum of further internal reflections.
fn residual_ratio(tf: f32) -> f32 {
    if tf < 1.0 {
        tf / (1.0 - tf)
    } else {
        0.0
    }
}

/// Marschner's azimuthal deflection of path p.
fn azimuthal_shift(p: usize, gamma_o: f32, gamma_t: f32) -> f32 {
    let p = p as f32;
    2.0 * p * gamma_t - 2.0 * gamma_o + p * PI
}

/// `a` brought into [−π, π].
fn wrap_angle(a: f32) -> f32 {
    a - TAU * ((a + PI) / TAU).floor()
}

/// The logistic density of scale `s`.
fn logistic(x: f32, s: f32) -> f32 {
    let e = (-x.abs() / s).exp();
    e / (s * (1.0 + e) * (1.0 + e))
}

fn logistic_cdf(x: f32, s: f32) -> f32 {
    1.0 / (1.0 + (-x / s).exp())
}

/// The logistic of scale `s` restricted to [−π, π] and renormalised.
fn trimmed_logistic(x: f32, s: f32) -> f32 {
    let mass = 1.0 - 2.0 * logistic_cdf(-PI, s);
    if mass > 0.0 {
        logistic(x, s) / mass
    } else {
        0.0
    }
}

/// Inverts the trimmed logistic's distribution at `u` ∈ [0, 1).
fn sample_trimmed_logistic(u: f32, s: f32) -> f32 {
    let below = logistic_cdf(-PI, s);
    let q = u * (1.0 - 2.0 * below) + below;
    (-s * (1.0 / q - 1.0).ln()).clamp(-PI, PI)
}

/// The modified Bessel function I₀ by its power series (converges fast for x ≤ 12).
fn bessel_i0(x: f32) -> f32 {
    let q = 0.25 * x * x;
    let mut term = 1.0f32;
    let mut sum = 1.0f32;
    for k in 1..40 {
        term *= q / (k * k) as f32;
        sum += term;
        if term < sum * 1e-8 {
            break;
        }
    }
    sum
}

/// ln I₀(x): the series below 12, its asymptotic expansion above.
fn log_bessel_i0(x: f32) -> f32 {
    if x > 12.0 {
        x + 0.5 * (1.0 / (8.0 * x) - (TAU * x).ln())
    } else {
        bessel_i0(x).ln()
    }
}

/// d'Eon et al.'s longitudinal lobe M(θ_i, θ_o) of variance `v`, normalised so that ∫ M cos θ_i
/// dθ_i = 1 (in logarithms where v is small, so it neither overflows nor underflows).
fn longitudinal(sin_i: f32, cos_i: f32, sin_o: f32, cos_o: f32, v: f32) -> f32 {
    let a = cos_i * cos_o / v;
    let b = sin_i * sin_o / v;
    if v <= 0.1 {
        (log_bessel_i0(a) - b - 1.0 / v + std::f32::consts::LN_2 + (0.5 / v).ln()).exp()
    } else {
        (-b).exp() * bessel_i0(a) / ((1.0 / v).sinh() * 2.0 * v)
    }
}

impl Gaussian {
    /// The lobe's density over (θ_i, φ) for a view at θ_o, per solid angle; also f·|cos θ|
    /// (the lobe scatters all it receives: its colour weighs it).
    fn pdf(&self, theta_o: f32, theta_i: f32, cos_i: f32, phi: f32) -> f32 {
        if FRAC_PI_2 - theta_i.abs() < 1e-3 || !(cos_i > 0.0) {
            return 0.0;
        }
        let (ru, rv) = (self.roughness_u, self.roughness_v);
        let (a, b) = self.longitudinal_range(theta_o);
        let t = 0.5 * (theta_i + theta_o) - self.offset;
        let theta_pdf = ru / (2.0 * (t * t + ru * ru) * (a - b) * cos_i);
        let phi = phi.abs();
        // Each lobe is its sampling density, over the azimuths it samples (Cycles evaluates
        // the transmission's tail past ±π/2 around the far side and cuts the reflection at
        // ±π/2, which its sampling does not: there the two disagree).
        let phi_pdf = if self.transmission {
            let p = PI - phi;
            if p > FRAC_PI_2 {
                return 0.0;
            }
            rv / (self.transmission_span() * (p * p + rv * rv))
        } else {
            if phi > PI * rv {
                return 0.0;
            }
            (0.5 * phi / rv).cos() * 0.25 / rv
        };
        theta_pdf * phi_pdf
    }

    /// The arctangents bounding the Cauchy-like longitudinal lobe for a view at θ_o.
    fn longitudinal_range(&self, theta_o: f32) -> (f32, f32) {
        let ru = self.roughness_u;
        (
            ((0.5 * (FRAC_PI_2 + theta_o) - self.offset) / ru).atan(),
            ((0.5 * (-FRAC_PI_2 + theta_o) - self.offset) / ru).atan(),
        )
    }

    fn transmission_span(&self) -> f32 {
        2.0 * (FRAC_PI_2 / self.roughness_v).atan()
    }

    fn sample(&self, theta_o: f32, u: Vec2) -> Option<(f32, f32)> {
        let (ru, rv) = (self.roughness_u, self.roughness_v);
        let (a, b) = self.longitudinal_range(theta_o);
        let t = ru * (u.x * (a - b) + b).tan();
        let theta_i = 2.0 * (t + self.offset) - theta_o;
        let phi = if self.transmission {
            PI + rv * (self.transmission_span() * (u.y - 0.5)).tan()
        } else {
            2.0 * (1.0 - 2.0 * u.y).clamp(-1.0, 1.0).asin() * rv
        };
        (theta_i.is_finite() && theta_i.abs() < FRAC_PI_2).then_some((theta_i, phi))
    }
}

/// A fibre seen from one direction: what `ViewedBsdf` evaluates and samples.
#[derive(Clone, Copy, Debug)]
pub struct ViewedHair {
    /// Cycles' azimuthal axes in the local frame (φ = atan2(ω·z_axis, ω·y_axis)).
    y_axis: Vec3,
    z_axis: Vec3,
    sin_theta_o: f32,
    cos_theta_o: f32,
    lobes: Lobes,
}

/// A sampled direction of a fibre.
#[derive(Clone, Copy, Debug)]
pub struct HairSample {
    pub wi: Vec3,
    /// f·|cos θ| (before the closure's colour, for the Hair BSDF) and the density.
    pub f: Vec3,
    pub pdf: f32,
}

impl ViewedHair {
    /// Local direction of longitudinal sine `sin_i` (cosine `cos_i` ≥ 0) and azimuth `phi`
    /// from the view's.
    fn direction(&self, sin_i: f32, cos_i: f32, phi: f32) -> Vec3 {
        // φ_o = −π/2 in Cycles' axes (the view lies along −z_axis).
        let phi_i = phi - FRAC_PI_2;
        let (s, c) = phi_i.sin_cos();
        Vec3::new(sin_i, 0.0, 0.0) + (self.y_axis * c + self.z_axis * s) * cos_i
    }

    /// (sin θ_i, cos θ_i, φ_i − φ_o) of local direction `wi`.
    fn angles(&self, wi: Vec3) -> (f32, f32, f32) {
        let sin_i = wi.x.clamp(-1.0, 1.0);
        let cos_i = (1.0 - sin_i * sin_i).max(0.0).sqrt();
        let phi_i = wi.dot(self.z_axis).atan2(wi.dot(self.y_axis));
        (sin_i, cos_i, phi_i + FRAC_PI_2)
    }

    /// f·|cos θ| and the solid-angle density of `sample` at local direction `wi`.
    pub fn eval_and_pdf(&self, wi: Vec3) -> (Vec3, f32) {
        let (sin_i, cos_i, phi) = self.angles(wi);
        match &self.lobes {
            Lobes::Chiang(c) => {
                c.eval_and_pdf(self.sin_theta_o, self.cos_theta_o, sin_i, cos_i, phi)
            }
            Lobes::Gaussian(g) => {
                let pdf = g.pdf(
                    self.sin_theta_o.asin(),
                    sin_i.asin(),
                    cos_i,
                    wrap_angle(phi),
                );
                (Vec3::splat(pdf), pdf)
            }
        }
    }

    /// A direction drawn by the lobes' densities: `u_lobe` picks the path (Chiang) and, rescaled,
    /// the longitudinal angle; `u` the rest.
    pub fn sample(&self, u_lobe: f32, u: Vec2) -> Option<HairSample> {
        let wi = match &self.lobes {
            Lobes::Chiang(c) => {
                let (sin_i, cos_i, phi) = c.sample(self.sin_theta_o, self.cos_theta_o, u_lobe, u);
                self.direction(sin_i, cos_i, phi)
            }
            Lobes::Gaussian(g) => {
                let (theta_i, phi) = g.sample(self.sin_theta_o.asin(), u)?;
                let (s, c) = theta_i.sin_cos();
                self.direction(s, c, phi)
            }
        };
        let (f, pdf) = self.eval_and_pdf(wi);
        (pdf > 0.0 && pdf.is_finite()).then_some(HairSample { wi, f, pdf })
    }

    /// Directional albedo: Σ A_p for Chiang's fibre (exact without tilt), 1 for the Hair BSDF.
    pub fn albedo(&self) -> Vec3 {
        match &self.lobes {
            Lobes::Chiang(c) => c.attenuation.iter().copied().sum(),
            Lobes::Gaussian(_) => Vec3::ONE,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    fn chiang(sigma: Vec3, roughness: f32, radial: f32, tilt: f32) -> HairBsdf {
        HairBsdf::new(&Hair::Chiang {
            sigma,
            roughness,
            radial_roughness: radial,
            coat: 0.0,
            ior: 1.55,
            tilt,
        })
    }

    /// A view at longitudinal angle `theta` and offset `h` across the fibre.
    fn view(theta: f32, h: f32) -> Vec3 {
        let (s, c) = theta.sin_cos();
        let g = h.asin();
        Vec3::new(s, -c * g.sin(), c * g.cos())
    }

    /// ∫ over the sphere of `g` by the midpoint rule in (sin θ, φ) (dω = d sin θ dφ).
    fn integrate(n: usize, mut g: impl FnMut(Vec3) -> f64) -> f64 {
        let mut sum = 0.0;
        for i in 0..n {
            let s = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
            let c = (1.0 - s * s).sqrt();
            for j in 0..2 * n {
                let phi = std::f64::consts::TAU * (j as f64 + 0.5) / (2 * n) as f64;
                let w = Vec3::new(s as f32, (c * phi.cos()) as f32, (c * phi.sin()) as f32);
                sum += g(w);
            }
        }
        sum * (2.0 / n as f64) * (std::f64::consts::TAU / (2 * n) as f64)
    }

    #[test]
    fn a_fibre_without_absorption_scatters_all_it_receives() {
        for &(roughness, radial, tilt) in &[(0.3, 0.3, 0.0), (0.6, 0.8, 2.0), (0.15, 0.2, 4.0)] {
            let fibre = chiang(Vec3::ZERO, roughness, radial, f32::to_radians(tilt));
            for &(theta, h) in &[(0.0, 0.0), (0.4, 0.5), (-0.9, -0.8), (1.2, 0.95)] {
                let v = fibre.viewed_from(view(theta, h)).unwrap();
                let energy = integrate(800, |w| v.eval_and_pdf(w).0.x as f64);
                let density = integrate(800, |w| v.eval_and_pdf(w).1 as f64);
                assert!(
                    (energy - 1.0).abs() < 0.01,
                    "{roughness} {theta} {h}: {energy}"
                );
                assert!(
                    (density - 1.0).abs() < 0.01,
                    "{roughness} {theta} {h}: {density}"
                );
                assert!((v.albedo() - Vec3::ONE).abs().max_element() < 1e-5);
                // The white furnace by sampling: the mean weight is the albedo, 1.
                let mut rng = Rng::new(3);
                let n = 200_000;
                let mut mean = 0.0f64;
                for _ in 0..n {
                    let (a, b, c) = (rng.uniform(), rng.uniform(), rng.uniform());
                    if let Some(s) = v.sample(a, Vec2::new(b, c)) {
                        mean += (s.f.x / s.pdf) as f64 / n as f64;
                    }
                }
                assert!((mean - 1.0).abs() < 0.01, "{roughness} {theta} {h}: {mean}");
            }
        }
    }

    #[test]
    fn a_tilted_fibre_scatters_its_albedo_and_its_density_stays_normalised() {
        let fibre = chiang(Vec3::new(0.2, 0.5, 1.5), 0.3, 0.3, 2f32.to_radians());
        for &(theta, h) in &[(0.0, 0.3), (0.7, -0.6)] {
            let v = fibre.viewed_from(view(theta, h)).unwrap();
            let energy = integrate(800, |w| v.eval_and_pdf(w).0.z as f64);
            let density = integrate(800, |w| v.eval_and_pdf(w).1 as f64);
            assert!(energy < 1.0 && energy > 0.0, "{energy}");
            assert!(
                (energy / v.albedo().z as f64 - 1.0).abs() < 0.01,
                "{energy}"
            );
            assert!((density - 1.0).abs() < 0.01, "{theta} {h}: {density}");
        }
    }

    /// Samples binned over (sin θ, φ) against the density integrated over each bin: a
    /// chi-square statistic over the bins with enough expected samples.
    #[test]
    fn samples_follow_the_density() {
        const BINS_S: usize = 16;
        const BINS_P: usize = 32;
        const N: usize = 400_000;
        let fibre = chiang(Vec3::new(0.3, 0.6, 1.2), 0.25, 0.4, 3f32.to_radians());
        let wo = view(0.5, 0.4);
        let v = fibre.viewed_from(wo).unwrap();
        let bin = |w: Vec3| {
            let s = ((w.x + 1.0) * 0.5 * BINS_S as f32) as usize;
            let phi = w.z.atan2(w.y).rem_euclid(TAU);
            let p = (phi / TAU * BINS_P as f32) as usize;
            s.min(BINS_S - 1) * BINS_P + p.min(BINS_P - 1)
        };
        let mut observed = vec![0f64; BINS_S * BINS_P];
        let mut rng = Rng::new(7);
        let mut misses = 0;
        for _ in 0..N {
            let (a, b, c) = (rng.uniform(), rng.uniform(), rng.uniform());
            match v.sample(a, Vec2::new(b, c)) {
                Some(s) => {
                    let (f, pdf) = v.eval_and_pdf(s.wi);
                    assert!((pdf - s.pdf).abs() <= 1e-4 * pdf && f == s.f);
                    observed[bin(s.wi)] += 1.0
                }
                None => misses += 1,
            }
        }
        assert_eq!(misses, 0);
        let mut expected = vec![0f64; BINS_S * BINS_P];
        let sub = 24;
        for i in 0..BINS_S * sub {
            let s = -1.0 + 2.0 * (i as f64 + 0.5) / (BINS_S * sub) as f64;
            let c = (1.0 - s * s).sqrt();
            for j in 0..BINS_P * sub {
                let phi = std::f64::consts::TAU * (j as f64 + 0.5) / (BINS_P * sub) as f64;
                let w = Vec3::new(s as f32, (c * phi.cos()) as f32, (c * phi.sin()) as f32);
                let area =
                    (2.0 / (BINS_S * sub) as f64) * (std::f64::consts::TAU / (BINS_P * sub) as f64);
                expected[bin(w)] += v.eval_and_pdf(w).1 as f64 * area * N as f64;
            }
        }
        let (mut chi2, mut dof) = (0.0, 0);
        for (o, e) in observed.iter().zip(&expected) {
            if *e > 20.0 {
                chi2 += (o - e) * (o - e) / e;
                dof += 1;
            }
        }
        // Mean dof, standard deviation sqrt(2 dof): far beyond 5σ is a mismatch.
        let bound = dof as f64 + 5.0 * (2.0 * dof as f64).sqrt();
        assert!(chi2 < bound, "chi2 {chi2} over {dof} bins");
    }

    #[test]
    fn the_hair_bsdf_lobes_are_normalised() {
        for transmission in [false, true] {
            let fibre = HairBsdf::new(&Hair::Gaussian {
                transmission,
                color: Vec3::ONE,
                offset: 0.0,
                roughness_u: 0.2,
                roughness_v: if transmission { 0.3 } else { 0.5 },
            });
            let v = fibre.viewed_from(view(0.3, 0.2)).unwrap();
            let density = integrate(1000, |w| v.eval_and_pdf(w).1 as f64);
            assert!((density - 1.0).abs() < 0.01, "{transmission}: {density}");
        }
    }
}
