//! Perlin noise and the Noise Texture as Blender defines them (Cycles' `noise_fbm` over Perlin's
//! improved noise (Perlin, 2002) with Jenkins' lookup3 lattice hashes, `hash`): 1D, 2D and 3D
//! noise, fBm, distortion and colour, and the same noise at a Bump's three nearby points at once
//! (`noise_texture_at3`). The 3D gradients and interpolation are written once over `Lanes`: a
//! point's eight lattice corners as lanes (`perlin3`, four lanes, or eight with AVX2), or
//! points of one lattice cell as lanes (`snoise3_in_cell`, four lanes, or eight with AVX2 in
//! `noise_avx2`), with the same values bit for bit.

use super::hash::{self, has_avx2, hash1, hash2, hash_float, hash_float2, LOOKUP3_SEED};
use super::inputs::{input, splat, v3, Operands, Socket, Ty};
pub(super) use super::lanes::floor;
use super::lanes::{grad3, CornerLanes, Lanes, Pair, U32x4, Words};
use crate::math::{Vec3, Vec4};
use std::ops::{Add, Div, Mul, Sub};

/// The Noise node's inputs.
pub(super) const NOISE_INPUTS: &[Socket] = &[
    Socket::vector("Vector", Vec4::ZERO),
    Socket::float("W", 0.0),
    Socket::float("Scale", 5.0),
    Socket::float("Detail", 2.0),
    Socket::float("Roughness", 0.5),
    Socket::float("Lacunarity", 2.0),
    Socket::float("Offset", 0.0),
    Socket::float("Gain", 1.0),
    Socket::float("Distortion", 0.0),
];

/// The Noise node's outputs.
pub(super) const NOISE_OUTPUTS: &[Socket] = &[
    Socket::output("Fac", Ty::Float),
    Socket::output("Color", Ty::Color),
];

