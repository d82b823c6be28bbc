//! Phase functions: how light scattered in a medium leaves, per steradian, as Cycles defines
//! its volume closures — Henyey–Greenstein (Henyey & Greenstein 1941), Rayleigh, Draine
//! (Draine 2003), the approximate Mie function of fog and cloud droplets (Jendersie &
//! d'Eon 2023: a mixture of Henyey–Greenstein and Draine fitted to the droplets' diameter) and
//! Fournier–Forand's function of ocean particles (Fournier & Forand 1994, in the closed form
//! and with the cumulative distribution of Fournier & Jonasz 1999), its slope from the
//! particles' index of refraction and backscatter fraction as Cycles derives it.
//!
//! Every phase function but Fournier–Forand is sampled by a Henyey–Greenstein lobe (or a
//! mixture of two, or the uniform sphere for Rayleigh) whose density `sample` returns with the
//! value, so the weight f / pdf stays bounded and MIS reads the true sampling density.
//! Fournier–Forand is sampled exactly, by inverting its cumulative distribution (Newton's
//! method kept inside a shrinking bracket), so its weight is one.

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
    /// Fournier–Forand's function (`FournierForand`), built by `Phase::fournier_forand`.
    FournierForand(FournierForand),
}

/// Fournier–Forand's phase function of particles of relative index of refraction n whose
/// sizes follow a power law (Junge) of slope μ = 3 − 2ν. With x = sin²(θ/2) and
/// δ = 4x / (3(n − 1)²):
///
/// p(θ) = [ν(1 − δ) − (1 − δ^ν) + (δ(1 − δ^ν) − ν(1 − δ)) / x] / (4π (1 − δ)² δ^ν)
///        + c (3cos²θ − 1) / (16π),
///
/// c = (δ₁₈₀^−ν − 1) / (δ₁₈₀ − 1) making it integrate to one; the probability of scattering by
/// less than θ is F(x) = [1 − δ^(ν+1) − (1 − δ^ν) x] / ((1 − δ) δ^ν) + c cosθ sin²θ / 8.
/// ν follows from the backscatter fraction B (the probability of scattering by more than 90°)
/// as ν = −ln(2B(δ₉₀ − 1) + 1) / ln δ₉₀.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FournierForand {
    /// 4 / (3(n − 1)²): δ = `delta_scale` × x.
    delta_scale: f32,
    /// ν, negative: the steeper the forward peak, the nearer to zero.
    nu: f32,
    /// c, the weight of the (3cos²θ − 1) term.
    c: f32,
}

/// Where |1 − δ| is below this, p and F are read from their first-order expansions in δ − 1
/// (their closed forms divide zero by zero at δ = 1).
const FF_NEAR_ONE: f64 = 1e-4;

/// The smallest x = sin²(θ/2) the phase function is read at: half the step of an f32 cosine
/// next to 1, so that the forward direction itself has a finite density.
const FF_MIN_X: f64 = 1.0 / (1u64 << 26) as f64;

impl FournierForand {
    /// The function of particles of index of refraction `ior` (relative to the medium) with
    /// backscatter fraction `backscatter`, clamped as Cycles clamps them: |B| below 0.5 (0.5
    /// is isotropic only in the limit) and n above 1. A B of 0 (a forward delta) is taken as
    /// 10⁻⁴.
    pub fn new(backscatter: f32, ior: f32) -> FournierForand {
        let b = if backscatter.is_finite() {
            (backscatter.abs() as f64).clamp(1e-4, 0.5 - 1e-3)
        } else {
            0.1
        };
        let n = if ior.is_finite() {
            (ior as f64).max(1.0 + 1e-3)
        } else {
            1.33
        };
        let mut delta_scale = 4.0 / (3.0 * (n - 1.0) * (n - 1.0));
        // δ₉₀ = 1 (n ≈ 1.8165) leaves ν undefined: step off it.
        if ((0.5 * delta_scale) - 1.0f64).abs() < 1e-6 {
            delta_scale *= 1.0 + 4e-6;
        }
        let d90 = 0.5 * delta_scale;
        let d180 = delta_scale;
        let nu = -(2.0 * b * (d90 - 1.0) + 1.0).ln() / d90.ln();
        let c = (d180.powf(-nu) - 1.0) / (d180 - 1.0);
        FournierForand {
            delta_scale: delta_scale as f32,
            nu: nu as f32,
            c: c as f32,
        }
    }

