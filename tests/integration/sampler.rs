//! The path tracer's Sobol sampler (`Rng::sobol`, `photon::sobol`): the first 2^m samples of a
//! pixel are stratified in every dimension, every pair and jointly in every triple, its numbers are uniform over pixels,
//! dimensions are independent of each other, an integral converges faster than with
//! independent random numbers, and the estimates of a small bright feature are unbiased per
//! pixel with errors independent from one pixel to the next.

use crate::support::chi2::chi2_test;
use photon::math::Vec2;
use photon::rng::Rng;

/// Chi-square tests in this file (for the Šidák correction).
const NUM_TESTS: usize = 3;

/// The pairs one sample of a camera path draws: the pixel filter's, the light point's (with
/// its light choice) and the BSDF direction's (with its lobe).
fn draws(rng: &mut Rng) -> [Vec2; 3] {
    let filter = rng.uniform2();
    let light = rng.uniform3().1;
    [filter, light, rng.uniform3().1]
}

/// Whether `points` put exactly one point in every elementary interval 2^−a × 2^−(m−a) of the
/// unit square, for every a (a (0, m, 2)-net).
fn is_net(points: &[Vec2], m: u32) -> bool {
    (0..=m).all(|a| {
        let (nx, ny) = (1usize << a, 1usize << (m - a));
        let mut cells = vec![0u32; nx * ny];
        for p in points {
            let i = ((p.x * nx as f32) as usize).min(nx - 1);
            let j = ((p.y * ny as f32) as usize).min(ny - 1);
            cells[i * ny + j] += 1;
        }
        cells.iter().all(|&c| c == 1)
    })
}

/// Whether `values` fall one in each interval of length 2^−m.
fn is_stratified(values: &[f32], m: u32) -> bool {
    let n = 1usize << m;
    let mut cells = vec![0u32; n];
    for &v in values {
        cells[((v * n as f32) as usize).min(n - 1)] += 1;
    }
    cells.iter().all(|&c| c == 1)
}

/// Whether the points (c, p) put exactly 2^t points in every elementary box
/// 2^−a × 2^−b × 2^−c of the unit cube with a + b + c = m − t (a (t, m, 3)-net).
fn is_net_3d(points: &[(f32, Vec2)], m: u32, t: u32) -> bool {
    let k = m - t;
    (0..=k).all(|a| {
        (0..=k - a).all(|b| {
            let c = k - a - b;
            let (na, nb, nc) = (1usize << a, 1usize << b, 1usize << c);
            let mut cells = vec![0u32; na * nb * nc];
            let bin = |v: f32, n: usize| ((v * n as f32) as usize).min(n - 1);
            for (u, p) in points {
                cells[(bin(*u, na) * nb + bin(p.x, nb)) * nc + bin(p.y, nc)] += 1;
            }
            cells.iter().all(|&n| n == 1 << t)
        })
    })
}

#[test]
fn the_first_power_of_two_samples_of_a_pixel_are_stratified_in_every_dimension() {
    for pixel in 0..64u64 {
        for m in [2u32, 4, 6, 8] {
            let n = 1u32 << m;
            let (mut filter, mut light, mut bsdf, mut roulette) = (vec![], vec![], vec![], vec![]);
            for i in 0..n {
                let mut rng = Rng::sobol(7, pixel, i);
                filter.push(rng.uniform2());
                light.push(rng.uniform3());
                bsdf.push(rng.uniform3());
                roulette.push(rng.uniform());
            }
            assert!(is_net(&filter, m), "pixel {pixel}, {n} samples: filter");
            for (name, triples) in [("light", &light), ("bsdf", &bsdf)] {
                let pairs: Vec<Vec2> = triples.iter().map(|t| t.1).collect();
                let choices: Vec<f32> = triples.iter().map(|t| t.0).collect();
                assert!(is_net(&pairs, m), "pixel {pixel}, {n} samples: {name} pair");
                assert!(is_stratified(&choices, m), "{pixel}, {n}: {name} choice");
                assert!(is_net_3d(triples, m, 1), "{pixel}, {n}: {name} jointly");
            }
            assert!(is_stratified(&roulette, m), "{pixel}, {n}: roulette");
        }
    }
    // Independent random numbers are not: the check has something to find.
    let mut rng = Rng::new(1);
    let random: Vec<Vec2> = (0..64).map(|_| rng.uniform2()).collect();
    assert!(!is_net(&random, 6));
    let random: Vec<(f32, Vec2)> = (0..64).map(|_| rng.uniform3()).collect();
    assert!(!is_net_3d(&random, 6, 1));
}

