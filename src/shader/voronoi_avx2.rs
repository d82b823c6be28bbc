//! The Voronoi F1 search in 3D with the Euclidean metric on AVX2 (x86-64 machines that have
//! it; the caller checks): `nearest_point_euclidean_3d`'s result bit for bit. The 2 × 2 × 2
//! cells on `local`'s nearer side along each axis are searched first, eight at once; then the
//! box of each of the other cells is tested against the best distance so far, all at once,
//! and those within it searched eight at a time. The nearest point is the least (distance,
//! Cycles' index) over the searched cells, so the order of the search does not matter.

use super::hash::avx2 as hash;
use super::hash::LOOKUP3_SEED;
use crate::math::Vec3;
use std::arch::x86_64::*;

const SEED3: i32 = LOOKUP3_SEED.wrapping_add((3 << 2) + 13) as i32;
const SEED4: i32 = LOOKUP3_SEED.wrapping_add((4 << 2) + 13) as i32;

/// The offset of the cell of Cycles' index `i` (z outermost, x innermost).
const OFFSETS: [[f32; 3]; 27] = {
    let mut o = [[0.0; 3]; 27];
    let mut i = 0;
    while i < 27 {
        o[i] = [
            (i % 3) as f32 - 1.0,
            ((i / 3) % 3) as f32 - 1.0,
            (i / 9) as f32 - 1.0,
        ];
        i += 1;
    }
    o
};

/// For each side of the home cell's centre `local` is on (bit a set where it is at least
/// ½ along axis a): the Cycles indices of the 2 × 2 × 2 cells on that side (lane
/// dx + 2 dy + 4 dz) and their set.
const BLOCKS: [([usize; 8], u32); 8] = {
    let mut blocks = [([0; 8], 0); 8];
    let mut sides = 0;
    while sides < 8 {
        // The sign of each axis' step: 2 · bit − 1.
        let (ix, iy, iz) = (
            2 * (sides & 1) as isize - 1,
            3 * (2 * ((sides >> 1) & 1) as isize - 1),
            9 * (2 * (sides >> 2) as isize - 1),
        );
        let mut lane = 0;
        while lane < 8 {
            let d = (lane & 1) as isize * ix
                + ((lane >> 1) & 1) as isize * iy
                + (lane >> 2) as isize * iz;
            let index = (13 + d) as usize;
            blocks[sides].0[lane] = index;
            blocks[sides].1 |= 1 << index;
            lane += 1;
        }
        sides += 1;
    }
    blocks
};

/// For group g and each axis, which of the box gaps (offset + 1) the cell of index
/// 8 g + lane reads (3: none, for the five lanes past the 27 cells).
const GAP_PICKS: [[[i32; 8]; 3]; 4] = {
    let mut picks = [[[3; 8]; 3]; 4];
    let mut i = 0;
    while i < 27 {
        picks[i / 8][0][i % 8] = (i % 3) as i32;
        picks[i / 8][1][i % 8] = ((i / 3) % 3) as i32;
        picks[i / 8][2][i % 8] = (i / 9) as i32;
        i += 1;
    }
    picks
};

/// `unit` lane by lane: `h as f32` exactly (its high and low 16 bits convert exactly, and
/// their sum rounds once, to nearest even, as the conversion does), times 1 / (2³² − 1).
#[target_feature(enable = "avx2")]
#[inline]
fn unit(h: __m256i) -> __m256 {
    let hi = _mm256_cvtepi32_ps(_mm256_srli_epi32::<16>(h));
    let lo = _mm256_cvtepi32_ps(_mm256_and_si256(h, _mm256_set1_epi32(0xFFFF)));
    let f = _mm256_add_ps(_mm256_mul_ps(hi, _mm256_set1_ps(65536.0)), lo);
    _mm256_mul_ps(f, _mm256_set1_ps(1.0 / 4_294_967_295.0))
}

