//! The Voronoi Texture (Worley's cellular texture, Worley 1996) as Blender defines it (Cycles'
//! `voronoi.h`: F1, F2 and Smooth F1 over 2D and 3D cells, four metrics, fractal octaves), cell
//! points hashed as the file's Blender version hashes them (`CellHash`): Blender 4 from the bits
//! of the cell's float coordinates by Jenkins' lookup3 (`hash`), Blender 5 from its integer
//! coordinates by the PCG hashes of Jarzynski & Olano 2020 ("Hash Functions for GPU
//! Rendering"), kept to signed 31-bit results. The F1 search visits cells nearest first and
//! skips those that cannot hold a nearer point; in 3D with the Euclidean metric and lookup3
//! several cells at a time, the search written once over `lanes::Lanes` and run on four lanes,
//! or eight with AVX2, with the same result bit for bit.

use super::hash::{self, has_avx2, hash2, hash3, unit, LOOKUP3_SEED};
use super::inputs::{input, splat, v3, Operands, Socket, Ty};
use super::lanes::{floor, Lanes, Words};
use super::math::smoothstep;
use super::noise::lerp;
use crate::math::{Vec3, Vec4};

/// The Voronoi node's inputs.
pub(super) const VORONOI_INPUTS: &[Socket] = &[
    Socket::vector("Vector", Vec4::ZERO),
    Socket::float("W", 0.0),
    Socket::float("Scale", 5.0),
    Socket::float("Detail", 0.0),
    Socket::float("Roughness", 0.5),
    Socket::float("Lacunarity", 2.0),
    Socket::float("Smoothness", 1.0),
    Socket::float("Exponent", 0.5),
    Socket::float("Randomness", 1.0),
];