#[test]
fn numbers_are_uniform_over_pixels() {
    // Sample 5's third pair (a BSDF direction) over 160 000 pixels: a 16 × 16 histogram.
    let (bins, pixels) = (16usize, 160_000u64);
    let mut observed = vec![0.0; bins * bins];
    for pixel in 0..pixels {
        let mut rng = Rng::sobol(3, pixel, 5);
        let v = draws(&mut rng)[2];
        let i = ((v.x * bins as f32) as usize).min(bins - 1);
        let j = ((v.y * bins as f32) as usize).min(bins - 1);
        observed[i * bins + j] += 1.0;
    }
    let expected = vec![pixels as f64 / (bins * bins) as f64; bins * bins];
    let p = chi2_test("sobol pair over pixels", &observed, &expected, NUM_TESTS);
    assert!(p.is_ok(), "{}", p.unwrap_err());
}

#[test]
fn dimensions_are_independent_of_each_other() {
    // Within each pixel's first 64 samples, the first coordinates of two different pairs (a
    // filter offset and a light point) against each other: uniform over the square when the
    // dimensions are decorrelated, a scrambled diagonal if they shared one ordering.
    let bins = 8usize;
    let mut observed = vec![0.0; bins * bins];
    let pixels = 4000u64;
    for pixel in 0..pixels {
        for i in 0..64 {
            let mut rng = Rng::sobol(11, pixel, i);
            let a = rng.uniform2().x;
            let b = rng.uniform3().1.x;
            let (x, y) = (
                ((a * bins as f32) as usize).min(bins - 1),
                ((b * bins as f32) as usize).min(bins - 1),
            );
            observed[x * bins + y] += 1.0;
        }
    }
    let expected = vec![(pixels * 64) as f64 / (bins * bins) as f64; bins * bins];
    let p = chi2_test("filter x against light x", &observed, &expected, NUM_TESTS);
    assert!(p.is_ok(), "{}", p.unwrap_err());
    // The same numbers without the per-dimension shuffle (pairs 0 and 1 of one sample drawn
    // with one ordering: sample i's x of both is the scrambled van der Corput point i) fail.
    let mut diagonal = vec![0.0; bins * bins];
    for pixel in 0..pixels {
        for i in 0..64u32 {
            let seeds = |x: u32| photon::sobol::Seeds {
                shuffle: pixel as u32,
                x: x ^ pixel as u32,
                y: 0,
                z: 0,
            };
            let f = |x: u32| (x >> 8) as f32 / 16_777_216.0;
            let a = f(photon::sobol::sample_1d(i, seeds(1)));
            let b = f(photon::sobol::sample_1d(i, seeds(2)));
            let (x, y) = (
                ((a * bins as f32) as usize).min(bins - 1),
                ((b * bins as f32) as usize).min(bins - 1),
            );
            diagonal[x * bins + y] += 1.0;
        }
    }
    assert!(chi2_test("shared ordering", &diagonal, &expected, 1).is_err());
}

