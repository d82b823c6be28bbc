//! The voxel grids that fill a Blender Volume object (smoke, fire, clouds; read from OpenVDB
//! files by `super::vdb`): named float or colour grids in the object's space, sampled by
//! trilinear interpolation between voxel centres as Cycles samples them with linear
//! interpolation, and bounded block by block for the media's majorants (`MajorantGrid`: a
//! piecewise-constant bound that free flights step through, the majorant grid of Cycles 5's
//! null-scattering volumes). Outside a grid's voxels its value is zero (the background of
//! density-like grids).

use crate::math::{Affine3A, Mat4, Vec3, Vec4};

/// Bytes of voxel values a scene may hold in all (a dense 1024³ float grid): grids past it are
/// refused before they are allocated.
pub const MAX_GRID_BYTES: u64 = 4 << 30;

/// One named grid, dense over a box of voxels.
#[derive(Debug)]
pub struct Grid {
    pub name: String,
    /// 1 (float grids) or 3 (colour and vector grids).
    pub channels: usize,
    /// Voxels per axis.
    pub size: [usize; 3],
    /// The values, x fastest: `values[((z * size[1] + y) * size[0] + x) * channels + c]`.
    values: Vec<f32>,
    /// Blender object coordinates → the dense box's voxel coordinates (voxel centres at
    /// integers, the first voxel at 0).
    object_to_voxel: Affine3A,
    /// The inverse: voxel coordinates → object coordinates.
    voxel_to_object: Affine3A,
}

impl Grid {
    /// A grid of `channels` values per voxel over `size` voxels, whose first voxel sits at
    /// `voxel_to_object` × 0; `None` when the values do not fill the box or the transform is
    /// singular.
    pub fn new(
        name: String,
        channels: usize,
        size: [usize; 3],
        values: Vec<f32>,
        voxel_to_object: Mat4,
    ) -> Option<Grid> {
        let count = size.iter().try_fold(channels, |n, &s| n.checked_mul(s))?;
        let voxel_to_object = Affine3A::from_mat4(voxel_to_object);
        let object_to_voxel = voxel_to_object.inverse();
        let usable = matches!(channels, 1 | 3)
            && values.len() == count
            && voxel_to_object.matrix3.determinant().abs() > 0.0
            && object_to_voxel.is_finite();
        usable.then_some(Grid {
            name,
            channels,
            size,
            values,
            object_to_voxel,
            voxel_to_object,
        })
    }

    /// Bytes its values take.
    pub fn bytes(&self) -> u64 {
        (self.values.len() * std::mem::size_of::<f32>()) as u64
    }

    /// The value at object point `p`: trilinear between the eight nearest voxel centres, a
    /// float grid's value in all three channels; alpha 1.
    #[inline]
    pub fn sample(&self, p: Vec3) -> Vec4 {
        let v = self.object_to_voxel.transform_point3(p);
        let f = v.floor();
        let t = v - f;
        let base = [f.x as i64, f.y as i64, f.z as i64];
        let mut sum = Vec3::ZERO;
        for corner in 0..8 {
            let step = [corner & 1, (corner >> 1) & 1, corner >> 2];
            let mut w = 1.0;
            for a in 0..3 {
                w *= if step[a] == 1 { t[a] } else { 1.0 - t[a] };
            }
            if w > 0.0 {
                sum += w * self.voxel(
                    base[0] + step[0] as i64,
                    base[1] + step[1] as i64,
                    base[2] + step[2] as i64,
                );
            }
        }
        sum.extend(1.0)
    }

    /// The value at object point `p` as one voxel of the eight around it, drawn with the
    /// trilinear weights by `u` (three numbers in [0, 1)): per axis the upper voxel when
    /// `u` falls below the point's fraction along it. Its expectation over `u` is `sample`'s
    /// value; a tree that maps it non-linearly (a temperature through Blackbody) sees the
    /// voxels' own values, as Cycles 5's stochastic interpolation does (Pharr et al. 2024,
    /// "Filtering After Shading with Stochastic Texture Filtering").
    #[inline]
    pub fn sample_one_voxel(&self, p: Vec3, u: Vec3) -> Vec4 {
        let v = self.object_to_voxel.transform_point3(p);
        let f = v.floor();
        let t = v - f;
        let pick = |a: usize| f[a] as i64 + i64::from(u[a] < t[a]);
        self.voxel(pick(0), pick(1), pick(2)).extend(1.0)
    }