/// Perlin's interpolant 6t⁵ − 15t⁴ + 10t³, for one value or lanes of them.
#[inline(always)]
pub(super) fn fade<T>(t: T) -> T
where
    T: Copy + Mul<Output = T> + Mul<f32, Output = T> + Sub<f32, Output = T> + Add<f32, Output = T>,
{
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

pub(super) fn negate_if(v: f32, condition: u32) -> f32 {
    if condition != 0 {
        -v
    } else {
        v
    }
}

/// `a` when `c`, else `b`, without a branch (the gradient picks are unpredictable).
pub(super) fn select(c: bool, a: f32, b: f32) -> f32 {
    let mask = (c as u32).wrapping_neg();
    f32::from_bits((a.to_bits() & mask) | (b.to_bits() & !mask))
}

/// −v when `bit` (0 or 1) is 1, without a branch: a flip of the sign bit, as negation is.
pub(super) fn flip_sign(v: f32, bit: u32) -> f32 {
    f32::from_bits(v.to_bits() ^ (bit << 31))
}

pub(super) fn floorfrac(x: f32) -> (i32, f32) {
    let f = floor(x);
    (f as i32, x - f)
}

pub(super) fn grad1(hash: u32, x: f32) -> f32 {
    let h = hash & 15;
    let g = 1.0 + (h & 7) as f32;
    negate_if(g, h & 8) * x
}

pub(super) fn grad2(hash: u32, x: f32, y: f32) -> f32 {
    let h = hash & 7;
    let first = h < 4;
    let (u, v) = (select(first, x, y), select(first, 2.0 * y, 2.0 * x));
    flip_sign(u, h & 1) + flip_sign(v, (h >> 1) & 1)
}

pub(super) fn lerp(a: f32, b: f32, t: f32) -> f32 {
    (1.0 - t) * a + t * b
}

pub(super) fn perlin1(x: f32) -> f32 {
    let (xi, fx) = floorfrac(x);
    let u = fade(fx);
    lerp(
        grad1(hash1(xi as u32), fx),
        grad1(hash1(xi.wrapping_add(1) as u32), fx - 1.0),
        u,
    )
}

pub(super) fn perlin2(x: f32, y: f32) -> f32 {
    let (xi, fx) = floorfrac(x);
    let (yi, fy) = floorfrac(y);
    let (u, v) = (fade(fx), fade(fy));
    let h = |dx: i32, dy: i32| hash2(xi.wrapping_add(dx) as u32, yi.wrapping_add(dy) as u32);
    let v0 = grad2(h(0, 0), fx, fy);
    let v1 = grad2(h(1, 0), fx - 1.0, fy);
    let v2 = grad2(h(0, 1), fx, fy - 1.0);
    let v3 = grad2(h(1, 1), fx - 1.0, fy - 1.0);
    let x1 = 1.0 - u;
    (1.0 - v) * (v0 * x1 + v1 * u) + v * (v2 * x1 + v3 * u)
}

/// `hash3` of a lattice cell's eight corners (index dx + 2 dy + 4 dz), four at a time
/// (`hash::U32x4`): the near face's corners (dz = 0), then the far face's.
pub(super) fn corner_hashes(xi: i32, yi: i32, zi: i32) -> [U32x4; 2] {
    let s = LOOKUP3_SEED.wrapping_add((3 << 2) + 13);
    let (x0, y0, z0) = (xi as u32, yi as u32, zi as u32);
    let a = U32x4::new([x0, x0.wrapping_add(1), x0, x0.wrapping_add(1)]);
    let b = U32x4::new([y0, y0, y0.wrapping_add(1), y0.wrapping_add(1)]);
    let (a, b) = (
        a + <U32x4 as Words>::splat(s),
        b + <U32x4 as Words>::splat(s),
    );
    let z = |dz: u32| <U32x4 as Words>::splat(s.wrapping_add(z0).wrapping_add(dz));
    [hash::finish(a, b, z(0)), hash::finish(a, b, z(1))]
}

pub(super) fn perlin3(x: f32, y: f32, z: f32) -> f32 {
    let (xi, fx) = floorfrac(x);
    let (yi, fy) = floorfrac(y);
    let (zi, fz) = floorfrac(z);
    let [near, far] = corner_hashes(xi, yi, zi);
    let f = Vec4::new(fx, fy, fz, 0.0);
    perlin3_corners::<Pair<Vec4>>(Pair(near, far), f, f - 1.0)
}

/// `perlin3` at one point given its lattice cell's eight corner hashes `h` as lanes (index
/// dx + 2 dy + 4 dz) and its offsets `f` from the cell's lower corner and `g` = `f` − 1 (x,
/// y, z in lanes 0–2): each corner's gradient in its lane, the interpolation along x and y
/// as sums of neighbouring lanes (a + b is b + a bit for bit), as
/// z1 · (y1 · (g000 · x1 + g100 · u) + v · (g010 · x1 + g110 · u)) + w · (same, far face).
#[inline(always)]
pub(super) fn perlin3_corners<C: CornerLanes>(h: C::Words, f: Vec4, g: Vec4) -> f32 {
    let t = fade(f);
    let rest = Vec4::ONE - t;
    let xs = C::by_bit::<0>(f.x, g.x);
    let ys = C::by_bit::<1>(f.y, g.y);
    let zs = C::by_bit::<2>(f.z, g.z);
    let rows = (grad3(h, xs, ys, zs) * C::by_bit::<0>(rest.x, t.x)).pair_sums();
    let faces = (rows * C::by_bit::<0>(rest.y, t.y)).pair_sums();
    let [near, far] = faces.first_of_halves();
    rest.z * near + t.z * far
}

/// Signed noise in about [−1, 1], repeating every 100000 (Cycles' `snoise_*d`: each
/// coordinate taken modulo the period, plus ½ where it was at least 10⁶).
pub(super) fn snoise(dimensions: u8, p: Vec3, w: f32) -> f32 {
    // fmod is the identity below the period (and a library call).
    let m = |x: f32| {
        if x.abs() < 100_000.0 {
            x
        } else if x.abs() < 1_000_000.0 {
            x % 100_000.0
        } else {
            x % 100_000.0 + 0.5
        }
    };
    match dimensions {
        1 => 0.25 * perlin1(m(w)),
        2 => 0.6616 * perlin2(m(p.x), m(p.y)),
        _ => 0.9820 * perlin3_fast(m(p.x), m(p.y), m(p.z)),
    }
}

/// `perlin3`, its eight corners as the lanes of one AVX2 register where the machine has it
/// (`noise_avx2::perlin3`, the same value bit for bit); NaN coordinates take `perlin3`.
#[inline(always)]
pub(super) fn perlin3_fast(x: f32, y: f32, z: f32) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() && !(x.is_nan() || y.is_nan() || z.is_nan()) {
        // SAFETY: AVX2 is present (checked above).
        return unsafe { noise_avx2::perlin3(x, y, z) };
    }
    perlin3(x, y, z)
}

#[derive(Clone, Copy, PartialEq)]
pub(super) struct Fractal {
    pub(super) detail: f32,
    pub(super) roughness: f32,
    pub(super) lacunarity: f32,
    pub(super) normalize: bool,
}

/// Cycles' `noise_fbm`.
pub(super) fn fbm(dimensions: u8, p: Vec3, w: f32, f: &Fractal) -> f32 {
    #[cfg(target_arch = "x86_64")]
    if dimensions == 3 && has_avx2() {
        // SAFETY: AVX2 is present (checked above).
        return unsafe { noise_avx2::fbm3(p, f) };
    }
    fractal_sum(f, 0.0, |scale| snoise(dimensions, scale * p, scale * w))
}

