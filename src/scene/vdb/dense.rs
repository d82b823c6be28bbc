//! The dense box a grid is made into: the bounding box of its active voxels and tiles, the
//! size check before allocating, and filling it from tiles and leaves.

use super::format::{damaged, Fault, Parse};
use super::tree::Topology;

/// The inclusive index box of the active voxels and tiles, if any.
pub(super) fn active_box(topology: &Topology) -> Option<[[i64; 3]; 2]> {
    let mut lo = [i64::MAX; 3];
    let mut hi = [i64::MIN; 3];
    let mut grow = |a: [i64; 3], b: [i64; 3]| {
        for k in 0..3 {
            lo[k] = lo[k].min(a[k]);
            hi[k] = hi[k].max(b[k]);
        }
    };
    for tile in topology.tiles.iter().filter(|t| t.active) {
        let extent = (1i64 << tile.log2_extent) - 1;
        grow(tile.origin, tile.origin.map(|o| o + extent));
    }
    for leaf in &topology.leaves {
        for (w, &word) in leaf.mask.iter().enumerate() {
            if word == 0 {
                continue;
            }
            // Word w holds x = w, y = bit / 8, z = bit % 8.
            let (mut y_lo, mut y_hi, mut z_lo, mut z_hi) = (7, 0, 7, 0);
            for b in (0..64).filter(|b| word >> b & 1 != 0) {
                y_lo = y_lo.min(b / 8);
                y_hi = y_hi.max(b / 8);
                z_lo = z_lo.min(b % 8);
                z_hi = z_hi.max(b % 8);
            }
            let o = leaf.origin;
            grow(
                [o[0] + w as i64, o[1] + y_lo, o[2] + z_lo],
                [o[0] + w as i64, o[1] + y_hi, o[2] + z_hi],
            );
        }
    }
    (lo[0] <= hi[0]).then_some([lo, hi])
}

/// The bytes of a dense box from `lo` to `hi` (inclusive), refused past `max_bytes`.
pub(super) fn dense_bytes(
    lo: [i64; 3],
    hi: [i64; 3],
    channels: usize,
    max_bytes: u64,
) -> Parse<u64> {
    if (0..3).any(|k| hi[k] < lo[k]) {
        return damaged("an empty or inverted bounding box");
    }
    let size = [0, 1, 2].map(|k| (hi[k] - lo[k] + 1) as u64);
    let bytes = size
        .iter()
        .try_fold((channels * 4) as u64, |acc, &n| acc.checked_mul(n))
        .unwrap_or(u64::MAX);
    if bytes > max_bytes || lo.iter().chain(&hi).any(|&v| i32::try_from(v).is_err()) {
        return Err(Fault::TooLarge {
            size,
            bytes,
            max_bytes,
        });
    }
    Ok(bytes)
}

/// The dense array being filled.
pub(super) struct Dense {
    lo: [i64; 3],
    hi: [i64; 3],
    pub(super) size: [usize; 3],
    channels: usize,
    pub(super) values: Vec<f32>,
}

impl Dense {
    pub(super) fn new(lo: [i64; 3], hi: [i64; 3], channels: usize, background: &[f32; 3]) -> Dense {
        let size = [0, 1, 2].map(|k| (hi[k] - lo[k] + 1) as usize);
        let voxels = size[0] * size[1] * size[2];
        let mut values = Vec::with_capacity(voxels * channels);
        for _ in 0..voxels {
            values.extend_from_slice(&background[..channels]);
        }
        Dense {
            lo,
            hi,
            size,
            channels,
            values,
        }
    }

    fn index(&self, x: i64, y: i64, z: i64) -> usize {
        let [sx, sy, _] = self.size;
        let local = [x - self.lo[0], y - self.lo[1], z - self.lo[2]].map(|v| v as usize);
        ((local[2] * sy + local[1]) * sx + local[0]) * self.channels
    }

    /// Sets every voxel of the box `a`..=`b` (clipped to the dense box) to `value`.
    pub(super) fn fill(&mut self, a: [i64; 3], b: [i64; 3], value: &[f32]) {
        let lo = [0, 1, 2].map(|k| a[k].max(self.lo[k]));
        let hi = [0, 1, 2].map(|k| b[k].min(self.hi[k]));
        if (0..3).any(|k| lo[k] > hi[k]) {
            return;
        }
        for z in lo[2]..=hi[2] {
            for y in lo[1]..=hi[1] {
                let start = self.index(lo[0], y, z);
                let end = self.index(hi[0], y, z) + self.channels;
                for voxel in self.values[start..end].chunks_exact_mut(self.channels) {
                    voxel.copy_from_slice(value);
                }
            }
        }
    }

    /// Writes a leaf's 8³ values (x slowest, z fastest in the leaf) into the box.
    pub(super) fn leaf(&mut self, origin: [i64; 3], values: &[f32]) {
        let c = self.channels;
        let far = origin.map(|o| o + 7);
        if (0..3).all(|k| origin[k] >= self.lo[k] && far[k] <= self.hi[k]) {
            // Wholly inside: no test per voxel.
            let base = self.index(origin[0], origin[1], origin[2]);
            let (row, slice) = (self.size[0] * c, self.size[0] * self.size[1] * c);
            for (n, value) in values.chunks_exact(c).enumerate() {
                let at = base + (n >> 6) * c + ((n >> 3) & 7) * row + (n & 7) * slice;
                self.values[at..at + c].copy_from_slice(value);
            }
            return;
        }
        for (n, value) in values.chunks_exact(c).enumerate() {
            let x = origin[0] + (n >> 6) as i64;
            let y = origin[1] + ((n >> 3) & 7) as i64;
            let z = origin[2] + (n & 7) as i64;
            if (0..3).all(|k| [x, y, z][k] >= self.lo[k] && [x, y, z][k] <= self.hi[k]) {
                let at = self.index(x, y, z);
                self.values[at..at + c].copy_from_slice(value);
            }
        }
    }
}