/// The Voronoi node's outputs.
pub(super) const VORONOI_OUTPUTS: &[Socket] = &[
    Socket::output("Distance", Ty::Float),
    Socket::output("Color", Ty::Color),
    Socket::output("Position", Ty::Vector),
];

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum VoronoiFeature {
    F1,
    F2,
    SmoothF1,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Metric {
    Euclidean,
    Manhattan,
    Chebychev,
    Minkowski,
}

/// How a cell's point and colour are drawn from its coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum CellHash {
    /// Blender 4: lookup3 of the float coordinates' bits.
    Lookup3,
    /// Blender 5: PCG of the integer coordinates.
    Pcg,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct VoronoiKind {
    pub(super) dimensions: u8,
    pub(super) feature: VoronoiFeature,
    pub(super) metric: Metric,
    pub(super) normalize: bool,
    pub(super) cell_hash: CellHash,
}

pub(super) struct VoronoiParams {
    pub(super) scale: f32,
    pub(super) detail: f32,
    pub(super) roughness: f32,
    pub(super) lacunarity: f32,
    pub(super) smoothness: f32,
    pub(super) exponent: f32,
    pub(super) randomness: f32,
    pub(super) kind: VoronoiKind,
}

/// `hash_float2_to_float2` (2D) or `hash_float3_to_float3` (3D): a cell's point offset.
pub(super) fn cell_point(dimensions: u8, c: Vec3) -> Vec3 {
    let (x, y) = (c.x.to_bits(), c.y.to_bits());
    if dimensions == 2 {
        Vec3::new(unit(hash2(x, y)), unit(hash3(x, y, 1f32.to_bits())), 0.0)
    } else {
        Vec3::from_array(cell_points(c.x, c.y, c.z))
    }
}

/// `hash_float2_to_float3` (2D) or `hash_float3_to_float3` (3D): a cell's colour.
pub(super) fn cell_color(dimensions: u8, c: Vec3) -> Vec3 {
    let (x, y) = (c.x.to_bits(), c.y.to_bits());
    if dimensions == 2 {
        Vec3::new(
            unit(hash2(x, y)),
            unit(hash3(x, y, 1f32.to_bits())),
            unit(hash3(x, y, 2f32.to_bits())),
        )
    } else {
        cell_point(3, c)
    }
}

/// PCG's 2D hash (Jarzynski & Olano 2020) on signed words, its result kept to 31 bits.
fn pcg2(x: i32, y: i32) -> [i32; 2] {
    const M: i32 = 1664525;
    let mut v = [x, y].map(|c| c.wrapping_mul(M).wrapping_add(1013904223));
    v[0] = v[0].wrapping_add(v[1].wrapping_mul(M));
    v[1] = v[1].wrapping_add(v[0].wrapping_mul(M));
    v = v.map(|c| c ^ (c >> 16));
    v[0] = v[0].wrapping_add(v[1].wrapping_mul(M));
    v[1] = v[1].wrapping_add(v[0].wrapping_mul(M));
    v.map(|c| c & 0x7FFF_FFFF)
}

/// PCG's 3D hash (Jarzynski & Olano 2020) on signed words, its result kept to 31 bits.
fn pcg3(x: i32, y: i32, z: i32) -> [i32; 3] {
    let mut v = [x, y, z].map(|c| c.wrapping_mul(1664525).wrapping_add(1013904223));
    let round = |v: &mut [i32; 3]| {
        v[0] = v[0].wrapping_add(v[1].wrapping_mul(v[2]));
        v[1] = v[1].wrapping_add(v[2].wrapping_mul(v[0]));
        v[2] = v[2].wrapping_add(v[0].wrapping_mul(v[1]));
    };
    round(&mut v);
    v = v.map(|c| c ^ (c >> 16));
    round(&mut v);
    v.map(|c| c & 0x7FFF_FFFF)
}

/// A 31-bit hash as a float in [0, 1].
fn pcg_unit(h: i32) -> f32 {
    h as f32 * (1.0 / 2147483648.0)
}

/// The integer coordinates of the cell `cell + offset` (both whole numbers), z = 0 in 2D:
/// what Blender 5 hashes.
fn cell_words(dimensions: u8, cell: Vec3, offset: Vec3) -> [i32; 3] {
    let c = [cell.x, cell.y, cell.z].map(|v| v as i32);
    let o = [offset.x, offset.y, offset.z].map(|v| v as i32);
    let z = if dimensions == 2 {
        0
    } else {
        c[2].wrapping_add(o[2])
    };
    [c[0].wrapping_add(o[0]), c[1].wrapping_add(o[1]), z]
}

/// The point offset of the cell `cell + offset` (both whole numbers) by `hash`.
pub(super) fn hashed_point(hash: CellHash, dimensions: u8, cell: Vec3, offset: Vec3) -> Vec3 {
    match hash {
        CellHash::Lookup3 => cell_point(dimensions, cell + offset),
        CellHash::Pcg if dimensions == 2 => {
            let [x, y, _] = cell_words(dimensions, cell, offset);
            let [a, b] = pcg2(x, y);
            Vec3::new(pcg_unit(a), pcg_unit(b), 0.0)
        }
        CellHash::Pcg => hashed_color(hash, dimensions, cell, offset),
    }
}

/// The colour of the cell `cell + offset` (both whole numbers) by `hash`.
pub(super) fn hashed_color(hash: CellHash, dimensions: u8, cell: Vec3, offset: Vec3) -> Vec3 {
    match hash {
        CellHash::Lookup3 => cell_color(dimensions, cell + offset),
        CellHash::Pcg => {
            let [x, y, z] = cell_words(dimensions, cell, offset);
            Vec3::from_array(pcg3(x, y, z).map(pcg_unit))
        }
    }
}

pub(super) fn voronoi_distance(metric: Metric, exponent: f32, a: Vec3, b: Vec3) -> f32 {
    let d = (a - b).abs();
    match metric {
        Metric::Euclidean => a.distance(b),
        Metric::Manhattan => d.x + d.y + d.z,
        Metric::Chebychev => d.max_element(),
        Metric::Minkowski => {
            (d.x.powf(exponent) + d.y.powf(exponent) + d.z.powf(exponent)).powf(1.0 / exponent)
        }
    }
}

/// The cell offsets a search visits, in Cycles' order (z outermost, x innermost).
pub(super) fn cell_offsets(dimensions: u8, reach: i32) -> impl Iterator<Item = Vec3> {
    let zr = if dimensions == 2 { 0 } else { reach };
    (-zr..=zr).flat_map(move |k| {
        (-reach..=reach).flat_map(move |j| {
            (-reach..=reach).map(move |i| Vec3::new(i as f32, j as f32, k as f32))
        })
    })
}

/// One octave: (distance, colour, position).
/// Without `color` the F1 colour is not computed (zero).
pub(super) fn voronoi_octave(p: &VoronoiParams, coord: Vec3, color: bool) -> (f32, Vec3, Vec3) {
    let dims = p.kind.dimensions;
    let cell = Vec3::new(floor(coord.x), floor(coord.y), floor(coord.z));
    let local = coord - cell;
    let metric = p.kind.metric;
    let hash = p.kind.cell_hash;
    match p.kind.feature {
        VoronoiFeature::SmoothF1 if p.smoothness != 0.0 => {
            let mut distance = 0.0f32;
            let mut color = Vec3::ZERO;
            let mut position = Vec3::ZERO;
            let mut h = -1.0f32;
            for offset in cell_offsets(dims, 2) {
                let point = offset + hashed_point(hash, dims, cell, offset) * p.randomness;
                let d = voronoi_distance(metric, p.exponent, point, local);
                h = if h == -1.0 {
                    1.0
                } else {
                    smoothstep(0.0, 1.0, 0.5 + 0.5 * (distance - d) / p.smoothness)
                };
                let mut correction = p.smoothness * h * (1.0 - h);
                distance = lerp(distance, d, h) - correction;
                correction /= 1.0 + 3.0 * p.smoothness;
                let c = hashed_color(hash, dims, cell, offset);
                color = color.lerp(c, h) - Vec3::splat(correction);
                position = position.lerp(point, h) - Vec3::splat(correction);
            }
            (distance, color, cell + position)
        }
        VoronoiFeature::F2 => {
            let (mut d1, mut d2) = (f32::MAX, f32::MAX);
            let (mut o1, mut o2) = (Vec3::ZERO, Vec3::ZERO);
            let (mut p1, mut p2) = (Vec3::ZERO, Vec3::ZERO);
            for offset in cell_offsets(dims, 1) {
                let point = offset + hashed_point(hash, dims, cell, offset) * p.randomness;
                let d = voronoi_distance(metric, p.exponent, point, local);
                if d < d1 {
                    (d2, o2, p2) = (d1, o1, p1);
                    (d1, o1, p1) = (d, offset, point);
                } else if d < d2 {
                    (d2, o2, p2) = (d, offset, point);
                }
            }
            (d2, hashed_color(hash, dims, cell, o2), p2 + cell)
        }
        _ => {
            // The nearest point, the first in Cycles' order on a tie. A cell's point lies in
            // [offset, offset + randomness] on each axis, so a cell whose box is farther from
            // `local` than the best point so far cannot win: it is skipped unhashed (exact).
            // The cells are visited nearest first (the home cell, then those sharing a face,
            // an edge, a corner), so the best point is found early and most cells are skipped.
            // (As Cycles computes it: cell + 0 turns a −0 coordinate into +0 before hashing.)
            let prune = metric != Metric::Minkowski;
            let mut best = f32::MAX;
            let mut best_index = usize::MAX;
            let (mut target_offset, mut target) = (Vec3::ZERO, Vec3::ZERO);
            let order: &[(u8, [i8; 3])] = if dims == 2 {
                &NEAREST_FIRST_2D
            } else {
                &NEAREST_FIRST_3D
            };
            // Per axis, the squared gap from `local` to the boxes of offset −1, 0 and 1.
            let gap2 = [local.x, local.y, local.z].map(|l| {
                [-1.0f32, 0.0, 1.0].map(|o| {
                    let g = (o - l).max(l - (o + p.randomness)).max(0.0);
                    g * g
                })
            });
            if metric == Metric::Euclidean && dims == 3 && hash == CellHash::Lookup3 {
                let (best, offset, point) =
                    nearest_point_euclidean_3d(cell, local, p.randomness, &gap2);
                let color = if color {
                    hashed_color(hash, dims, cell, offset)
                } else {
                    Vec3::ZERO
                };
                return (best, color, point + cell);
            }
            for &(index, [i, j, k]) in order {
                let index = index as usize;
                let offset = Vec3::new(i as f32, j as f32, k as f32);
                if prune && best != f32::MAX {
                    let bound = best * (1.0 + 1e-6);
                    let far = if metric == Metric::Euclidean {
                        // Squared, without the root (the bound's margin covers the rounding).
                        let [a, b, c] = [i, j, k].map(|o| (o + 1) as usize);
                        gap2[0][a] + gap2[1][b] + gap2[2][c] > bound * bound
                    } else {
                        let below = offset - local;
                        let above = local - (offset + Vec3::splat(p.randomness));
                        let gap = below.max(above).max(Vec3::ZERO);
                        voronoi_distance(metric, p.exponent, gap, Vec3::ZERO) > bound
                    };
                    if far {
                        continue;
                    }
                }
                let point = offset + hashed_point(hash, dims, cell, offset) * p.randomness;
                let d = voronoi_distance(metric, p.exponent, point, local);
                if d < best || (d == best && index < best_index) {
                    (best, best_index, target_offset, target) = (d, index, offset, point);
                }
            }
            let color = if color {
                hashed_color(hash, dims, cell, target_offset)
            } else {
                Vec3::ZERO
            };
            (best, color, target + cell)
        }
    }
}

/// `hash_float3_to_float3` of cells given as lanes (one, four or eight): the point offsets
/// of 3D cells, `hash3` for x and `hash4` with w = 1.0 and 2.0 for y and z.
#[inline(always)]
pub(super) fn cell_points<F: Lanes>(x: F, y: F, z: F) -> [F; 3] {
    let (x, y, z) = (x.to_bits(), y.to_bits(), z.to_bits());
    let s3 = F::Words::splat(LOOKUP3_SEED.wrapping_add((3 << 2) + 13));
    let first = hash::finish(x + s3, y + s3, z + s3);
    // hash4(x, y, z, w) for w = 1.0 and 2.0 share their first mix.
    let s4 = F::Words::splat(LOOKUP3_SEED.wrapping_add((4 << 2) + 13));
    let (a, b, c) = hash::mix(x + s4, y + s4, z + s4);
    let second = hash::finish(a + F::Words::splat(1f32.to_bits()), b, c);
    let third = hash::finish(a + F::Words::splat(2f32.to_bits()), b, c);
    [F::unit(first), F::unit(second), F::unit(third)]
}

/// The Voronoi F1 search in 3D with the Euclidean metric (`voronoi_octave`'s, exact):
/// (distance, offset, point) of the nearest cell point to `local` in `cell`'s frame; `gap2`
/// holds per axis the squared gaps from `local` to the boxes of offsets −1, 0, 1. Eight cells
/// at a time where the machine has AVX2, else four (`nearest_point_euclidean_3d_lanes`, the
/// same result).
pub(super) fn nearest_point_euclidean_3d(
    cell: Vec3,
    local: Vec3,
    randomness: f32,
    gap2: &[[f32; 3]; 3],
) -> (f32, Vec3, Vec3) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: AVX2 is present (checked above).
        return unsafe { nearest_point_euclidean_3d_avx2(cell, local, randomness, gap2) };
    }
    nearest_point_euclidean_3d_lanes::<Vec4>(cell, local, randomness, gap2)
}