/// `noise_fbm`'s sum of octaves of `noise` (called with each octave's scale), for one point
/// or several as lanes.
pub(super) fn fractal_sum<T>(f: &Fractal, zero: T, noise: impl Fn(f32) -> T) -> T
where
    T: Copy + Add<Output = T> + Add<f32, Output = T> + Mul<f32, Output = T> + Div<f32, Output = T>,
{
    let mut fscale = 1.0f32;
    let mut amp = 1.0f32;
    let mut maxamp = 0.0f32;
    let mut sum = zero;
    let octaves = f.detail as i32;
    for _ in 0..=octaves {
        sum = sum + noise(fscale) * amp;
        maxamp += amp;
        amp *= f.roughness;
        fscale *= f.lacunarity;
    }
    let lerp = |a: T, b: T, t: f32| a * (1.0 - t) + b * t;
    let rmd = f.detail - f.detail.floor();
    if rmd != 0.0 {
        let sum2 = sum + noise(fscale) * amp;
        if f.normalize {
            lerp(
                sum * 0.5 / maxamp + 0.5,
                sum2 * 0.5 / (maxamp + amp) + 0.5,
                rmd,
            )
        } else {
            lerp(sum, sum2, rmd)
        }
    } else if f.normalize {
        sum * 0.5 / maxamp + 0.5
    } else {
        sum
    }
}

/// Cycles' random offsets that seed the distortion and colour channels.
pub(super) fn offset(dimensions: u8, seed: f32) -> (Vec3, f32) {
    if dimensions == 1 {
        return (Vec3::ZERO, 100.0 + hash_float(seed) * 100.0);
    }
    let c = |k: f32| 100.0 + hash_float2(seed, k) * 100.0;
    (Vec3::new(c(0.0), c(1.0), c(2.0)), 0.0)
}

/// The Noise Texture (FBM type): its Fac and Color outputs.
/// Without `color` the Color output is not computed (grey).
pub(super) fn noise_texture(
    dimensions: u8,
    p: Vec3,
    w: f32,
    f: &Fractal,
    distortion: f32,
    color: bool,
) -> (f32, Vec3) {
    let (mut p, mut w) = (p, w);
    let masked = |v: Vec3| match dimensions {
        2 => Vec3::new(v.x, v.y, 0.0),
        _ => v,
    };
    p = masked(p);
    if distortion != 0.0 {
        match dimensions {
            1 => w += snoise(1, p, w + offset(1, 0.0).1) * distortion,
            _ => {
                let mut d = Vec3::ZERO;
                for (k, seed) in [0.0f32, 1.0, 2.0]
                    .iter()
                    .enumerate()
                    .take(dimensions as usize)
                {
                    d[k] =
                        snoise(dimensions, p + masked(offset(dimensions, *seed).0), w) * distortion;
                }
                p += d;
            }
        }
    }
    let value = fbm(dimensions, p, w, f);
    if !color {
        return (value, Vec3::splat(value));
    }
    let (s1, s2) = match dimensions {
        1 => (1.0, 2.0),
        2 => (2.0, 3.0),
        _ => (3.0, 4.0),
    };
    let shifted = |seed: f32| {
        let (o, ow) = offset(dimensions, seed);
        fbm(dimensions, p + masked(o), w + ow, f)
    };
    (value, Vec3::new(value, shifted(s1), shifted(s2)))
}

// ----- the same noise at a Bump's three points at once ---------------------------------------
//
// A Bump reads its height at the shading point and a small step along each tangent: three
// points that nearly always lie in the same lattice cell of every octave. There the eight
// corner hashes are computed once and the three points' gradients and interpolation run as
// lanes of one vector, each lane the very operations of `perlin3` in the same order (no fused
// multiply-add), so the values are the scalar code's bit for bit; points in different cells,
// far coordinates and other dimensions take the scalar code.

/// Three points' coordinates as lanes (the fourth repeats the first).
pub(super) fn lanes(v: [f32; 3]) -> Vec4 {
    Vec4::new(v[0], v[1], v[2], v[0])
}

/// The lattice cells (x, y, z) of points given as lanes, when every group of four lanes lies
/// in one cell and near enough (below `snoise`'s period) for `snoise3_in_cell`.
#[inline(always)]
pub(super) fn one_cell<F: Lanes>(x: F, y: F, z: F) -> Option<[F; 3]> {
    let (cx, cy, cz) = (x.floor(), y.floor(), z.floor());
    let near = x.all_below(100_000.0) && y.all_below(100_000.0) && z.all_below(100_000.0);
    let one = cx.uniform_quads() && cy.uniform_quads() && cz.uniform_quads();
    (near && one).then_some([cx, cy, cz])
}

