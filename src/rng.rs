//! Deterministic random streams. Every random number in Photon comes from a `Rng` seeded by a hash
//! of (pixel or work item, sample index, user seed), so an image never depends on thread timing.
//!
//! A stream is either pseudo-random — PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast
//! Space-Efficient Statistically Good Algorithms for Random Number Generation"), seeded through
//! a SplitMix64-style hash — or quasi-random: the dimensions of one sample of a pixel's
//! Owen-scrambled Sobol sequence (`sobol`), each `uniform` one dimension and each `uniform2`
//! one pair, numbered in the order they are drawn, as pbrt-v4's samplers number them. The path
//! tracer's and the photon method's camera paths draw from the second, everything else from the
//! first.

use crate::math::Vec2;
use crate::sobol::{sample_1d, sample_2d, sample_3d, Seeds};

/// 64-bit finaliser from SplitMix64: a bijective mix of all input bits.
pub fn hash64(mut x: u64) -> u64 {
    x ^= x >> 30;
    x = x.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x ^= x >> 27;
    x = x.wrapping_mul(0x94d0_49bb_1331_11eb);
    x ^ (x >> 31)
}

/// Hash several integers into one seed.
pub fn hash_combine(values: &[u64]) -> u64 {
    values.iter().fold(0x9e37_79b9_7f4a_7c15, |h, &v| {
        hash64(h ^ v.wrapping_add(0x9e37_79b9_7f4a_7c15))
    })
}

/// A stream of uniform numbers: PCG32, or the dimensions of one Sobol sample.
#[derive(Clone, Debug)]
pub struct Rng {
    source: Source,
}

#[derive(Clone, Debug)]
enum Source {
    Pcg {
        state: u64,
        inc: u64,
    },
    /// Sample `index` of the Owen-scrambled Sobol sequence of the pixel hashed into `pixel`;
    /// `dimension` is the number of the next dimension (or pair) drawn.
    Sobol {
        pixel: u64,
        index: u32,
        dimension: u64,
    },
}

