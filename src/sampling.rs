//! Warps from the unit square to the domains Photon samples, each with its density, plus the
//! discrete distribution used to pick lights by power, the 2D piecewise-constant one used for
//! environment maps, and the MIS power heuristic.
//! Formulas follow pbrt-v4, chapter A.5 ("Sampling multidimensional functions").
//! Every warp is checked against its pdf by the chi-square tests in `tests/integration/warps.rs`.

use crate::math::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// Shirley–Chiu concentric map from [0,1)² to the unit disk (area-preserving, low distortion).
pub fn square_to_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (
            o.y,
            std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y),
        )
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Cosine-weighted direction on the +Z hemisphere (Malley's method).
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density of `square_to_cosine_hemisphere` per unit solid angle.
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// Uniform direction on the unit sphere.
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform direction inside the cone of half-angle acos(`cos_max`) around +Z.
pub fn square_to_uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let z = 1.0 - u.x * (1.0 - cos_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Density of `square_to_uniform_cone` per unit solid angle.
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max))
}

/// Uniform barycentric coordinates (b1, b2) on a triangle; b0 = 1 − b1 − b2.
/// Uses the low-distortion map of Heitz 2019 ("A Low-Distortion Map Between Triangle and Square").
pub fn square_to_triangle(u: Vec2) -> Vec2 {
    let (b0, b1);
    if u.x < u.y {
        b0 = u.x / 2.0;
        b1 = u.y - b0;
    } else {
        b1 = u.y / 2.0;
        b0 = u.x - b1;
    }
    Vec2::new(b0, b1)
}

/// Balance-style power heuristic with β = 2 (Veach 1997, §9.2.4), for one sample from each strategy.
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let a = pdf_a * pdf_a;
    let b = pdf_b * pdf_b;
    if a == 0.0 {
        return 0.0;
    }
    if !b.is_finite() {
        return 0.0;
    }
    if !a.is_finite() {
        return 1.0;
    }
    a / (a + b)
}

/// A discrete distribution over indices, proportional to non-negative weights.
#[derive(Clone, Debug, Default)]
pub struct Distribution1D {
    /// Cumulative sums normalised to end at 1; `cdf[i]` is the probability of indices < i+1.
    cdf: Vec<f32>,
    pmf: Vec<f32>,
    total: f64,
}

impl Distribution1D {
    /// Weights that are negative or not finite count as zero. A distribution whose weights are
    /// all zero is empty: `sample` returns `None`.
    pub fn new(weights: &[f32]) -> Self {
        let clean: Vec<f64> = weights
            .iter()
            .map(|&w| {
                if w.is_finite() && w > 0.0 {
                    w as f64
                } else {
                    0.0
                }
            })
            .collect();
        let total: f64 = clean.iter().sum();
        if total <= 0.0 {
            return Distribution1D {
                cdf: Vec::new(),
                pmf: vec![0.0; weights.len()],
                total: 0.0,
            };
        }
        let mut acc = 0.0f64;
        let mut cdf = Vec::with_capacity(clean.len());
        for &w in &clean {
            acc += w;
            cdf.push((acc / total) as f32);
        }
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        let pmf = clean.iter().map(|&w| (w / total) as f32).collect();
        Distribution1D { cdf, pmf, total }
    }

    pub fn is_empty(&self) -> bool {
        self.cdf.is_empty()
    }

    /// Sum of the weights.
    pub fn total(&self) -> f64 {
        self.total
    }

    /// Draw an index with probability proportional to its weight; returns (index, pmf).
    /// Never returns an index of zero weight.
    pub fn sample(&self, u: f32) -> Option<(usize, f32)> {
        if self.cdf.is_empty() {
            return None;
        }
        let mut i = self
            .cdf
            .partition_point(|&c| c <= u)
            .min(self.cdf.len() - 1);
        // Skip zero-weight entries that share a cdf value with their predecessor.
        while self.pmf[i] == 0.0 && i + 1 < self.pmf.len() {
            i += 1;
        }
        while self.pmf[i] == 0.0 && i > 0 {
            i -= 1;
        }
        Some((i, self.pmf[i]))
    }

