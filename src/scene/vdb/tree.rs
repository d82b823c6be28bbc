//! The tree of one OpenVDB grid (Museth 2013): its topology — root tiles and children, each
//! internal node's masks and tile values, each leaf's value mask — and then the leaves' value
//! buffers, each value array read as `readCompressedValues` writes it (active-mask code,
//! inactive values, selection mask, then raw, zipped or Blosc-compressed values).

use std::ops::Range;

use super::compression::{decompress_blosc, half_to_f32, inflate_zlib};
use super::format::{
    damaged, Cursor, Fault, Parse, ValueKind, COMPRESS_ACTIVE_MASK, COMPRESS_BLOSC, COMPRESS_ZIP,
    LEAF_LOG2, LEAF_VOXELS, LEAF_WORDS, LOWER_LOG2, UPPER_EXTENT_LOG2, UPPER_LOG2,
};

/// A tile: a box of `1 << log2_extent` voxels per axis holding one value.
#[derive(Debug)]
pub(super) struct Tile {
    pub(super) origin: [i64; 3],
    pub(super) log2_extent: u32,
    pub(super) value: [f32; 3],
    pub(super) active: bool,
}

/// A leaf node's origin and value mask (8³ voxels).
pub(super) struct Leaf {
    pub(super) origin: [i64; 3],
    pub(super) mask: [u64; LEAF_WORDS],
}

/// A tree's structure: tiles at every level and the leaves, in the order their buffers follow.
pub(super) struct Topology {
    pub(super) background: [f32; 3],
    pub(super) tiles: Vec<Tile>,
    pub(super) leaves: Vec<Leaf>,
}

/// Reads a tree's topology and buffers, decoding values (float and vec3 trees) or only
/// stepping over them.
pub(super) struct TreeReader<'a, 'c> {
    c: &'c mut Cursor<'a>,
    kind: ValueKind,
    half: bool,
    compression: u32,
    pub(super) decode: bool,
    pub(super) background: [f32; 3],
    /// Decoded bytes of one array (reused).
    bytes: Vec<u8>,
    /// Decoded values of one array, `channels` per value (reused).
    values: Vec<f32>,
}

impl<'a, 'c> TreeReader<'a, 'c> {
    pub(super) fn new(
        c: &'c mut Cursor<'a>,
        kind: ValueKind,
        half: bool,
        compression: u32,
    ) -> Self {
        TreeReader {
            c,
            kind,
            half,
            compression,
            decode: matches!(kind, ValueKind::Float | ValueKind::Vec3),
            background: [0.0; 3],
            bytes: Vec::new(),
            values: Vec::new(),
        }
    }

    /// One full-precision value (zeros when values are skipped).
    fn value(&mut self) -> Parse<[f32; 3]> {
        let bytes = self.c.take(self.kind.bytes())?;
        let mut out = [0.0; 3];
        if self.decode {
            for (o, b) in out.iter_mut().zip(bytes.chunks_exact(4)) {
                *o = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            }
        }
        Ok(out)
    }

    pub(super) fn topology(&mut self) -> Parse<(Topology, Vec<Range<usize>>)> {
        let buffer_count = self.c.i32()?;
        if buffer_count != 1 {
            return damaged(format!("a tree with {buffer_count} buffers"));
        }
        self.background = self.value()?;
        let mut topology = Topology {
            background: self.background,
            tiles: Vec::new(),
            leaves: Vec::new(),
        };
        let tile_count = self.c.u32()?;
        let child_count = self.c.u32()?;
        for _ in 0..tile_count {
            let origin = self.c.coord()?;
            let value = self.value()?;
            let active = self.c.u8()? != 0;
            self.keep_tile(&mut topology, origin, UPPER_EXTENT_LOG2, value, active);
        }
        // The leaves of each root child, with the child's origin: their buffers follow in
        // the order of the children's origins.
        let mut children = Vec::new();
        for _ in 0..child_count {
            let origin = self.c.coord()?;
            let aligned = (1i64 << UPPER_EXTENT_LOG2) - 1;
            if origin.iter().any(|o| o & aligned != 0) {
                return damaged(format!("a root child at {origin:?} is not aligned"));
            }
            let first = topology.leaves.len();
            self.internal(&mut topology, origin, UPPER_LOG2)?;
            children.push((origin, first..topology.leaves.len()));
        }
        children.sort_by_key(|(origin, _)| *origin);
        if children.windows(2).any(|w| w[0].0 == w[1].0) {
            return damaged("two root children at the same place");
        }
        Ok((topology, children.into_iter().map(|(_, r)| r).collect()))
    }

    fn keep_tile(
        &self,
        topology: &mut Topology,
        origin: [i64; 3],
        log2_extent: u32,
        value: [f32; 3],
        active: bool,
    ) {
        if self.decode && (active || value != self.background) {
            topology.tiles.push(Tile {
                origin,
                log2_extent,
                value,
                active,
            });
        }
    }

