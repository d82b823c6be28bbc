//! Bob Jenkins' lookup3 hash (Jenkins, 2006, `lookup3.c`: its `mix` and `final` steps), the
//! hash Blender's procedural textures draw their lattice gradients and cell points from,
//! written once over `HashWord`: one word (`W`), or the four and eight lanes of `lanes`
//! (`U32x4`, `U32x8`), which hash Perlin noise's lattice corners and the Voronoi search's
//! cells several at a time. Every lane computes exactly the scalar hash.

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
    use crate::shader::lanes::{U32x4, Words};

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
        use crate::shader::lanes::eight::U32x8;
        let load =
            |v: &[u32; 8]| U32x8(unsafe { _mm256_loadu_si256(v.as_ptr() as *const __m256i) });
        let store = |v: U32x8| {
            let mut out = [0u32; 8];
            unsafe { _mm256_storeu_si256(out.as_mut_ptr() as *mut __m256i, v.0) };
            out
        };
        for _ in 0..10_000 {
            let v: [[u32; 8]; 3] = [[0; 8]; 3].map(|_| [0; 8].map(|_| word()));
            let [a, b, c] = [load(&v[0]), load(&v[1]), load(&v[2])];
            let (finished, (ma, mb, mc)) = (finish(a, b, c), mix(a, b, c));
            let (finished, mixed) = (store(finished), [store(ma), store(mb), store(mc)]);
            for k in 0..8 {
                let (a, b, c) = (W(v[0][k]), W(v[1][k]), W(v[2][k]));
                assert_eq!(finished[k], finish(a, b, c).0);
                let (sa, sb, sc) = mix(a, b, c);
                assert_eq!([mixed[0][k], mixed[1][k], mixed[2][k]], [sa.0, sb.0, sc.0]);
            }
        }
    }
}
