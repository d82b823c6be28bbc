//! Phase functions: how light scattered in a medium leaves, per steradian, as Cycles defines
//! its volume closures — Henyey–Greenstein (Henyey & Greenstein 1941), Rayleigh, Draine
//! (Draine 2003) and the approximate Mie function of fog and cloud droplets (Jendersie &
//! d'Eon 2023: a mixture of Henyey–Greenstein and Draine fitted to the droplets' diameter).
//!
//! Every phase function here is sampled by a Henyey–Greenstein lobe (or a mixture of two, or
//! the uniform sphere for Rayleigh) whose density `sample` returns with the value, so the
//! weight f / pdf stays bounded and MIS reads the true sampling density.

use crate::math::{Frame, Vec3};
use std::f32::consts::PI;

/// A phase function (see the module header). Directions are unit vectors; `cos` is the cosine
/// between the direction the light travelled and the one it leaves along (0: sideways).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Phase {
    /// Mean cosine g in (−1, 1).
    HenyeyGreenstein(f32),
    Rayleigh,
    /// Draine's phase function of g and α (α = 1: Cornette–Shanks).
    Draine {
        g: f32,
        alpha: f32,
    },
    /// Jendersie & d'Eon's mixture: `(1 − mixture)` × HG(`g_hg`) + `mixture` × Draine(`g_d`,
    /// `alpha`).
    Mie {
        g_hg: f32,
        g_d: f32,
        alpha: f32,
        mixture: f32,
    },
}

/// The largest |g| used: a lobe sharper than this is a numerical delta.
const MAX_G: f32 = 0.999;

/// The Henyey–Greenstein phase function of `g` at cosine `cos` (per steradian).
pub fn henyey_greenstein(cos: f32, g: f32) -> f32 {
    let d = 1.0 + g * g - 2.0 * g * cos;
    (1.0 - g * g) / (4.0 * PI * d * d.sqrt())
}

/// A direction scattered from `dir` by the Henyey–Greenstein phase function of `g`
/// (importance-sampled: the phase function cancels against its density).
pub fn sample_henyey_greenstein(dir: Vec3, g: f32, u: [f32; 2]) -> Vec3 {
    let cos = if g.abs() < 1e-3 {
        1.0 - 2.0 * u[0]
    } else {
        let k = (1.0 - g * g) / (1.0 - g + 2.0 * g * u[0]);
        ((1.0 + g * g - k * k) / (2.0 * g)).clamp(-1.0, 1.0)
    };
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = 2.0 * PI * u[1];
    let frame = Frame::from_normal(dir);
    frame.to_world(Vec3::new(sin * phi.cos(), sin * phi.sin(), cos))
}

/// Draine's phase function of `g` and `alpha` at cosine `cos`.
fn draine(cos: f32, g: f32, alpha: f32) -> f32 {
    let norm = 1.0 + alpha * (1.0 + 2.0 * g * g) / 3.0;
    henyey_greenstein(cos, g) * (1.0 + alpha * cos * cos) / norm
}

impl Phase {
    /// Henyey–Greenstein of anisotropy `g`, clamped away from a delta as Cycles clamps it.
    pub fn henyey_greenstein(g: f32) -> Phase {
        Phase::HenyeyGreenstein(if g.is_finite() {
            g.clamp(-MAX_G, MAX_G)
        } else {
            0.0
        })
    }

    /// The value at cosine `cos` between the light's travel direction and the scattered one.
    pub fn eval(&self, cos: f32) -> f32 {
        match *self {
            Phase::HenyeyGreenstein(g) => henyey_greenstein(cos, g),
            Phase::Rayleigh => 3.0 / (16.0 * PI) * (1.0 + cos * cos),
            Phase::Draine { g, alpha } => draine(cos, g, alpha),
            Phase::Mie {
                g_hg,
                g_d,
                alpha,
                mixture,
            } => (1.0 - mixture) * henyey_greenstein(cos, g_hg) + mixture * draine(cos, g_d, alpha),
        }
    }

