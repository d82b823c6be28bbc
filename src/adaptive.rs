//! Adaptive sampling as Cycles' noise threshold defines it: pixels whose estimated error has
//! fallen below a threshold stop taking samples, their neighbours' too once every neighbour has.
//!
//! The error of a pixel is the one of Dammertz, Hanika, Keller and Lensch ("A hierarchical
//! automatic stopping condition for Monte Carlo global illumination", WSCG 2010, §2.1), applied
//! per pixel as Cycles does (`film_adaptive_sampling_convergence_check`): the samples are split
//! into two classes of equal size, each stratified on its own (class A: the samples whose index
//! has an odd number of bits set among the odd-numbered bits, Christensen, Kensler and Kilpatrick
//! 2018, §10.2.1); A, twice the sum of the class-A samples, estimates the pixel from half of
//! them, and the error is |I − A| summed over R, G and B, divided by the number of samples and
//! by √(R + G + B) of the pixel's mean (by R + G + B itself where that exceeds 1: bright pixels
//! need relatively less). A pixel is converged when the error is below 5 × the threshold (Cycles'
//! factor). Checks happen after every 16th sample once more than the minimum number of samples
//! plus one are taken; after each, every pixel next to an unconverged one (in a 3 × 3 box) is
//! sampled again — Cycles' two-pass box filter of the converged mask.
//!
//! Blender's settings map on directly: `threshold` 0 is automatic (1 / samples, at least 0.001),
//! `min_samples` 0 is automatic (16 / threshold^0.3, at least 4).

use crate::math::Vec3;

/// Samples between two convergence checks (Cycles' `adaptive_step`).
pub const STEP: u32 = 16;

/// Cycles' factor between the threshold the user gives and the error a pixel must reach.
const THRESHOLD_SCALE: f32 = 5.0;

/// Blender's adaptive-sampling settings (Render > Sampling > Noise Threshold).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveSettings {
    /// Noise threshold; 0: automatic.
    pub threshold: f32,
    /// Samples every pixel takes before the first check; 0: automatic.
    pub min_samples: u32,
}

/// The settings resolved for a render of `spp` samples per pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Convergence {
    /// The error a pixel must fall below (the threshold × 5).
    pub error: f32,
    /// Samples every pixel takes before the first check.
    pub min_samples: u32,
}

impl AdaptiveSettings {
    /// The threshold and minimum samples Cycles uses for `spp` samples per pixel.
    pub fn resolve(&self, spp: u32) -> Convergence {
        let threshold = if self.threshold > 0.0 {
            self.threshold
        } else {
            (1.0 / spp.max(1) as f32).max(0.001)
        };
        let min_samples = if self.min_samples > 0 {
            self.min_samples
        } else {
            (16.0 / threshold.powf(0.3)).ceil() as u32
        };
        Convergence {
            error: threshold * THRESHOLD_SCALE,
            min_samples: min_samples.max(4),
        }
    }
}

impl Convergence {
    /// Whether the pixels are checked once `taken` samples of the lock-step are done: every
    /// `STEP`th sample after the first `min_samples` + 1.
    pub fn check_due(&self, taken: u32) -> bool {
        taken > self.min_samples + 1 && taken.is_multiple_of(STEP)
    }

    /// How many of `remaining` samples to take before the next check, `taken` being done: all
    /// of them until the first check, then up to the next multiple of `STEP`.
    pub fn step(&self, taken: u32, remaining: u32) -> u32 {
        let first = (self.min_samples + 2).next_multiple_of(STEP);
        let next = if taken < first {
            first
        } else {
            (taken + 1).next_multiple_of(STEP)
        };
        (next - taken).min(remaining)
    }

    /// Whether a pixel whose `n` samples sum to `sum`, and whose class-A samples sum to `sum_a`,
    /// has converged.
    pub fn converged(&self, sum: Vec3, sum_a: Vec3, n: u32) -> bool {
        n > 0 && pixel_error(sum, sum_a, n) < self.error
    }
}

