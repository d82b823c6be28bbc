//! Owen-scrambled Sobol points: the low-discrepancy numbers of the path tracer's camera paths.
//!
//! Every dimension (or pair of dimensions) of a sample is drawn from its own randomisation of
//! the first two Sobol dimensions — a (0, 2)-sequence in base 2, whose first 2^m points put
//! exactly one point in every elementary interval of area 2^−m — as Burley describes ("Practical
//! Hash-based Owen Scrambling", JCGT 9(4), 2020) and Cycles' Sobol–Burley sampler and pbrt-v4's
//! padded and Z-Sobol samplers do: the sample index is shuffled by a nested uniform scramble
//! (so each dimension visits the points in its own order, which decorrelates the dimensions of
//! one path), and the point's coordinates are Owen-scrambled (so every pixel and dimension has
//! its own randomisation, unbiased, with the stratification kept). Both scrambles are Laine and
//! Karras's hash-based permutation in Burley's form: operations in which each bit depends only on
//! the bits below it, applied to bit-reversed values, so each bit of the result depends on the
//! bits above it — the digit tree of Owen's scrambling.
//!
//! A dimension is identified by its seeds (`rng` hashes pixel, user seed and the dimension's
//! number into them); the same seeds and index always give the same point.

/// Direction numbers of Sobol's second dimension (primitive polynomial x + 1): its generator
/// matrix is Pascal's triangle mod 2, each column the one before XOR itself shifted by one.
const SECOND_DIMENSION: [u32; 32] = {
    let mut v = [0u32; 32];
    v[0] = 1 << 31;
    let mut k = 1;
    while k < 32 {
        v[k] = v[k - 1] ^ (v[k - 1] >> 1);
        k += 1;
    }
    v
};

/// Direction numbers of Sobol's third dimension (primitive polynomial x² + x + 1, initial
/// numbers m = 1, 3 as in Joe and Kuo's table): v_k = v_(k−1) ⊕ v_(k−2) ⊕ v_(k−2)/4.
const THIRD_DIMENSION: [u32; 32] = {
    let mut v = [0u32; 32];
    v[0] = 1 << 31;
    v[1] = 3 << 30;
    let mut k = 2;
    while k < 32 {
        v[k] = v[k - 1] ^ v[k - 2] ^ (v[k - 2] >> 2);
        k += 1;
    }
    v
};

/// The XOR of the direction numbers each byte of an index selects: `table[b][v]` is the sum of
/// `directions[8b + k]` over the bits k set in v.
const fn byte_tables(directions: &[u32; 32]) -> [[u32; 256]; 4] {
    let mut tables = [[0u32; 256]; 4];
    let mut b = 0;
    while b < 4 {
        let mut v = 0;
        while v < 256 {
            let mut x = 0u32;
            let mut k = 0;
            while k < 8 {
                if v & (1 << k) != 0 {
                    x ^= directions[8 * b + k];
                }
                k += 1;
            }
            tables[b][v] = x;
            v += 1;
        }
        b += 1;
    }
    tables
}

const SECOND_TABLES: [[u32; 256]; 4] = byte_tables(&SECOND_DIMENSION);
const THIRD_TABLES: [[u32; 256]; 4] = byte_tables(&THIRD_DIMENSION);

/// The product of a generator matrix (as byte tables) with `index`.
fn generate(tables: &[[u32; 256]; 4], index: u32) -> u32 {
    let byte = |b: usize| tables[b][(index >> (8 * b)) as usize & 0xff];
    byte(0) ^ byte(1) ^ byte(2) ^ byte(3)
}

/// Sobol's first dimension at `index` (the van der Corput sequence), as a 32-bit fraction.
pub fn sobol_first(index: u32) -> u32 {
    index.reverse_bits()
}

/// Sobol's second dimension at `index`, as a 32-bit fraction.
pub fn sobol_second(index: u32) -> u32 {
    generate(&SECOND_TABLES, index)
}

/// Sobol's third dimension at `index`, as a 32-bit fraction.
pub fn sobol_third(index: u32) -> u32 {
    generate(&THIRD_TABLES, index)
}