#[test]
fn a_smooth_integral_converges_faster_than_with_random_numbers() {
    // ∫∫ cos-weighted bump over the square, 64 samples per "pixel", 2000 pixels: the mean
    // squared error of Sobol estimates against independent numbers' (both unbiased).
    let f = |u: Vec2, v: Vec2| (u.x * u.y).sqrt() * (1.0 + v.x - v.y * v.y);
    // ∫ sqrt(xy) = (2/3)², ∫ (1 + x − y²) = 1 + 1/2 − 1/3.
    let truth = (4.0 / 9.0) * (1.0 + 0.5 - 1.0 / 3.0);
    let mse = |sobol: bool| {
        let mut sum = 0.0f64;
        for pixel in 0..2000u64 {
            let mut estimate = 0.0f64;
            for i in 0..64u32 {
                let mut rng = match sobol {
                    true => Rng::sobol(5, pixel, i),
                    false => Rng::for_item(5, pixel, i as u64),
                };
                let u = rng.uniform2();
                let v = rng.uniform2();
                estimate += f(u, v) as f64 / 64.0;
            }
            sum += (estimate - truth).powi(2);
        }
        sum / 2000.0
    };
    let (sobol, random) = (mse(true), mse(false));
    assert!(
        sobol * 4.0 < random,
        "MSE with Sobol {sobol:.3e}, random {random:.3e}"
    );
}

#[test]
fn a_highlight_is_unbiased_per_pixel_and_neighbours_err_independently() {
    // A highlight as a camera path sees it: the pixel filter's offset, the point on the light
    // and the BSDF's lobe and direction all have to fall in the right place (a product of
    // indicators, 2.6 % of the 6D cube). 64 × 64 pixels of 256 samples: the mean of their
    // estimates is within 5 standard errors of the exact value, and neighbouring pixels' errors
    // are uncorrelated (a shared scramble would correlate them and move a whole highlight
    // together, as one seed's 5 % low highlight seemed to).
    let disk = |p: Vec2, cx: f32, cy: f32, r: f32| (p.x - cx).powi(2) + (p.y - cy).powi(2) < r * r;
    let f = |rng: &mut Rng| {
        let filter = rng.uniform2();
        let (_, light) = rng.uniform3();
        let (lobe, direction) = rng.uniform3();
        let hit = disk(filter, 0.4, 0.5, 0.35)
            && disk(light, 0.3, 0.6, 0.25)
            && lobe < 0.5
            && direction.x < 0.7;
        hit as u32 as f64
    };
    let pi = std::f64::consts::PI;
    let truth = pi * 0.35f64.powi(2) * pi * 0.25f64.powi(2) * 0.5 * 0.7;
    let (side, spp) = (64u64, 256u32);
    let errors: Vec<f64> = (0..side * side)
        .map(|pixel| {
            let sum: f64 = (0..spp).map(|i| f(&mut Rng::sobol(1, pixel, i))).sum();
            sum / spp as f64 - truth
        })
        .collect();
    let n = errors.len() as f64;
    let mean = errors.iter().sum::<f64>() / n;
    let var = errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0);
    assert!(
        mean.abs() < 5.0 * (var / n).sqrt(),
        "mean error {mean:.2e}, standard error {:.2e}",
        (var / n).sqrt()
    );
    let correlation = |step: u64| {
        let pairs: Vec<(f64, f64)> = (0..side * side)
            .filter(|&p| p + step < side * side && (step != 1 || p % side != side - 1))
            .map(|p| (errors[p as usize], errors[(p + step) as usize]))
            .collect();
        let c: f64 = pairs.iter().map(|(a, b)| (a - mean) * (b - mean)).sum();
        c / pairs.len() as f64 / var
    };
    for (step, name) in [(1, "horizontal"), (side, "vertical")] {
        let r = correlation(step);
        assert!(
            r.abs() < 5.0 / n.sqrt(),
            "{name} neighbours' correlation {r:.3}"
        );
    }
}

#[test]
fn the_same_sample_gives_the_same_numbers_and_other_pixels_others() {
    let numbers = |pixel: u64, index: u32| {
        let mut rng = Rng::sobol(9, pixel, index);
        (0..6).map(|_| rng.uniform()).collect::<Vec<f32>>()
    };
    assert_eq!(numbers(4, 3), numbers(4, 3));
    assert_ne!(numbers(4, 3), numbers(5, 3));
    assert_ne!(numbers(4, 3), numbers(4, 2));
    let mut other_seed = Rng::sobol(10, 4, 3);
    assert_ne!(other_seed.uniform(), numbers(4, 3)[0]);
}