/// `super::cell_points4` on eight cells.
#[target_feature(enable = "avx2")]
#[inline]
fn cell_points8(x: __m256, y: __m256, z: __m256) -> [__m256; 3] {
    let (x, y, z) = (
        _mm256_castps_si256(x),
        _mm256_castps_si256(y),
        _mm256_castps_si256(z),
    );
    let add = _mm256_add_epi32;
    let s3 = _mm256_set1_epi32(SEED3);
    let s4 = _mm256_set1_epi32(SEED4);
    let w = |v: f32| _mm256_set1_epi32(v.to_bits() as i32);
    // SAFETY: this function runs only with AVX2.
    let (first, second, third) = unsafe {
        let first = hash::finish(add(x, s3), add(y, s3), add(z, s3));
        // hash4(x, y, z, w) for w = 1.0 and 2.0 share their first mix.
        let (a, b, c) = hash::mix(add(x, s4), add(y, s4), add(z, s4));
        (
            first,
            hash::finish(add(a, w(1.0)), b, c),
            hash::finish(add(a, w(2.0)), b, c),
        )
    };
    [unit(first), unit(second), unit(third)]
}

/// `super::nearest_of_four` on eight cells: Cycles' indices and offsets as lanes.
#[target_feature(enable = "avx2")]
#[inline]
fn nearest_of_eight(
    index: &[usize; 8],
    offset: [__m256; 3],
    cell: Vec3,
    local: Vec3,
    randomness: f32,
    nearest: &mut (f32, usize, Vec3, Vec3),
) {
    let s = _mm256_set1_ps;
    let (add, sub, mul) = (_mm256_add_ps, _mm256_sub_ps, _mm256_mul_ps);
    let [ox, oy, oz] = offset;
    let [hx, hy, hz] = cell_points8(add(ox, s(cell.x)), add(oy, s(cell.y)), add(oz, s(cell.z)));
    let r = s(randomness);
    let (px, py, pz) = (
        add(ox, mul(hx, r)),
        add(oy, mul(hy, r)),
        add(oz, mul(hz, r)),
    );
    let (dx, dy, dz) = (
        sub(px, s(local.x)),
        sub(py, s(local.y)),
        sub(pz, s(local.z)),
    );
    let d = _mm256_sqrt_ps(add(add(mul(dx, dx), mul(dy, dy)), mul(dz, dz)));
    let within = _mm256_cmp_ps::<_CMP_LE_OQ>(d, s(nearest.0));
    let hits = _mm256_movemask_ps(within) as u32;
    if hits == 0 {
        return;
    }
    // The least distance among the lanes not farther than the best (NaN never is), then
    // the least index among its lanes: the rule below applied lane by lane in any order
    // keeps the least (distance, index).
    let d = _mm256_blendv_ps(s(f32::INFINITY), d, within);
    let m = _mm256_min_ps(d, _mm256_permute2f128_ps::<1>(d, d));
    let m = _mm256_min_ps(m, _mm256_permute_ps::<0b01_00_11_10>(m));
    let m = _mm256_min_ps(m, _mm256_permute_ps::<0b10_11_00_01>(m));
    let least = _mm_cvtss_f32(_mm256_castps256_ps128(m));
    let mut ties = hits & _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(d, m)) as u32;
    let mut k = ties.trailing_zeros() as usize;
    ties &= ties - 1;
    while ties != 0 {
        let j = ties.trailing_zeros() as usize;
        ties &= ties - 1;
        if index[j] < index[k] {
            k = j;
        }
    }
    if least < nearest.0 || (least == nearest.0 && index[k] < nearest.1) {
        let store = |v: __m256| {
            let mut out = [0.0f32; 8];
            // SAFETY: an unaligned store of eight floats into eight floats.
            unsafe { _mm256_storeu_ps(out.as_mut_ptr(), v) };
            out
        };
        let (px, py, pz) = (store(px), store(py), store(pz));
        let o = OFFSETS[index[k]];
        *nearest = (
            least,
            index[k],
            Vec3::new(o[0], o[1], o[2]),
            Vec3::new(px[k], py[k], pz[k]),
        );
    }
}