/// `nearest_point_euclidean_3d_lanes` on eight lanes, for machines with AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(super) fn nearest_point_euclidean_3d_avx2(
    cell: Vec3,
    local: Vec3,
    randomness: f32,
    gap2: &[[f32; 3]; 3],
) -> (f32, Vec3, Vec3) {
    use super::lanes::eight::F32x8;
    nearest_point_euclidean_3d_lanes::<F32x8>(cell, local, randomness, gap2)
}

/// The nearest point found so far: (distance, Cycles' index of its cell, offset, point).
type Nearest = (f32, usize, Vec3, Vec3);

/// `nearest_point_euclidean_3d` with `F::N` cells at a time. The cells of the 2 × 2 × 2 block
/// on `local`'s nearer side of the home cell along each axis are searched first, nearest
/// first, `F::N` of them at once; then the box of each other cell is tested against the best
/// distance so far, `F::N` boxes at once, and those within it searched `F::N` at a time. The
/// nearest point is the least (distance, Cycles' index) over the searched cells, so the order
/// of the search does not matter.
#[inline(always)]
pub(super) fn nearest_point_euclidean_3d_lanes<F: Lanes>(
    cell: Vec3,
    local: Vec3,
    randomness: f32,
    gap2: &[[f32; 3]; 3],
) -> (f32, Vec3, Vec3) {
    let mut nearest: Nearest = (f32::MAX, usize::MAX, Vec3::ZERO, Vec3::ZERO);
    let up = |l: f32| !(l < 0.5);
    let sides = up(local.x) as usize | (up(local.y) as usize) << 1 | (up(local.z) as usize) << 2;
    let block = &SIDE_BLOCKS[sides];
    let load = |o: &[[f32; 8]; 3]| [F::load(&o[0]), F::load(&o[1]), F::load(&o[2])];
    let first = load(&block.offsets);
    nearest_of_lanes(&block.index, first, cell, local, randomness, &mut nearest);
    // The other cells whose box lies within the bound (squared, without the root: its
    // margin covers the rounding).
    let bound = nearest.0 * (1.0 + 1e-6);
    let far = bound * bound;
    let axis = |g: &[f32; 3]| [g[0], g[1], g[2], f32::MAX];
    let tables = [axis(&gap2[0]), axis(&gap2[1]), axis(&gap2[2])];
    let mut within = 0u32;
    let mut group = 0;
    while group * F::N < 27 {
        let pick = |a: usize| {
            let picks: &[i32; 8] = GAP_PICKS[a][group * F::N..][..8].try_into().unwrap();
            F::lookup(tables[a], picks)
        };
        let sum = pick(0) + pick(1) + pick(2);
        // Not farther: as the test that skips a cell, NaN included.
        let near = !sum.above(far).bitmask() & ((1 << F::N) - 1);
        within |= near << (group * F::N);
        group += 1;
    }
    let mut left = within & !block.searched[F::N] & ((1 << 27) - 1);
    while left != 0 {
        let mut index = [0usize; 8];
        let mut offsets = [[0.0f32; 8]; 3];
        let mut n = 0;
        while left != 0 && n < F::N {
            let i = left.trailing_zeros() as usize;
            left &= left - 1;
            index[n] = i;
            for (lane, o) in offsets.iter_mut().zip(OFFSETS[i]) {
                lane[n] = o;
            }
            n += 1;
        }
        // The empty lanes repeat the batch's first cell (a tie with itself: no change).
        for k in n..F::N {
            index[k] = index[0];
            for lane in &mut offsets {
                lane[k] = lane[0];
            }
        }
        nearest_of_lanes(
            &index,
            load(&offsets),
            cell,
            local,
            randomness,
            &mut nearest,
        );
    }
    (nearest.0, nearest.2, nearest.3)
}