/// `0.9820 * perlin3` (`snoise` in 3D) of points given as lanes in the cells `one_cell`
/// found, each lane the very operations of `perlin3` in the same order; `h` holds the cells'
/// eight corner hashes (index dx + 2 dy + 4 dz, each group's in all its four lanes).
#[inline(always)]
pub(super) fn snoise3_in_cell<F: Lanes>(h: [F::Words; 8], p: [F; 3], cell: [F; 3]) -> F {
    let ([x, y, z], [cx, cy, cz]) = (p, cell);
    let (fx, fy, fz) = (x - cx, y - cy, z - cz);
    let (u, v, w) = (fade(fx), fade(fy), fade(fz));
    let (gx, gy, gz) = (fx - 1.0, fy - 1.0, fz - 1.0);
    let g000 = grad3(h[0], fx, fy, fz);
    let g100 = grad3(h[1], gx, fy, fz);
    let g010 = grad3(h[2], fx, gy, fz);
    let g110 = grad3(h[3], gx, gy, fz);
    let g001 = grad3(h[4], fx, fy, gz);
    let g101 = grad3(h[5], gx, fy, gz);
    let g011 = grad3(h[6], fx, gy, gz);
    let g111 = grad3(h[7], gx, gy, gz);
    let one = F::splat(1.0);
    let (x1, y1, z1) = (one - u, one - v, one - w);
    let near = y1 * (g000 * x1 + g100 * u) + v * (g010 * x1 + g110 * u);
    let far = y1 * (g001 * x1 + g101 * u) + v * (g011 * x1 + g111 * u);
    (z1 * near + w * far) * 0.9820
}

/// `snoise3_in_cell` of three points given as lanes, or the scalar noise of each where they
/// are not in one cell (with AVX2 `noise_avx2::snoise3_one`).
pub(super) fn snoise3_lanes(x: Vec4, y: Vec4, z: Vec4) -> Vec4 {
    let Some(cell) = one_cell(x, y, z) else {
        let (xs, ys, zs) = (x.to_array(), y.to_array(), z.to_array());
        let n = |k: usize| snoise(3, Vec3::new(xs[k], ys[k], zs[k]), 0.0);
        return lanes([n(0), n(1), n(2)]);
    };
    let [near, far] = corner_hashes(cell[0].x as i32, cell[1].x as i32, cell[2].x as i32);
    let (n, f) = (near.to_array(), far.to_array());
    let h = [n[0], n[1], n[2], n[3], f[0], f[1], f[2], f[3]].map(<U32x4 as Words>::splat);
    snoise3_in_cell(h, [x, y, z], cell)
}

/// `fbm` in 3D of three points given as lanes (with AVX2 `noise_avx2::fbm3_lanes`).
pub(super) fn fbm3_lanes(x: Vec4, y: Vec4, z: Vec4, f: &Fractal) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: AVX2 is present (checked above).
        return unsafe { noise_avx2::fbm3_lanes(x, y, z, f) };
    }
    fractal_sum(f, Vec4::ZERO, |s| snoise3_lanes(s * x, s * y, s * z))
}

/// Perlin noise on AVX2 (x86-64 machines that have it; the callers check): `perlin3`'s
/// corners as eight lanes, and `snoise3_in_cell` on four or eight lanes, each lane the scalar
/// operations in the same order (no fused multiply-add), so the values are theirs bit for bit.
#[cfg(target_arch = "x86_64")]
mod noise_avx2 {
    use crate::math::{Vec3, Vec4};
    use crate::shader::hash::{self, LOOKUP3_SEED};
    use crate::shader::lanes::eight::{F32x8, U32x8};
    use crate::shader::lanes::{U32x4, Words};
    use crate::shader::noise::{
        fractal_sum, one_cell, perlin3_corners, snoise, snoise3_in_cell, snoise3_lanes, Fractal,
    };
    use std::arch::x86_64::*;

    const SEED3: u32 = LOOKUP3_SEED.wrapping_add((3 << 2) + 13);

    /// The words `$words` of the eight corner hashes for `snoise3_in_cell`: each group of four
    /// lanes of `$near` (its corners 0–3) and `$far` (4–7) holds its cell's corners, each
    /// corner broadcast to the group by `$shuffle`.
    macro_rules! broadcast_corners {
        ($shuffle:ident, $words:ident, $near:expr, $far:expr) => {{
            let (near, far) = ($near, $far);
            [
                $words($shuffle::<0x00>(near)),
                $words($shuffle::<0x55>(near)),
                $words($shuffle::<0xAA>(near)),
                $words($shuffle::<0xFF>(near)),
                $words($shuffle::<0x00>(far)),
                $words($shuffle::<0x55>(far)),
                $words($shuffle::<0xAA>(far)),
                $words($shuffle::<0xFF>(far)),
            ]
        }};
    }

    /// `super::fbm` in 3D, its octaves' noise inlined.
    #[target_feature(enable = "avx2")]
    pub fn fbm3(p: Vec3, f: &Fractal) -> f32 {
        fractal_sum(f, 0.0, |scale| {
            let q = scale * p;
            // `snoise` in 3D, whose coordinates' fmod is the identity below the period.
            let below = |v: f32| v.abs() < 100_000.0;
            if below(q.x) && below(q.y) && below(q.z) {
                0.9820 * perlin3(q.x, q.y, q.z)
            } else {
                snoise(3, q, 0.0)
            }
        })
    }