/// See the module's header; `gap2` as `super::nearest_point_euclidean_3d` takes it.
#[target_feature(enable = "avx2")]
pub fn nearest_point_euclidean_3d(
    cell: Vec3,
    local: Vec3,
    randomness: f32,
    gap2: &[[f32; 3]; 3],
) -> (f32, Vec3, Vec3) {
    let mut nearest = (f32::MAX, usize::MAX, Vec3::ZERO, Vec3::ZERO);
    let up = |l: f32| !(l < 0.5);
    let sides = up(local.x) as usize | (up(local.y) as usize) << 1 | (up(local.z) as usize) << 2;
    let side = |a: usize| _mm256_set1_ps(if sides >> a & 1 != 0 { 1.0 } else { -1.0 });
    // Lane dx + 2 dy + 4 dz: offset (dx sx, dy sy, dz sz), each zero a +0.
    let zero = _mm256_setzero_ps();
    let block = [
        _mm256_blend_ps::<0xAA>(zero, side(0)),
        _mm256_blend_ps::<0xCC>(zero, side(1)),
        _mm256_blend_ps::<0xF0>(zero, side(2)),
    ];
    let (index, done) = &BLOCKS[sides];
    nearest_of_eight(index, block, cell, local, randomness, &mut nearest);
    // The other cells whose box lies within the bound (squared, without the root: its
    // margin covers the rounding), as `super::nearest_point_euclidean_3d` tests them.
    let bound = nearest.0 * (1.0 + 1e-6);
    let far = _mm256_set1_ps(bound * bound);
    let axis = |g: &[f32; 3]| _mm256_setr_ps(g[0], g[1], g[2], f32::MAX, 0.0, 0.0, 0.0, 0.0);
    let (g0, g1, g2) = (axis(&gap2[0]), axis(&gap2[1]), axis(&gap2[2]));
    let mut within = 0u32;
    for (group, picks) in GAP_PICKS.iter().enumerate() {
        let pick = |g: __m256, axis: usize| {
            // SAFETY: an unaligned load of eight words from eight words.
            let i = unsafe { _mm256_loadu_si256(picks[axis].as_ptr() as *const __m256i) };
            _mm256_permutevar8x32_ps(g, i)
        };
        let sum = _mm256_add_ps(_mm256_add_ps(pick(g0, 0), pick(g1, 1)), pick(g2, 2));
        // Not farther: as the test that skips a cell, NaN included.
        let near = _mm256_cmp_ps::<_CMP_NGT_UQ>(sum, far);
        within |= (_mm256_movemask_ps(near) as u32) << (8 * group);
    }
    let mut left = within & !*done & ((1 << 27) - 1);
    while left != 0 {
        let mut index = [0usize; 8];
        let mut offsets = [[0.0f32; 8]; 3];
        let mut n = 0;
        while left != 0 && n < 8 {
            let i = left.trailing_zeros() as usize;
            left &= left - 1;
            index[n] = i;
            for (lane, o) in offsets.iter_mut().zip(OFFSETS[i]) {
                lane[n] = o;
            }
            n += 1;
        }
        // The empty lanes repeat the batch's first cell (a tie with itself: no change).
        for k in n..8 {
            index[k] = index[0];
            for lane in &mut offsets {
                lane[k] = lane[0];
            }
        }
        // SAFETY: unaligned loads of eight floats from eight floats.
        let lanes = offsets.map(|o| unsafe { _mm256_loadu_ps(o.as_ptr()) });
        nearest_of_eight(&index, lanes, cell, local, randomness, &mut nearest);
    }
    (nearest.0, nearest.2, nearest.3)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::hash::has_avx2;
    use crate::shader::noise::floor;
    use crate::shader::noise::tests::awkward_coordinate;
    use crate::shader::voronoi::nearest_point_euclidean_3d_lanes4;
    use crate::shader::voronoi_avx2;

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_voronoi_search_is_the_four_lane_search_bit_for_bit() {
        if !has_avx2() {
            return;
        }
        let mut rng = crate::rng::Rng::new(23);
        for k in 0..200_000 {
            let coord =
                Vec3::from_array([k, k / 3, k / 5].map(|j| awkward_coordinate(&mut rng, j)));
            let randomness = [1.0, 0.5, 0.0, 0.93, 1e-3][k % 5];
            let cell = Vec3::new(floor(coord.x), floor(coord.y), floor(coord.z));
            let local = coord - cell;
            let gap2 = [local.x, local.y, local.z].map(|l| {
                [-1.0f32, 0.0, 1.0].map(|o| {
                    let g = (o - l).max(l - (o + randomness)).max(0.0);
                    g * g
                })
            });
            // SAFETY: AVX2 is present (checked above).
            let got =
                unsafe { voronoi_avx2::nearest_point_euclidean_3d(cell, local, randomness, &gap2) };
            let want = nearest_point_euclidean_3d_lanes4(cell, local, randomness, &gap2);
            let bits = |(d, o, p): (f32, Vec3, Vec3)| {
                (
                    d.to_bits(),
                    o.to_array().map(f32::to_bits),
                    p.to_array().map(f32::to_bits),
                )
            };
            assert_eq!(bits(got), bits(want), "{coord} {randomness}");
        }
    }
}