/// The Euclidean F1 search over `F::N` cells (Cycles' indices and offsets as lanes) at once:
/// their points, distances to `local` (`a.distance(b)`'s operations lane by lane) and the
/// update of `nearest` with Cycles' tie rule (the first in its order).
#[inline(always)]
fn nearest_of_lanes<F: Lanes>(
    index: &[usize; 8],
    offset: [F; 3],
    cell: Vec3,
    local: Vec3,
    randomness: f32,
    nearest: &mut Nearest,
) {
    let [ox, oy, oz] = offset;
    let [hx, hy, hz] = cell_points(ox + cell.x, oy + cell.y, oz + cell.z);
    let (px, py, pz) = (
        ox + hx * randomness,
        oy + hy * randomness,
        oz + hz * randomness,
    );
    let (dx, dy, dz) = (px - local.x, py - local.y, pz - local.z);
    let d = (dx * dx + dy * dy + dz * dz).sqrt();
    let within = d.at_most(nearest.0);
    let hits = within.bitmask();
    if hits == 0 {
        return;
    }
    // The least distance among the lanes not farther than the best (NaN never is), then
    // the least index among its lanes: the rule below applied lane by lane in any order
    // keeps the least (distance, index).
    let d = F::select(within, d, F::splat(f32::INFINITY));
    let least = d.least();
    let mut ties = hits & d.equal(least).bitmask();
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
        let (px, py, pz) = (px.store(), py.store(), pz.store());
        let o = OFFSETS[index[k]];
        *nearest = (
            least,
            index[k],
            Vec3::from_array(o),
            Vec3::new(px[k], py[k], pz[k]),
        );
    }
}

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