    /// The density `sample` draws the cosine `cos` with.
    pub fn pdf(&self, cos: f32) -> f32 {
        match *self {
            Phase::HenyeyGreenstein(g) | Phase::Draine { g, .. } => henyey_greenstein(cos, g),
            Phase::Rayleigh => 1.0 / (4.0 * PI),
            Phase::Mie {
                g_hg, g_d, mixture, ..
            } => {
                (1.0 - mixture) * henyey_greenstein(cos, g_hg)
                    + mixture * henyey_greenstein(cos, g_d)
            }
        }
    }

    /// A direction scattered from travel direction `dir`, with the phase value there and the
    /// density it was drawn with (`pdf`). `u` uniform in [0, 1)³.
    pub fn sample(&self, dir: Vec3, u: [f32; 3]) -> (Vec3, f32, f32) {
        let g = match *self {
            Phase::HenyeyGreenstein(g) | Phase::Draine { g, .. } => g,
            Phase::Rayleigh => 0.0,
            Phase::Mie {
                g_hg, g_d, mixture, ..
            } => {
                if u[2] < mixture {
                    g_d
                } else {
                    g_hg
                }
            }
        };
        let wi = sample_henyey_greenstein(dir, g, [u[0], u[1]]);
        let cos = dir.dot(wi);
        (wi, self.eval(cos), self.pdf(cos))
    }

