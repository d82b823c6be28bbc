//! The photon map of Jensen's "Biased Monte Carlo Ray Tracing" notes (2000, "Photon maps": the
//! photon map data structure) and of "Realistic Image Synthesis Using Photon Mapping" (2001,
//! §6.3–6.4): compact photons in a left-balanced kd-tree stored as a flat array in heap order,
//! with k-nearest-neighbour search. Depends only on math, so it is tested on its own.
//!
//! A photon is 24 bytes: position (3 × f32), power as Ward's shared-exponent RGBE (4 bytes),
//! incoming direction as two bytes (θ, φ), the kd split axis and flags, and the surface normal
//! as two more bytes (θ, φ; for Christensen's precomputed irradiance, see
//! `integrator::photon`), padded to the f32 alignment. The tree is built by
//! splitting on the largest extent of each subtree's bounding box at the left-balanced median
//! (found by selection, `select_nth_unstable_by`), so node `i` has children `2i+1` and `2i+2` and
//! no pointers are stored. Search keeps a bounded max-heap of squared distances and shrinks the
//! search radius to the k-th distance once the heap is full; a single-nearest search with a
//! filter (`nearest_accepted`) needs no heap.

use crate::math::Vec3;
use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::f32::consts::PI;

/// Flag: the photon arrived straight from a light (first hit).
const FLAG_DIRECT: u8 = 1 << 2;
/// Flag: the photon's path is light → specular+ → this surface (a caustic photon).
const FLAG_CAUSTIC: u8 = 1 << 3;
/// Bits 4–7 hold the number of bounces before the hit, saturated at 15.
const BOUNCE_SHIFT: u8 = 4;

/// One stored photon (24 bytes).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Photon {
    pub position: [f32; 3],
    rgbe: [u8; 4],
    theta: u8,
    phi: u8,
    /// Bits 0–1: kd split axis; bit 2 direct; bit 3 caustic; bits 4–7 bounces.
    flags: u8,
    normal: [u8; 2],
    /// A precomputed-irradiance record's reach (`with_reach`); 0 for photons.
    reach: [u8; 2],
    _pad: u8,
}

impl Photon {
    /// A photon at `position` carrying `power` (W) that arrived from direction `wi` (unit,
    /// pointing away from the surface, towards where the photon came from); `bounces` is the
    /// number of surfaces it scattered from before this hit (0: straight from the light).
    pub fn new(position: Vec3, power: Vec3, wi: Vec3, bounces: u32, caustic: bool) -> Photon {
        let (theta, phi) = encode_direction(wi);
        let mut flags = (bounces.min(15) as u8) << BOUNCE_SHIFT;
        if bounces == 0 {
            flags |= FLAG_DIRECT;
        }
        if caustic {
            flags |= FLAG_CAUSTIC;
        }
        Photon {
            position: position.to_array(),
            rgbe: encode_rgbe(power),
            theta,
            phi,
            flags,
            normal: [theta, phi],
            reach: [0; 2],
            _pad: 0,
        }
    }

    /// The same photon with the surface normal `n` (unit) recorded; without it the normal is
    /// the incoming direction.
    pub fn with_normal(mut self, n: Vec3) -> Photon {
        let (t, p) = encode_direction(n);
        self.normal = [t, p];
        self
    }

    /// This record's reach: the radius of the estimate it holds, as a fraction in [0, 1] of the
    /// maximum search radius (quantised to 16 bits).
    pub fn with_reach(mut self, fraction: f32) -> Photon {
        let q = (fraction.clamp(0.0, 1.0) * u16::MAX as f32).round() as u16;
        self.reach = q.to_le_bytes();
        self
    }

    /// The fraction `with_reach` stored.
    pub fn reach(&self) -> f32 {
        u16::from_le_bytes(self.reach) as f32 / u16::MAX as f32
    }

    /// The recorded surface normal (quantised to two bytes).
    pub fn normal(&self) -> Vec3 {
        decode_direction(self.normal[0], self.normal[1])
    }

    pub fn position(&self) -> Vec3 {
        Vec3::from_array(self.position)
    }

    pub fn power(&self) -> Vec3 {
        decode_rgbe(self.rgbe)
    }

    /// Unit direction towards where the photon came from.
    pub fn incoming(&self) -> Vec3 {
        decode_direction(self.theta, self.phi)
    }

    pub fn is_direct(&self) -> bool {
        self.flags & FLAG_DIRECT != 0
    }