/// The 2 × 2 × 2 cells on one side of the home cell's centre, nearest first.
#[derive(Clone, Copy)]
struct SideBlock {
    /// Cycles' indices.
    index: [usize; 8],
    /// Per axis, the offsets (each zero a +0).
    offsets: [[f32; 8]; 3],
    /// The set of the first n cells, for each n.
    searched: [u32; 9],
}

/// For each side of the home cell's centre `local` is on (bit a set where it is at least
/// ½ along axis a), its `SideBlock`: the home cell, the three sharing a face with it, the
/// three sharing an edge, the one sharing a corner.
const SIDE_BLOCKS: [SideBlock; 8] = {
    const STEPS: [usize; 8] = [0b000, 0b001, 0b010, 0b100, 0b011, 0b101, 0b110, 0b111];
    let empty = SideBlock {
        index: [0; 8],
        offsets: [[0.0; 8]; 3],
        searched: [0; 9],
    };
    let mut blocks = [empty, empty, empty, empty, empty, empty, empty, empty];
    let mut sides = 0;
    while sides < 8 {
        let mut lane = 0;
        while lane < 8 {
            let mut index = 13;
            let mut axis = 0;
            while axis < 3 {
                if STEPS[lane] >> axis & 1 != 0 {
                    let up = sides >> axis & 1 != 0;
                    blocks[sides].offsets[axis][lane] = if up { 1.0 } else { -1.0 };
                    let stride = [1, 3, 9][axis];
                    index = if up { index + stride } else { index - stride };
                }
                axis += 1;
            }
            blocks[sides].index[lane] = index;
            blocks[sides].searched[lane + 1] = blocks[sides].searched[lane] | 1 << index;
            lane += 1;
        }
        sides += 1;
    }
    blocks
};