    /// An internal node of `1 << (3 * log2)` children or tiles, each a lower internal node
    /// (upper nodes) or a leaf (lower nodes).
    fn internal(&mut self, topology: &mut Topology, origin: [i64; 3], log2: u32) -> Parse<()> {
        let count = 1usize << (3 * log2);
        let child_mask = self.c.mask(count / 64)?;
        let value_mask = self.c.mask(count / 64)?;
        self.value_array(count, &value_mask)?;
        let child_log2 = if log2 == UPPER_LOG2 {
            LOWER_LOG2 + LEAF_LOG2
        } else {
            LEAF_LOG2
        };
        let child_origin = |i: usize| {
            let local = [
                i >> (2 * log2),
                (i >> log2) & ((1 << log2) - 1),
                i & ((1 << log2) - 1),
            ];
            [0, 1, 2].map(|a| origin[a] + ((local[a] as i64) << child_log2))
        };
        if self.decode {
            let channels = self.kind.channels();
            for i in 0..count {
                if bit(&child_mask, i) {
                    continue;
                }
                let mut value = [0.0; 3];
                value[..channels].copy_from_slice(&self.values[i * channels..(i + 1) * channels]);
                let active = bit(&value_mask, i);
                self.keep_tile(topology, child_origin(i), child_log2, value, active);
            }
        }
        for i in (0..count).filter(|&i| bit(&child_mask, i)) {
            if log2 == UPPER_LOG2 {
                self.internal(topology, child_origin(i), LOWER_LOG2)?;
            } else {
                topology.leaves.push(Leaf {
                    origin: child_origin(i),
                    mask: self.c.leaf_mask()?,
                });
            }
        }
        Ok(())
    }

    /// One value array of `count` values (`readCompressedValues`): the active-mask code,
    /// the inactive values and selection mask it names, then the stored values. When
    /// decoding, leaves the `count` values in `self.values`.
    fn value_array(&mut self, count: usize, value_mask: &[u64]) -> Parse<()> {
        if self.kind == ValueKind::Bool && count == LEAF_VOXELS {
            // Boolean leaves store their origin and their values as a second bit mask.
            self.c.take(3 * 4 + LEAF_VOXELS / 8)?;
            return Ok(());
        }
        let code = self.c.u8()?;
        let background = self.background;
        let negated = background.map(|v| -v);
        let (mut inactive, mut other_inactive) =
            (if code == 0 { background } else { negated }, background);
        match code {
            0 | 1 | 3 | 6 => {}
            2 | 4 => inactive = self.value()?,
            5 => {
                inactive = self.value()?;
                other_inactive = self.value()?;
            }
            _ => return damaged(format!("unknown value-array code {code}")),
        }
        let selection = if matches!(code, 3..=5) {
            Some(self.c.mask(count / 64)?)
        } else {
            None
        };
        let mask_compressed = self.compression & COMPRESS_ACTIVE_MASK != 0 && code != 6;
        let stored = if mask_compressed {
            value_mask.iter().map(|w| w.count_ones() as usize).sum()
        } else {
            count
        };
        self.stored_values(stored)?;
        if !self.decode || stored == count {
            return Ok(());
        }
        // Spread the active values over the array and rebuild the inactive ones.
        let channels = self.kind.channels();
        let mut full = vec![0.0f32; count * channels];
        let mut next = 0;
        for (i, out) in full.chunks_exact_mut(channels).enumerate() {
            if bit(value_mask, i) {
                out.copy_from_slice(&self.values[next * channels..(next + 1) * channels]);
                next += 1;
            } else if selection.as_ref().is_some_and(|s| bit(s, i)) {
                out.copy_from_slice(&other_inactive[..channels]);
            } else {
                out.copy_from_slice(&inactive[..channels]);
            }
        }
        self.values = full;
        Ok(())
    }

    /// `count` stored values, raw, zipped or Blosc-compressed; decoded into `self.values`.
    /// An empty half-precision array is not written at all (not even its length).
    fn stored_values(&mut self, count: usize) -> Parse<()> {
        if count == 0 && self.half {
            self.values.clear();
            return Ok(());
        }
        let size = count * self.kind.stored_bytes(self.half);
        let compressed = self.compression & (COMPRESS_BLOSC | COMPRESS_ZIP) != 0;
        let raw = if compressed {
            let length = self.c.i64()?;
            if length <= 0 {
                if length.unsigned_abs() != size as u64 {
                    return damaged(format!(
                        "an uncompressed array of {} bytes where {size} are expected",
                        length.unsigned_abs()
                    ));
                }
                Some(self.c.take(size)?)
            } else {
                let chunk = self
                    .c
                    .take(usize::try_from(length).map_err(|_| Fault::Truncated)?)?;
                if self.decode {
                    self.bytes.resize(size, 0);
                    if self.compression & COMPRESS_BLOSC != 0 {
                        decompress_blosc(chunk, &mut self.bytes)?;
                    } else {
                        inflate_zlib(chunk, &mut self.bytes)?;
                    }
                }
                None
            }
        } else {
            Some(self.c.take(size)?)
        };
        if !self.decode {
            return Ok(());
        }
        let bytes = raw.unwrap_or(&self.bytes);
        self.values.clear();
        if self.half {
            self.values.extend(
                bytes
                    .chunks_exact(2)
                    .map(|b| half_to_f32(u16::from_le_bytes([b[0], b[1]]))),
            );
        } else {
            self.values.extend(
                bytes
                    .chunks_exact(4)
                    .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
            );
        }
        Ok(())
    }

    /// The leaves' buffers, in the order `order` gives; `visit` receives each leaf's values
    /// when decoding.
    pub(super) fn buffers(
        &mut self,
        topology: &Topology,
        order: &[Range<usize>],
        mut visit: impl FnMut(&Leaf, &[f32]),
    ) -> Parse<()> {
        for leaf in order.iter().flat_map(|r| &topology.leaves[r.clone()]) {
            if self.c.leaf_mask()? != leaf.mask {
                return damaged("a leaf's value mask differs between topology and buffers");
            }
            self.value_array(LEAF_VOXELS, &leaf.mask)?;
            if self.decode {
                visit(leaf, &self.values);
            }
        }
        Ok(())
    }
}

pub(super) fn bit(mask: &[u64], i: usize) -> bool {
    mask[i / 64] >> (i % 64) & 1 != 0
}