/// A seeded permutation of 32-bit integers in which bit k of the result depends only on bits
/// 0..=k of `x` (Laine–Karras, with Burley's constants: an addition and products by even
/// numbers only carry upwards).
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Owen's scrambling of the 32-bit fraction `x` (a nested uniform scramble): each bit flipped
/// by a hash of the bits above it.
pub fn owen_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// The random seeds of one dimension (or pair): the index shuffle's and each coordinate's
/// scramble's.
#[derive(Clone, Copy, Debug)]
pub struct Seeds {
    pub shuffle: u32,
    pub x: u32,
    pub y: u32,
    pub z: u32,
}

/// Point `index` of the Owen-scrambled (0, 2)-sequence of the dimension pair `seeds`, as two
/// 32-bit fractions. The first 2^m indices give a (0, m, 2)-net.
pub fn sample_2d(index: u32, seeds: Seeds) -> (u32, u32) {
    let Seeds {
        shuffle,
        x: sx,
        y: sy,
        ..
    } = seeds;
    let i = owen_scramble(index, shuffle);
    // Scrambling the first dimension undoes its bit reversal: rev(LK(rev(rev(i)))).
    (
        laine_karras(i, sx).reverse_bits(),
        owen_scramble(sobol_second(i), sy),
    )
}

/// Point `index` of the Owen-scrambled first three Sobol dimensions of the dimension triple
/// `seeds`, as a number (the third dimension) and a pair (the first two, a (0, 2)-sequence):
/// a choice and the 2D sample that follows it — a light and a point on it, a BSDF lobe and a
/// direction — stratified together (the three form a (1, 3)-sequence), as Cycles draws them
/// from one 4D Sobol point.
pub fn sample_3d(index: u32, seeds: Seeds) -> (u32, (u32, u32)) {
    let i = owen_scramble(index, seeds.shuffle);
    (
        owen_scramble(sobol_third(i), seeds.z),
        (
            laine_karras(i, seeds.x).reverse_bits(),
            owen_scramble(sobol_second(i), seeds.y),
        ),
    )
}

/// Point `index` of the Owen-scrambled van der Corput sequence of the dimension `seeds`, as a
/// 32-bit fraction: the first 2^m indices fall one in each interval of length 2^−m.
pub fn sample_1d(index: u32, seeds: Seeds) -> u32 {
    laine_karras(owen_scramble(index, seeds.shuffle), seeds.x).reverse_bits()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_points_are_sobols() {
        // (0, 0), (1/2, 1/2), (3/4, 1/4), (1/4, 3/4), (3/8, 5/8), ...
        let f = |x: u32| x as f64 / 4_294_967_296.0;
        let points: Vec<(f64, f64)> = (0..5)
            .map(|i| (f(sobol_first(i)), f(sobol_second(i))))
            .collect();
        assert_eq!(
            points,
            [
                (0.0, 0.0),
                (0.5, 0.5),
                (0.25, 0.75),
                (0.75, 0.25),
                (0.125, 0.625)
            ]
        );
    }

    #[test]
    fn the_byte_tables_give_the_matrix_product() {
        let direct = |v: &[u32; 32], index: u32| {
            (0..32)
                .filter(|k| index & (1 << k) != 0)
                .fold(0, |x, k| x ^ v[k])
        };
        for index in [0u32, 1, 2, 3, 255, 256, 0x1234_5678, 0xdead_beef, u32::MAX] {
            assert_eq!(sobol_second(index), direct(&SECOND_DIMENSION, index));
            assert_eq!(sobol_third(index), direct(&THIRD_DIMENSION, index));
        }
    }

    #[test]
    fn owen_scrambling_is_a_permutation_that_keeps_prefixes_together() {
        // Values that share their top k bits still share them after scrambling.
        for seed in [0u32, 1, 0xdead_beef] {
            let mut seen = std::collections::HashSet::new();
            for x in 0..4096u32 {
                let y = owen_scramble(x << 20, seed);
                assert!(seen.insert(y >> 20), "not a permutation of the top 12 bits");
                let z = owen_scramble((x << 20) | 0xfffff, seed);
                assert_eq!(y >> 20, z >> 20);
            }
        }
    }
}