/// For each axis, which of the box gaps (offset + 1) the cell of Cycles' index i reads
/// (3: none, for the lanes past the 27 cells).
const GAP_PICKS: [[i32; 40]; 3] = {
    let mut picks = [[3; 40]; 3];
    let mut i = 0;
    while i < 27 {
        picks[0][i] = (i % 3) as i32;
        picks[1][i] = ((i / 3) % 3) as i32;
        picks[2][i] = (i / 9) as i32;
        i += 1;
    }
    picks
};

/// The cells around a Voronoi point's home cell as (Cycles' visiting order, offset), nearest
/// first: the home cell, then the cells sharing a face, an edge, a corner with it.
pub(super) const fn nearest_first<const N: usize>(dims: usize) -> [(u8, [i8; 3]); N] {
    let mut out = [(0u8, [0i8; 3]); N];
    let mut n = 0;
    let mut shared = 0;
    while shared <= dims {
        let mut index = 0;
        while index < N {
            let o = [
                (index % 3) as i8 - 1,
                ((index / 3) % 3) as i8 - 1,
                if dims == 2 { 0 } else { (index / 9) as i8 - 1 },
            ];
            let nonzero = (o[0] != 0) as usize + (o[1] != 0) as usize + (o[2] != 0) as usize;
            if nonzero == shared {
                out[n] = (index as u8, o);
                n += 1;
            }
            index += 1;
        }
        shared += 1;
    }
    out
}