    /// The value of voxel (x, y, z), zero outside the box.
    #[inline]
    fn voxel(&self, x: i64, y: i64, z: i64) -> Vec3 {
        let [sx, sy, sz] = self.size.map(|s| s as i64);
        if x < 0 || y < 0 || z < 0 || x >= sx || y >= sy || z >= sz {
            return Vec3::ZERO;
        }
        let i = (((z * sy + y) * sx + x) as usize) * self.channels;
        match self.channels {
            3 => Vec3::new(self.values[i], self.values[i + 1], self.values[i + 2]),
            _ => Vec3::splat(self.values[i]),
        }
    }

    /// The largest value of each channel that `sample` can take at object points whose voxel
    /// coordinates fall in the box from voxel `lo` to voxel `hi` (inclusive corners, clamped
    /// to the grid): the largest voxel value touching it.
    pub fn max_over(&self, lo: [i64; 3], hi: [i64; 3]) -> Vec3 {
        let mut most = Vec3::ZERO; // interpolation outside the voxels reaches zero too
        if self.size.contains(&0) {
            return most; // an empty grid (a fluid's flame before anything burns)
        }
        let clamp = |v: i64, a: usize| v.clamp(0, self.size[a] as i64 - 1);
        for z in clamp(lo[2], 2)..=clamp(hi[2], 2) {
            for y in clamp(lo[1], 1)..=clamp(hi[1], 1) {
                for x in clamp(lo[0], 0)..=clamp(hi[0], 0) {
                    most = most.max(self.voxel(x, y, z));
                }
            }
        }
        most
    }

    /// The voxels of this grid (rounded outwards, one more each side for interpolation) that
    /// cover the box of `other`'s voxel coordinates from `lo` to `hi`.
    pub fn voxel_box_of(&self, other: &Grid, lo: Vec3, hi: Vec3) -> ([i64; 3], [i64; 3]) {
        let mut min = Vec3::splat(f32::INFINITY);
        let mut max = Vec3::splat(f32::NEG_INFINITY);
        for corner in 0..8 {
            let pick = |bit: usize, a: f32, b: f32| if corner >> bit & 1 == 0 { a } else { b };
            let v = Vec3::new(
                pick(0, lo.x, hi.x),
                pick(1, lo.y, hi.y),
                pick(2, lo.z, hi.z),
            );
            let mine = self.object_to_voxel.transform_point3(other.object_point(v));
            min = min.min(mine);
            max = max.max(mine);
        }
        let lo = min.floor() - Vec3::ONE;
        let hi = max.ceil() + Vec3::ONE;
        let to_i = |v: Vec3| [v.x, v.y, v.z].map(|x| x.clamp(-1e9, 1e9) as i64);
        (to_i(lo), to_i(hi))
    }

    /// Object coordinates → voxel coordinates.
    pub fn object_to_voxel(&self) -> Affine3A {
        self.object_to_voxel
    }

    /// Object coordinates of voxel coordinates `v`.
    pub fn object_point(&self, v: Vec3) -> Vec3 {
        self.voxel_to_object.transform_point3(v)
    }
}

/// The grids of one Volume object, and the bound of its medium's extinction over blocks of
/// them (set once the material is known: `Scene::bound_volumes`).
#[derive(Debug, Default)]
pub struct VolumeGrids {
    pub grids: Vec<Grid>,
    pub majorant: Option<MajorantGrid>,
    /// The medium's density is per unit of world length (Blender's volume space "World"),
    /// not of the object's own ("Object", the default: `Scene::object_space_density`).
    pub world_space: bool,
    /// Where the medium is; `None`: the whole box.
    pub extent: Option<MediumExtent>,
    /// Each lookup reads one voxel drawn by the trilinear weights (`Grid::sample_one_voxel`),
    /// as Blender 5 interpolates; else trilinear (Blender 4).
    pub stochastic: bool,
}