    /// Probability of drawing `index`.
    pub fn pmf(&self, index: usize) -> f32 {
        self.pmf.get(index).copied().unwrap_or(0.0)
    }

    /// Like `sample`, and also `u` rescaled to [0, 1) within the chosen index's share of the
    /// unit interval: a fresh uniform number for a continuous position inside that entry.
    pub fn sample_remapped(&self, u: f32) -> Option<(usize, f32, f32)> {
        let (i, pmf) = self.sample(u)?;
        let below = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        Some((i, pmf, ((u - below) / pmf).clamp(0.0, 1.0 - f32::EPSILON)))
    }
}

/// A piecewise-constant density on [0, 1)² from a grid of non-negative weights (row-major, row
/// 0 at y = 0): a row is drawn from the marginal distribution of row sums, then a column from
/// that row's conditional distribution (pbrt-v4, A.5.6).
#[derive(Clone, Debug, Default)]
pub struct Distribution2D {
    rows: Vec<Distribution1D>,
    marginal: Distribution1D,
    width: usize,
    height: usize,
}

impl Distribution2D {
    pub fn new(weights: &[f32], width: usize, height: usize) -> Self {
        let rows: Vec<Distribution1D> = weights
            .chunks(width.max(1))
            .take(height)
            .map(Distribution1D::new)
            .collect();
        let sums: Vec<f32> = rows.iter().map(|r| r.total() as f32).collect();
        Distribution2D {
            marginal: Distribution1D::new(&sums),
            rows,
            width,
            height,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.marginal.is_empty()
    }

    /// A point of [0, 1)² (x along a row) and its density per unit area.
    pub fn sample(&self, u: Vec2) -> Option<(Vec2, f32)> {
        let (row, p_row, v) = self.marginal.sample_remapped(u.y)?;
        let (col, p_col, w) = self.rows[row].sample_remapped(u.x)?;
        let point = Vec2::new(
            (col as f32 + w) / self.width as f32,
            (row as f32 + v) / self.height as f32,
        );
        Some((point, p_row * p_col * (self.width * self.height) as f32))
    }

    /// Density of `sample` at `point` per unit area.
    pub fn pdf(&self, point: Vec2) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let col = ((point.x * self.width as f32) as usize).min(self.width - 1);
        let row = ((point.y * self.height as f32) as usize).min(self.height - 1);
        self.marginal.pmf(row) * self.rows[row].pmf(col) * (self.width * self.height) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distribution_never_picks_zero_weights_and_matches_pmf() {
        let d = Distribution1D::new(&[0.0, 1.0, 0.0, 3.0, 0.0]);
        let mut counts = [0usize; 5];
        let n = 100_000;
        for i in 0..n {
            let (k, p) = d.sample((i as f32 + 0.5) / n as f32).unwrap();
            assert!(p > 0.0);
            counts[k] += 1;
        }
        assert_eq!(counts[0] + counts[2] + counts[4], 0);
        assert!((counts[1] as f32 / n as f32 - 0.25).abs() < 0.01);
        assert!((d.pmf(3) - 0.75).abs() < 1e-6);
        assert!(Distribution1D::new(&[0.0, f32::NAN]).sample(0.5).is_none());
    }

    #[test]
    fn power_heuristic_handles_infinite_and_zero_pdfs() {
        assert_eq!(power_heuristic(0.0, 1.0), 0.0);
        assert_eq!(power_heuristic(f32::INFINITY, 1.0), 1.0);
        assert_eq!(power_heuristic(1.0, f32::INFINITY), 0.0);
        assert!((power_heuristic(1.0, 1.0) - 0.5).abs() < 1e-6);
    }
}