pub(super) const NEAREST_FIRST_2D: [(u8, [i8; 3]); 9] = nearest_first::<9>(2);
pub(super) const NEAREST_FIRST_3D: [(u8, [i8; 3]); 27] = nearest_first::<27>(3);

/// Cycles' `fractal_voronoi_x_fx` with the node's normalisation: (distance, colour, position).
/// Without `color` the F1 colour is not computed (zero).
pub(super) fn voronoi(p: &VoronoiParams, coord: Vec3, with_color: bool) -> (f32, Vec3, Vec3) {
    let r = 0.5 + 0.5 * p.randomness;
    let corner = if p.kind.dimensions == 2 {
        Vec3::new(r, r, 0.0)
    } else {
        Vec3::splat(r)
    };
    let f2 = if p.kind.feature == VoronoiFeature::F2 {
        2.0
    } else {
        1.0
    };
    let max_distance = voronoi_distance(p.kind.metric, p.exponent, Vec3::ZERO, corner) * f2;
    let mut amplitude = 1.0f32;
    let mut max_amplitude = 0.0f32;
    let mut scale = 1.0f32;
    let (mut distance, mut color, mut position) = (0.0f32, Vec3::ZERO, Vec3::ZERO);
    let zero_input = p.detail == 0.0 || p.roughness == 0.0;
    let octaves = p.detail.ceil() as i32;
    for i in 0..=octaves {
        let (d, c, pos) = voronoi_octave(p, coord * scale, with_color);
        if zero_input {
            max_amplitude = 1.0;
            (distance, color, position) = (d, c, pos);
            break;
        }
        if i as f32 <= p.detail {
            max_amplitude += amplitude;
            distance += d * amplitude;
            color += c * amplitude;
            position = position.lerp(pos / scale, amplitude);
            scale *= p.lacunarity;
            amplitude *= p.roughness;
        } else {
            let rmd = p.detail - p.detail.floor();
            if rmd != 0.0 {
                max_amplitude = lerp(max_amplitude, max_amplitude + amplitude, rmd);
                distance = lerp(distance, distance + d * amplitude, rmd);
                color = color.lerp(color + c * amplitude, rmd);
                position = position.lerp(position.lerp(pos / scale, amplitude), rmd);
            }
        }
    }
    if p.kind.normalize {
        distance /= max_amplitude * max_distance;
        color /= max_amplitude;
    }
    let position = if p.scale != 0.0 {
        position / p.scale
    } else {
        Vec3::ZERO
    };
    (distance, color, position)
}