/// Which part of a Volume object's box holds its medium, as Cycles bounds it. Both rules
/// start from the voxels of the grids its material reads whose value reaches the volume's
/// Clipping (Blender's `volume.render.clipping`), grown by one voxel to each face neighbour
/// (linear interpolation's reach); outside the part, a tree that does not follow the grids (a
/// constant emission) has no medium.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExtentRule {
    /// Every OpenVDB leaf node (8³ voxels, at index multiples of 8) holding one of those
    /// voxels: the mesh Cycles 4 builds, and Cycles 5 when it ray-marches volumes.
    Leaves,
    /// The bounding box of those voxels: the mesh Cycles 5 builds for its unbiased (null
    /// scattering) volumes.
    Bounds,
}

/// The part of a Volume object that holds its medium (`ExtentRule`): cells of whole voxels
/// in the grids' index space, each holding medium or not.
#[derive(Debug)]
pub struct MediumExtent {
    /// Object coordinates → the grids' OpenVDB index coordinates (voxel `i` spans `i..i + 1`).
    pub object_to_index: Affine3A,
    /// Where the first cell starts (an index), each cell's edge in voxels and the cells per
    /// axis.
    pub start: [i64; 3],
    pub cell: [i64; 3],
    pub dims: [usize; 3],
    /// Whether each cell holds medium, x fastest.
    pub mask: Vec<bool>,
}

/// Voxels per OpenVDB leaf node edge.
const LEAF: i64 = 8;

impl MediumExtent {
    /// The part of the voxels at `indices` (OpenVDB index coordinates), each grown by one
    /// voxel to its face neighbours, that `rule` makes; `None` when there are none.
    pub fn of_voxels(
        rule: ExtentRule,
        object_to_index: Affine3A,
        indices: impl Iterator<Item = [i64; 3]>,
    ) -> Option<MediumExtent> {
        match rule {
            ExtentRule::Leaves => Self::leaves(object_to_index, indices),
            ExtentRule::Bounds => Self::bounds(object_to_index, indices),
        }
    }

    fn leaves(
        object_to_index: Affine3A,
        indices: impl Iterator<Item = [i64; 3]>,
    ) -> Option<MediumExtent> {
        let mut leaves = std::collections::HashSet::new();
        for v in indices {
            leaves.insert(v.map(|i| i.div_euclid(LEAF)));
            for a in 0..3 {
                for step in [-1, 1] {
                    let mut n = v;
                    n[a] += step;
                    leaves.insert(n.map(|i| i.div_euclid(LEAF)));
                }
            }
        }
        let first = [0, 1, 2].map(|a| leaves.iter().map(|l| l[a]).min());
        let last = [0, 1, 2].map(|a| leaves.iter().map(|l| l[a]).max());
        let first = [first[0]?, first[1]?, first[2]?];
        let dims = [0, 1, 2].map(|a| (last[a].unwrap_or(first[a]) - first[a] + 1) as usize);
        let mut mask = vec![false; dims.iter().product()];
        for l in leaves {
            let [x, y, z] = [0, 1, 2].map(|a| (l[a] - first[a]) as usize);
            mask[(z * dims[1] + y) * dims[0] + x] = true;
        }
        Some(MediumExtent {
            object_to_index,
            start: first.map(|f| f * LEAF),
            cell: [LEAF; 3],
            dims,
            mask,
        })
    }

    /// One cell: from the lowest voxel less one to the highest plus one, per axis.
    fn bounds(
        object_to_index: Affine3A,
        indices: impl Iterator<Item = [i64; 3]>,
    ) -> Option<MediumExtent> {
        let mut range: Option<([i64; 3], [i64; 3])> = None;
        for v in indices {
            let (lo, hi) = range.get_or_insert((v, v));
            for a in 0..3 {
                lo[a] = lo[a].min(v[a]);
                hi[a] = hi[a].max(v[a]);
            }
        }
        let (lo, hi) = range?;
        Some(MediumExtent {
            object_to_index,
            start: lo.map(|i| i - 1),
            cell: [0, 1, 2].map(|a| hi[a] - lo[a] + 3),
            dims: [1; 3],
            mask: vec![true],
        })
    }

