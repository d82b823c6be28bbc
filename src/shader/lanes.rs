//! Lanes of floats and of 32-bit words, so that Perlin's gradients and interpolation and the
//! Voronoi search's cell points are written once for one value, four or eight: `Lanes` is a
//! float of one lane (`f32`), four (`Vec4`, one SSE register on x86-64) or eight (`F32x8`, one
//! AVX2 register, made only where the machine has AVX2), and `Words` its partner of 32-bit
//! words (`W`, `U32x4`, `U32x8`) on which Jenkins' lookup3 runs (`hash::HashWord`). Every lane
//! computes exactly the scalar operations, so the widths give the same values bit for bit.

use super::hash::{HashWord, W};
use crate::math::Vec4;
use std::ops::{Add, BitAnd, BitOr, BitXor, Mul, Sub};

/// Lanes of 32-bit words: lookup3's arithmetic and what Perlin's gradient reads of a hash.
pub(super) trait Words: HashWord + BitAnd<Output = Self> + BitOr<Output = Self> {
    /// How many lanes.
    const N: usize;
    fn splat(v: u32) -> Self;
    /// All ones in the lanes whose word, as a signed integer, is less than `v`, else zero.
    fn less_than(self, v: u32) -> Self;
    /// All ones in the lanes whose word is `v`, else zero.
    fn equals(self, v: u32) -> Self;
    /// Each lane shifted left by `N` bits.
    fn shifted_left<const N: i32>(self) -> Self;
    /// Bit k set where lane k's top bit is (where a mask's lane is all ones).
    fn bitmask(self) -> u32;
}

/// Lanes of floats, with their words (`Words`).
pub(super) trait Lanes:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Add<f32, Output = Self>
    + Sub<f32, Output = Self>
    + Mul<f32, Output = Self>
{
    type Words: Words;
    /// How many lanes.
    const N: usize;
    fn splat(v: f32) -> Self;
    /// The first `N` of eight floats, and back (the lanes past `N` zero).
    fn load(v: &[f32; 8]) -> Self;
    fn store(self) -> [f32; 8];
    /// Lane k is `table[picks[k]]` (`picks` from 0 to 3).
    fn lookup(table: [f32; 4], picks: &[i32; 8]) -> Self;
    fn sqrt(self) -> Self;
    /// The least lane (no lane NaN).
    fn least(self) -> f32;
    /// Masks of the lanes at most, above and equal to `v` (each false where a lane is NaN).
    fn at_most(self, v: f32) -> Self::Words;
    fn above(self, v: f32) -> Self::Words;
    fn equal(self, v: f32) -> Self::Words;
    /// `a` in the lanes where `mask` is all ones, `b` where it is zero.
    fn select(mask: Self::Words, a: Self, b: Self) -> Self;
    /// The lanes' bits xor `bits` (a flip of the sign where `bits` holds bit 31).
    fn xor_bits(self, bits: Self::Words) -> Self;
    /// The lanes' bits as words, and back.
    fn to_bits(self) -> Self::Words;
    /// `hash::unit` lane by lane: the word as a float, over 2³² − 1.
    fn unit(h: Self::Words) -> Self;
    /// `floor` lane by lane, exact for |v| < 2²² (larger lanes are left to the caller).
    fn floor(self) -> Self;
    /// Whether |v| < `limit` in every lane (false where a lane is NaN).
    fn all_below(self, limit: f32) -> bool;
    /// Whether each group of four lanes holds one value (the first lane's).
    fn uniform_quads(self) -> bool;
}

/// The operators, `HashWord` and `Words` of a type of words in one SIMD register, `$t(pub
/// reg)` of `$n` lanes, from its intrinsics (add, sub, xor, and, or, shift left, shift right,
/// splat, signed greater-than, equal, the float sign-bit mask and the cast to floats).
#[cfg(target_arch = "x86_64")]
macro_rules! simd_words {
    ($t:ident, $n:expr, $add:ident, $sub:ident, $xor:ident, $and:ident, $or:ident, $shl:ident,
     $shr:ident, $splat:ident, $gt:ident, $eq:ident, $movemask:ident, $cast:ident) => {
        $crate::shader::lanes::simd_words!(@op $t, Add, add, $add);
        $crate::shader::lanes::simd_words!(@op $t, Sub, sub, $sub);
        $crate::shader::lanes::simd_words!(@op $t, BitXor, bitxor, $xor);
        $crate::shader::lanes::simd_words!(@op $t, BitAnd, bitand, $and);
        $crate::shader::lanes::simd_words!(@op $t, BitOr, bitor, $or);

        impl $crate::shader::hash::HashWord for $t {
            #[inline(always)]
            fn rotl<const L: i32, const R: i32>(self) -> $t {
                // SAFETY: the type is made only where its instructions run (SSE2 is in every
                // x86-64; eight lanes only after the check for AVX2).
                unsafe { $t($or($shl::<L>(self.0), $shr::<R>(self.0))) }
            }
        }

        impl $crate::shader::lanes::Words for $t {
            const N: usize = $n;
            #[inline(always)]
            fn splat(v: u32) -> $t {
                // SAFETY: as `rotl`'s.
                unsafe { $t($splat(v as i32)) }
            }
            #[inline(always)]
            fn less_than(self, v: u32) -> $t {
                // SAFETY: as `rotl`'s.
                unsafe { $t($gt($splat(v as i32), self.0)) }
            }
            #[inline(always)]
            fn equals(self, v: u32) -> $t {
                // SAFETY: as `rotl`'s.
                unsafe { $t($eq(self.0, $splat(v as i32))) }
            }
            #[inline(always)]
            fn shifted_left<const N: i32>(self) -> $t {
                // SAFETY: as `rotl`'s.
                unsafe { $t($shl::<N>(self.0)) }
            }
            #[inline(always)]
            fn bitmask(self) -> u32 {
                // SAFETY: as `rotl`'s.
                unsafe { $movemask($cast(self.0)) as u32 }
            }
        }
    };
    (@op $t:ident, $trait:ident, $method:ident, $intrinsic:ident) => {
        impl std::ops::$trait for $t {
            type Output = $t;
            #[inline(always)]
            fn $method(self, o: $t) -> $t {
                // SAFETY: as `rotl`'s.
                unsafe { $t($intrinsic(self.0, o.0)) }
            }
        }
    };
}
#[cfg(target_arch = "x86_64")]
use simd_words;