    /// `super::fbm3_lanes`, the octaves evaluated two at a time (`snoise3_pair`):
    /// `fractal_sum` calls for scales s, s · lacunarity, .. in turn, so a call computes its
    /// octave and the next (the very scale `fractal_sum` passes next), which the next call
    /// returns.
    #[target_feature(enable = "avx2")]
    pub fn fbm3_lanes(x: Vec4, y: Vec4, z: Vec4, f: &Fractal) -> Vec4 {
        let mut pending = None;
        let pending = std::cell::Cell::from_mut(&mut pending);
        // How many times `fractal_sum` calls: the last of an odd number is one octave alone
        // (`snoise3_one`). (Were this count off, the values would be the same.)
        let calls = (f.detail as i32 + 1).max(0) + (f.detail - f.detail.floor() != 0.0) as i32;
        let mut call = 0;
        let call = std::cell::Cell::from_mut(&mut call);
        fractal_sum(f, Vec4::ZERO, |s| {
            call.set(call.get() + 1);
            if let Some(v) = pending.take() {
                return v;
            }
            if call.get() == calls {
                return snoise3_one(s * x, s * y, s * z);
            }
            let t = s * f.lacunarity;
            let [a, b] = snoise3_pair([s * x, t * x], [s * y, t * y], [s * z, t * z]);
            pending.set(Some(b));
            a
        })
    }

    /// lookup3's `hash3` of lattice corners, eight at once: lane k of the cells' coordinates
    /// `x`, `y` plus (k & 1, k >> 1 & 1), and `z` as given.
    #[inline(always)]
    fn corner_hashes8(x: __m256i, y: __m256i, z: __m256i) -> U32x8 {
        // SAFETY: the callers run only with AVX2.
        let (dx, dy) = unsafe {
            (
                _mm256_setr_epi32(0, 1, 0, 1, 0, 1, 0, 1),
                _mm256_setr_epi32(0, 0, 1, 1, 0, 0, 1, 1),
            )
        };
        let seed = <U32x8 as Words>::splat(SEED3);
        let (x, y, z) = (U32x8(x) + seed, U32x8(y) + seed, U32x8(z) + seed);
        hash::finish(x + U32x8(dx), y + U32x8(dy), z)
    }

    /// The eight corners of one cell (lane dx + 2 dy + 4 dz) of integer coordinates the
    /// first lanes of `x`, `y`, `z`, hashed at once.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn cell_corner_hashes(x: __m128i, y: __m128i, z: __m128i) -> U32x8 {
        let dz = _mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1);
        corner_hashes8(
            _mm256_broadcastd_epi32(x),
            _mm256_broadcastd_epi32(y),
            _mm256_add_epi32(_mm256_broadcastd_epi32(z), dz),
        )
    }

    /// `super::perlin3` at one point (coordinates not NaN), its eight lattice corners as
    /// the lanes of one register (`perlin3_corners`).
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn perlin3(x: f32, y: f32, z: f32) -> f32 {
        let p = _mm_set_ps(0.0, z, y, x);
        let cell = _mm_floor_ps(p);
        let f = Vec4::from(_mm_sub_ps(p, cell));
        let c = _mm_cvttps_epi32(cell);
        let h = cell_corner_hashes(
            c,
            _mm_shuffle_epi32::<0x55>(c),
            _mm_shuffle_epi32::<0xAA>(c),
        );
        perlin3_corners::<F32x8>(h, f, f - 1.0)
    }

    /// `snoise3_lanes` of two sets of lanes (two octaves of a Bump's three points) at once
    /// (`snoise3_in_cell` on eight lanes): each set's eight corner hashes in two eight-lane
    /// hashes (near face, far face), each broadcast to its set's four lanes.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn snoise3_pair(x: [Vec4; 2], y: [Vec4; 2], z: [Vec4; 2]) -> [Vec4; 2] {
        let join = |v: [Vec4; 2]| F32x8::join(v[0], v[1]);
        let p = [join(x), join(y), join(z)];
        let Some(cell) = one_cell(p[0], p[1], p[2]) else {
            return [0, 1].map(|k| snoise3_lanes(x[k], y[k], z[k]));
        };
        let word = |c: F32x8| _mm256_cvttps_epi32(c.0);
        let (a, b, c) = (word(cell[0]), word(cell[1]), word(cell[2]));
        let near = corner_hashes8(a, b, c).0;
        let far = corner_hashes8(a, b, _mm256_add_epi32(c, _mm256_set1_epi32(1))).0;
        let h = broadcast_corners!(_mm256_shuffle_epi32, U32x8, near, far);
        snoise3_in_cell(h, p, cell).halves()
    }

    /// `snoise3_lanes` of one set of lanes (one octave of a Bump's three points): its cell's
    /// eight corner hashes in one eight-lane hash, each broadcast to the four lanes.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub fn snoise3_one(x: Vec4, y: Vec4, z: Vec4) -> Vec4 {
        let Some(cell) = one_cell(x, y, z) else {
            return snoise3_lanes(x, y, z);
        };
        let word = |c: Vec4| _mm_cvttps_epi32(c.into());
        let (a, b, c) = (word(cell[0]), word(cell[1]), word(cell[2]));
        let corners = cell_corner_hashes(a, b, c).0;
        let (near, far) = (
            _mm256_castsi256_si128(corners),
            _mm256_extracti128_si256::<1>(corners),
        );
        let h = broadcast_corners!(_mm_shuffle_epi32, U32x4, near, far);
        snoise3_in_cell(h, [x, y, z], cell)
    }
}