    /// Nothing holds medium: the grids read have no voxel at or above the clipping value (as
    /// Cycles builds no volume from them).
    pub fn none(object_to_index: Affine3A) -> MediumExtent {
        MediumExtent {
            object_to_index,
            start: [0; 3],
            cell: [1; 3],
            dims: [0; 3],
            mask: Vec::new(),
        }
    }

    /// Whether object point `p` lies in a cell that holds medium.
    pub fn contains(&self, p: Vec3) -> bool {
        let index = self.object_to_index.transform_point3(p);
        let mut at = [0usize; 3];
        for a in 0..3 {
            let k = ((index[a] as f64 - self.start[a] as f64) / self.cell[a] as f64).floor();
            if !(k >= 0.0 && k < self.dims[a] as f64) {
                return false;
            }
            at[a] = k as usize;
        }
        self.mask[(at[2] * self.dims[1] + at[1]) * self.dims[0] + at[0]]
    }
}

/// A bound of a medium's extinction over blocks of voxels of one grid: constant in each block,
/// the first and last blocks of each axis reaching on over a margin of a block (interpolation
/// past the grid's edge only fades towards zero, and the medium's extent is grown by one voxel),
/// zero beyond it.
#[derive(Debug)]
pub struct MajorantGrid {
    /// Blocks per axis.
    pub blocks: [usize; 3],
    /// Voxels per block edge.
    pub edge: [usize; 3],
    /// The bound per block, x fastest.
    pub values: Vec<f32>,
    /// Object coordinates → the grid's voxel coordinates (block k of axis a covers
    /// [k × edge[a], (k + 1) × edge[a])).
    pub object_to_voxel: Affine3A,
}

impl MajorantGrid {
    /// The bound along the ray `origin + t dir` (object coordinates) at `t`, and where along
    /// the ray it stops holding (the ray leaves the block; infinite when it never does).
    pub fn along(&self, origin: Vec3, dir: Vec3, t: f32) -> (f32, f32) {
        if self.values.is_empty() {
            return (0.0, f32::INFINITY); // the blocks of a grid without voxels
        }
        let o = self.object_to_voxel.transform_point3(origin);
        let d = self.object_to_voxel.transform_vector3(dir);
        // Past the blocks by more than a block on any axis nothing is interpolated from the
        // grid's voxels, nor is any cell of the medium's extent there: no bound, until the ray
        // reaches that padded box (if it does).
        let (enter, leave) = self.padded_span(o, d);
        if t < enter {
            return (0.0, enter);
        }
        if !(t < leave) {
            return (0.0, f32::INFINITY);
        }
        let p = o + t * d;
        let mut index = [0usize; 3];
        let mut end = f32::INFINITY;
        for a in 0..3 {
            let e = self.edge[a] as f32;
            let last = self.blocks[a] - 1;
            let k = ((p[a] / e).floor().max(0.0) as usize).min(last);
            index[a] = k;
            let wall = if d[a] > 0.0 && k < last {
                Some((k + 1) as f32 * e)
            } else if d[a] < 0.0 && k > 0 {
                Some(k as f32 * e)
            } else {
                None
            };
            if let Some(wall) = wall {
                end = end.min((wall - o[a]) / d[a]);
            }
        }
        end = end.min(leave);
        // Rounding can put the wall behind `t`: step past it.
        if !(end > t) {
            end = t + 1e-5 * (1.0 + t.abs());
        }
        let [bx, by, _] = self.blocks;
        (self.values[(index[2] * by + index[1]) * bx + index[0]], end)
    }
}

impl MajorantGrid {
    /// Where the ray `o + t d` (voxel coordinates) is within the blocks grown by a block (at
    /// least two voxels) on every side: (enter, leave), empty (enter ≥ leave) when it misses
    /// them.
    fn padded_span(&self, o: Vec3, d: Vec3) -> (f32, f32) {
        let (mut enter, mut leave) = (f32::NEG_INFINITY, f32::INFINITY);
        for a in 0..3 {
            let e = self.edge[a] as f32;
            let pad = e.max(2.0);
            let (lo, hi) = (-pad, self.blocks[a] as f32 * e + pad);
            if d[a] == 0.0 {
                if !(o[a] >= lo && o[a] <= hi) {
                    return (f32::INFINITY, f32::INFINITY);
                }
                continue;
            }
            let (t0, t1) = ((lo - o[a]) / d[a], (hi - o[a]) / d[a]);
            enter = enter.max(t0.min(t1));
            leave = leave.min(t0.max(t1));
        }
        (enter, leave)
    }
}