    /// F(x), the probability of scattering by less than θ, and the density per steradian p(x)
    /// at x = sin²(θ/2) in (0, 1], in f64 (they share δ^ν).
    fn cdf_and_density(&self, x: f64) -> (f64, f64) {
        let (nu, c) = (self.nu as f64, self.c as f64);
        let delta = self.delta_scale as f64 * x;
        let cos = 1.0 - 2.0 * x;
        let e = delta - 1.0;
        let (cdf, density) = if e.abs() < FF_NEAR_ONE {
            let cdf = 1.0 + nu * (1.0 - x) * (1.0 - 0.5 * (nu + 1.0) * e);
            let p0 = nu * ((nu - 1.0) - (nu + 1.0) / x) / (8.0 * std::f64::consts::PI);
            let p1 = nu * (nu + 1.0) * ((2.0 * nu + 1.0) / x - 2.0 * (nu - 1.0))
                / (24.0 * std::f64::consts::PI);
            (cdf, p0 + p1 * e)
        } else {
            let m = 1.0 - delta;
            let pow = delta.powf(nu);
            let cdf = (1.0 - pow * delta - (1.0 - pow) * x) / (m * pow);
            let density = (nu * m - (1.0 - pow) + (delta * (1.0 - pow) - nu * m) / x)
                / (4.0 * std::f64::consts::PI * m * m * pow);
            (cdf, density)
        };
        (
            cdf + 0.125 * c * cos * (1.0 - cos * cos),
            density + c * (3.0 * cos * cos - 1.0) / (16.0 * std::f64::consts::PI),
        )
    }

    /// The density per steradian at x = sin²(θ/2) in (0, 1].
    fn density(&self, x: f64) -> f64 {
        self.cdf_and_density(x).1
    }

    /// F(x) for any x in [0, 1] (the tests read it).
    #[cfg(test)]
    fn cdf(&self, x: f64) -> f64 {
        match x > 0.0 {
            true => self.cdf_and_density(x.min(1.0)).0,
            false => 0.0,
        }
    }