    /// Jendersie & d'Eon's fit of droplets of `diameter` micrometres (Cycles' Mie phase),
    /// their equations 11–18 by range of the diameter.
    pub fn mie(diameter: f32) -> Phase {
        let d = diameter.max(0.0);
        let (g_hg, g_d, alpha, mixture) = if d <= 0.1 {
            (
                13.8 * d * d,
                1.1456 * d * (9.29044 * d).sin(),
                250.0,
                0.252977 - 312.983 * d.powf(4.3),
            )
        } else if d < 1.5 {
            let l = d.ln();
            let a = (l - 0.238604) * (l + 1.00667);
            let b = 0.507522 - 0.15677 * l;
            let c = 1.19692 * (a / b).cos() + 1.37932 * l + 0.0625835;
            (
                0.862 - 0.143 * l * l,
                0.379685 * c.cos() + 0.344213,
                250.0,
                0.146209 * (3.38707 * l + 2.11193).cos() + 0.316072 + 0.0778917 * l,
            )
        } else if d < 5.0 {
            let l = d.ln();
            let ll = l.ln();
            (
                0.0604931 * ll + 0.940256,
                0.500411 - 0.081287 / (-2.0 * l + l.tan() + 1.27551),
                7.30354 * l + 6.31675,
                0.026914 * (l - (5.68947 * (ll - 0.0292149)).cos()) + 0.3764,
            )
        } else {
            (
                (-0.0990567 / (d - 1.67154)).exp(),
                (-2.20679 / (d + 3.91029) - 0.428934).exp(),
                (3.62489 - 8.29288 / (d + 5.52825)).exp(),
                (-0.599085 / (d - 0.641583) - 0.665888).exp(),
            )
        };
        Phase::Mie {
            g_hg: g_hg.clamp(-MAX_G, MAX_G),
            g_d: g_d.clamp(-MAX_G, MAX_G),
            alpha,
            mixture: mixture.clamp(0.0, 1.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;

    /// P(cos ≤ x) of a Henyey–Greenstein lobe of `g`, in f64.
    fn hg_cdf(g: f64, x: f64) -> f64 {
        if g.abs() < 1e-3 {
            return (x + 1.0) / 2.0;
        }
        (1.0 - g * g) / (2.0 * g) * (1.0 / (1.0 + g * g - 2.0 * g * x).sqrt() - 1.0 / (1.0 + g))
    }

    /// P(cos ≤ x) of the density `sample` draws from.
    fn sampling_cdf(phase: &Phase, x: f64) -> f64 {
        match *phase {
            Phase::HenyeyGreenstein(g) | Phase::Draine { g, .. } => hg_cdf(g as f64, x),
            Phase::Rayleigh => (x + 1.0) / 2.0,
            Phase::Mie {
                g_hg, g_d, mixture, ..
            } => {
                let m = mixture as f64;
                (1.0 - m) * hg_cdf(g_hg as f64, x) + m * hg_cdf(g_d as f64, x)
            }
        }
    }

    fn phases() -> Vec<Phase> {
        vec![
            Phase::henyey_greenstein(0.0),
            Phase::henyey_greenstein(0.7),
            Phase::henyey_greenstein(-0.4),
            Phase::Rayleigh,
            Phase::Draine { g: 0.3, alpha: 1.0 },
            Phase::mie(0.05),
            Phase::mie(1.0),
            Phase::mie(3.0),
            Phase::mie(20.0),
        ]
    }

    /// Each phase function integrates to one over the sphere, and so does its sampling density
    /// (by quadrature, for the lobes f32 quadrature resolves: E[f / pdf] = 1 below covers the
    /// sharp ones).
    #[test]
    fn phase_functions_and_densities_are_normalised() {
        for phase in phases().into_iter().take(7) {
            let n = 200_000;
            let (mut f, mut p) = (0.0f64, 0.0f64);
            for i in 0..n {
                let cos = -1.0 + 2.0 * (i as f32 + 0.5) / n as f32;
                f += phase.eval(cos) as f64;
                p += phase.pdf(cos) as f64;
            }
            // ∫ over the sphere = 2π ∫ d cos.
            let scale = 2.0 * std::f64::consts::PI * 2.0 / n as f64;
            assert!(
                (f * scale - 1.0).abs() < 2e-3,
                "{phase:?}: ∫f = {}",
                f * scale
            );
            assert!(
                (p * scale - 1.0).abs() < 2e-3,
                "{phase:?}: ∫pdf = {}",
                p * scale
            );
        }
    }

    /// Sampled directions follow `pdf`: the histogram of cosines in 20 bins against the
    /// density's integral over each bin, and f / pdf averages to one.
    #[test]
    fn sampling_follows_its_density() {
        let dir = Vec3::new(0.3, -0.5, 0.8).normalize();
        for phase in phases() {
            let mut rng = Rng::new(5);
            let n = 200_000;
            let bins = 20;
            let mut hist = vec![0u32; bins];
            let mut weight = 0.0f64;
            for _ in 0..n {
                let (wi, f, pdf) = phase.sample(dir, [rng.uniform(), rng.uniform(), rng.uniform()]);
                let cos = dir.dot(wi).clamp(-1.0, 1.0);
                assert!(
                    (pdf - phase.pdf(cos)).abs() <= 1e-3 * pdf.max(1.0),
                    "{phase:?}"
                );
                weight += (f / pdf) as f64;
                let b = (((cos + 1.0) * 0.5 * bins as f32) as usize).min(bins - 1);
                hist[b] += 1;
            }
            assert!(
                (weight / n as f64 - 1.0).abs() < 0.02,
                "{phase:?}: E[f/pdf] = {}",
                weight / n as f64
            );
            for (b, &count) in hist.iter().enumerate() {
                let edge = |k: usize| -1.0 + 2.0 * k as f64 / bins as f64;
                let mass = sampling_cdf(&phase, edge(b + 1)) - sampling_cdf(&phase, edge(b));
                let expected = mass as f32 * n as f32;
                let sigma = expected.sqrt().max(1.0);
                assert!(
                    (count as f32 - expected).abs() < 5.0 * sigma + 0.01 * expected,
                    "{phase:?} bin {b}: {count} vs {expected}"
                );
            }
        }
    }
}
