//! Bob Jenkins' lookup3 hash (Jenkins, 2006, `lookup3.c`: its `mix` and `final` steps), the
//! hash Blender's procedural textures draw their lattice gradients and cell points from, for
//! one value or for four at once. `U32x4` holds four lanes in one SSE2 register on x86-64
//! (plain arrays elsewhere): the compiler does not vectorise the hash's rotations by itself,
//! and Perlin noise's eight lattice corners and the Voronoi search's cells are hashed four at
//! a time. Every lane computes exactly the scalar hash. `U32x4::grad3` turns four corners'
//! hashes into Perlin's gradients the same way, lane by lane. `avx2` hashes eight lanes at
//! once where the machine has AVX2.

use std::ops::{Add, BitXor, Sub};

/// What lookup3's steps need of a word: wrapping add and subtract, xor and rotation.
pub trait HashWord: Copy + Add<Output = Self> + Sub<Output = Self> + BitXor<Output = Self> {
    /// `self` rotated left by `L` bits (`R` = 32 − `L`).
    fn rotl<const L: i32, const R: i32>(self) -> Self;
}

/// One 32-bit word with lookup3's wrapping arithmetic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct W(pub u32);

impl Add for W {
    type Output = W;
    #[inline(always)]
    fn add(self, o: W) -> W {
        W(self.0.wrapping_add(o.0))
    }
}

impl Sub for W {
    type Output = W;
    #[inline(always)]
    fn sub(self, o: W) -> W {
        W(self.0.wrapping_sub(o.0))
    }
}

impl BitXor for W {
    type Output = W;
    #[inline(always)]
    fn bitxor(self, o: W) -> W {
        W(self.0 ^ o.0)
    }
}

impl HashWord for W {
    #[inline(always)]
    fn rotl<const L: i32, const R: i32>(self) -> W {
        W(self.0.rotate_left(L as u32))
    }
}

/// Jenkins' lookup3 `mix` of (a, b, c).
#[inline(always)]
pub fn mix<T: HashWord>(mut a: T, mut b: T, mut c: T) -> (T, T, T) {
    a = a - c;
    a = a ^ c.rotl::<4, 28>();
    c = c + b;
    b = b - a;
    b = b ^ a.rotl::<6, 26>();
    a = a + c;
    c = c - b;
    c = c ^ b.rotl::<8, 24>();
    b = b + a;
    a = a - c;
    a = a ^ c.rotl::<16, 16>();
    c = c + b;
    b = b - a;
    b = b ^ a.rotl::<19, 13>();
    a = a + c;
    c = c - b;
    c = c ^ b.rotl::<4, 28>();
    b = b + a;
    (a, b, c)
}

/// Jenkins' lookup3 `final` of (a, b, c), returning c.
#[inline(always)]
pub fn finish<T: HashWord>(mut a: T, mut b: T, mut c: T) -> T {
    c = c ^ b;
    c = c - b.rotl::<14, 18>();
    a = a ^ c;
    a = a - c.rotl::<11, 21>();
    b = b ^ a;
    b = b - a.rotl::<25, 7>();
    c = c ^ b;
    c = c - b.rotl::<16, 16>();
    a = a ^ c;
    a = a - c.rotl::<4, 28>();
    b = b ^ a;
    b = b - a.rotl::<14, 18>();
    c = c ^ b;
    c - b.rotl::<24, 8>()
}

#[cfg(target_arch = "x86_64")]
mod lanes {
    use crate::math::Vec4;
    use std::arch::x86_64::*;

    /// Four 32-bit words in one SSE2 register (SSE2 is part of every x86-64).
    #[derive(Clone, Copy, Debug)]
    pub struct U32x4(__m128i);

    impl U32x4 {
        #[inline(always)]
        pub fn new(v: [u32; 4]) -> U32x4 {
            // SAFETY: SSE2 is always present on x86-64; the load is unaligned.
            unsafe { U32x4(_mm_loadu_si128(v.as_ptr() as *const __m128i)) }
        }