    pub fn is_caustic(&self) -> bool {
        self.flags & FLAG_CAUSTIC != 0
    }

    /// Bounces before this hit (saturated at 15).
    pub fn bounces(&self) -> u32 {
        (self.flags >> BOUNCE_SHIFT) as u32
    }

    fn axis(&self) -> usize {
        (self.flags & 3) as usize
    }

    fn set_axis(&mut self, axis: usize) {
        self.flags = (self.flags & !3) | (axis as u8 & 3);
    }
}

/// Ward's shared-exponent encoding (Graphics Gems II, "Real pixels"), rounding to nearest: the
/// largest component keeps 8 bits of mantissa, so every component's error is at most half a
/// step, below 1/256 of the largest component; zero stays zero.
pub fn encode_rgbe(c: Vec3) -> [u8; 4] {
    let c = c.max(Vec3::ZERO);
    let v = c.max_element();
    if !(v > 1e-32) || !v.is_finite() {
        return [0; 4];
    }
    // v = m · 2^e with m in [0.5, 1); bump e when rounding would carry the mantissa to 256.
    let mut e = v.log2().floor() as i32 + 1;
    while (v * (256.0 / 2f32.powi(e))).round() >= 256.0 {
        e += 1;
    }
    let e = e.clamp(-127, 127);
    let scale = 256.0 / 2f32.powi(e);
    let q = |x: f32| (x * scale).round().min(255.0) as u8;
    [q(c.x), q(c.y), q(c.z), (e + 128) as u8]
}

/// Inverse of `encode_rgbe`.
pub fn decode_rgbe(b: [u8; 4]) -> Vec3 {
    if b[3] == 0 {
        return Vec3::ZERO;
    }
    let f = 2f32.powi(b[3] as i32 - 128 - 8);
    Vec3::new(b[0] as f32, b[1] as f32, b[2] as f32) * f
}

/// A unit direction as (θ, φ) bytes: 256 steps of θ ∈ [0, π] and of φ ∈ [0, 2π).
pub fn encode_direction(d: Vec3) -> (u8, u8) {
    let theta = d.z.clamp(-1.0, 1.0).acos();
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let t = (theta * (256.0 / PI)).floor().clamp(0.0, 255.0) as u8;
    let p = ((phi * (256.0 / (2.0 * PI))).floor() as i32).rem_euclid(256) as u8;
    (t, p)
}

/// Sines and cosines of the 256 cell centres of θ and of φ, computed once: decoding is on the
/// path of every photon lookup, and two `sin_cos` calls per photon cost more than the lookup's
/// distance test (Jensen's notes suggest the same tables).
struct DirectionTables {
    theta: [(f32, f32); 256],
    phi: [(f32, f32); 256],
}

static DIRECTION_TABLES: std::sync::LazyLock<DirectionTables> = std::sync::LazyLock::new(|| {
    let mut t = DirectionTables {
        theta: [(0.0, 0.0); 256],
        phi: [(0.0, 0.0); 256],
    };
    for i in 0..256 {
        t.theta[i] = ((i as f32 + 0.5) * (PI / 256.0)).sin_cos();
        t.phi[i] = ((i as f32 + 0.5) * (2.0 * PI / 256.0)).sin_cos();
    }
    t
});

/// Inverse of `encode_direction` at the centre of the cell: the angular error is at most about
/// √((π/512)² + (π/256)²) ≈ 0.0137 rad.
pub fn decode_direction(theta: u8, phi: u8) -> Vec3 {
    let tables = &*DIRECTION_TABLES;
    let (st, ct) = tables.theta[theta as usize];
    let (sp, cp) = tables.phi[phi as usize];
    Vec3::new(st * cp, st * sp, ct)
}

/// The part of [`t0`, `t1`] where o + t·d lies at or below `plane` (`below`) or at or above
/// it; `None` when empty.
fn clip(o: f32, d: f32, plane: f32, below: bool, t0: f32, t1: f32) -> Option<(f32, f32)> {
    let (a, b) = if d == 0.0 {
        match (o <= plane) == below || o == plane {
            true => (t0, t1),
            false => return None,
        }
    } else {
        let cross = (plane - o) / d;
        // Moving up the axis (d > 0) the segment is below the plane before `cross`.
        match (d > 0.0) == below {
            true => (t0, t1.min(cross)),
            false => (t0.max(cross), t1),
        }
    };
    (a <= b).then_some((a, b))
}

/// Photons in a left-balanced kd-tree (heap order).
#[derive(Clone, Debug, Default)]
pub struct PhotonMap {
    photons: Vec<Photon>,
}