/// One point's Noise Texture inputs: (scaled position, scaled W, fractal, distortion).
pub(super) type NoiseInput = (Vec3, f32, Fractal, f32);

/// `noise_texture` at a Bump's three points (its section header).
pub(super) fn noise_texture_at3(
    dimensions: u8,
    at: &[NoiseInput; 3],
    color: bool,
) -> [(f32, Vec3); 3] {
    let (_, _, f, distortion) = at[0];
    let shared = at.iter().all(|a| a.2 == f && a.3 == distortion);
    if dimensions != 3 || !shared {
        return at.map(|(p, w, f, d)| noise_texture(dimensions, p, w, &f, d, color));
    }
    let (mut x, mut y, mut z) = (
        lanes(at.map(|a| a.0.x)),
        lanes(at.map(|a| a.0.y)),
        lanes(at.map(|a| a.0.z)),
    );
    if distortion != 0.0 {
        let d = [0.0f32, 1.0, 2.0].map(|seed| {
            let o = offset(3, seed).0;
            snoise3_lanes(x + o.x, y + o.y, z + o.z) * distortion
        });
        (x, y, z) = (x + d[0], y + d[1], z + d[2]);
    }
    let value = fbm3_lanes(x, y, z, &f);
    let shifted = |seed: f32| {
        let o = offset(3, seed).0;
        fbm3_lanes(x + o.x, y + o.y, z + o.z, &f)
    };
    let (g, b) = if color {
        (shifted(3.0), shifted(4.0))
    } else {
        (value, value)
    };
    [0, 1, 2].map(|k| (value[k], Vec3::new(value[k], g[k], b[k])))
}

/// One point's Noise Texture inputs (Vector, W, Scale, Detail, Roughness, Lacunarity,
/// Offset, Gain, Distortion) as `noise_texture` takes them.
#[inline(always)]
pub(super) fn noise_input(normalize: bool, ins: &impl Operands) -> NoiseInput {
    const VECTOR: usize = input(NOISE_INPUTS, "Vector");
    const W: usize = input(NOISE_INPUTS, "W");
    const SCALE: usize = input(NOISE_INPUTS, "Scale");
    const DETAIL: usize = input(NOISE_INPUTS, "Detail");
    const ROUGHNESS: usize = input(NOISE_INPUTS, "Roughness");
    const LACUNARITY: usize = input(NOISE_INPUTS, "Lacunarity");
    const DISTORTION: usize = input(NOISE_INPUTS, "Distortion");
    let scale = ins.float(SCALE);
    let p = ins.vector(VECTOR) * scale;
    let f = Fractal {
        detail: ins.float(DETAIL).clamp(0.0, 15.0),
        roughness: ins.float(ROUGHNESS).max(0.0),
        lacunarity: ins.float(LACUNARITY),
        normalize,
    };
    (p, ins.float(W) * scale, f, ins.float(DISTORTION))
}

/// The Noise Texture (FBM): Fac and Color; the colour only when `used` reads it.
#[inline(always)]
pub(super) fn eval_noise(
    dimensions: u8,
    normalize: bool,
    used: u32,
    ins: &impl Operands,
) -> [Vec4; 2] {
    let (p, w, params, distortion) = noise_input(normalize, ins);
    let color = used & 2 != 0;
    let (fac, color) = noise_texture(dimensions, p, w, &params, distortion, color);
    [splat(fac), v3(color)]
}