        #[inline(always)]
        pub fn splat(v: u32) -> U32x4 {
            // SAFETY: SSE2 is always present on x86-64.
            unsafe { U32x4(_mm_set1_epi32(v as i32)) }
        }

        #[inline(always)]
        pub fn to_array(self) -> [u32; 4] {
            let mut out = [0u32; 4];
            // SAFETY: SSE2 is always present on x86-64; the store is unaligned.
            unsafe { _mm_storeu_si128(out.as_mut_ptr() as *mut __m128i, self.0) };
            out
        }
    }

    impl std::ops::Add for U32x4 {
        type Output = U32x4;
        #[inline(always)]
        fn add(self, o: U32x4) -> U32x4 {
            // SAFETY: SSE2 is always present on x86-64.
            unsafe { U32x4(_mm_add_epi32(self.0, o.0)) }
        }
    }

    impl std::ops::Sub for U32x4 {
        type Output = U32x4;
        #[inline(always)]
        fn sub(self, o: U32x4) -> U32x4 {
            // SAFETY: SSE2 is always present on x86-64.
            unsafe { U32x4(_mm_sub_epi32(self.0, o.0)) }
        }
    }

    impl std::ops::BitXor for U32x4 {
        type Output = U32x4;
        #[inline(always)]
        fn bitxor(self, o: U32x4) -> U32x4 {
            // SAFETY: SSE2 is always present on x86-64.
            unsafe { U32x4(_mm_xor_si128(self.0, o.0)) }
        }
    }

