//! The pieces of the OpenVDB file format every part of the reader shares: checked
//! little-endian reads, what a parse step found wrong, the format's constants and node sizes,
//! and the value types of grids.

use super::compression::CodecError;

/// What a parse step found wrong, before it is known which file and grid to name.
#[derive(Debug)]
pub(super) enum Fault {
    NotVdb,
    Version(u32),
    Truncated,
    Damaged(String),
    Unsupported(String),
    TooLarge {
        size: [u64; 3],
        bytes: u64,
        max_bytes: u64,
    },
}

impl From<CodecError> for Fault {
    fn from(error: CodecError) -> Fault {
        match error {
            CodecError::Damaged(what) => Fault::Damaged(what),
            CodecError::Unsupported(what) => Fault::Unsupported(what),
        }
    }
}

pub(super) type Parse<T> = Result<T, Fault>;

pub(super) fn damaged<T>(what: impl Into<String>) -> Parse<T> {
    Err(Fault::Damaged(what.into()))
}

pub(super) const MAGIC: [u8; 8] = [0x20, 0x42, 0x44, 0x56, 0, 0, 0, 0];
/// The first version with per-grid compression and per-array active-mask codes.
pub(super) const OLDEST_VERSION: u32 = 222;
/// The version OpenVDB 6 to 12 write.
pub(super) const NEWEST_VERSION: u32 = 224;
pub(super) const UUID_BYTES: usize = 36;
pub(super) const COMPRESS_ZIP: u32 = 0x1;
pub(super) const COMPRESS_ACTIVE_MASK: u32 = 0x2;
pub(super) const COMPRESS_BLOSC: u32 = 0x4;
/// Appended to the tree type of grids whose floats are stored at half precision.
pub(super) const HALF_FLOAT_SUFFIX: &str = "_HalfFloat";
/// Separates a grid's name from the index OpenVDB appends to make duplicate names unique.
pub(super) const UNIQUE_NAME_SEPARATOR: char = '\u{1e}';

/// Little-endian reads from the file's bytes, each checked against its end.
pub(super) struct Cursor<'a> {
    pub(super) data: &'a [u8],
    pub(super) pos: usize,
}

impl<'a> Cursor<'a> {
    pub(super) fn at(data: &'a [u8], pos: usize) -> Cursor<'a> {
        Cursor { data, pos }
    }

    pub(super) fn take(&mut self, n: usize) -> Parse<&'a [u8]> {
        let end = self.pos.checked_add(n).ok_or(Fault::Truncated)?;
        let bytes = self.data.get(self.pos..end).ok_or(Fault::Truncated)?;
        self.pos = end;
        Ok(bytes)
    }

    pub(super) fn array<const N: usize>(&mut self) -> Parse<[u8; N]> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N)?);
        Ok(out)
    }

    pub(super) fn u8(&mut self) -> Parse<u8> {
        Ok(self.take(1)?[0])
    }

    pub(super) fn u32(&mut self) -> Parse<u32> {
        Ok(u32::from_le_bytes(self.array()?))
    }

    pub(super) fn i32(&mut self) -> Parse<i32> {
        Ok(i32::from_le_bytes(self.array()?))
    }

    pub(super) fn i64(&mut self) -> Parse<i64> {
        Ok(i64::from_le_bytes(self.array()?))
    }

    pub(super) fn f64(&mut self) -> Parse<f64> {
        Ok(f64::from_le_bytes(self.array()?))
    }

    pub(super) fn coord(&mut self) -> Parse<[i64; 3]> {
        Ok([self.i32()? as i64, self.i32()? as i64, self.i32()? as i64])
    }

    pub(super) fn string(&mut self) -> Parse<String> {
        let n = self.u32()? as usize;
        Ok(String::from_utf8_lossy(self.take(n)?).into_owned())
    }

    pub(super) fn leaf_mask(&mut self) -> Parse<[u64; LEAF_WORDS]> {
        let mut mask = [0u64; LEAF_WORDS];
        for (word, bytes) in mask
            .iter_mut()
            .zip(self.take(LEAF_WORDS * 8)?.chunks_exact(8))
        {
            *word = u64::from_le_bytes(bytes.try_into().unwrap_or_default());
        }
        Ok(mask)
    }

    pub(super) fn mask(&mut self, words: usize) -> Parse<Vec<u64>> {
        let bytes = self.take(words * 8)?;
        Ok(bytes
            .chunks_exact(8)
            .map(|w| u64::from_le_bytes([w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7]]))
            .collect())
    }
}

/// What a grid's values are, from its tree type.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum ValueKind {
    Float,
    Vec3,
    /// A type the reader skips but does not read: `bytes` per value, `reals` of them
    /// stored at half precision when the grid is.
    Skipped {
        bytes: usize,
        reals: usize,
    },
    /// Boolean trees: one byte per tile value, leaves as two bit masks.
    Bool,
    /// A tree whose layout the reader does not know (masks, points, strings).
    Opaque,
}

impl ValueKind {
    pub(super) fn of(tree_type: &str) -> ValueKind {
        let Some(value) = tree_type
            .strip_prefix("Tree_")
            .and_then(|t| t.strip_suffix("_5_4_3"))
        else {
            return ValueKind::Opaque;
        };
        match value {
            "float" => ValueKind::Float,
            "vec3s" => ValueKind::Vec3,
            "double" => ValueKind::Skipped { bytes: 8, reals: 1 },
            "vec3d" => ValueKind::Skipped {
                bytes: 24,
                reals: 3,
            },
            "int32" | "uint32" => ValueKind::Skipped { bytes: 4, reals: 0 },
            "int64" => ValueKind::Skipped { bytes: 8, reals: 0 },
            "vec3i" => ValueKind::Skipped {
                bytes: 12,
                reals: 0,
            },
            "bool" => ValueKind::Bool,
            _ => ValueKind::Opaque,
        }
    }

    pub(super) fn channels(self) -> usize {
        match self {
            ValueKind::Vec3 => 3,
            _ => 1,
        }
    }

    /// Bytes of one value at full precision (background, tiles, inactive values).
    pub(super) fn bytes(self) -> usize {
        match self {
            ValueKind::Float => 4,
            ValueKind::Vec3 => 12,
            ValueKind::Skipped { bytes, .. } => bytes,
            ValueKind::Bool | ValueKind::Opaque => 1,
        }
    }

    /// Bytes of one value in a (possibly half-precision) value array.
    pub(super) fn stored_bytes(self, half: bool) -> usize {
        match (self, half) {
            (ValueKind::Float, true) => 2,
            (ValueKind::Vec3, true) => 6,
            (ValueKind::Skipped { reals, .. }, true) if reals > 0 => 2 * reals,
            _ => self.bytes(),
        }
    }
}

pub(super) const LEAF_LOG2: u32 = 3;
pub(super) const LEAF_VOXELS: usize = 1 << (3 * LEAF_LOG2);
pub(super) const LEAF_WORDS: usize = LEAF_VOXELS / 64;
/// log2 of the voxels per axis of the lower and upper internal nodes (4 and 5 levels of
/// children, each child 8³ or 16³ voxels…).
pub(super) const LOWER_LOG2: u32 = 4;
pub(super) const UPPER_LOG2: u32 = 5;
pub(super) const UPPER_EXTENT_LOG2: u32 = UPPER_LOG2 + LOWER_LOG2 + LEAF_LOG2;