/// Number of nodes in the left subtree of a left-balanced (complete) tree of `n` nodes.
fn left_subtree_size(n: usize) -> usize {
    if n <= 1 {
        return 0;
    }
    let h = usize::BITS - 1 - n.leading_zeros(); // depth of the last level
    let full_above = (1usize << h) - 1;
    let last = n - full_above;
    let half = 1usize << (h - 1);
    (half - 1) + last.min(half)
}

/// Partition `p` in place so that its median (at `left_subtree_size`) splits it on the axis of
/// largest extent, recursively; subtrees are built in parallel when large.
fn partition(p: &mut [Photon]) {
    let n = p.len();
    if n == 0 {
        return;
    }
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for q in p.iter() {
        lo = lo.min(q.position());
        hi = hi.max(q.position());
    }
    let ext = hi - lo;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let m = left_subtree_size(n);
    p.select_nth_unstable_by(m, |a, b| a.position[axis].total_cmp(&b.position[axis]));
    p[m].set_axis(axis);
    let (left, rest) = p.split_at_mut(m);
    let right = &mut rest[1..];
    if n > 50_000 {
        rayon::join(|| partition(left), || partition(right));
    } else {
        partition(left);
        partition(right);
    }
}

/// Copy the partitioned slice into heap order: node `i` at `heap[i]`.
fn to_heap(p: &[Photon], heap: &mut [Photon], i: usize) {
    if p.is_empty() {
        return;
    }
    let m = left_subtree_size(p.len());
    heap[i] = p[m];
    to_heap(&p[..m], heap, 2 * i + 1);
    to_heap(&p[m + 1..], heap, 2 * i + 2);
}

/// Which of two halves photon `index` of a map belongs to (`PhotonMap::nearest_split`): a hash
/// of the index, because the kd-tree's heap order puts left and right children, which lie on
/// either side of their parent's plane, at odd and even indices.
pub fn in_first_half(index: usize) -> bool {
    let mut x = index as u64;
    x = (x ^ (x >> 31)).wrapping_mul(0x7fb5_d329_728e_a185);
    x = (x ^ (x >> 27)).wrapping_mul(0x81da_def4_bc2d_d44d);
    (x ^ (x >> 33)) & 1 == 0
}

/// One neighbour found by `PhotonMap::nearest`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbor {
    pub dist2: f32,
    pub index: u32,
}

impl Eq for Neighbor {}
impl PartialOrd for Neighbor {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Neighbor {
    fn cmp(&self, other: &Self) -> Ordering {
        self.dist2
            .total_cmp(&other.dist2)
            .then(self.index.cmp(&other.index))
    }
}

/// The result buffer of a k-nearest search (reused between queries to avoid allocation).
#[derive(Clone, Debug, Default)]
pub struct Neighbors {
    heap: BinaryHeap<Neighbor>,
    k: usize,
    /// Current squared search radius: the maximum, shrunk to the k-th distance once full.
    pub radius2: f32,
}

impl Neighbors {
    pub fn len(&self) -> usize {
        self.heap.len()
    }

    pub fn is_empty(&self) -> bool {
        self.heap.is_empty()
    }

    /// True when k photons were found (`radius2` is then the k-th squared distance).
    pub fn is_full(&self) -> bool {
        self.heap.len() >= self.k
    }

    pub fn iter(&self) -> impl Iterator<Item = &Neighbor> {
        self.heap.iter()
    }

    /// The photon on the search circle when k were found (it set `radius2`), else `None`.
    pub fn boundary(&self) -> Option<u32> {
        self.heap.peek().filter(|_| self.is_full()).map(|n| n.index)
    }

    fn offer(&mut self, n: Neighbor) {
        if self.heap.len() < self.k {
            self.heap.push(n);
        } else if let Some(mut top) = self.heap.peek_mut() {
            if n < *top {
                *top = n;
            }
        }
        if self.heap.len() == self.k {
            if let Some(top) = self.heap.peek() {
                self.radius2 = top.dist2;
            }
        }
    }
}

impl PhotonMap {
    /// Balance `photons` into a kd-tree.
    pub fn build(mut photons: Vec<Photon>) -> PhotonMap {
        partition(&mut photons);
        let mut heap = photons.clone();
        to_heap(&photons, &mut heap, 0);
        PhotonMap { photons: heap }
    }

    pub fn len(&self) -> usize {
        self.photons.len()
    }

    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }

    /// All photons, in heap order.
    pub fn photons(&self) -> &[Photon] {
        &self.photons
    }

    /// Find the (at most) `k` photons nearest to `p` within squared distance `max_dist2`.
    pub fn nearest(&self, p: Vec3, k: usize, max_dist2: f32, out: &mut Neighbors) {
        self.nearest_where(p, k, max_dist2, out, |_| true);
    }

    /// `nearest` among the photons `accept` takes: rejected photons never shrink the radius,
    /// so the k found are the k nearest accepted ones (e.g. on the same side of a surface).
    pub fn nearest_where(
        &self,
        p: Vec3,
        k: usize,
        max_dist2: f32,
        out: &mut Neighbors,
        accept: impl Fn(&Photon) -> bool,
    ) {
        out.heap.clear();
        out.k = k;
        out.radius2 = max_dist2;
        if k == 0 {
            return;
        }
        self.search(p, max_dist2, |index, dist2| {
            if accept(&self.photons[index]) {
                out.offer(Neighbor {
                    dist2,
                    index: index as u32,
                });
            }
            out.radius2
        });
    }

    /// Two independent samples of the photons around `p` in one search: the `k` nearest to `p`
    /// within `max_dist2` among the accepted photons of the first half (`in_first_half`) go to
    /// `first`, and every accepted photon of the second half closer than the first half's k-th
    /// to `second`. The halves are disjoint, so what the second half holds inside the radius is
    /// independent of the radius itself.
    pub fn nearest_split(
        &self,
        p: Vec3,
        k: usize,
        max_dist2: f32,
        first: &mut Neighbors,
        second: &mut Vec<Neighbor>,
        accept: impl Fn(&Photon) -> bool,
    ) {
        first.heap.clear();
        first.k = k;
        first.radius2 = max_dist2;
        second.clear();
        if k == 0 {
            return;
        }
        self.search(p, max_dist2, |index, dist2| {
            if accept(&self.photons[index]) {
                let n = Neighbor {
                    dist2,
                    index: index as u32,
                };
                match in_first_half(index) {
                    true => first.offer(n),
                    false => second.push(n),
                }
            }
            first.radius2
        });
        let r2 = first.radius2;
        second.retain(|n| n.dist2 < r2);
    }

    /// The photon nearest to `p` within squared distance `max_dist2` among those `accept`
    /// takes (called with the photon and its squared distance), as (index, squared distance).
    /// The filter runs inside the search, so the radius shrinks only on accepted photons.
    pub fn nearest_accepted(
        &self,
        p: Vec3,
        max_dist2: f32,
        accept: impl Fn(&Photon, f32) -> bool,
    ) -> Option<(u32, f32)> {
        let mut best = (u32::MAX, max_dist2);
        self.search(p, max_dist2, |index, dist2| {
            if accept(&self.photons[index], dist2) {
                best = (index as u32, dist2);
            }
            best.1
        });
        (best.0 != u32::MAX).then_some(best)
    }

