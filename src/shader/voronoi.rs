//! The Voronoi Texture (Worley's cellular texture, Worley 1996) as Blender defines it (Cycles'
//! `voronoi.h`: F1, F2 and Smooth F1 over 2D and 3D cells, four metrics, fractal octaves), cell
//! points from Jenkins' lookup3 (`hash`). The F1 search visits cells nearest first and skips those
//! that cannot hold a nearer point; in 3D with the Euclidean metric four cells at a time, or eight
//! with AVX2 (`voronoi_avx2`), with the same result bit for bit.

use super::hash::{
    self, has_avx2, hash2, hash3, lookup3_final, lookup3_mix, unit, U32x4, LOOKUP3_SEED,
};
use super::inputs::{input, splat, v3, Operands, Socket, Ty};
use super::math::smoothstep;
use super::noise::{floor, lerp};
#[cfg(target_arch = "x86_64")]
use super::voronoi_avx2;
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

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct VoronoiKind {
    pub(super) dimensions: u8,
    pub(super) feature: VoronoiFeature,
    pub(super) metric: Metric,
    pub(super) normalize: bool,
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
    let (x, y, z) = (c.x.to_bits(), c.y.to_bits(), c.z.to_bits());
    if dimensions == 2 {
        Vec3::new(unit(hash2(x, y)), unit(hash3(x, y, 1f32.to_bits())), 0.0)
    } else {
        // hash4(x, y, z, w) for w = 1.0 and 2.0 share their first mix.
        let s = LOOKUP3_SEED.wrapping_add((4 << 2) + 13);
        let (a, b, c) = lookup3_mix(s.wrapping_add(x), s.wrapping_add(y), s.wrapping_add(z));
        Vec3::new(
            unit(hash3(x, y, z)),
            unit(lookup3_final(a.wrapping_add(1f32.to_bits()), b, c)),
            unit(lookup3_final(a.wrapping_add(2f32.to_bits()), b, c)),
        )
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
    match p.kind.feature {
        VoronoiFeature::SmoothF1 if p.smoothness != 0.0 => {
            let mut distance = 0.0f32;
            let mut color = Vec3::ZERO;
            let mut position = Vec3::ZERO;
            let mut h = -1.0f32;
            for offset in cell_offsets(dims, 2) {
                let point = offset + cell_point(dims, cell + offset) * p.randomness;
                let d = voronoi_distance(metric, p.exponent, point, local);
                h = if h == -1.0 {
                    1.0
                } else {
                    smoothstep(0.0, 1.0, 0.5 + 0.5 * (distance - d) / p.smoothness)
                };
                let mut correction = p.smoothness * h * (1.0 - h);
                distance = lerp(distance, d, h) - correction;
                correction /= 1.0 + 3.0 * p.smoothness;
                let c = cell_color(dims, cell + offset);
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
                let point = offset + cell_point(dims, cell + offset) * p.randomness;
                let d = voronoi_distance(metric, p.exponent, point, local);
                if d < d1 {
                    (d2, o2, p2) = (d1, o1, p1);
                    (d1, o1, p1) = (d, offset, point);
                } else if d < d2 {
                    (d2, o2, p2) = (d, offset, point);
                }
            }
            (d2, cell_color(dims, cell + o2), p2 + cell)
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
            if metric == Metric::Euclidean && dims == 3 {
                let (best, offset, point) =
                    nearest_point_euclidean_3d(cell, local, p.randomness, &gap2);
                let color = if color {
                    cell_color(dims, cell + offset)
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
                let point = offset + cell_point(dims, cell + offset) * p.randomness;
                let d = voronoi_distance(metric, p.exponent, point, local);
                if d < best || (d == best && index < best_index) {
                    (best, best_index, target_offset, target) = (d, index, offset, point);
                }
            }
            let color = if color {
                cell_color(dims, cell + target_offset)
            } else {
                Vec3::ZERO
            };
            (best, color, target + cell)
        }
    }
}

/// `cell_point` in 3D of four cells given as lanes: the same hashes, lane by lane.
#[inline(always)]
pub(super) fn cell_points4(x: Vec4, y: Vec4, z: Vec4) -> [Vec4; 3] {
    let bits = |v: Vec4| U32x4::new(v.to_array().map(f32::to_bits));
    let (x, y, z) = (bits(x), bits(y), bits(z));
    let s3 = U32x4::splat(LOOKUP3_SEED.wrapping_add((3 << 2) + 13));
    let first = hash::finish(x + s3, y + s3, z + s3);
    // hash4(x, y, z, w) for w = 1.0 and 2.0 share their first mix.
    let s4 = U32x4::splat(LOOKUP3_SEED.wrapping_add((4 << 2) + 13));
    let (a, b, c) = hash::mix(x + s4, y + s4, z + s4);
    let second = hash::finish(a + U32x4::splat(1f32.to_bits()), b, c);
    let third = hash::finish(a + U32x4::splat(2f32.to_bits()), b, c);
    let unit4 = |h: U32x4| Vec4::from_array(h.to_array().map(unit));
    [unit4(first), unit4(second), unit4(third)]
}

/// The Voronoi F1 search in 3D with the Euclidean metric (`voronoi_octave`'s, exact):
/// (distance, offset, point) of the nearest cell point to `local` in `cell`'s frame; `gap2`
/// holds per axis the squared gaps from `local` to the boxes of offsets −1, 0, 1. Eight cells
/// at a time where the machine has AVX2 (`voronoi_avx2`), else four (the same result).
pub(super) fn nearest_point_euclidean_3d(
    cell: Vec3,
    local: Vec3,
    randomness: f32,
    gap2: &[[f32; 3]; 3],
) -> (f32, Vec3, Vec3) {
    #[cfg(target_arch = "x86_64")]
    if has_avx2() {
        // SAFETY: AVX2 is present (checked above).
        return unsafe { voronoi_avx2::nearest_point_euclidean_3d(cell, local, randomness, gap2) };
    }
    nearest_point_euclidean_3d_lanes4(cell, local, randomness, gap2)
}

/// `nearest_point_euclidean_3d` four cells at a time: the home cell and, per axis, the face
/// neighbour on `local`'s nearer side are searched first, four at once; then the other cells
/// nearest first, skipping those whose box lies farther than the best point so far, the
/// others queued and searched four at a time.
pub(super) fn nearest_point_euclidean_3d_lanes4(
    cell: Vec3,
    local: Vec3,
    randomness: f32,
    gap2: &[[f32; 3]; 3],
) -> (f32, Vec3, Vec3) {
    let mut nearest = (f32::MAX, usize::MAX, Vec3::ZERO, Vec3::ZERO);
    let side = |l: f32| if l < 0.5 { -1.0f32 } else { 1.0 };
    let (sx, sy, sz) = (side(local.x), side(local.y), side(local.z));
    // Cycles' index of offset (i, j, k): z outermost, x innermost.
    let index = |o: Vec3| (o.x + 1.0 + 3.0 * (o.y + 1.0) + 9.0 * (o.z + 1.0)) as usize;
    let first = [
        Vec3::ZERO,
        Vec3::new(sx, 0.0, 0.0),
        Vec3::new(0.0, sy, 0.0),
        Vec3::new(0.0, 0.0, sz),
    ]
    .map(|o| (index(o), o));
    nearest_of_four(&first, cell, local, randomness, &mut nearest);
    let done = first.iter().fold(0u32, |m, (i, _)| m | 1 << i);
    let mut batch = [first[0]; 4];
    let mut queued = 0;
    // Squared, without the root (the bound's margin covers the rounding); it changes only
    // when a batch finds a nearer point.
    let limit = |nearest: f32| {
        let bound = nearest * (1.0 + 1e-6);
        bound * bound
    };
    let mut far = limit(nearest.0);
    for &(index, [a, b, c], offset) in &NEAREST_FIRST_3D_BOXES {
        if done >> index & 1 != 0 {
            continue;
        }
        if gap2[0][a] + gap2[1][b] + gap2[2][c] > far {
            continue;
        }
        batch[queued] = (index, offset);
        queued += 1;
        if queued == 4 {
            nearest_of_four(&batch, cell, local, randomness, &mut nearest);
            far = limit(nearest.0);
            queued = 0;
        }
    }
    if queued > 0 {
        // The empty lanes repeat the batch's first cell (a tie with itself: no change).
        for k in queued..4 {
            batch[k] = batch[0];
        }
        nearest_of_four(&batch, cell, local, randomness, &mut nearest);
    }
    (nearest.0, nearest.2, nearest.3)
}

/// The Euclidean F1 search over four cells (index in Cycles' order, offset) at once: their
/// points, distances to `local` (`a.distance(b)`'s operations lane by lane) and the update of
/// `nearest` = (distance, index, offset, point) with Cycles' tie rule (the first in its order).
pub(super) fn nearest_of_four(
    cells: &[(usize, Vec3); 4],
    cell: Vec3,
    local: Vec3,
    randomness: f32,
    nearest: &mut (f32, usize, Vec3, Vec3),
) {
    let lane = |f: fn(Vec3) -> f32| Vec4::from_array(cells.map(|(_, o)| f(o)));
    let (ox, oy, oz) = (lane(|o| o.x), lane(|o| o.y), lane(|o| o.z));
    let [hx, hy, hz] = cell_points4(ox + cell.x, oy + cell.y, oz + cell.z);
    let (px, py, pz) = (
        ox + hx * randomness,
        oy + hy * randomness,
        oz + hz * randomness,
    );
    let (dx, dy, dz) = (px - local.x, py - local.y, pz - local.z);
    let d = (dx * dx + dy * dy + dz * dz).sqrt().to_array();
    let (px, py, pz) = (px.to_array(), py.to_array(), pz.to_array());
    for k in 0..4 {
        let (index, offset) = cells[k];
        if d[k] < nearest.0 || (d[k] == nearest.0 && index < nearest.1) {
            *nearest = (d[k], index, offset, Vec3::new(px[k], py[k], pz[k]));
        }
    }
}

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

/// `NEAREST_FIRST_3D` as the 3D Euclidean search reads it: (index, the offset's per-axis
/// indices into the box gaps (offset + 1), offset).
pub(super) const NEAREST_FIRST_3D_BOXES: [(usize, [usize; 3], Vec3); 27] = {
    let mut boxes = [(0, [0; 3], Vec3::ZERO); 27];
    let mut n = 0;
    while n < 27 {
        let (index, [i, j, k]) = NEAREST_FIRST_3D[n];
        boxes[n] = (
            index as usize,
            [(i + 1) as usize, (j + 1) as usize, (k + 1) as usize],
            Vec3::new(i as f32, j as f32, k as f32),
        );
        n += 1;
    }
    boxes
};

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
            for dims in [2u8, 3] {
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
                            let point = o + cell_point(dims, cell + o) * randomness;
                            let d = voronoi_distance(metric, 1.5, point, x - cell);
                            if d < nearest {
                                (nearest, at) = (d, o);
                            }
                        }
                        let position = at + cell_point(dims, cell + at) * randomness + cell;
                        let (d, color, found) = voronoi_octave(&p, x, true);
                        assert_eq!(d.to_bits(), nearest.to_bits(), "{metric:?} {x}");
                        assert_eq!(found, position, "{metric:?} {x}");
                        assert_eq!(color, cell_color(dims, cell + at), "{metric:?} {x}");
                        let (d, _, found) = voronoi_octave(&p, x, false);
                        assert_eq!((d, found), (nearest, position), "{metric:?} {x}");
                    }
                }
            }
        }
    }
}