    impl U32x4 {
        /// Perlin's 3D gradient (`super::GRAD3_AXES`, the signs hash bits 0 and 1) of each
        /// lane's hash at that lane's offset (x, y, z): masks and a flip of the sign bit, as
        /// the scalar code's selects and negation.
        #[inline(always)]
        pub fn grad3(self, x: Vec4, y: Vec4, z: Vec4) -> Vec4 {
            // SAFETY: SSE2 is always present on x86-64.
            unsafe {
                let h = _mm_and_si128(self.0, _mm_set1_epi32(15));
                let mask = |m: __m128i| _mm_castsi128_ps(m);
                let pick = |m: __m128, a: __m128, b: __m128| {
                    _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b))
                };
                let (x, y, z): (__m128, __m128, __m128) = (x.into(), y.into(), z.into());
                let below8 = mask(_mm_cmplt_epi32(h, _mm_set1_epi32(8)));
                let below4 = mask(_mm_cmplt_epi32(h, _mm_set1_epi32(4)));
                let v_is_x = mask(_mm_or_si128(
                    _mm_cmpeq_epi32(h, _mm_set1_epi32(12)),
                    _mm_cmpeq_epi32(h, _mm_set1_epi32(14)),
                ));
                let u = pick(below8, x, y);
                let v = pick(below4, y, pick(v_is_x, x, z));
                let sign_u = mask(_mm_slli_epi32::<31>(_mm_and_si128(h, _mm_set1_epi32(1))));
                let sign_v = mask(_mm_slli_epi32::<30>(_mm_and_si128(h, _mm_set1_epi32(2))));
                Vec4::from(_mm_add_ps(_mm_xor_ps(u, sign_u), _mm_xor_ps(v, sign_v)))
            }
        }
    }

    impl crate::shader::hash::HashWord for U32x4 {
        #[inline(always)]
        fn rotl<const L: i32, const R: i32>(self) -> U32x4 {
            // SAFETY: SSE2 is always present on x86-64.
            unsafe {
                U32x4(_mm_or_si128(
                    _mm_slli_epi32::<L>(self.0),
                    _mm_srli_epi32::<R>(self.0),
                ))
            }
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
mod lanes {
    use crate::math::Vec4;

    /// Four 32-bit words, lane by lane.
    #[derive(Clone, Copy, Debug)]
    pub struct U32x4([u32; 4]);

    impl U32x4 {
        pub fn new(v: [u32; 4]) -> U32x4 {
            U32x4(v)
        }

        pub fn splat(v: u32) -> U32x4 {
            U32x4([v; 4])
        }

        pub fn to_array(self) -> [u32; 4] {
            self.0
        }

        /// Perlin's 3D gradient (`super::GRAD3_AXES`, the signs hash bits 0 and 1) of each
        /// lane's hash at that lane's offset (x, y, z).
        pub fn grad3(self, x: Vec4, y: Vec4, z: Vec4) -> Vec4 {
            let (x, y, z) = (x.to_array(), y.to_array(), z.to_array());
            Vec4::from_array([0, 1, 2, 3].map(|k| {
                let h = self.0[k] & 15;
                let [a, b] = crate::shader::hash::GRAD3_AXES[h as usize];
                let axis = [x[k], y[k], z[k]];
                let flip = |v: f32, bit: u32| f32::from_bits(v.to_bits() ^ (bit << 31));
                flip(axis[a], h & 1) + flip(axis[b], (h >> 1) & 1)
            }))
        }

        fn zip(self, o: U32x4, f: impl Fn(u32, u32) -> u32) -> U32x4 {
            U32x4([0, 1, 2, 3].map(|k| f(self.0[k], o.0[k])))
        }
    }

    impl std::ops::Add for U32x4 {
        type Output = U32x4;
        fn add(self, o: U32x4) -> U32x4 {
            self.zip(o, u32::wrapping_add)
        }
    }

    impl std::ops::Sub for U32x4 {
        type Output = U32x4;
        fn sub(self, o: U32x4) -> U32x4 {
            self.zip(o, u32::wrapping_sub)
        }
    }

    impl std::ops::BitXor for U32x4 {
        type Output = U32x4;
        fn bitxor(self, o: U32x4) -> U32x4 {
            self.zip(o, |a, b| a ^ b)
        }
    }

    impl crate::shader::hash::HashWord for U32x4 {
        fn rotl<const L: i32, const R: i32>(self) -> U32x4 {
            U32x4(self.0.map(|v| v.rotate_left(L as u32)))
        }
    }
}

pub use lanes::U32x4;

/// lookup3's `mix` and `final` on eight words at once in one AVX2 register, for x86-64
/// machines that have AVX2 (the callers check `is_x86_feature_detected!("avx2")` and keep the
/// four-lane code otherwise): every lane computes exactly the scalar hash. They are forced
/// inline (which a `#[target_feature]` function cannot be) into the callers' AVX2 code.
#[cfg(target_arch = "x86_64")]
pub mod avx2 {
    use std::arch::x86_64::*;

    /// Eight words; made only by `mix` and `finish`, whose callers have checked for AVX2.
    #[derive(Clone, Copy)]
    struct U32x8(__m256i);

    impl std::ops::Add for U32x8 {
        type Output = U32x8;
        #[inline(always)]
        fn add(self, o: U32x8) -> U32x8 {
            // SAFETY: a U32x8 exists only where AVX2 does.
            unsafe { U32x8(_mm256_add_epi32(self.0, o.0)) }
        }
    }

    impl std::ops::Sub for U32x8 {
        type Output = U32x8;
        #[inline(always)]
        fn sub(self, o: U32x8) -> U32x8 {
            // SAFETY: a U32x8 exists only where AVX2 does.
            unsafe { U32x8(_mm256_sub_epi32(self.0, o.0)) }
        }
    }

    impl std::ops::BitXor for U32x8 {
        type Output = U32x8;
        #[inline(always)]
        fn bitxor(self, o: U32x8) -> U32x8 {
            // SAFETY: a U32x8 exists only where AVX2 does.
            unsafe { U32x8(_mm256_xor_si256(self.0, o.0)) }
        }
    }

    impl crate::shader::hash::HashWord for U32x8 {
        #[inline(always)]
        fn rotl<const L: i32, const R: i32>(self) -> U32x8 {
            // SAFETY: a U32x8 exists only where AVX2 does.
            unsafe {
                U32x8(_mm256_or_si256(
                    _mm256_slli_epi32::<L>(self.0),
                    _mm256_srli_epi32::<R>(self.0),
                ))
            }
        }
    }

    /// `super::mix` lane by lane.
    ///
    /// # Safety
    /// The machine must have AVX2.
    #[inline(always)]
    pub unsafe fn mix(a: __m256i, b: __m256i, c: __m256i) -> (__m256i, __m256i, __m256i) {
        let (a, b, c) = crate::shader::hash::mix(U32x8(a), U32x8(b), U32x8(c));
        (a.0, b.0, c.0)
    }

    /// `super::finish` lane by lane.
    ///
    /// # Safety
    /// The machine must have AVX2.
    #[inline(always)]
    pub unsafe fn finish(a: __m256i, b: __m256i, c: __m256i) -> __m256i {
        crate::shader::hash::finish(U32x8(a), U32x8(b), U32x8(c)).0
    }
}

/// The axes (0 x, 1 y, 2 z) of the two components Perlin's 3D gradient of hash `h & 15`
/// adds (Cycles' `grad3`: u is x below 8, else y; v is y below 4, x at 12 and 14, else z).
pub const GRAD3_AXES: [[usize; 2]; 16] = {
    let mut axes = [[0; 2]; 16];
    let mut h = 0;
    while h < 16 {
        let u = if h < 8 { 0 } else { 1 };
        let v = if h < 4 {
            1
        } else if h == 12 || h == 14 {
            0
        } else {
            2
        };
        axes[h] = [u, v];
        h += 1;
    }
    axes
};

// ----- the hashes of Blender's procedural textures ------------------------------------------

/// Jenkins' lookup3 `final` mix of (a, b, c), returning c.
#[inline(always)]
pub(super) fn lookup3_final(a: u32, b: u32, c: u32) -> u32 {
    finish(W(a), W(b), W(c)).0
}

pub(super) const LOOKUP3_SEED: u32 = 0xdead_beef;

pub(super) fn hash1(x: u32) -> u32 {
    let s = LOOKUP3_SEED.wrapping_add((1 << 2) + 13);
    lookup3_final(s.wrapping_add(x), s, s)
}

pub(super) fn hash2(x: u32, y: u32) -> u32 {
    let s = LOOKUP3_SEED.wrapping_add((2 << 2) + 13);
    lookup3_final(s.wrapping_add(x), s.wrapping_add(y), s)
}

pub(super) fn hash3(x: u32, y: u32, z: u32) -> u32 {
    let s = LOOKUP3_SEED.wrapping_add((3 << 2) + 13);
    lookup3_final(s.wrapping_add(x), s.wrapping_add(y), s.wrapping_add(z))
}

/// `hash_float2_to_float`: the hash of two floats' bits mapped to [0, 1].
pub(super) fn hash_float2(x: f32, y: f32) -> f32 {
    hash2(x.to_bits(), y.to_bits()) as f32 * (1.0 / 4_294_967_295.0)
}

pub(super) fn hash_float(x: f32) -> f32 {
    hash1(x.to_bits()) as f32 * (1.0 / 4_294_967_295.0)
}

/// Jenkins' lookup3 `mix` of (a, b, c).
#[inline(always)]
pub(super) fn lookup3_mix(a: u32, b: u32, c: u32) -> (u32, u32, u32) {
    let (a, b, c) = mix(W(a), W(b), W(c));
    (a.0, b.0, c.0)
}

pub(super) fn hash4(x: u32, y: u32, z: u32, w: u32) -> u32 {
    let s = LOOKUP3_SEED.wrapping_add((4 << 2) + 13);
    let (a, b, c) = lookup3_mix(s.wrapping_add(x), s.wrapping_add(y), s.wrapping_add(z));
    lookup3_final(a.wrapping_add(w), b, c)
}

pub(super) fn unit(h: u32) -> f32 {
    h as f32 * (1.0 / 4_294_967_295.0)
}

/// Whether this machine has AVX2, for the eight-lane noise and Voronoi kernels (the
/// detection is cached by the standard library).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) fn has_avx2() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec4;

    #[test]
    fn four_lanes_hash_as_four_words() {
        let mut rng = crate::rng::Rng::new(3);
        let mut word =
            || (rng.uniform() * 4_294_967_295.0) as u32 ^ (rng.uniform() * 65536.0) as u32;
        for _ in 0..10_000 {
            let v: [[u32; 4]; 3] = [[0; 4]; 3].map(|_| [0; 4].map(|_| word()));
            let [a, b, c] = v.map(U32x4::new);
            let lanes = finish(a, b, c).to_array();
            let (ma, mb, mc) = mix(a, b, c);
            let mixed = [ma.to_array(), mb.to_array(), mc.to_array()];
            for k in 0..4 {
                let (a, b, c) = (W(v[0][k]), W(v[1][k]), W(v[2][k]));
                assert_eq!(lanes[k], finish(a, b, c).0);
                let (sa, sb, sc) = mix(a, b, c);
                assert_eq!([mixed[0][k], mixed[1][k], mixed[2][k]], [sa.0, sb.0, sc.0]);
            }
        }
        assert_eq!(U32x4::splat(7).to_array(), [7; 4]);
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn eight_lanes_hash_as_eight_words() {
        use std::arch::x86_64::*;
        if !is_x86_feature_detected!("avx2") {
            return;
        }
        let mut rng = crate::rng::Rng::new(5);
        let mut word =
            || (rng.uniform() * 4_294_967_295.0) as u32 ^ (rng.uniform() * 65536.0) as u32;
        let load = |v: &[u32; 8]| unsafe { _mm256_loadu_si256(v.as_ptr() as *const __m256i) };
        let store = |v: __m256i| {
            let mut out = [0u32; 8];
            unsafe { _mm256_storeu_si256(out.as_mut_ptr() as *mut __m256i, v) };
            out
        };
        for _ in 0..10_000 {
            let v: [[u32; 8]; 3] = [[0; 8]; 3].map(|_| [0; 8].map(|_| word()));
            let [a, b, c] = [load(&v[0]), load(&v[1]), load(&v[2])];
            // SAFETY: AVX2 is present (checked above).
            let (finished, (ma, mb, mc)) = unsafe { (avx2::finish(a, b, c), avx2::mix(a, b, c)) };
            let (finished, mixed) = (store(finished), [store(ma), store(mb), store(mc)]);
            for k in 0..8 {
                let (a, b, c) = (W(v[0][k]), W(v[1][k]), W(v[2][k]));
                assert_eq!(finished[k], finish(a, b, c).0);
                let (sa, sb, sc) = mix(a, b, c);
                assert_eq!([mixed[0][k], mixed[1][k], mixed[2][k]], [sa.0, sb.0, sc.0]);
            }
        }
    }

    #[test]
    fn four_lanes_gradients_as_cycles_grad3() {
        let (x, y, z) = (
            Vec4::new(0.25, -0.0, 1.5, -2.0),
            Vec4::new(-0.5, 0.75, 0.0, 3.0),
            Vec4::new(0.125, -1.0, -0.0, 0.5),
        );
        for h in 0..64u32 {
            let lanes = U32x4::new([h, h + 5, h * 7, h + 13]);
            let got = lanes.grad3(x, y, z).to_array();
            for (k, hash) in lanes.to_array().into_iter().enumerate() {
                // Cycles' grad3, with its branches.
                let h = hash & 15;
                let (px, py, pz) = (x[k], y[k], z[k]);
                let u = if h < 8 { px } else { py };
                let v = if h < 4 {
                    py
                } else if h == 12 || h == 14 {
                    px
                } else {
                    pz
                };
                let want = (if h & 1 != 0 { -u } else { u }) + (if h & 2 != 0 { -v } else { v });
                assert_eq!(got[k].to_bits(), want.to_bits(), "hash {hash}");
            }
        }
    }
}
