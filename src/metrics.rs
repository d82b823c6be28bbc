//! Image error metrics used to show accuracy (README.md, "How correctness is shown"):
//! relMSE = mean((I − R)² / (R² + 0.01)) over pixels and RGB channels, RMSE, and the relative
//! difference of the image means. R is the reference.

/// Errors of an image against a reference of the same size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageError {
    pub rel_mse: f64,
    /// relMSE with the worst `OUTLIER_SHARE` of the pixels (at least one) left out: a render
    /// whose relMSE is ruled by a few pixels of rare, bright paths (a small lamp seen through
    /// glass) shows here what the rest of the image does.
    pub rel_mse_without_outliers: f64,
    pub rmse: f64,
    /// (mean(I) − mean(R)) / mean(R), over RGB.
    pub mean_relative_difference: f64,
    pub mean_image: f64,
    pub mean_reference: f64,
}

/// Share of the pixels `ImageError::rel_mse_without_outliers` leaves out (10 of a 64 × 64
/// image).
pub const OUTLIER_SHARE: f64 = 0.0025;

/// Compare RGB of `image` with `reference` (alpha is ignored). Both must have the same length.
pub fn compare(image: &[[f32; 4]], reference: &[[f32; 4]]) -> ImageError {
    assert_eq!(
        image.len(),
        reference.len(),
        "images must have the same size"
    );
    let (mut sq, mut sum_i, mut sum_r) = (0.0f64, 0.0f64, 0.0f64);
    let mut per_pixel = Vec::with_capacity(image.len());
    for (p, r) in image.iter().zip(reference) {
        let mut rel = 0.0f64;
        for c in 0..3 {
            let (i, r) = (p[c] as f64, r[c] as f64);
            let d = i - r;
            rel += d * d / (r * r + 0.01);
            sq += d * d;
            sum_i += i;
            sum_r += r;
        }
        per_pixel.push(rel);
    }
    let rel: f64 = per_pixel.iter().sum();
    let n = (image.len() * 3).max(1) as f64;
    let outliers = ((image.len() as f64 * OUTLIER_SHARE).ceil() as usize).min(image.len());
    per_pixel.sort_by(f64::total_cmp);
    let kept = image.len() - outliers;
    let trimmed: f64 = per_pixel[..kept].iter().sum();
    ImageError {
        rel_mse: rel / n,
        rel_mse_without_outliers: trimmed / (kept * 3).max(1) as f64,
        rmse: (sq / n).sqrt(),
        mean_relative_difference: if sum_r != 0.0 {
            (sum_i - sum_r) / sum_r
        } else {
            0.0
        },
        mean_image: sum_i / n,
        mean_reference: sum_r / n,
    }
}

/// Per-pixel relative squared error mapped to a false colour (black → blue → green → yellow →
/// red as the error grows by decades from 1e-4 to 1), for looking at where two images differ.
pub fn false_colour_error(image: &[[f32; 4]], reference: &[[f32; 4]]) -> Vec<[f32; 4]> {
    image
        .iter()
        .zip(reference)
        .map(|(p, r)| {
            let mut e = 0.0f32;
            for c in 0..3 {
                let d = p[c] - r[c];
                e += d * d / (r[c] * r[c] + 0.01);
            }
            let e = e / 3.0;
            let x = if e > 0.0 {
                ((e.log10() + 4.0) / 4.0).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let ramp = [
                [0.0, 0.0, 0.0],
                [0.0, 0.0, 1.0],
                [0.0, 1.0, 0.0],
                [1.0, 1.0, 0.0],
                [1.0, 0.0, 0.0],
            ];
            let f = x * 4.0;
            let i = (f as usize).min(3);
            let t = f - i as f32;
            let c = |k: usize| ramp[i][k] * (1.0 - t) + ramp[i + 1][k] * t;
            [c(0), c(1), c(2), 1.0]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_images_have_zero_error_and_scaled_ones_do_not() {
        let r = vec![[0.5, 0.2, 1.0, 1.0]; 10];
        assert_eq!(compare(&r, &r).rel_mse, 0.0);
        let brighter: Vec<[f32; 4]> = r
            .iter()
            .map(|p| [p[0] * 1.1, p[1] * 1.1, p[2] * 1.1, 1.0])
            .collect();
        let e = compare(&brighter, &r);
        assert!((e.mean_relative_difference - 0.1).abs() < 1e-6);
        // (0.05² / 0.26 + 0.02² / 0.05 + 0.1² / 1.01) / 3
        let expected = (0.0025 / 0.26 + 0.0004 / 0.05 + 0.01 / 1.01) / 3.0;
        assert!((e.rel_mse - expected).abs() < 1e-6);
    }

    #[test]
    fn one_firefly_rules_the_relmse_but_not_the_relmse_without_outliers() {
        // 400 pixels: the worst 0.25 % is one pixel.
        let r = vec![[0.5, 0.5, 0.5, 1.0]; 400];
        let mut image: Vec<[f32; 4]> = r.iter().map(|p| [p[0] * 1.1, p[1], p[2], 1.0]).collect();
        let even = compare(&image, &r);
        image[17] = [50.0, 50.0, 50.0, 1.0];
        let e = compare(&image, &r);
        assert!(e.rel_mse > 100.0 * even.rel_mse, "{e:?}");
        assert!(
            (e.rel_mse_without_outliers - even.rel_mse).abs() < 1e-9,
            "{e:?}"
        );
        assert!((even.rel_mse_without_outliers - even.rel_mse).abs() < 1e-9);
    }
}