/// The Voronoi Texture: Vector, W, Scale, Detail, Roughness, Lacunarity, Smoothness,
/// Exponent, Randomness to Distance, Color (only when `used` reads it) and Position.
#[inline(always)]
pub(super) fn eval_voronoi(kind: VoronoiKind, used: u32, ins: &impl Operands) -> [Vec4; 3] {
    const VECTOR: usize = input(VORONOI_INPUTS, "Vector");
    const SCALE: usize = input(VORONOI_INPUTS, "Scale");
    const DETAIL: usize = input(VORONOI_INPUTS, "Detail");
    const ROUGHNESS: usize = input(VORONOI_INPUTS, "Roughness");
    const LACUNARITY: usize = input(VORONOI_INPUTS, "Lacunarity");
    const SMOOTHNESS: usize = input(VORONOI_INPUTS, "Smoothness");
    const EXPONENT: usize = input(VORONOI_INPUTS, "Exponent");
    const RANDOMNESS: usize = input(VORONOI_INPUTS, "Randomness");
    let scale = ins.float(SCALE);
    let params = VoronoiParams {
        scale,
        detail: ins.float(DETAIL).clamp(0.0, 15.0),
        roughness: ins.float(ROUGHNESS).clamp(0.0, 1.0),
        lacunarity: ins.float(LACUNARITY),
        smoothness: (ins.float(SMOOTHNESS) / 2.0).clamp(0.0, 0.5),
        exponent: ins.float(EXPONENT),
        randomness: ins.float(RANDOMNESS).clamp(0.0, 1.0),
        kind,
    };
    let mut p = ins.vector(VECTOR) * scale;
    if kind.dimensions == 2 {
        p.z = 0.0;
    }
    let (distance, color, position) = voronoi(&params, p, used & 2 != 0);
    [splat(distance), v3(color), v3(position)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::noise::tests::awkward_coordinate;

    #[test]
    fn voronoi_f1_is_the_nearest_of_the_neighbouring_cells_points() {
        // The pruned, nearest-first search finds what visiting all 27 (or 9) cells finds.
        let mut rng = crate::rng::Rng::new(6);
        for metric in [
            Metric::Euclidean,
            Metric::Manhattan,
            Metric::Chebychev,
            Metric::Minkowski,
        ] {
            for (dims, hash) in [2u8, 3]
                .into_iter()
                .flat_map(|d| [CellHash::Lookup3, CellHash::Pcg].map(move |h| (d, h)))
            {
                for randomness in [1.0f32, 0.6, 0.0] {
                    let p = VoronoiParams {
                        scale: 1.0,
                        detail: 0.0,
                        roughness: 0.5,
                        lacunarity: 2.0,
                        smoothness: 0.0,
                        exponent: 1.5,
                        randomness,
                        kind: VoronoiKind {
                            dimensions: dims,
                            feature: VoronoiFeature::F1,
                            metric,
                            normalize: false,
                            cell_hash: hash,
                        },
                    };
                    for k in 0..5_000 {
                        let s = [2.0, 50.0][k % 2];
                        let c = |rng: &mut crate::rng::Rng| (rng.uniform() * 2.0 - 1.0) * s;
                        let z = if dims == 2 { 0.0 } else { c(&mut rng) };
                        let x = Vec3::new(c(&mut rng), c(&mut rng), z);
                        let cell = x.floor();
                        // Cycles' search: every cell in its order, the first on a tie.
                        let (mut nearest, mut at) = (f32::MAX, Vec3::ZERO);
                        for o in cell_offsets(dims, 1) {
                            let point = o + hashed_point(hash, dims, cell, o) * randomness;
                            let d = voronoi_distance(metric, 1.5, point, x - cell);
                            if d < nearest {
                                (nearest, at) = (d, o);
                            }
                        }
                        let position = at + hashed_point(hash, dims, cell, at) * randomness + cell;
                        let (d, color, found) = voronoi_octave(&p, x, true);
                        assert_eq!(d.to_bits(), nearest.to_bits(), "{metric:?} {hash:?} {x}");
                        assert_eq!(found, position, "{metric:?} {hash:?} {x}");
                        assert_eq!(
                            color,
                            hashed_color(hash, dims, cell, at),
                            "{metric:?} {hash:?} {x}"
                        );
                        let (d, _, found) = voronoi_octave(&p, x, false);
                        assert_eq!((d, found), (nearest, position), "{metric:?} {hash:?} {x}");
                    }
                }
            }
        }
    }

    #[test]
    fn voronoi_search_is_the_same_on_one_four_and_eight_lanes() {
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
            let bits = |(d, o, p): (f32, Vec3, Vec3)| {
                (
                    d.to_bits(),
                    o.to_array().map(f32::to_bits),
                    p.to_array().map(f32::to_bits),
                )
            };
            let want = bits(nearest_point_euclidean_3d_lanes::<f32>(
                cell, local, randomness, &gap2,
            ));
            let four = nearest_point_euclidean_3d_lanes::<Vec4>(cell, local, randomness, &gap2);
            assert_eq!(bits(four), want, "{coord} {randomness}");
            #[cfg(target_arch = "x86_64")]
            if has_avx2() {
                // SAFETY: AVX2 is present (checked above).
                let eight =
                    unsafe { nearest_point_euclidean_3d_avx2(cell, local, randomness, &gap2) };
                assert_eq!(bits(eight), want, "{coord} {randomness}");
            }
        }
    }
}