impl Words for W {
    const N: usize = 1;
    #[inline(always)]
    fn splat(v: u32) -> W {
        W(v)
    }
    #[inline(always)]
    fn less_than(self, v: u32) -> W {
        W(((self.0 as i32) < v as i32) as u32).wrapping_neg_word()
    }
    #[inline(always)]
    fn equals(self, v: u32) -> W {
        W((self.0 == v) as u32).wrapping_neg_word()
    }
    #[inline(always)]
    fn shifted_left<const N: i32>(self) -> W {
        W(self.0 << N)
    }
    #[inline(always)]
    fn bitmask(self) -> u32 {
        self.0 >> 31
    }
}

impl W {
    /// 1 → all ones, 0 → 0.
    #[inline(always)]
    fn wrapping_neg_word(self) -> W {
        W(self.0.wrapping_neg())
    }
}

impl BitAnd for W {
    type Output = W;
    #[inline(always)]
    fn bitand(self, o: W) -> W {
        W(self.0 & o.0)
    }
}

impl BitOr for W {
    type Output = W;
    #[inline(always)]
    fn bitor(self, o: W) -> W {
        W(self.0 | o.0)
    }
}

impl Lanes for f32 {
    type Words = W;
    const N: usize = 1;
    #[inline(always)]
    fn splat(v: f32) -> f32 {
        v
    }
    #[inline(always)]
    fn load(v: &[f32; 8]) -> f32 {
        v[0]
    }
    #[inline(always)]
    fn store(self) -> [f32; 8] {
        [self, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    }
    #[inline(always)]
    fn lookup(table: [f32; 4], picks: &[i32; 8]) -> f32 {
        table[picks[0] as usize]
    }
    #[inline(always)]
    fn sqrt(self) -> f32 {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn least(self) -> f32 {
        self
    }
    #[inline(always)]
    fn at_most(self, v: f32) -> W {
        W((self <= v) as u32).wrapping_neg_word()
    }
    #[inline(always)]
    fn above(self, v: f32) -> W {
        W((self > v) as u32).wrapping_neg_word()
    }
    #[inline(always)]
    fn equal(self, v: f32) -> W {
        W((self == v) as u32).wrapping_neg_word()
    }
    #[inline(always)]
    fn select(mask: W, a: f32, b: f32) -> f32 {
        f32::from_bits((a.to_bits() & mask.0) | (b.to_bits() & !mask.0))
    }
    #[inline(always)]
    fn xor_bits(self, bits: W) -> f32 {
        f32::from_bits(self.to_bits() ^ bits.0)
    }
    #[inline(always)]
    fn to_bits(self) -> W {
        W(f32::to_bits(self))
    }
    #[inline(always)]
    fn unit(h: W) -> f32 {
        super::hash::unit(h.0)
    }
    #[inline(always)]
    fn floor(self) -> f32 {
        floor(self)
    }
    #[inline(always)]
    fn all_below(self, limit: f32) -> bool {
        self.abs() < limit
    }
    #[inline(always)]
    fn uniform_quads(self) -> bool {
        true
    }
}

#[cfg(target_arch = "x86_64")]
mod four {
    use crate::math::Vec4;
    use crate::shader::lanes::Lanes;
    use std::arch::x86_64::*;

    /// Four 32-bit words in one SSE2 register (SSE2 is part of every x86-64).
    #[derive(Clone, Copy, Debug)]
    pub struct U32x4(pub __m128i);

    impl U32x4 {
        #[inline(always)]
        pub fn new(v: [u32; 4]) -> U32x4 {
            // SAFETY: SSE2 is always present on x86-64; the load is unaligned.
            unsafe { U32x4(_mm_loadu_si128(v.as_ptr() as *const __m128i)) }
        }

        #[inline(always)]
        pub fn to_array(self) -> [u32; 4] {
            let mut out = [0u32; 4];
            // SAFETY: SSE2 is always present on x86-64; the store is unaligned.
            unsafe { _mm_storeu_si128(out.as_mut_ptr() as *mut __m128i, self.0) };
            out
        }
    }

    crate::shader::lanes::simd_words!(
        U32x4,
        4,
        _mm_add_epi32,
        _mm_sub_epi32,
        _mm_xor_si128,
        _mm_and_si128,
        _mm_or_si128,
        _mm_slli_epi32,
        _mm_srli_epi32,
        _mm_set1_epi32,
        _mm_cmpgt_epi32,
        _mm_cmpeq_epi32,
        _mm_movemask_ps,
        _mm_castsi128_ps
    );

    impl Lanes for Vec4 {
        type Words = U32x4;
        const N: usize = 4;
        #[inline(always)]
        fn splat(v: f32) -> Vec4 {
            Vec4::splat(v)
        }
        #[inline(always)]
        fn load(v: &[f32; 8]) -> Vec4 {
            Vec4::new(v[0], v[1], v[2], v[3])
        }
        #[inline(always)]
        fn store(self) -> [f32; 8] {
            let [a, b, c, d] = self.to_array();
            [a, b, c, d, 0.0, 0.0, 0.0, 0.0]
        }
        #[inline(always)]
        fn lookup(table: [f32; 4], picks: &[i32; 8]) -> Vec4 {
            Vec4::from_array([0, 1, 2, 3].map(|k| table[picks[k] as usize]))
        }
        #[inline(always)]
        fn sqrt(self) -> Vec4 {
            Vec4::sqrt(self)
        }
        #[inline(always)]
        fn least(self) -> f32 {
            self.min_element()
        }
        #[inline(always)]
        fn at_most(self, v: f32) -> U32x4 {
            // SAFETY: SSE2 is always present on x86-64.
            unsafe { U32x4(_mm_castps_si128(_mm_cmple_ps(self.into(), _mm_set1_ps(v)))) }
        }
        #[inline(always)]
        fn above(self, v: f32) -> U32x4 {
            // SAFETY: SSE2 is always present on x86-64.
            unsafe { U32x4(_mm_castps_si128(_mm_cmpgt_ps(self.into(), _mm_set1_ps(v)))) }
        }
        #[inline(always)]
        fn equal(self, v: f32) -> U32x4 {
            // SAFETY: SSE2 is always present on x86-64.
            unsafe { U32x4(_mm_castps_si128(_mm_cmpeq_ps(self.into(), _mm_set1_ps(v)))) }
        }
        #[inline(always)]
        fn select(mask: U32x4, a: Vec4, b: Vec4) -> Vec4 {
            // SAFETY: SSE2 is always present on x86-64.
            unsafe {
                let m = _mm_castsi128_ps(mask.0);
                let (a, b): (__m128, __m128) = (a.into(), b.into());
                Vec4::from(_mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b)))
            }
        }
        #[inline(always)]
        fn xor_bits(self, bits: U32x4) -> Vec4 {
            // SAFETY: SSE2 is always present on x86-64.
            unsafe { Vec4::from(_mm_xor_ps(self.into(), _mm_castsi128_ps(bits.0))) }
        }
        #[inline(always)]
        fn to_bits(self) -> U32x4 {
            // SAFETY: SSE2 is always present on x86-64.
            unsafe { U32x4(_mm_castps_si128(self.into())) }
        }
        #[inline(always)]
        fn unit(h: U32x4) -> Vec4 {
            Vec4::from_array(h.to_array().map(crate::shader::hash::unit))
        }
        #[inline(always)]
        fn floor(self) -> Vec4 {
            #[cfg(target_feature = "sse4.1")]
            // SAFETY: SSE4.1 is enabled for this build.
            unsafe {
                Vec4::from(_mm_floor_ps(self.into()))
            }
            #[cfg(not(target_feature = "sse4.1"))]
            crate::shader::lanes::floor_by_rounding(self)
        }
        #[inline(always)]
        fn all_below(self, limit: f32) -> bool {
            self.abs().cmplt(Vec4::splat(limit)).all()
        }
        #[inline(always)]
        fn uniform_quads(self) -> bool {
            self.cmpeq(Vec4::splat(self.x)).all()
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
mod four {
    use crate::math::Vec4;
    use crate::shader::lanes::{Lanes, Words};

    /// Four 32-bit words, lane by lane.
    #[derive(Clone, Copy, Debug)]
    pub struct U32x4([u32; 4]);

    impl U32x4 {
        pub fn new(v: [u32; 4]) -> U32x4 {
            U32x4(v)
        }

        pub fn to_array(self) -> [u32; 4] {
            self.0
        }

        fn zip(self, o: U32x4, f: impl Fn(u32, u32) -> u32) -> U32x4 {
            U32x4([0, 1, 2, 3].map(|k| f(self.0[k], o.0[k])))
        }

        fn each(self, f: impl Fn(u32) -> u32) -> U32x4 {
            U32x4(self.0.map(f))
        }
    }

    /// One operation lane by lane.
    macro_rules! lane_op {
        ($trait:ident, $method:ident, $f:expr) => {
            impl std::ops::$trait for U32x4 {
                type Output = U32x4;
                fn $method(self, o: U32x4) -> U32x4 {
                    self.zip(o, $f)
                }
            }
        };
    }
    lane_op!(Add, add, u32::wrapping_add);
    lane_op!(Sub, sub, u32::wrapping_sub);
    lane_op!(BitXor, bitxor, |a, b| a ^ b);
    lane_op!(BitAnd, bitand, |a, b| a & b);
    lane_op!(BitOr, bitor, |a, b| a | b);

    impl crate::shader::hash::HashWord for U32x4 {
        fn rotl<const L: i32, const R: i32>(self) -> U32x4 {
            self.each(|v| v.rotate_left(L as u32))
        }
    }

    impl Words for U32x4 {
        const N: usize = 4;
        fn splat(v: u32) -> U32x4 {
            U32x4([v; 4])
        }
        fn less_than(self, v: u32) -> U32x4 {
            self.each(|a| ((a as i32) < v as i32) as u32 * u32::MAX)
        }
        fn equals(self, v: u32) -> U32x4 {
            self.each(|a| (a == v) as u32 * u32::MAX)
        }
        fn shifted_left<const N: i32>(self) -> U32x4 {
            self.each(|a| a << N)
        }
        fn bitmask(self) -> u32 {
            (0..4).fold(0, |m, k| m | (self.0[k] >> 31) << k)
        }
    }

    impl Lanes for Vec4 {
        type Words = U32x4;
        const N: usize = 4;
        fn splat(v: f32) -> Vec4 {
            Vec4::splat(v)
        }
        fn load(v: &[f32; 8]) -> Vec4 {
            Vec4::new(v[0], v[1], v[2], v[3])
        }
        fn store(self) -> [f32; 8] {
            let [a, b, c, d] = self.to_array();
            [a, b, c, d, 0.0, 0.0, 0.0, 0.0]
        }
        fn lookup(table: [f32; 4], picks: &[i32; 8]) -> Vec4 {
            Vec4::from_array([0, 1, 2, 3].map(|k| table[picks[k] as usize]))
        }
        fn sqrt(self) -> Vec4 {
            Vec4::sqrt(self)
        }
        fn least(self) -> f32 {
            self.min_element()
        }
        fn at_most(self, v: f32) -> U32x4 {
            U32x4(self.to_array().map(|a| f32::at_most(a, v).0))
        }
        fn above(self, v: f32) -> U32x4 {
            U32x4(self.to_array().map(|a| f32::above(a, v).0))
        }
        fn equal(self, v: f32) -> U32x4 {
            U32x4(self.to_array().map(|a| f32::equal(a, v).0))
        }
        fn select(mask: U32x4, a: Vec4, b: Vec4) -> Vec4 {
            let (a, b) = (a.to_array(), b.to_array());
            Vec4::from_array(
                [0, 1, 2, 3].map(|k| f32::select(crate::shader::hash::W(mask.0[k]), a[k], b[k])),
            )
        }
        fn xor_bits(self, bits: U32x4) -> Vec4 {
            let v = self.to_array();
            Vec4::from_array([0, 1, 2, 3].map(|k| f32::from_bits(v[k].to_bits() ^ bits.0[k])))
        }
        fn to_bits(self) -> U32x4 {
            U32x4(self.to_array().map(f32::to_bits))
        }
        fn unit(h: U32x4) -> Vec4 {
            Vec4::from_array(h.0.map(crate::shader::hash::unit))
        }
        fn floor(self) -> Vec4 {
            crate::shader::lanes::floor_by_rounding(self)
        }
        fn all_below(self, limit: f32) -> bool {
            self.abs().cmplt(Vec4::splat(limit)).all()
        }
        fn uniform_quads(self) -> bool {
            self.cmpeq(Vec4::splat(self.x)).all()
        }
    }
}

pub(super) use four::U32x4;

/// Twice the lanes of `T` in two of them (`.0` the first half): eight lanes where the machine
/// has no AVX2, as two SSE registers.
#[derive(Clone, Copy)]
pub(super) struct Pair<T>(pub T, pub T);

/// An operation on both halves (with `f32`: of a float and each lane).
macro_rules! pair_op {
    ($trait:ident, $method:ident) => {
        impl<T: $trait<Output = T>> $trait for Pair<T> {
            type Output = Pair<T>;
            #[inline(always)]
            fn $method(self, o: Pair<T>) -> Pair<T> {
                Pair(self.0.$method(o.0), self.1.$method(o.1))
            }
        }
    };
    ($trait:ident, $method:ident, f32) => {
        pair_op!($trait, $method);
        impl<F: Lanes> $trait<f32> for Pair<F> {
            type Output = Pair<F>;
            #[inline(always)]
            fn $method(self, o: f32) -> Pair<F> {
                Pair(self.0.$method(o), self.1.$method(o))
            }
        }
    };
}
pair_op!(Add, add, f32);
pair_op!(Sub, sub, f32);
pair_op!(Mul, mul, f32);
pair_op!(BitAnd, bitand);
pair_op!(BitOr, bitor);
pair_op!(BitXor, bitxor);

impl<T: Words> HashWord for Pair<T> {
    #[inline(always)]
    fn rotl<const L: i32, const R: i32>(self) -> Pair<T> {
        Pair(self.0.rotl::<L, R>(), self.1.rotl::<L, R>())
    }
}

impl<T: Words> Words for Pair<T> {
    const N: usize = 2 * T::N;
    #[inline(always)]
    fn splat(v: u32) -> Pair<T> {
        Pair(T::splat(v), T::splat(v))
    }
    #[inline(always)]
    fn less_than(self, v: u32) -> Pair<T> {
        Pair(self.0.less_than(v), self.1.less_than(v))
    }
    #[inline(always)]
    fn equals(self, v: u32) -> Pair<T> {
        Pair(self.0.equals(v), self.1.equals(v))
    }
    #[inline(always)]
    fn shifted_left<const N: i32>(self) -> Pair<T> {
        Pair(self.0.shifted_left::<N>(), self.1.shifted_left::<N>())
    }
    #[inline(always)]
    fn bitmask(self) -> u32 {
        self.0.bitmask() | self.1.bitmask() << T::N
    }
}

impl<F: Lanes> Pair<F> {
    /// The second half's share of eight values, first.
    #[inline(always)]
    fn upper<T: Copy + Default>(v: &[T; 8]) -> [T; 8] {
        let mut out = [T::default(); 8];
        out[..8 - F::N].copy_from_slice(&v[F::N..]);
        out
    }
}

impl<F: Lanes> Lanes for Pair<F> {
    type Words = Pair<F::Words>;
    const N: usize = 2 * F::N;
    #[inline(always)]
    fn splat(v: f32) -> Pair<F> {
        Pair(F::splat(v), F::splat(v))
    }
    #[inline(always)]
    fn load(v: &[f32; 8]) -> Pair<F> {
        Pair(F::load(v), F::load(&Self::upper(v)))
    }
    #[inline(always)]
    fn store(self) -> [f32; 8] {
        let mut out = self.0.store();
        out[F::N..].copy_from_slice(&self.1.store()[..8 - F::N]);
        out
    }
    #[inline(always)]
    fn lookup(table: [f32; 4], picks: &[i32; 8]) -> Pair<F> {
        Pair(
            F::lookup(table, picks),
            F::lookup(table, &Self::upper(picks)),
        )
    }
    #[inline(always)]
    fn sqrt(self) -> Pair<F> {
        Pair(self.0.sqrt(), self.1.sqrt())
    }
    #[inline(always)]
    fn least(self) -> f32 {
        self.0.least().min(self.1.least())
    }
    #[inline(always)]
    fn at_most(self, v: f32) -> Pair<F::Words> {
        Pair(self.0.at_most(v), self.1.at_most(v))
    }
    #[inline(always)]
    fn above(self, v: f32) -> Pair<F::Words> {
        Pair(self.0.above(v), self.1.above(v))
    }
    #[inline(always)]
    fn equal(self, v: f32) -> Pair<F::Words> {
        Pair(self.0.equal(v), self.1.equal(v))
    }
    #[inline(always)]
    fn select(mask: Pair<F::Words>, a: Pair<F>, b: Pair<F>) -> Pair<F> {
        Pair(F::select(mask.0, a.0, b.0), F::select(mask.1, a.1, b.1))
    }
    #[inline(always)]
    fn xor_bits(self, bits: Pair<F::Words>) -> Pair<F> {
        Pair(self.0.xor_bits(bits.0), self.1.xor_bits(bits.1))
    }
    #[inline(always)]
    fn to_bits(self) -> Pair<F::Words> {
        Pair(self.0.to_bits(), self.1.to_bits())
    }
    #[inline(always)]
    fn unit(h: Pair<F::Words>) -> Pair<F> {
        Pair(F::unit(h.0), F::unit(h.1))
    }
    #[inline(always)]
    fn floor(self) -> Pair<F> {
        Pair(self.0.floor(), self.1.floor())
    }
    #[inline(always)]
    fn all_below(self, limit: f32) -> bool {
        self.0.all_below(limit) && self.1.all_below(limit)
    }
    #[inline(always)]
    fn uniform_quads(self) -> bool {
        self.0.uniform_quads() && self.1.uniform_quads()
    }
}

/// Eight lanes that hold a lattice cell's corners (lane dx + 2 dy + 4 dz), for Perlin noise
/// at one point: `F32x8`, or a `Pair` of `Vec4` (near face, far face).
pub(super) trait CornerLanes: Lanes {
    /// `b` in the lanes whose bit `BIT` is set, else `a`.
    fn by_bit<const BIT: usize>(a: f32, b: f32) -> Self;
    /// Each pair of neighbouring lanes' sum, in each group of four lanes
    /// (a0 + a1, a2 + a3, a0 + a1, a2 + a3).
    fn pair_sums(self) -> Self;
    /// Lanes 0 and 4.
    fn first_of_halves(self) -> [f32; 2];
}

impl CornerLanes for Pair<Vec4> {
    #[inline(always)]
    fn by_bit<const BIT: usize>(a: f32, b: f32) -> Pair<Vec4> {
        match BIT {
            0 => Pair(Vec4::new(a, b, a, b), Vec4::new(a, b, a, b)),
            1 => Pair(Vec4::new(a, a, b, b), Vec4::new(a, a, b, b)),
            _ => Pair(Vec4::splat(a), Vec4::splat(b)),
        }
    }
    #[inline(always)]
    fn pair_sums(self) -> Pair<Vec4> {
        let sums = |v: Vec4| {
            let (a, b) = (Vec4::new(v.x, v.z, v.x, v.z), Vec4::new(v.y, v.w, v.y, v.w));
            a + b
        };
        Pair(sums(self.0), sums(self.1))
    }
    #[inline(always)]
    fn first_of_halves(self) -> [f32; 2] {
        [self.0.x, self.1.x]
    }
}

/// `x.floor()` without the library call baseline x86-64 makes for it (bit for bit the same,
/// −0 and NaN included): beyond 2²³ every float is an integer.
pub(super) fn floor(x: f32) -> f32 {
    if !(x.abs() < 8_388_608.0) {
        return x;
    }
    let t = x as i32 as f32;
    if t > x {
        t - 1.0
    } else if t < x {
        t
    } else {
        x
    }
}

/// `floor` lane by lane for |v| < 2²² (the same values, −0 included): adding and taking
/// away 1.5 · 2²³ rounds to an integer.
#[allow(dead_code)]
#[inline(always)]
pub(super) fn floor_by_rounding(v: Vec4) -> Vec4 {
    const ROUND: f32 = 12_582_912.0;
    let t = (v + ROUND) - ROUND;
    Vec4::select(t.cmpgt(v), t - 1.0, Vec4::select(t.cmplt(v), t, v))
}

/// Eight lanes in one AVX2 register, for x86-64 machines that have AVX2: made only in code
/// that has checked for it (`hash::has_avx2`), into which these operations are forced inline
/// (which a `#[target_feature]` function cannot be).
#[cfg(target_arch = "x86_64")]
pub(super) mod eight {
    use crate::math::Vec4;
    use crate::shader::lanes::Lanes;
    use std::arch::x86_64::*;

    /// Eight 32-bit words.
    #[derive(Clone, Copy)]
    pub struct U32x8(pub __m256i);

    /// Eight floats.
    #[derive(Clone, Copy)]
    pub struct F32x8(pub __m256);

    impl F32x8 {
        /// Two sets of four lanes, `low` in lanes 0–3.
        #[inline(always)]
        pub fn join(low: Vec4, high: Vec4) -> F32x8 {
            // SAFETY: an F32x8 is made only where AVX2 is.
            unsafe { F32x8(_mm256_set_m128(high.into(), low.into())) }
        }

        /// Lanes 0–3 and 4–7.
        #[inline(always)]
        pub fn halves(self) -> [Vec4; 2] {
            // SAFETY: an F32x8 is made only where AVX2 is.
            unsafe {
                [
                    Vec4::from(_mm256_castps256_ps128(self.0)),
                    Vec4::from(_mm256_extractf128_ps::<1>(self.0)),
                ]
            }
        }
    }

    crate::shader::lanes::simd_words!(
        U32x8,
        8,
        _mm256_add_epi32,
        _mm256_sub_epi32,
        _mm256_xor_si256,
        _mm256_and_si256,
        _mm256_or_si256,
        _mm256_slli_epi32,
        _mm256_srli_epi32,
        _mm256_set1_epi32,
        _mm256_cmpgt_epi32,
        _mm256_cmpeq_epi32,
        _mm256_movemask_ps,
        _mm256_castsi256_ps
    );

    /// One AVX operation on two registers of floats, and on a register and a float.
    macro_rules! float_op {
        ($trait:ident, $method:ident, $intrinsic:ident) => {
            impl std::ops::$trait for F32x8 {
                type Output = F32x8;
                #[inline(always)]
                fn $method(self, o: F32x8) -> F32x8 {
                    // SAFETY: an F32x8 exists only where AVX2 does.
                    unsafe { F32x8($intrinsic(self.0, o.0)) }
                }
            }
            impl std::ops::$trait<f32> for F32x8 {
                type Output = F32x8;
                #[inline(always)]
                fn $method(self, o: f32) -> F32x8 {
                    // SAFETY: an F32x8 exists only where AVX2 does.
                    unsafe { F32x8($intrinsic(self.0, _mm256_set1_ps(o))) }
                }
            }
        };
    }
    float_op!(Add, add, _mm256_add_ps);
    float_op!(Sub, sub, _mm256_sub_ps);
    float_op!(Mul, mul, _mm256_mul_ps);

    impl F32x8 {
        /// A comparison of every lane with `v`.
        #[inline(always)]
        fn compare<const OP: i32>(self, v: f32) -> U32x8 {
            // SAFETY: an F32x8 exists only where AVX2 does.
            unsafe {
                U32x8(_mm256_castps_si256(_mm256_cmp_ps::<OP>(
                    self.0,
                    _mm256_set1_ps(v),
                )))
            }
        }
    }

    impl Lanes for F32x8 {
        type Words = U32x8;
        const N: usize = 8;
        #[inline(always)]
        fn splat(v: f32) -> F32x8 {
            // SAFETY: an F32x8 is made only where AVX2 is.
            unsafe { F32x8(_mm256_set1_ps(v)) }
        }
        #[inline(always)]
        fn load(v: &[f32; 8]) -> F32x8 {
            // SAFETY: an F32x8 is made only where AVX2 is; an unaligned load of eight floats.
            unsafe { F32x8(_mm256_loadu_ps(v.as_ptr())) }
        }
        #[inline(always)]
        fn store(self) -> [f32; 8] {
            let mut out = [0.0f32; 8];
            // SAFETY: an F32x8 exists only where AVX2 does; an unaligned store of eight floats.
            unsafe { _mm256_storeu_ps(out.as_mut_ptr(), self.0) };
            out
        }
        #[inline(always)]
        fn lookup(table: [f32; 4], picks: &[i32; 8]) -> F32x8 {
            // SAFETY: an F32x8 is made only where AVX2 is; an unaligned load of eight words.
            unsafe {
                let [a, b, c, d] = table;
                let table = _mm256_setr_ps(a, b, c, d, 0.0, 0.0, 0.0, 0.0);
                let picks = _mm256_loadu_si256(picks.as_ptr() as *const __m256i);
                F32x8(_mm256_permutevar8x32_ps(table, picks))
            }
        }
        #[inline(always)]
        fn sqrt(self) -> F32x8 {
            // SAFETY: an F32x8 exists only where AVX2 does.
            unsafe { F32x8(_mm256_sqrt_ps(self.0)) }
        }
        #[inline(always)]
        fn least(self) -> f32 {
            // SAFETY: an F32x8 exists only where AVX2 does.
            unsafe {
                let d = self.0;
                let m = _mm256_min_ps(d, _mm256_permute2f128_ps::<1>(d, d));
                let m = _mm256_min_ps(m, _mm256_permute_ps::<0b01_00_11_10>(m));
                let m = _mm256_min_ps(m, _mm256_permute_ps::<0b10_11_00_01>(m));
                _mm_cvtss_f32(_mm256_castps256_ps128(m))
            }
        }
        #[inline(always)]
        fn at_most(self, v: f32) -> U32x8 {
            self.compare::<_CMP_LE_OQ>(v)
        }
        #[inline(always)]
        fn above(self, v: f32) -> U32x8 {
            self.compare::<_CMP_GT_OQ>(v)
        }
        #[inline(always)]
        fn equal(self, v: f32) -> U32x8 {
            self.compare::<_CMP_EQ_OQ>(v)
        }
        #[inline(always)]
        fn select(mask: U32x8, a: F32x8, b: F32x8) -> F32x8 {
            // SAFETY: an F32x8 exists only where AVX2 does.
            unsafe { F32x8(_mm256_blendv_ps(b.0, a.0, _mm256_castsi256_ps(mask.0))) }
        }
        #[inline(always)]
        fn xor_bits(self, bits: U32x8) -> F32x8 {
            // SAFETY: an F32x8 exists only where AVX2 does.
            unsafe { F32x8(_mm256_xor_ps(self.0, _mm256_castsi256_ps(bits.0))) }
        }
        #[inline(always)]
        fn to_bits(self) -> U32x8 {
            // SAFETY: an F32x8 exists only where AVX2 does.
            unsafe { U32x8(_mm256_castps_si256(self.0)) }
        }
        /// `h as f32` exactly (its high and low 16 bits convert exactly, and their sum
        /// rounds once, to nearest even, as the conversion does), times 1 / (2³² − 1).
        #[inline(always)]
        fn unit(h: U32x8) -> F32x8 {
            // SAFETY: a U32x8 exists only where AVX2 does.
            unsafe {
                let hi = _mm256_cvtepi32_ps(_mm256_srli_epi32::<16>(h.0));
                let lo = _mm256_cvtepi32_ps(_mm256_and_si256(h.0, _mm256_set1_epi32(0xFFFF)));
                let f = _mm256_add_ps(_mm256_mul_ps(hi, _mm256_set1_ps(65536.0)), lo);
                F32x8(_mm256_mul_ps(f, _mm256_set1_ps(1.0 / 4_294_967_295.0)))
            }
        }
        #[inline(always)]
        fn floor(self) -> F32x8 {
            // SAFETY: an F32x8 exists only where AVX2 does.
            unsafe { F32x8(_mm256_floor_ps(self.0)) }
        }
        #[inline(always)]
        fn all_below(self, limit: f32) -> bool {
            // SAFETY: an F32x8 exists only where AVX2 does.
            unsafe {
                let abs = _mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0);
                let below = _mm256_cmp_ps::<_CMP_LT_OQ>(abs, _mm256_set1_ps(limit));
                _mm256_movemask_ps(below) == 0xFF
            }
        }
        #[inline(always)]
        fn uniform_quads(self) -> bool {
            // SAFETY: an F32x8 exists only where AVX2 does.
            unsafe {
                let first = _mm256_permute_ps::<0>(self.0);
                _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, first)) == 0xFF
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
impl CornerLanes for eight::F32x8 {
    #[inline(always)]
    fn by_bit<const BIT: usize>(a: f32, b: f32) -> eight::F32x8 {
        use std::arch::x86_64::*;
        // SAFETY: an F32x8 is made only where AVX2 is.
        unsafe {
            let (a, b) = (_mm256_set1_ps(a), _mm256_set1_ps(b));
            eight::F32x8(match BIT {
                0 => _mm256_blend_ps::<0xAA>(a, b),
                1 => _mm256_blend_ps::<0xCC>(a, b),
                _ => _mm256_blend_ps::<0xF0>(a, b),
            })
        }
    }
    #[inline(always)]
    fn pair_sums(self) -> eight::F32x8 {
        // SAFETY: an F32x8 exists only where AVX2 does.
        unsafe { eight::F32x8(std::arch::x86_64::_mm256_hadd_ps(self.0, self.0)) }
    }
    #[inline(always)]
    fn first_of_halves(self) -> [f32; 2] {
        let [a, b] = self.halves();
        [a.x, b.x]
    }
}

/// Perlin's 3D gradient of each lane's hash at that lane's offset (x, y, z), as Cycles'
/// `grad3` (u is x below 8, else y; v is y below 4, x at 12 and 14, else
/// z; their signs hash bits 0 and 1): selects and a flip of the sign bit, as the scalar code's
/// branches and negation.
#[inline(always)]
pub(super) fn grad3<F: Lanes>(hash: F::Words, x: F, y: F, z: F) -> F {
    let h = hash & F::Words::splat(15);
    let u = F::select(h.less_than(8), x, y);
    let v_is_x = h.equals(12) | h.equals(14);
    let v = F::select(h.less_than(4), y, F::select(v_is_x, x, z));
    let sign_u = (h & F::Words::splat(1)).shifted_left::<31>();
    let sign_v = (h & F::Words::splat(2)).shifted_left::<30>();
    u.xor_bits(sign_u) + v.xor_bits(sign_v)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cycles' grad3, with its branches.
    fn cycles_grad3(hash: u32, x: f32, y: f32, z: f32) -> f32 {
        let h = hash & 15;
        let u = if h < 8 { x } else { y };
        let v = if h < 4 {
            y
        } else if h == 12 || h == 14 {
            x
        } else {
            z
        };
        (if h & 1 != 0 { -u } else { u }) + (if h & 2 != 0 { -v } else { v })
    }

    #[test]
    fn gradients_are_cycles_grad3_at_every_width() {
        let (x, y, z) = (
            Vec4::new(0.25, -0.0, 1.5, -2.0),
            Vec4::new(-0.5, 0.75, 0.0, 3.0),
            Vec4::new(0.125, -1.0, -0.0, 0.5),
        );
        for h in 0..64u32 {
            let hashes = [h, h + 5, h * 7, h + 13];
            let got = grad3(U32x4::new(hashes), x, y, z).to_array();
            for (k, hash) in hashes.into_iter().enumerate() {
                let want = cycles_grad3(hash, x[k], y[k], z[k]);
                assert_eq!(got[k].to_bits(), want.to_bits(), "hash {hash}");
                let one = grad3(W(hash), x[k], y[k], z[k]);
                assert_eq!(one.to_bits(), want.to_bits(), "hash {hash}");
            }
            #[cfg(target_arch = "x86_64")]
            if crate::shader::hash::has_avx2() {
                use eight::{F32x8, U32x8};
                use std::arch::x86_64::*;
                let words = [hashes, hashes.map(|v| v ^ 9)].concat();
                // SAFETY: AVX2 is present (checked above); an unaligned load of eight words.
                let h8 = U32x8(unsafe { _mm256_loadu_si256(words.as_ptr() as *const __m256i) });
                let lanes = |v: Vec4| F32x8::join(v, v * -3.0);
                let got = grad3(h8, lanes(x), lanes(y), lanes(z)).halves();
                for (k, &hash) in words.iter().enumerate() {
                    let s = if k < 4 { 1.0 } else { -3.0 };
                    let (a, b, c) = (x[k % 4] * s, y[k % 4] * s, z[k % 4] * s);
                    let want = cycles_grad3(hash, a, b, c);
                    assert_eq!(got[k / 4][k % 4].to_bits(), want.to_bits(), "hash {hash}");
                }
            }
        }
    }

    #[test]
    fn floors_are_the_library_floor() {
        let mut rng = crate::rng::Rng::new(4);
        for _ in 0..20_000 {
            let v = Vec4::from_array([0; 4].map(|_| (rng.uniform() - 0.5) * 2e5));
            let v = Vec4::new(v.x, -0.0, v.z.floor(), v.w);
            let want = v.to_array().map(|x| x.floor().to_bits());
            assert_eq!(Lanes::floor(v).to_array().map(f32::to_bits), want);
            assert_eq!(floor_by_rounding(v).to_array().map(f32::to_bits), want);
        }
    }
}
