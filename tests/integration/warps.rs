//! Chi-square tests of every warp in `photon::sampling` against its density.

use crate::support::chi2::{chi2_sphere, chi2_test};
use photon::film::{FilterKind, FilterSettings, PixelFilter};
use photon::math::Vec2;
use photon::rng::Rng;
use photon::sampling::*;

/// Chi-square tests in this file (for the Šidák correction).
const NUM_TESTS: usize = 10;
const N: usize = 400_000;

fn uniform2(rng: &mut Rng) -> Vec2 {
    rng.uniform2()
}

#[test]
fn cosine_hemisphere_matches_its_pdf() {
    let mut rng = Rng::new(1);
    let p = chi2_sphere(
        "cosine hemisphere",
        N,
        |_| Some(square_to_cosine_hemisphere(uniform2(&mut rng))),
        |w| cosine_hemisphere_pdf(w.z) as f64,
        NUM_TESTS,
    );
    assert!(p.is_ok(), "{}", p.unwrap_err());
}

#[test]
fn uniform_sphere_matches_its_pdf() {
    let mut rng = Rng::new(2);
    let p = chi2_sphere(
        "uniform sphere",
        N,
        |_| Some(square_to_uniform_sphere(uniform2(&mut rng))),
        |_| UNIFORM_SPHERE_PDF as f64,
        NUM_TESTS,
    );
    assert!(p.is_ok(), "{}", p.unwrap_err());
}

#[test]
fn uniform_cones_match_their_pdf() {
    for (k, &cos_max) in [0.95f32, 0.5, -0.3].iter().enumerate() {
        let mut rng = Rng::new(3 + k as u64);
        let p = chi2_sphere(
            &format!("uniform cone cos_max {cos_max}"),
            N,
            |_| Some(square_to_uniform_cone(uniform2(&mut rng), cos_max)),
            |w| {
                if w.z >= cos_max {
                    uniform_cone_pdf(cos_max) as f64
                } else {
                    0.0
                }
            },
            NUM_TESTS,
        );
        assert!(p.is_ok(), "{}", p.unwrap_err());
    }
}

#[test]
fn disk_is_uniform() {
    // Bins of equal area in (r², φ).
    let (nr, nphi) = (16, 32);
    let mut observed = vec![0.0; nr * nphi];
    let mut rng = Rng::new(10);
    for _ in 0..N {
        let p = square_to_disk(uniform2(&mut rng));
        let r2 = p.length_squared() as f64;
        assert!(r2 <= 1.0 + 1e-6);
        let phi = (p.y as f64)
            .atan2(p.x as f64)
            .rem_euclid(std::f64::consts::TAU);
        let i = ((r2 * nr as f64) as usize).min(nr - 1);
        let j = ((phi / std::f64::consts::TAU * nphi as f64) as usize).min(nphi - 1);
        observed[i * nphi + j] += 1.0;
    }
    let expected = vec![N as f64 / (nr * nphi) as f64; nr * nphi];
    let p = chi2_test("disk", &observed, &expected, NUM_TESTS);
    assert!(p.is_ok(), "{}", p.unwrap_err());
}

#[test]
fn triangle_is_uniform() {
    // A grid over (b1, b2) ∈ [0,1]²: cells below the diagonal hold area h², cells cut by it
    // h²/2, cells above it nothing (a sample there fails the test at once).
    let n = 24;
    let mut observed = vec![0.0; n * n];
    let mut rng = Rng::new(11);
    for _ in 0..N {
        let b = square_to_triangle(uniform2(&mut rng));
        assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
        let i = ((b.x * n as f32) as usize).min(n - 1);
        let j = ((b.y * n as f32) as usize).min(n - 1);
        observed[i * n + j] += 1.0;
    }
    let cell = 1.0 / (n * n) as f64;
    let expected: Vec<f64> = (0..n * n)
        .map(|k| {
            let (i, j) = (k / n, k % n);
            let area = if i + j + 2 <= n {
                cell
            } else if i + j + 1 == n {
                0.5 * cell
            } else {
                0.0
            };
            2.0 * area * N as f64
        })
        .collect();
    let p = chi2_test("triangle", &observed, &expected, NUM_TESTS);
    assert!(p.is_ok(), "{}", p.unwrap_err());
}

