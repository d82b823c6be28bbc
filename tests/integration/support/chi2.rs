//! The one chi-square goodness-of-fit harness every sampler test uses (after Mitsuba's
//! `chi2.py` and pbrt-v4's `ChiSquareTest`): histogram the samples, compute expected counts by
//! integrating the claimed density over each bin, pool bins with expected count < 5, fail at once
//! on a sample in a bin the density says is empty, and turn the statistic into a p-value with the
//! regularised incomplete gamma function. The significance level 0.01 is Šidák-corrected for the
//! number of tests run.

use photon::math::Vec3;
use std::f64::consts::PI;

pub const SIGNIFICANCE: f64 = 0.01;

/// Per-test level such that `num_tests` independent tests together have false-alarm rate 0.01.
pub fn sidak_level(num_tests: usize) -> f64 {
    1.0 - (1.0 - SIGNIFICANCE).powf(1.0 / num_tests.max(1) as f64)
}

/// ln Γ(x) for x > 0 (Lanczos approximation, g = 7, nine terms).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection formula.
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, &c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma Q(a, x) = Γ(a, x)/Γ(a): the chi-square survival function
/// is Q(dof/2, χ²/2). Series for x < a + 1, Lentz's continued fraction otherwise.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let log_prefactor = -x + a * x.ln() - ln_gamma(a);
    if x < a + 1.0 {
        // P(a, x) = e^{-x} x^a / Γ(a+1) · Σ x^n / ((a+1)…(a+n)).
        let mut term = 1.0 / a;
        let mut sum = term;
        let mut n = a;
        for _ in 0..10_000 {
            n += 1.0;
            term *= x / n;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        (1.0 - sum * log_prefactor.exp()).clamp(0.0, 1.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (log_prefactor.exp() * h).clamp(0.0, 1.0)
    }
}

/// Chi-square test of `observed` counts against `expected` counts (same total). Returns the
/// p-value, or an error naming the failure.
pub fn chi2_test(
    name: &str,
    observed: &[f64],
    expected: &[f64],
    num_tests: usize,
) -> Result<f64, String> {
    assert_eq!(observed.len(), expected.len());
    let total: f64 = observed.iter().sum();
    for (i, (&o, &e)) in observed.iter().zip(expected).enumerate() {
        if o > 0.0 && e <= 1e-9 * total.max(1.0) {
            return Err(format!(
                "{name}: {o} samples in bin {i}, where the pdf integrates to {e}"
            ));
        }
    }
    // Pool the bins with small expected counts, smallest first, into one.
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    let mut chi2 = 0.0;
    let mut bins = 0usize;
    for &i in &order {
        if expected[i] <= 0.0 {
            continue;
        }
        if expected[i] < 5.0 || pool_e > 0.0 && pool_e < 5.0 {
            pool_o += observed[i];
            pool_e += expected[i];
            continue;
        }
        chi2 += (observed[i] - expected[i]).powi(2) / expected[i];
        bins += 1;
    }
    if pool_e > 0.0 {
        chi2 += (pool_o - pool_e).powi(2) / pool_e;
        bins += 1;
    }
    if bins < 2 {
        return Ok(1.0);
    }
    let dof = (bins - 1) as f64;
    let p = gamma_q(0.5 * dof, 0.5 * chi2);
    let level = sidak_level(num_tests);
    if p < level {
        return Err(format!(
            "{name}: chi² = {chi2:.1} with {dof} degrees of freedom, p = {p:.3e} < {level:.3e}"
        ));
    }
    Ok(p)
}

const SIMPSON_WEIGHTS: [f64; 3] = [1.0, 4.0, 1.0];

/// Simpson's rule on a rectangle from its 3×3 stencil of values: `values[i][j]` is `f` at the
/// `i`-th of (x0, midpoint, x1) and the `j`-th of (y0, midpoint, y1).
fn simpson_2d(values: &[[f64; 3]; 3], x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
    let mut sum = 0.0;
    for (i, row) in values.iter().enumerate() {
        for (j, &value) in row.iter().enumerate() {
            sum += SIMPSON_WEIGHTS[i] * SIMPSON_WEIGHTS[j] * value;
        }
    }
    sum * (x1 - x0) * (y1 - y0) / 36.0
}

/// Adaptive Simpson integration of `f` over a rectangle, to absolute tolerance `tol`. `values`
/// is the rectangle's stencil and `whole` Simpson's rule over it. The four quarters' stencils
/// are one 5×5 grid whose every other point is the parent's stencil, so a refinement evaluates
/// `f` at the 16 new points only (the same points, so the same sums, as four separate stencils).
#[allow(clippy::too_many_arguments)]
fn adaptive_2d(
    f: &impl Fn(f64, f64) -> f64,
    values: &[[f64; 3]; 3],
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    whole: f64,
    tol: f64,
    depth: u32,
) -> f64 {
    let (xm, ym) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let xs = [x0, 0.5 * (x0 + xm), xm, 0.5 * (xm + x1), x1];
    let ys = [y0, 0.5 * (y0 + ym), ym, 0.5 * (ym + y1), y1];
    let mut grid = [[0.0; 5]; 5];
    for (a, row) in grid.iter_mut().enumerate() {
        for (b, value) in row.iter_mut().enumerate() {
            *value = if a % 2 == 0 && b % 2 == 0 {
                values[a / 2][b / 2]
            } else {
                f(xs[a], ys[b])
            };
        }
    }
    // The quarters, each with the offset of its stencil in the grid.
    let quads = [
        (x0, xm, y0, ym, 0, 0),
        (xm, x1, y0, ym, 2, 0),
        (x0, xm, ym, y1, 0, 2),
        (xm, x1, ym, y1, 2, 2),
    ];
    let stencils = quads.map(|(.., a, b)| {
        std::array::from_fn::<_, 3, _>(|i| std::array::from_fn::<_, 3, _>(|j| grid[a + i][b + j]))
    });
    let parts: [f64; 4] = std::array::from_fn(|k| {
        simpson_2d(&stencils[k], quads[k].0, quads[k].1, quads[k].2, quads[k].3)
    });
    let sum: f64 = parts.iter().sum();
    // Converged when the refinement changes little in absolute or in relative terms.
    if depth == 0 || (sum - whole).abs() <= 15.0 * tol.max(1e-5 * sum.abs()) {
        return sum + (sum - whole) / 15.0;
    }
    quads
        .iter()
        .zip(stencils.iter().zip(parts))
        .map(|(&(a, b, c, d, ..), (values, part))| {
            adaptive_2d(f, values, a, b, c, d, part, 0.25 * tol, depth - 1)
        })
        .sum()
}

/// Integral of `f` over a rectangle: a fixed `pre`×`pre` grid (so narrow peaks are seen) refined
/// adaptively. Neighbouring cells share their edges' stencil points, so `f` is evaluated once on
/// the (2 `pre` + 1)² points of the grid.
pub fn integrate_2d(
    f: &impl Fn(f64, f64) -> f64,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    pre: usize,
    tol: f64,
) -> f64 {
    let cell_tol = tol / (pre * pre) as f64;
    let edges = |lo: f64, hi: f64| -> Vec<f64> {
        (0..=pre)
            .map(|i| lo + (hi - lo) * i as f64 / pre as f64)
            .collect()
    };
    let (x_edges, y_edges) = (edges(x0, x1), edges(y0, y1));
    // Cell edges at even indices, their midpoints at odd ones.
    let points = |edges: &[f64]| -> Vec<f64> {
        let mut out = vec![edges[0]];
        for pair in edges.windows(2) {
            out.extend([0.5 * (pair[0] + pair[1]), pair[1]]);
        }
        out
    };
    let (xs, ys) = (points(&x_edges), points(&y_edges));
    let grid: Vec<Vec<f64>> = xs
        .iter()
        .map(|&x| ys.iter().map(|&y| f(x, y)).collect())
        .collect();
    let mut total = 0.0;
    for i in 0..pre {
        for j in 0..pre {
            let (a, b) = (x_edges[i], x_edges[i + 1]);
            let (c, d) = (y_edges[j], y_edges[j + 1]);
            let values: [[f64; 3]; 3] =
                std::array::from_fn(|k| std::array::from_fn(|l| grid[2 * i + k][2 * j + l]));
            let whole = simpson_2d(&values, a, b, c, d);
            total += adaptive_2d(f, &values, a, b, c, d, whole, cell_tol, 8);
        }
    }
    total.max(0.0)
}

/// Binning of the sphere of directions in (cos θ, φ): equal solid angle per bin, and the
/// density per unit (cos θ, φ) equals the solid-angle density.
pub struct SphereBins {
    pub n_cos: usize,
    pub n_phi: usize,
}

impl SphereBins {
    pub const DEFAULT: SphereBins = SphereBins {
        n_cos: 20,
        n_phi: 40,
    };

    pub fn index(&self, w: Vec3) -> usize {
        let cos = (w.z as f64).clamp(-1.0, 1.0);
        let mut phi = (w.y as f64).atan2(w.x as f64);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let i = (((cos + 1.0) * 0.5 * self.n_cos as f64) as usize).min(self.n_cos - 1);
        let j = ((phi / (2.0 * PI) * self.n_phi as f64) as usize).min(self.n_phi - 1);
        i * self.n_phi + j
    }

    /// Integral of `pdf` (solid-angle density) over every bin.
    pub fn integrate(&self, pdf: &impl Fn(Vec3) -> f64) -> Vec<f64> {
        let f = |cos: f64, phi: f64| {
            let sin = (1.0 - cos * cos).max(0.0).sqrt();
            let w = Vec3::new(
                (sin * phi.cos()) as f32,
                (sin * phi.sin()) as f32,
                cos as f32,
            );
            let p = pdf(w);
            if p.is_finite() {
                p
            } else {
                0.0
            }
        };
        let mut out = Vec::with_capacity(self.n_cos * self.n_phi);
        for i in 0..self.n_cos {
            let c0 = -1.0 + 2.0 * i as f64 / self.n_cos as f64;
            let c1 = -1.0 + 2.0 * (i + 1) as f64 / self.n_cos as f64;
            for j in 0..self.n_phi {
                let p0 = 2.0 * PI * j as f64 / self.n_phi as f64;
                let p1 = 2.0 * PI * (j + 1) as f64 / self.n_phi as f64;
                out.push(integrate_2d(&f, c0, c1, p0, p1, 6, 1e-8));
            }
        }
        out
    }
}

/// Chi-square test of a direction sampler against its solid-angle density. `sample(k)` draws the
/// k-th sample (`None`: the sampler produced nothing, which the density's missing mass must
/// explain); `pdf` is the claimed density. Returns the p-value.
pub fn chi2_sphere(
    name: &str,
    n_samples: usize,
    mut sample: impl FnMut(usize) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f64,
    num_tests: usize,
) -> Result<f64, String> {
    let bins = SphereBins::DEFAULT;
    let n_bins = bins.n_cos * bins.n_phi;
    // The last bin counts samples that produced no direction.
    let mut observed = vec![0.0; n_bins + 1];
    for k in 0..n_samples {
        match sample(k) {
            Some(w) if w.is_finite() => observed[bins.index(w.normalize())] += 1.0,
            Some(w) => return Err(format!("{name}: non-finite direction {w:?}")),
            None => observed[n_bins] += 1.0,
        }
    }
    let integrals = bins.integrate(&pdf);
    let mass: f64 = integrals.iter().sum();
    if mass > 1.0 + 2e-3 {
        return Err(format!("{name}: the pdf integrates to {mass} > 1"));
    }
    let mut expected: Vec<f64> = integrals.iter().map(|&p| p * n_samples as f64).collect();
    expected.push((1.0 - mass).max(0.0) * n_samples as f64);
    chi2_test(name, &observed, &expected, num_tests)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn incomplete_gamma_matches_known_values() {
        // Q(1, x) = e^{-x}; chi-square with 2 dof at 5.991 has p = 0.05; 10 dof at 23.209: 0.01.
        assert!((gamma_q(1.0, 2.0) - (-2.0f64).exp()).abs() < 1e-12);
        assert!((gamma_q(1.0, 0.5 * 5.991) - 0.05).abs() < 1e-4);
        assert!((gamma_q(5.0, 0.5 * 23.209) - 0.01).abs() < 1e-4);
        assert!((gamma_q(50.0, 0.5 * 124.342) - 0.05).abs() < 1e-4);
        assert!((ln_gamma(5.0) - 24.0f64.ln()).abs() < 1e-12);
    }
}