/// Whether sample `index` of a pixel is in class A (half of any aligned block of 4 indices).
pub fn is_class_a(index: u32) -> bool {
    (index & 0xaaaa_aaaa).count_ones() & 1 == 1
}

/// The relative error of a pixel (module header): `sum` of all `n` samples, `sum_a` of its
/// class-A samples.
pub fn pixel_error(sum: Vec3, sum_a: Vec3, n: u32) -> f32 {
    let scale = 1.0 / n as f32;
    let difference = (sum - 2.0 * sum_a).abs();
    let error = (difference.x + difference.y + difference.z) * scale;
    let intensity = (sum.x + sum.y + sum.z) * scale;
    let normalise = if intensity < 1.0 {
        intensity.max(0.0).sqrt()
    } else {
        intensity
    };
    error / (1e-4 + normalise)
}

/// Mark every pixel next to an active one (in its 3 × 3 box) active: `active` is a `width` ×
/// `height` mask, row by row.
pub fn spread_active(active: &mut [bool], width: usize, height: usize) {
    let rows = active.to_vec();
    for y in 0..height {
        for x in 0..width {
            let k = y * width + x;
            active[k] = rows[k] || (x > 0 && rows[k - 1]) || (x + 1 < width && rows[k + 1]);
        }
    }
    let columns = active.to_vec();
    for y in 0..height {
        for x in 0..width {
            let k = y * width + x;
            active[k] = columns[k]
                || (y > 0 && columns[k - width])
                || (y + 1 < height && columns[k + width]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn automatic_settings_are_cycles() {
        let auto = AdaptiveSettings {
            threshold: 0.0,
            min_samples: 0,
        };
        // Threshold 0.01 → 64 samples minimum (Cycles' comment: 0.1 → 32, 0.001 → 128).
        assert_eq!(auto.resolve(100).min_samples, 64);
        assert!((auto.resolve(100).error - 0.05).abs() < 1e-6);
        assert_eq!(auto.resolve(100_000).min_samples, 128);
        assert!((auto.resolve(100_000).error - 0.005).abs() < 1e-6);
        let fixed = AdaptiveSettings {
            threshold: 0.1,
            min_samples: 2,
        };
        assert_eq!(fixed.resolve(64).min_samples, 4);
    }

    #[test]
    fn checks_come_every_sixteen_samples_after_the_minimum() {
        let s = Convergence {
            error: 0.05,
            min_samples: 64,
        };
        let due: Vec<u32> = (1..=128).filter(|&n| s.check_due(n)).collect();
        assert_eq!(due, [80, 96, 112, 128]);
        // Steps land exactly on the checks.
        let mut taken = 0;
        let mut stops = Vec::new();
        while taken < 128 {
            taken += s.step(taken, 128 - taken);
            stops.push(taken);
        }
        assert_eq!(stops, [80, 96, 112, 128]);
    }

    #[test]
    fn class_a_is_half_of_every_block_of_four() {
        for block in 0..64u32 {
            let a = (4 * block..4 * block + 4)
                .filter(|&i| is_class_a(i))
                .count();
            assert_eq!(a, 2);
        }
    }

    #[test]
    fn the_error_is_zero_when_both_halves_agree_and_grows_with_their_difference() {
        let sum = Vec3::splat(0.3 * 64.0);
        assert_eq!(pixel_error(sum, sum * 0.5, 64), 0.0);
        let small = pixel_error(sum, sum * 0.49, 64);
        let large = pixel_error(sum, sum * 0.4, 64);
        assert!(small > 0.0 && large > 5.0 * small);
    }

    #[test]
    fn an_active_pixel_wakes_its_three_by_three_box() {
        let (w, h) = (5, 4);
        let mut active = vec![false; w * h];
        active[w + 1] = true;
        spread_active(&mut active, w, h);
        let on: Vec<usize> = (0..w * h).filter(|&k| active[k]).collect();
        assert_eq!(on, [0, 1, 2, 5, 6, 7, 10, 11, 12]);
    }
}