#[test]
fn harness_rejects_a_wrong_pdf_and_samples_in_empty_bins() {
    // Cosine-distributed samples against the uniform-hemisphere density.
    let mut rng = Rng::new(12);
    let wrong = chi2_sphere(
        "cosine vs uniform",
        50_000,
        |_| Some(square_to_cosine_hemisphere(uniform2(&mut rng))),
        |w| {
            if w.z > 0.0 {
                0.5 / std::f64::consts::PI
            } else {
                0.0
            }
        },
        1,
    );
    assert!(wrong.is_err());
    // Uniform-sphere samples where the density claims only the upper hemisphere.
    let mut rng = Rng::new(13);
    let empty = chi2_sphere(
        "sphere vs hemisphere",
        1_000,
        |_| Some(square_to_uniform_sphere(uniform2(&mut rng))),
        |w| {
            if w.z > 0.0 {
                0.5 / std::f64::consts::PI
            } else {
                0.0
            }
        },
        1,
    );
    assert!(empty.unwrap_err().contains("samples in bin"));
}

/// Histogram of `N` pixel-filter offsets drawn by `filter` over `bins`² cells of the square
/// [−radius, radius]², with the counts `density` (separable, unnormalised) expects in each.
fn filter_histogram(
    filter: &PixelFilter,
    radius: f64,
    density: impl Fn(f64) -> f64,
    seed: u64,
) -> (Vec<f64>, Vec<f64>) {
    let bins = 24;
    let cell = 2.0 * radius / bins as f64;
    let mut observed = vec![0.0; bins * bins];
    let mut rng = Rng::new(seed);
    for _ in 0..N {
        let o = filter.sample(uniform2(&mut rng));
        let (x, y) = (o.x as f64, o.y as f64);
        // A sample outside the window lands in no cell and fails below (the totals differ).
        if x.abs() <= radius && y.abs() <= radius {
            let i = (((x + radius) / cell) as usize).min(bins - 1);
            let j = (((y + radius) / cell) as usize).min(bins - 1);
            observed[i * bins + j] += 1.0;
        }
    }
    assert_eq!(
        observed.iter().sum::<f64>(),
        N as f64,
        "samples outside the window"
    );
    // The 1D integral of the density over each column, by the midpoint rule on a fine grid.
    let steps = 64;
    let column: Vec<f64> = (0..bins)
        .map(|i| {
            (0..steps)
                .map(|k| density(-radius + cell * (i as f64 + (k as f64 + 0.5) / steps as f64)))
                .sum::<f64>()
        })
        .collect();
    let total: f64 = column.iter().sum();
    let expected = (0..bins * bins)
        .map(|k| N as f64 * column[k / bins] * column[k % bins] / (total * total))
        .collect();
    (observed, expected)
}

/// Blender's pixel filters as Cycles defines them (film.cpp): Blackman–Harris over twice the
/// width, a Gaussian exp(−2(6x/3w)²) over three times it, a box over the width.
fn cycles_filter(kind: FilterKind, width: f64, x: f64) -> f64 {
    match kind {
        FilterKind::BlackmanHarris => {
            let a = std::f64::consts::TAU * (x / (2.0 * width) + 0.5);
            0.35875 - 0.48829 * a.cos() + 0.14128 * (2.0 * a).cos() - 0.01168 * (3.0 * a).cos()
        }
        FilterKind::Gaussian => {
            let v = x * 6.0 / (3.0 * width);
            (-2.0 * v * v).exp()
        }
        FilterKind::Box => 1.0,
    }
}

#[test]
fn pixel_filters_sample_cycles_filters() {
    for (k, (kind, width)) in [
        (FilterKind::BlackmanHarris, 1.5f64),
        (FilterKind::Gaussian, 3.0),
        (FilterKind::Box, 1.0),
    ]
    .into_iter()
    .enumerate()
    {
        let settings = FilterSettings::new(kind, width as f32).unwrap();
        let filter = PixelFilter::new(&settings);
        let radius = settings.radius() as f64;
        let (observed, expected) = filter_histogram(
            &filter,
            radius,
            |x| cycles_filter(kind, width, x),
            20 + k as u64,
        );
        let name = format!("{kind:?} {width} px");
        let p = chi2_test(&name, &observed, &expected, NUM_TESTS);
        assert!(p.is_ok(), "{}", p.unwrap_err());
    }
}

#[test]
fn a_filter_does_not_pass_for_another() {
    // 1-px Gaussian offsets (σ = 0.25 px) judged against the 1.5-px Blackman–Harris window,
    // both within ±1.5 px: the harness must tell them apart.
    let gaussian = FilterSettings::new(FilterKind::Gaussian, 1.0).unwrap();
    let radius = gaussian.radius() as f64;
    let (observed, expected) = filter_histogram(
        &PixelFilter::new(&gaussian),
        radius,
        |x| cycles_filter(FilterKind::BlackmanHarris, 1.5, x),
        30,
    );
    assert!(chi2_test("gaussian vs blackman-harris", &observed, &expected, 1).is_err());
}