    /// The x = sin²(θ/2) at which F reaches `u` (F is increasing from F(0) = 0 to F(1) = 1):
    /// Newton steps on F(x) − u, dF/dx = 4π p(x), each kept inside the bracket that the
    /// signs of F − u so far leave (a bisection where a step would leave it). The first guess
    /// is the forward peak's power law, F ≈ δ^−ν for small δ.
    fn invert(&self, u: f64) -> f64 {
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        let guess = u.powf(-1.0 / self.nu as f64) / self.delta_scale as f64;
        let mut x = if guess.is_finite() {
            guess.clamp(FF_MIN_X, 0.5)
        } else {
            0.5
        };
        for _ in 0..64 {
            let (cdf, density) = self.cdf_and_density(x);
            let residual = cdf - u;
            if residual.abs() < 1e-9 {
                break;
            }
            if residual > 0.0 {
                hi = x;
            } else {
                lo = x;
            }
            if hi - lo < 1e-15 * hi.max(FF_MIN_X) {
                break;
            }
            let slope = 4.0 * std::f64::consts::PI * density;
            let step = x - residual / slope;
            // Bisect in log space below the middle of a wide bracket (the forward peak spans
            // many orders of magnitude of x), linearly above.
            x = if step > lo && step < hi && slope.is_finite() && slope > 0.0 {
                step
            } else if lo > 0.0 && hi > 4.0 * lo {
                (lo * hi).sqrt()
            } else if lo == 0.0 && hi > FF_MIN_X {
                (hi * 1e-3).max(hi * hi).max(0.5 * FF_MIN_X)
            } else {
                0.5 * (lo + hi)
            };
        }
        x.clamp(0.0, 1.0)
    }
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
            Phase::FournierForand(ff) => {
                ff.density((0.5 * (1.0 - cos as f64)).clamp(FF_MIN_X, 1.0)) as f32
            }
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
            Phase::FournierForand(_) => self.eval(cos),
        }
    }

    /// A direction scattered from travel direction `dir`, with the phase value there and the
    /// density it was drawn with (`pdf`). `u` uniform in [0, 1)³.
    pub fn sample(&self, dir: Vec3, u: [f32; 3]) -> (Vec3, f32, f32) {
        let g = match *self {
            Phase::FournierForand(ff) => {
                // x = sin²(θ/2): sinθ = 2√(x(1 − x)) keeps tiny angles that 1 − cosθ loses.
                let x = ff.invert(u[0] as f64);
                let cos = (1.0 - 2.0 * x) as f32;
                let sin = (2.0 * (x * (1.0 - x)).sqrt()) as f32;
                let phi = 2.0 * PI * u[1];
                let wi = Frame::from_normal(dir)
                    .to_world(Vec3::new(sin * phi.cos(), sin * phi.sin(), cos))
                    .normalize();
                let p = self.eval(dir.dot(wi));
                return (wi, p, p);
            }
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

    /// Fournier–Forand's function of particles of index of refraction `ior` and backscatter
    /// fraction `backscatter` (`FournierForand::new`).
    pub fn fournier_forand(backscatter: f32, ior: f32) -> Phase {
        Phase::FournierForand(FournierForand::new(backscatter, ior))
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
            // cos ≤ x: scattered by more than the angle of x.
            Phase::FournierForand(ff) => 1.0 - ff.cdf(0.5 * (1.0 - x)),
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
            Phase::fournier_forand(0.1, 1.33),
            Phase::fournier_forand(0.01, 1.05),
            Phase::fournier_forand(0.3, 1.2),
            Phase::fournier_forand(0.2, 2.5),
        ]
    }

    /// The Fournier–Forand functions of `phases` and a few edge cases: a B at its clamp, an
    /// index next to δ₉₀ = 1.
    fn fournier_forands() -> Vec<FournierForand> {
        let mut all: Vec<FournierForand> = phases()
            .into_iter()
            .filter_map(|p| match p {
                Phase::FournierForand(ff) => Some(ff),
                _ => None,
            })
            .collect();
        all.push(FournierForand::new(0.6, 1.1));
        all.push(FournierForand::new(0.05, 1.8165));
        all
    }

    /// A backscatter fraction of 0 (a forward delta) is taken as 10⁻⁴: nearly every sample goes
    /// straight on, all with weight one.
    #[test]
    fn fournier_forand_without_backscatter_is_a_forward_peak() {
        let phase = Phase::fournier_forand(0.0, 1.33);
        let dir = Vec3::new(0.6, 0.0, 0.8);
        let mut rng = Rng::new(2);
        let mut straight = 0;
        for _ in 0..10_000 {
            let (wi, f, pdf) = phase.sample(dir, [rng.uniform(), rng.uniform(), rng.uniform()]);
            assert!(f == pdf && pdf > 0.0 && pdf.is_finite(), "{f} {pdf}");
            straight += (dir.dot(wi) > 0.999) as u32;
        }
        assert!(straight > 9_900, "{straight}");
    }

    /// Fournier–Forand integrates to one (quadrature in x = sin²(θ/2) = tᵐ, m ≥ 2/|ν|, which
    /// flattens the forward peak's x^−(1+ν)), its F is the integral of 4π p dx, and the probability of
    /// scattering by more than 90° is the backscatter fraction it was built from.
    #[test]
    fn fournier_forand_is_normalised_and_has_its_backscatter_fraction() {
        for ff in fournier_forands() {
            let n = 400_000;
            let m = (2.0 / -ff.nu as f64).ceil().max(4.0) as i32;
            let mut total = 0.0f64;
            for i in 0..n {
                let t = (i as f64 + 0.5) / n as f64;
                let dx = m as f64 * t.powi(m - 1) / n as f64;
                total += 4.0 * std::f64::consts::PI * ff.density(t.powi(m)) * dx;
            }
            assert!((total - 1.0).abs() < 1e-3, "{ff:?}: ∫p = {total}");
            assert!(ff.cdf(0.0).abs() < 1e-12 && (ff.cdf(1.0) - 1.0).abs() < 1e-9);
            for x in [1e-6f64, 1e-3, 0.05, 0.3, 0.5, 0.9] {
                let h = 1e-4 * x.min(1.0 - x);
                let slope = (ff.cdf(x + h) - ff.cdf(x - h)) / (2.0 * h);
                let density = 4.0 * std::f64::consts::PI * ff.density(x);
                assert!(
                    (slope - density).abs() < 1e-4 * density,
                    "{ff:?} at x = {x}: F' = {slope}, 4πp = {density}"
                );
            }
        }
        for (b, n) in [(0.1, 1.33), (0.01, 1.05), (0.3, 1.2), (0.2, 2.5)] {
            let backscatter = 1.0 - FournierForand::new(b, n).cdf(0.5);
            assert!(
                (backscatter - b as f64).abs() < 1e-5,
                "B {b} n {n}: {backscatter}"
            );
        }
    }

    /// Near δ = 1 the expansions meet the closed forms.
    #[test]
    fn fournier_forand_expansions_meet_the_closed_forms() {
        let ff = FournierForand::new(0.1, 1.33);
        let x_one = 1.0 / ff.delta_scale as f64;
        for side in [-1.0, 1.0] {
            let inside = x_one * (1.0 + side * 0.99 * FF_NEAR_ONE);
            let outside = x_one * (1.0 + side * 1.01 * FF_NEAR_ONE);
            let (a, b) = (ff.density(inside), ff.density(outside));
            assert!((a - b).abs() < 1e-4 * a, "{a} vs {b}");
            let (a, b) = (ff.cdf(inside), ff.cdf(outside));
            assert!((a - b).abs() < 1e-6, "{a} vs {b}");
        }
    }

    /// Sampling Fournier–Forand inverts F: in 50 bins of equal probability (finer where the
    /// forward peak is), the counts of 200 000 samples pass a χ² test, and f / pdf = 1.
    #[test]
    fn fournier_forand_sampling_passes_chi_square() {
        let dir = Vec3::new(-0.2, 0.9, 0.1).normalize();
        for ff in fournier_forands() {
            let phase = Phase::FournierForand(ff);
            let mut rng = Rng::new(11);
            let (n, bins) = (200_000, 50);
            let mut hist = vec![0u32; bins];
            for _ in 0..n {
                let (wi, f, pdf) = phase.sample(dir, [rng.uniform(), rng.uniform(), rng.uniform()]);
                assert!((wi.length() - 1.0).abs() < 1e-5);
                assert!(
                    f == pdf && pdf > 0.0 && pdf.is_finite(),
                    "{ff:?}: {f} {pdf}"
                );
                // x = sin²(θ/2) of the direction drawn, from sinθ = |dir × wi|, which resolves
                // the forward peak's tiny angles that the cosine rounds away.
                let (d, w) = (dir.as_dvec3(), wi.as_dvec3());
                let sin2 = d.cross(w).length_squared().min(1.0);
                let root = (1.0 - sin2).sqrt();
                let x = match d.dot(w) > 0.0 {
                    true => sin2 / (2.0 * (1.0 + root)),
                    false => 0.5 * (1.0 + root),
                };
                let b = ((ff.cdf(x) * bins as f64) as usize).min(bins - 1);
                hist[b] += 1;
            }
            let expected = n as f64 / bins as f64;
            let chi2: f64 = hist
                .iter()
                .map(|&c| (c as f64 - expected).powi(2) / expected)
                .sum();
            // 49 degrees of freedom: P(χ² > 94) ≈ 10⁻⁴.
            assert!(chi2 < 94.0, "{ff:?}: χ² = {chi2}, {hist:?}");
        }
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