/// A Noise Texture and its copies at a Bump's two offset points (`NoiseAt3`): each point's
/// Fac and Color; the colours only when one of `used` reads them.
#[inline(always)]
pub(super) fn eval_noise_at3(
    dimensions: u8,
    normalize: bool,
    used: &[u32; 3],
    ins: [&impl Operands; 3],
) -> [[Vec4; 2]; 3] {
    let color = used.iter().any(|u| u & 2 != 0);
    let at = ins.map(|i| noise_input(normalize, i));
    noise_texture_at3(dimensions, &at, color).map(|(fac, color)| [splat(fac), v3(color)])
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    #[test]
    fn noise_is_in_range_and_matches_known_structure() {
        let f = Fractal {
            detail: 2.0,
            roughness: 0.5,
            lacunarity: 2.0,
            normalize: true,
        };
        // Perlin noise is zero at lattice points: one octave of normalized fBm gives 0.5 there.
        let one = Fractal { detail: 0.0, ..f };
        assert!((fbm(3, Vec3::new(3.0, -2.0, 7.0), 0.0, &one) - 0.5).abs() < 1e-6);
        let mut lo = f32::MAX;
        let mut hi = f32::MIN;
        for i in 0..2000 {
            let p = Vec3::new(i as f32 * 0.137, i as f32 * 0.071, i as f32 * 0.029);
            let v = fbm(3, p, 0.0, &f);
            lo = lo.min(v);
            hi = hi.max(v);
        }
        assert!(lo > 0.0 && hi < 1.0 && hi - lo > 0.3, "{lo} {hi}");
        // Continuity: nearby points give nearby values.
        let a = fbm(3, Vec3::new(0.3, 0.4, 0.5), 0.0, &f);
        let b = fbm(3, Vec3::new(0.3001, 0.4, 0.5), 0.0, &f);
        assert!((a - b).abs() < 1e-3);
    }

    #[test]
    fn floor_is_the_library_floor() {
        for x in [
            -0.0f32,
            0.0,
            -1.5,
            2.0,
            -3.0,
            1e9,
            -1e9,
            8_388_607.5,
            -8_388_607.5,
        ] {
            assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "{x}");
        }
        assert!(floor(f32::NAN).is_nan());
        let mut rng = crate::rng::Rng::new(5);
        for _ in 0..100_000 {
            let x = (rng.uniform() - 0.5) * 2e7;
            assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "{x}");
        }
    }

    #[test]
    fn noise_at_a_bumps_three_points_is_the_scalar_noise_bit_for_bit() {
        // Points a small step apart (mostly one lattice cell), some across cell walls, far
        // ones (fmod), with and without distortion and colour, whole and fractional detail.
        let mut rng = crate::rng::Rng::new(9);
        let mut shared_cells = 0;
        for k in 0..20_000 {
            let scale = [1.0, 10.0, 300.0, 2.0e5][k % 4];
            let c = |rng: &mut crate::rng::Rng| (rng.uniform() * 2.0 - 1.0) * scale;
            let p = Vec3::new(c(&mut rng), c(&mut rng), c(&mut rng));
            let step = [1e-4, 1e-2, 0.3][k % 3];
            let points = [p, p + Vec3::X * step, p + Vec3::Y * step];
            let f = Fractal {
                detail: [0.0, 2.0, 3.5][k % 3],
                roughness: 0.5,
                lacunarity: 2.0,
                normalize: k % 2 == 0,
            };
            let distortion = [0.0, 0.0, 1.5][(k / 3) % 3];
            let color = k % 5 == 0;
            let inputs = points.map(|p| (p, 0.0, f, distortion));
            let fused = noise_texture_at3(3, &inputs, color);
            for (q, (fac, col)) in points.iter().zip(fused) {
                let (want, want_col) = noise_texture(3, *q, 0.0, &f, distortion, color);
                assert_eq!(fac.to_bits(), want.to_bits(), "{q:?} {k}");
                assert_eq!(
                    col.to_array().map(f32::to_bits),
                    want_col.to_array().map(f32::to_bits)
                );
            }
            let cell = |v: Vec3| v.floor();
            shared_cells += (cell(points[1]) == cell(p) && cell(points[2]) == cell(p)) as u32;
        }
        // Both paths ran: the shared-cell lanes and the scalar fallback.
        assert!((5_000..19_000).contains(&shared_cells), "{shared_cells}");
    }

    /// Random coordinates at several scales, with −0, integers and cell walls mixed in.
    pub(crate) fn awkward_coordinate(rng: &mut crate::rng::Rng, k: usize) -> f32 {
        let scale = [1.0, 10.0, 300.0, 9.0e4][k % 4];
        let v = (rng.uniform() * 2.0 - 1.0) * scale;
        match (k / 4) % 7 {
            0 => -0.0,
            1 => v.floor(),
            2 => v.floor() - f32::EPSILON * v.abs(),
            _ => v,
        }
    }

    #[test]
    fn perlin3_is_cycles_perlin3_bit_for_bit() {
        // Cycles' `perlin_3d` written out: a hash per corner, its branching `grad3`, `lerp`s.
        let grad = |hash: u32, x: f32, y: f32, z: f32| {
            let h = hash & 15;
            let u = if h < 8 { x } else { y };
            let v = if h < 4 {
                y
            } else if h == 12 || h == 14 {
                x
            } else {
                z
            };
            negate_if(u, h & 1) + negate_if(v, h & 2)
        };
        let tri_mix = |v: [f32; 8], x: f32, y: f32, z: f32| {
            let (x1, y1, z1) = (1.0 - x, 1.0 - y, 1.0 - z);
            z1 * (y1 * (v[0] * x1 + v[1] * x) + y * (v[2] * x1 + v[3] * x))
                + z * (y1 * (v[4] * x1 + v[5] * x) + y * (v[6] * x1 + v[7] * x))
        };
        let mut rng = crate::rng::Rng::new(20);
        for k in 0..200_000 {
            let [x, y, z] = [k, k / 3, k / 5].map(|j| awkward_coordinate(&mut rng, j));
            let ((xi, fx), (yi, fy), (zi, fz)) = (floorfrac(x), floorfrac(y), floorfrac(z));
            let corners = [0, 1, 2, 3, 4, 5, 6, 7].map(|c: i32| {
                let (dx, dy, dz) = (c & 1, c >> 1 & 1, c >> 2);
                let h = super::hash::hash3(
                    xi.wrapping_add(dx) as u32,
                    yi.wrapping_add(dy) as u32,
                    zi.wrapping_add(dz) as u32,
                );
                grad(h, fx - dx as f32, fy - dy as f32, fz - dz as f32)
            });
            let want = tri_mix(corners, fade(fx), fade(fy), fade(fz));
            assert_eq!(perlin3(x, y, z).to_bits(), want.to_bits(), "{x} {y} {z}");
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_perlin3_is_perlin3_bit_for_bit() {
        if !has_avx2() {
            return;
        }
        let mut rng = crate::rng::Rng::new(21);
        for k in 0..200_000 {
            let [x, y, z] = [k, k / 3, k / 5].map(|j| awkward_coordinate(&mut rng, j));
            // SAFETY: AVX2 is present (checked above).
            let got = unsafe { noise_avx2::perlin3(x, y, z) };
            assert_eq!(got.to_bits(), perlin3(x, y, z).to_bits(), "{x} {y} {z}");
            let p = Vec3::new(x, y, z) * 37.0;
            let want = 0.9820 * perlin3(p.x % 100_000.0, p.y % 100_000.0, p.z % 100_000.0);
            if p.abs().max_element() < 100_000.0 {
                assert_eq!(snoise(3, p, 0.0).to_bits(), want.to_bits());
            }
            // fBm: the octaves inlined, past the period too.
            let f = Fractal {
                detail: [0.0, 2.0, 3.5, 15.0][k % 4],
                roughness: 0.5,
                lacunarity: [2.0, 1.9][k % 2],
                normalize: k % 3 == 0,
            };
            let m = |v: f32| {
                if v.abs() < 100_000.0 {
                    v
                } else if v.abs() < 1_000_000.0 {
                    v % 100_000.0
                } else {
                    v % 100_000.0 + 0.5
                }
            };
            let reference = fractal_sum(&f, 0.0, |s| {
                let q = s * p;
                0.9820 * perlin3(m(q.x), m(q.y), m(q.z))
            });
            assert_eq!(fbm(3, p, 0.0, &f).to_bits(), reference.to_bits(), "{p}");
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_octave_pairs_are_snoise3_lanes_bit_for_bit() {
        if !has_avx2() {
            return;
        }
        let mut rng = crate::rng::Rng::new(22);
        for k in 0..100_000 {
            let set = |rng: &mut crate::rng::Rng, j: usize| {
                let p = [j, j + 1, j + 2].map(|i| awkward_coordinate(rng, i));
                let step = [1e-4, 1e-2, 0.3][j % 3];
                let (x, y, z) = (
                    lanes([p[0], p[0] + step, p[0]]),
                    lanes([p[1], p[1], p[1] + step]),
                    Vec4::splat(p[2]),
                );
                (x, y, z)
            };
            let (a, b) = (set(&mut rng, k), set(&mut rng, k / 2 + 1));
            // SAFETY: AVX2 is present (checked above).
            let one = unsafe { noise_avx2::snoise3_one(a.0, a.1, a.2) };
            assert_eq!(
                one.to_array().map(f32::to_bits),
                snoise3_lanes(a.0, a.1, a.2).to_array().map(f32::to_bits)
            );
            // SAFETY: AVX2 is present (checked above).
            let got = unsafe { noise_avx2::snoise3_pair([a.0, b.0], [a.1, b.1], [a.2, b.2]) };
            for (g, (x, y, z)) in got.iter().zip([a, b]) {
                let want = snoise3_lanes(x, y, z);
                assert_eq!(
                    g.to_array().map(f32::to_bits),
                    want.to_array().map(f32::to_bits),
                    "{x} {y} {z}"
                );
            }
        }
        // The octaves in pairs sum as one at a time.
        for k in 0..20_000 {
            let f = Fractal {
                detail: [0.0, 1.0, 2.0, 2.5, 3.25, 15.0][k % 6],
                roughness: 0.5,
                lacunarity: [2.0, 1.7][k % 2],
                normalize: k % 3 == 0,
            };
            let p = [0, 1, 2].map(|j| awkward_coordinate(&mut rng, k + j) * 0.01);
            let (x, y, z) = (
                lanes([p[0], p[0] + 1e-4, p[0]]),
                Vec4::splat(p[1]),
                Vec4::splat(p[2]),
            );
            let want = fractal_sum(&f, Vec4::ZERO, |s| snoise3_lanes(s * x, s * y, s * z));
            assert_eq!(
                fbm3_lanes(x, y, z, &f).to_array().map(f32::to_bits),
                want.to_array().map(f32::to_bits)
            );
        }
    }
}