impl VolumeGrids {
    /// The grid called `name`.
    pub fn get(&self, name: &str) -> Option<&Grid> {
        self.grids.iter().find(|g| g.name == name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> Grid {
        // 4 × 2 × 2 voxels of value x, voxels 0.5 apart from (1, 0, 0).
        let values = (0..16).map(|i| (i % 4) as f32).collect();
        let to_object =
            Mat4::from_translation(Vec3::new(1.0, 0.0, 0.0)) * Mat4::from_scale(Vec3::splat(0.5));
        Grid::new("density".into(), 1, [4, 2, 2], values, to_object).unwrap()
    }

    #[test]
    fn samples_interpolate_between_voxel_centres() {
        let g = ramp();
        assert_eq!(g.sample(Vec3::new(1.0, 0.0, 0.0)).x, 0.0);
        assert!((g.sample(Vec3::new(1.75, 0.25, 0.25)).x - 1.5).abs() < 1e-6);
        // Halfway past the last voxel the value falls towards the zero outside.
        assert!((g.sample(Vec3::new(2.75, 0.0, 0.0)).x - 1.5).abs() < 1e-6);
        assert_eq!(
            g.sample(Vec3::new(-5.0, 0.0, 0.0)),
            Vec4::new(0.0, 0.0, 0.0, 1.0)
        );
    }

    /// A grid without voxels (a fluid's flame before anything burns) is zero everywhere, and
    /// so are its majorant's blocks; no leaf holds medium.
    #[test]
    fn an_empty_grid_is_zero_everywhere() {
        let g = Grid::new("flame".into(), 1, [0, 0, 0], Vec::new(), Mat4::IDENTITY).unwrap();
        assert_eq!(g.max_over([-4, -4, -4], [4, 4, 4]), Vec3::ZERO);
        assert_eq!(g.sample(Vec3::ZERO).x, 0.0);
        let blocks = MajorantGrid {
            blocks: [0; 3],
            edge: [1; 3],
            values: Vec::new(),
            object_to_voxel: Affine3A::IDENTITY,
        };
        assert_eq!(blocks.along(Vec3::ZERO, Vec3::X, 0.0), (0.0, f32::INFINITY));
        assert!(!MediumExtent::none(Affine3A::IDENTITY).contains(Vec3::ZERO));
    }

    /// Leaves (8³ voxels at index multiples of 8) hold the medium where an active voxel or a
    /// face neighbour of one lies, and nowhere else.
    #[test]
    fn active_leaves_are_the_leaves_of_the_voxels_and_their_neighbours() {
        // Object coordinates are index coordinates halved.
        let object_to_index = Affine3A::from_scale(Vec3::splat(2.0));
        let voxels = [[0, 0, 0], [20, 3, 3]];
        let leaves =
            MediumExtent::of_voxels(ExtentRule::Leaves, object_to_index, voxels.into_iter())
                .unwrap();
        let at = |i: [f32; 3]| leaves.contains(Vec3::from(i) * 0.5);
        assert!(at([3.0, 3.0, 3.0]) && at([7.9, 0.0, 0.0]));
        // Voxel 0's neighbour −1 lies in leaf −1; leaf 1 (indices 8..16) holds nothing.
        assert!(at([-0.5, 0.0, 0.0]) && at([-8.0, 0.0, 0.0]));
        assert!(!at([12.0, 3.0, 3.0]) && !at([3.0, 12.0, 3.0]));
        assert!(at([16.0, 0.0, 0.0]) && at([23.9, 7.0, 7.0]));
        assert!(!at([30.0, 3.0, 3.0]) && !at([f32::NAN, 0.0, 0.0]));
        let none = std::iter::empty();
        assert!(MediumExtent::of_voxels(ExtentRule::Leaves, object_to_index, none).is_none());
    }

    /// A lookup of one voxel drawn by the trilinear weights returns one of the eight voxels'
    /// values, each as often as its weight: over many draws the mean is the trilinear value.
    #[test]
    fn one_voxel_lookups_average_to_the_trilinear_value() {
        let g = ramp();
        let p = Vec3::new(1.6, 0.2, 0.1); // voxel coordinates (1.2, 0.4, 0.2): value 1.2
        let exact = g.sample(p).x;
        let mut rng = crate::rng::Rng::new(7);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let u = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
            let v = g.sample_one_voxel(p, u).x;
            assert!(v == v.round(), "a voxel's own value, not a blend: {v}");
            sum += f64::from(v);
        }
        let mean = sum / f64::from(n);
        assert!(
            (mean - f64::from(exact)).abs() < 0.01,
            "{mean} against {exact}"
        );
    }

    /// The bounds rule holds the medium in the box from the lowest voxel less one to the
    /// highest plus one (voxel `i` spanning indices `i..i + 1`), leaves or not.
    #[test]
    fn bounds_are_the_box_of_the_voxels_grown_by_one() {
        let object_to_index = Affine3A::from_scale(Vec3::splat(2.0));
        let voxels = [[0, 0, 0], [2, 0, 0]];
        let bounds =
            MediumExtent::of_voxels(ExtentRule::Bounds, object_to_index, voxels.into_iter())
                .unwrap();
        let at = |i: [f32; 3]| bounds.contains(Vec3::from(i) * 0.5);
        assert!(at([-1.0, -1.0, -1.0]) && at([3.99, 1.99, 1.99]) && at([1.5, 0.5, 0.5]));
        assert!(!at([-1.01, 0.0, 0.0]) && !at([4.0, 0.0, 0.0]) && !at([0.0, 2.0, 0.0]));
        assert!(!at([0.0, 0.0, f32::NAN]));
        let none = std::iter::empty();
        assert!(MediumExtent::of_voxels(ExtentRule::Bounds, object_to_index, none).is_none());
    }

    #[test]
    fn the_bound_over_a_box_holds_every_sample_in_it() {
        let g = ramp();
        assert_eq!(g.max_over([0, 0, 0], [1, 1, 1]).x, 1.0);
        assert_eq!(g.max_over([-3, -3, -3], [9, 9, 9]).x, 3.0);
    }

    #[test]
    fn a_ray_steps_through_the_majorant_blocks_it_crosses() {
        let m = MajorantGrid {
            blocks: [3, 1, 1],
            edge: [2, 2, 2],
            values: vec![1.0, 5.0, 2.0],
            object_to_voxel: Affine3A::from_scale(Vec3::splat(2.0)),
        };
        // Voxel x = 2 t − 1: block 0 until t = 1.5, block 1 until 2.5, block 2 on over its
        // margin of a block (to voxel 8) until t = 4.5, nothing after.
        let origin = Vec3::new(-0.5, 0.2, 0.2);
        let x = Vec3::X;
        assert_eq!(m.along(origin, x, 0.0), (1.0, 1.5));
        assert_eq!(m.along(origin, x, 1.5), (5.0, 2.5));
        assert_eq!(m.along(origin, x, 2.5), (2.0, 4.5));
        assert_eq!(m.along(origin, x, 4.5), (0.0, f32::INFINITY));
        // Backwards from the far side (voxel 20): nothing until the margin at voxel 8, t = 6,
        // then the last block until its wall at voxel 4.
        assert_eq!(m.along(Vec3::new(10.0, 0.0, 0.0), -x, 0.0), (0.0, 6.0));
        assert_eq!(m.along(Vec3::new(10.0, 0.0, 0.0), -x, 6.0), (2.0, 8.0));
        // A ray that passes beside the blocks and their margin meets no bound.
        assert_eq!(
            m.along(Vec3::new(0.0, 5.0, 0.0), x, 0.0),
            (0.0, f32::INFINITY)
        );
    }

    #[test]
    fn grids_whose_values_do_not_fill_the_box_are_refused() {
        assert!(Grid::new("d".into(), 1, [2, 2, 2], vec![0.0; 7], Mat4::IDENTITY).is_none());
        assert!(Grid::new("d".into(), 2, [1, 1, 1], vec![0.0; 2], Mat4::IDENTITY).is_none());
        assert!(Grid::new("d".into(), 1, [1, 1, 1], vec![0.0], Mat4::ZERO).is_none());
    }
}