    /// Every photon whose disc of radius `radius` about it, facing the segment from `origin`
    /// along unit `dir` over [0, `length`], the segment crosses: whose projection `t` on the
    /// segment's line lies in [0, `length`] and whose squared distance `dist2` from the line is
    /// below `radius`², passed to `visit(photon, t, dist2)` (the beam query of Jarosz, Zwicker &
    /// Jensen 2008). The segment is clipped to each subtree's side of its split plane widened
    /// by `radius`, as a ray traverses a kd-tree; a subtree whose clipped part is empty is
    /// skipped.
    pub fn along_segment(
        &self,
        origin: Vec3,
        dir: Vec3,
        length: f32,
        radius: f32,
        mut visit: impl FnMut(&Photon, f32, f32),
    ) {
        let n = self.photons.len();
        if n == 0 || !(length > 0.0) || !(radius > 0.0) {
            return;
        }
        let (o, d) = (origin.to_array(), dir.to_array());
        let radius2 = radius * radius;
        // (node, the segment's part [t0, t1] that may come within `radius` of its subtree).
        // Each node pops one entry and pushes at most two, so the stack holds at most the
        // tree's depth plus one.
        let mut stack = [(0u32, 0.0f32, 0.0f32); 66];
        stack[0] = (0, 0.0, length);
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (i, t0, t1) = stack[top];
            let i = i as usize;
            let ph = &self.photons[i];
            let v = ph.position() - origin;
            let t = v.dot(dir);
            if (0.0..=length).contains(&t) {
                let dist2 = v.length_squared() - t * t;
                if dist2 < radius2 {
                    visit(ph, t, dist2);
                }
            }
            let left = 2 * i + 1;
            if left >= n {
                continue;
            }
            let axis = ph.axis();
            let split = ph.position[axis];
            // Where the segment lies at or below split + radius (the left subtree's side),
            // and at or above split − radius (the right subtree's).
            // A little wider than the radius, for rounding in the crossing distances.
            let widen = radius * (1.0 + 1e-4) + 1e-6 * split.abs();
            let below = clip(o[axis], d[axis], split + widen, true, t0, t1);
            let above = clip(o[axis], d[axis], split - widen, false, t0, t1);
            for (child, part) in [(left, below), (left + 1, above)] {
                if let (true, Some((a, b))) = (child < n, part) {
                    stack[top] = (child as u32, a, b);
                    top += 1;
                }
            }
        }
    }

    /// Jensen's kd-tree search, iterative: every photon closer to `p` than the current squared
    /// radius is passed to `visit(index, dist2)`, which returns the radius from then on. Each
    /// node is tested before its subtrees, the near subtree before the far one, and a far
    /// subtree is skipped when the split plane lies beyond the radius.
    fn search(&self, p: Vec3, max_dist2: f32, mut visit: impl FnMut(usize, f32) -> f32) {
        let n = self.photons.len();
        if n == 0 {
            return;
        }
        let p = p.to_array();
        let mut radius2 = max_dist2;
        // (node, squared distance from p to the split plane in front of it). Each level leaves
        // at most one far subtree waiting, and a tree of fewer than 2³² photons has at most 32
        // levels.
        let mut stack = [(0u32, 0.0f32); 34];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let (i, plane2) = stack[top];
            if plane2 >= radius2 {
                continue;
            }
            let i = i as usize;
            let ph = &self.photons[i];
            let d = [
                ph.position[0] - p[0],
                ph.position[1] - p[1],
                ph.position[2] - p[2],
            ];
            let dist2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            if dist2 < radius2 {
                radius2 = visit(i, dist2);
            }
            let left = 2 * i + 1;
            if left < n {
                let axis = ph.axis();
                let delta = p[axis] - ph.position[axis];
                let (near, far) = if delta < 0.0 {
                    (left, left + 1)
                } else {
                    (left + 1, left)
                };
                if far < n {
                    stack[top] = (far as u32, delta * delta);
                    top += 1;
                }
                if near < n {
                    stack[top] = (near as u32, 0.0);
                    top += 1;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The beam query finds exactly the photons a brute-force test over all of them finds.
    #[test]
    fn segment_query_matches_brute_force() {
        let mut rng = crate::rng::Rng::new(5);
        let photons: Vec<Photon> = (0..3000)
            .map(|_| {
                let p = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 4.0;
                Photon::new(p, Vec3::ONE, Vec3::Z, 1, false)
            })
            .collect();
        let map = PhotonMap::build(photons);
        for k in 0..200 {
            let origin = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 6.0 - 1.0;
            let mut dir = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 0.5;
            if k % 7 == 0 {
                dir.y = 0.0;
            }
            let dir = dir.normalize();
            let (length, radius) = (1.0 + 4.0 * rng.uniform(), 0.05 + 0.3 * rng.uniform());
            let mut found = Vec::new();
            map.along_segment(origin, dir, length, radius, |ph, _, _| {
                found.push(ph.position)
            });
            let want: Vec<[f32; 3]> = map
                .photons()
                .iter()
                .filter(|ph| {
                    let v = ph.position() - origin;
                    let t = v.dot(dir);
                    (0.0..=length).contains(&t) && v.length_squared() - t * t < radius * radius
                })
                .map(|ph| ph.position)
                .collect();
            let key = |a: &[f32; 3]| (a[0].to_bits(), a[1].to_bits(), a[2].to_bits());
            found.sort_by_key(key);
            let mut want = want;
            want.sort_by_key(key);
            assert_eq!(found, want, "segment {k}");
        }
    }

    #[test]
    fn photon_is_24_bytes() {
        assert_eq!(std::mem::size_of::<Photon>(), 24);
    }

    #[test]
    fn left_subtree_sizes() {
        // n = 1..7: complete trees.
        let expected = [0, 1, 1, 2, 3, 3, 3, 4, 5, 6, 7, 7];
        for (n, &e) in expected.iter().enumerate() {
            assert_eq!(left_subtree_size(n + 1), e, "n = {}", n + 1);
        }
    }
}