/// 32-bit fraction to [0, 1), never 1.
pub fn fraction(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

impl Rng {
    const MULT: u64 = 6_364_136_223_846_793_005;

    /// A stream identified by `seed`; different seeds give independent-looking streams.
    pub fn new(seed: u64) -> Self {
        let seq = hash64(seed ^ 0xda3e_39cb_94b9_5bdb);
        let mut rng = Rng {
            source: Source::Pcg {
                state: 0,
                inc: (seq << 1) | 1,
            },
        };
        rng.next_u32();
        if let Source::Pcg { state, .. } = &mut rng.source {
            *state = state.wrapping_add(hash64(seed));
        }
        rng.next_u32();
        rng
    }

    /// The stream for one work item: a pixel and sample, a photon batch, a cache record.
    pub fn for_item(seed: u64, item: u64, index: u64) -> Self {
        Self::new(hash_combine(&[seed, item, index]))
    }

    /// Sample `index` of pixel `pixel`'s Owen-scrambled Sobol sequence under `seed`: the first
    /// 2^m samples of a pixel are stratified in every dimension and every pair drawn by
    /// `uniform2` (module header of `sobol`).
    pub fn sobol(seed: u64, pixel: u64, index: u32) -> Self {
        Rng {
            source: Source::Sobol {
                pixel: hash_combine(&[seed, pixel, 0x50b0_1c0d_e5a3_71e5]),
                index,
                dimension: 0,
            },
        }
    }

    /// The seeds of the next Sobol dimension (or pair) of pixel hash `pixel`.
    fn dimension_seeds(pixel: u64, dimension: u64) -> Seeds {
        let a = hash64(pixel ^ dimension.wrapping_mul(0x9e37_79b9_7f4a_7c15));
        let b = hash64(a);
        Seeds {
            shuffle: a as u32,
            x: (a >> 32) as u32,
            y: b as u32,
            z: (b >> 32) as u32,
        }
    }

    pub fn next_u32(&mut self) -> u32 {
        match &mut self.source {
            Source::Pcg { state, inc } => {
                let old = *state;
                *state = old.wrapping_mul(Self::MULT).wrapping_add(*inc);
                let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
                let rot = (old >> 59) as u32;
                xorshifted.rotate_right(rot)
            }
            Source::Sobol {
                pixel,
                index,
                dimension,
            } => {
                let seeds = Self::dimension_seeds(*pixel, *dimension);
                *dimension += 1;
                sample_1d(*index, seeds)
            }
        }
    }

    /// Uniform in [0, 1), never 1.
    pub fn uniform(&mut self) -> f32 {
        fraction(self.next_u32())
    }

    /// Uniform in [0, 1)²: two numbers of a PCG stream, or one Sobol pair.
    pub fn uniform2(&mut self) -> Vec2 {
        if let Source::Sobol {
            pixel,
            index,
            dimension,
        } = &mut self.source
        {
            let seeds = Self::dimension_seeds(*pixel, *dimension);
            *dimension += 1;
            let (x, y) = sample_2d(*index, seeds);
            return Vec2::new(fraction(x), fraction(y));
        }
        let x = self.uniform();
        Vec2::new(x, self.uniform())
    }

    /// A number and a pair drawn together: `uniform()` then `uniform2()` of a PCG stream, or one
    /// Sobol triple, stratified jointly (`sobol::sample_3d`): for a choice and the 2D sample
    /// made after it (a light and a point on it, a lobe and a direction).
    pub fn uniform3(&mut self) -> (f32, Vec2) {
        if let Source::Sobol {
            pixel,
            index,
            dimension,
        } = &mut self.source
        {
            let seeds = Self::dimension_seeds(*pixel, *dimension);
            *dimension += 1;
            let (c, (x, y)) = sample_3d(*index, seeds);
            return (fraction(c), Vec2::new(fraction(x), fraction(y)));
        }
        let c = self.uniform();
        (c, self.uniform2())
    }

    /// Uniform integer in [0, n).
    pub fn below(&mut self, n: u32) -> u32 {
        ((self.next_u32() as u64 * n as u64) >> 32) as u32
    }
}

/// Where camera samples draw their numbers from: every method's pixel position, lens and moment,
/// and the rest of the path tracer's and the photon method's paths (light choice and point,
/// BSDF lobe and direction, Russian roulette, subsurface probes; the photon method's
/// final-gather rays, each its own dimensions) and photon tracing (each photon a sample of one
/// sequence per map: emission, then every bounce). The cache methods draw the rest of a sample
/// (gathers, lookups) from PCG32 streams whatever this says, and the irradiance cache's records
/// always do.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Sampler {
    /// Owen-scrambled Sobol points, each pixel and dimension randomised on its own (`sobol`).
    #[default]
    Sobol,
    /// Independent PCG32 numbers (`rng`).
    Random,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_is_in_range_and_has_the_right_mean() {
        let mut rng = Rng::new(7);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let u = rng.uniform();
            assert!((0.0..1.0).contains(&u));
            sum += u as f64;
        }
        // Standard error of the mean is sqrt(1/12/n) ≈ 0.00065; allow 5 sigma.
        assert!((sum / n as f64 - 0.5).abs() < 0.0033);
    }

    #[test]
    fn streams_are_deterministic_and_distinct() {
        let a: Vec<u32> = (0..8)
            .map({
                let mut r = Rng::for_item(1, 2, 3);
                move |_| r.next_u32()
            })
            .collect();
        let b: Vec<u32> = (0..8)
            .map({
                let mut r = Rng::for_item(1, 2, 3);
                move |_| r.next_u32()
            })
            .collect();
        let c: Vec<u32> = (0..8)
            .map({
                let mut r = Rng::for_item(1, 2, 4);
                move |_| r.next_u32()
            })
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }
}
