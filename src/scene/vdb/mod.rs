//! Reading the grids of OpenVDB files (Museth 2013, "VDB: High-resolution sparse volumes with
//! dynamic topology") as Blender writes them — smoke, fire and Geometry Nodes volumes — into
//! dense arrays the renderer samples.
//!
//! The file holds a header, then each grid: a descriptor (name, tree type, an instance parent,
//! stream offsets that are zero when the file was written without them), the grid's compression
//! flags, metadata and transform, the tree's topology (root tiles and children, each internal
//! node's child and value masks and tile values, each leaf's value mask) and then the leaves'
//! value buffers in the same order. Value arrays may leave out inactive values (the "active
//! mask" compression: a per-array code says which inactive values and which selection mask
//! rebuild them) and are stored raw, zipped or Blosc-compressed (`compression`).
//!
//! Only float and vec3 trees of the standard 5-4-3 configuration are read; files are checked
//! as they are read, so a damaged, truncated or foreign file is an error, never a panic, and
//! no buffer is sized from a length field before the length is checked against the file.

mod compression;
#[cfg(test)]
mod tests;

use std::ops::Range;
use std::path::{Path, PathBuf};

use compression::{decompress_blosc, half_to_f32, inflate_zlib, CodecError};

/// One grid of an OpenVDB file, made dense over its active voxels' bounding box.
#[derive(Clone, Debug)]
pub struct VdbGrid {
    pub name: String,
    /// 1 for float grids, 3 for vec3 grids.
    pub channels: usize,
    /// Index-space coordinate of the dense box's first voxel.
    pub origin: [i32; 3],
    /// Voxels per axis of the dense box.
    pub size: [usize; 3],
    /// The values, x fastest: `values[((z * size[1] + y) * size[0] + x) * channels + c]`;
    /// voxels not stored in the file hold the grid's background value.
    pub values: Vec<f32>,
    /// Index space (voxel centres at integer coordinates) to the grid's own space (which
    /// for Blender is the Volume object's local space), a column-major 4×4 affine matrix.
    pub index_to_local: glam::Mat4,
}

/// What went wrong, with a message a user understands (file, grid, what).
#[derive(Debug, thiserror::Error)]
pub enum VdbError {
    /// The file could not be read from disk.
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The file does not start as an OpenVDB file does.
    #[error("{}: not an OpenVDB file", path.display())]
    NotVdb { path: PathBuf },
    /// The file's format version is one this reader does not know.
    #[error(
        "{}: OpenVDB file format version {version} is not supported (versions {OLDEST_VERSION} \
         to {NEWEST_VERSION} are: Blender 2.83 and later)",
        path.display()
    )]
    Version { path: PathBuf, version: u32 },
    /// The file is truncated or inconsistent.
    #[error("{}: {}damaged OpenVDB file: {what}", path.display(), in_grid(grid))]
    Damaged {
        path: PathBuf,
        grid: Option<String>,
        what: String,
    },
    /// The grid uses a feature this reader does not implement (a value type, a transform,
    /// a codec).
    #[error("{}: {}{what} is not supported", path.display(), in_grid(grid))]
    Unsupported {
        path: PathBuf,
        grid: Option<String>,
        what: String,
    },
    /// No grid of that name is in the file.
    #[error("{}: no grid named '{grid}' (the file has {})", path.display(), list(available))]
    NoSuchGrid {
        path: PathBuf,
        grid: String,
        available: Vec<String>,
    },
    /// The grid's dense box would need more memory than allowed.
    #[error(
        "{}: grid '{grid}': its dense box of {}×{}×{} voxels needs {bytes} bytes, more than the \
         {max_bytes} allowed",
        path.display(), size[0], size[1], size[2]
    )]
    TooLarge {
        path: PathBuf,
        grid: String,
        size: [u64; 3],
        bytes: u64,
        max_bytes: u64,
    },
}

fn in_grid(grid: &Option<String>) -> String {
    grid.as_ref()
        .map(|name| format!("grid '{name}': "))
        .unwrap_or_default()
}

fn list(names: &[String]) -> String {
    if names.is_empty() {
        "no grids it can read".into()
    } else {
        names
            .iter()
            .map(|n| format!("'{n}'"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// Grid names and channel counts in the file, without reading voxels. Grids of types the
/// reader cannot read (double, integer, boolean, mask and point grids) are left out.
pub fn grid_names(path: &Path) -> Result<Vec<(String, usize)>, VdbError> {
    grid_names_in(&read_file(path)?, path)
}

/// Reads grid `name`, refusing before allocating when its dense box would need more than
/// `max_bytes` (from the file's bbox metadata or the topology, checked before the buffers).
pub fn read_grid(path: &Path, name: &str, max_bytes: u64) -> Result<VdbGrid, VdbError> {
    read_grid_in(&read_file(path)?, path, name, max_bytes)
}

/// `grid_names` of a file's bytes (`path` names it in errors).
fn grid_names_in(data: &[u8], path: &Path) -> Result<Vec<(String, usize)>, VdbError> {
    let grids = walk_grids(data, |_| false).map_err(|f| f.at(path, None))?;
    Ok(readable(&grids))
}

/// `read_grid` of a file's bytes (`path` names it in errors).
fn read_grid_in(data: &[u8], path: &Path, name: &str, max_bytes: u64) -> Result<VdbGrid, VdbError> {
    let grids = walk_grids(data, |entry| entry.name == name).map_err(|f| f.at(path, None))?;
    let Some(entry) = grids.iter().find(|entry| entry.name == name) else {
        // Walk the rest of the file to name what it holds.
        let available = grid_names_in(data, path)?
            .into_iter()
            .map(|(n, _)| n)
            .collect();
        return Err(VdbError::NoSuchGrid {
            path: path.to_path_buf(),
            grid: name.to_string(),
            available,
        });
    };
    read_entry(data, &grids, entry, max_bytes).map_err(|f| f.at(path, Some(name)))
}

fn read_file(path: &Path) -> Result<Vec<u8>, VdbError> {
    std::fs::read(path).map_err(|source| VdbError::Io {
        path: path.to_path_buf(),
        source,
    })
}

fn readable(grids: &[GridEntry]) -> Vec<(String, usize)> {
    grids
        .iter()
        .filter_map(|g| match g.kind {
            ValueKind::Float => Some((g.name.clone(), 1)),
            ValueKind::Vec3 => Some((g.name.clone(), 3)),
            _ => None,
        })
        .collect()
}

/// What a parse step found wrong, before it is known which file and grid to name.
#[derive(Debug)]
enum Fault {
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

impl Fault {
    fn at(self, path: &Path, grid: Option<&str>) -> VdbError {
        let path = path.to_path_buf();
        let grid_name = grid.map(str::to_string);
        match self {
            Fault::NotVdb => VdbError::NotVdb { path },
            Fault::Version(version) => VdbError::Version { path, version },
            Fault::Truncated => VdbError::Damaged {
                path,
                grid: grid_name,
                what: "the file ends early (truncated)".into(),
            },
            Fault::Damaged(what) => VdbError::Damaged {
                path,
                grid: grid_name,
                what,
            },
            Fault::Unsupported(what) => VdbError::Unsupported {
                path,
                grid: grid_name,
                what,
            },
            Fault::TooLarge {
                size,
                bytes,
                max_bytes,
            } => VdbError::TooLarge {
                path,
                grid: grid_name.unwrap_or_default(),
                size,
                bytes,
                max_bytes,
            },
        }
    }
}

impl From<CodecError> for Fault {
    fn from(error: CodecError) -> Fault {
        match error {
            CodecError::Damaged(what) => Fault::Damaged(what),
            CodecError::Unsupported(what) => Fault::Unsupported(what),
        }
    }
}

type Parse<T> = Result<T, Fault>;

fn damaged<T>(what: impl Into<String>) -> Parse<T> {
    Err(Fault::Damaged(what.into()))
}

const MAGIC: [u8; 8] = [0x20, 0x42, 0x44, 0x56, 0, 0, 0, 0];
/// The first version with per-grid compression and per-array active-mask codes.
const OLDEST_VERSION: u32 = 222;
/// The version OpenVDB 6 to 12 write.
const NEWEST_VERSION: u32 = 224;
const UUID_BYTES: usize = 36;
const COMPRESS_ZIP: u32 = 0x1;
const COMPRESS_ACTIVE_MASK: u32 = 0x2;
const COMPRESS_BLOSC: u32 = 0x4;
/// Appended to the tree type of grids whose floats are stored at half precision.
const HALF_FLOAT_SUFFIX: &str = "_HalfFloat";
/// Separates a grid's name from the index OpenVDB appends to make duplicate names unique.
const UNIQUE_NAME_SEPARATOR: char = '\u{1e}';

/// Little-endian reads from the file's bytes, each checked against its end.
struct Cursor<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    fn at(data: &'a [u8], pos: usize) -> Cursor<'a> {
        Cursor { data, pos }
    }

    fn take(&mut self, n: usize) -> Parse<&'a [u8]> {
        let end = self.pos.checked_add(n).ok_or(Fault::Truncated)?;
        let bytes = self.data.get(self.pos..end).ok_or(Fault::Truncated)?;
        self.pos = end;
        Ok(bytes)
    }

    fn array<const N: usize>(&mut self) -> Parse<[u8; N]> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N)?);
        Ok(out)
    }

    fn u8(&mut self) -> Parse<u8> {
        Ok(self.take(1)?[0])
    }

    fn u32(&mut self) -> Parse<u32> {
        Ok(u32::from_le_bytes(self.array()?))
    }

    fn i32(&mut self) -> Parse<i32> {
        Ok(i32::from_le_bytes(self.array()?))
    }

    fn i64(&mut self) -> Parse<i64> {
        Ok(i64::from_le_bytes(self.array()?))
    }

    fn f64(&mut self) -> Parse<f64> {
        Ok(f64::from_le_bytes(self.array()?))
    }

    fn coord(&mut self) -> Parse<[i64; 3]> {
        Ok([self.i32()? as i64, self.i32()? as i64, self.i32()? as i64])
    }

    fn string(&mut self) -> Parse<String> {
        let n = self.u32()? as usize;
        Ok(String::from_utf8_lossy(self.take(n)?).into_owned())
    }

    fn leaf_mask(&mut self) -> Parse<[u64; LEAF_WORDS]> {
        let mut mask = [0u64; LEAF_WORDS];
        for (word, bytes) in mask
            .iter_mut()
            .zip(self.take(LEAF_WORDS * 8)?.chunks_exact(8))
        {
            *word = u64::from_le_bytes(bytes.try_into().unwrap_or_default());
        }
        Ok(mask)
    }

    fn mask(&mut self, words: usize) -> Parse<Vec<u64>> {
        let bytes = self.take(words * 8)?;
        Ok(bytes
            .chunks_exact(8)
            .map(|w| u64::from_le_bytes([w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7]]))
            .collect())
    }
}

/// What a grid's values are, from its tree type.
#[derive(Clone, Copy, Debug, PartialEq)]
enum ValueKind {
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
    fn of(tree_type: &str) -> ValueKind {
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

    fn channels(self) -> usize {
        match self {
            ValueKind::Vec3 => 3,
            _ => 1,
        }
    }

    /// Bytes of one value at full precision (background, tiles, inactive values).
    fn bytes(self) -> usize {
        match self {
            ValueKind::Float => 4,
            ValueKind::Vec3 => 12,
            ValueKind::Skipped { bytes, .. } => bytes,
            ValueKind::Bool | ValueKind::Opaque => 1,
        }
    }

    /// Bytes of one value in a (possibly half-precision) value array.
    fn stored_bytes(self, half: bool) -> usize {
        match (self, half) {
            (ValueKind::Float, true) => 2,
            (ValueKind::Vec3, true) => 6,
            (ValueKind::Skipped { reals, .. }, true) if reals > 0 => 2 * reals,
            _ => self.bytes(),
        }
    }
}

/// One grid's descriptor and where its data starts.
#[derive(Debug)]
struct GridEntry {
    /// The name with OpenVDB's duplicate suffix, which instance parents refer to.
    unique_name: String,
    name: String,
    tree_type: String,
    kind: ValueKind,
    half: bool,
    instance_parent: String,
    /// First byte after the descriptor: the grid's compression flags.
    start: usize,
}

/// Reads the header and the grid descriptors up to the first grid `stop` accepts (or all of
/// them), skipping over each grid's data by its end offset or, in files written without
/// offsets, by parsing it.
fn walk_grids(data: &[u8], mut stop: impl FnMut(&GridEntry) -> bool) -> Parse<Vec<GridEntry>> {
    let mut c = Cursor::at(data, 0);
    if data.len() < MAGIC.len() || data[..MAGIC.len()] != MAGIC {
        return Err(Fault::NotVdb);
    }
    c.take(MAGIC.len())?;
    let version = c.u32()?;
    if !(OLDEST_VERSION..=NEWEST_VERSION).contains(&version) {
        return Err(Fault::Version(version));
    }
    let _library_major = c.u32()?;
    let _library_minor = c.u32()?;
    let has_offsets = c.u8()? != 0;
    c.take(UUID_BYTES)?;
    read_metadata(&mut c)?;
    let count = c.i32()?;
    if count < 0 {
        return damaged(format!("negative grid count {count}"));
    }
    let mut grids: Vec<GridEntry> = Vec::new();
    for _ in 0..count {
        let unique_name = c.string()?;
        let name = unique_name
            .split(UNIQUE_NAME_SEPARATOR)
            .next()
            .unwrap_or_default()
            .to_string();
        let mut tree_type = c.string()?;
        let half = tree_type.ends_with(HALF_FLOAT_SUFFIX);
        if half {
            tree_type.truncate(tree_type.len() - HALF_FLOAT_SUFFIX.len());
        }
        let instance_parent = c.string()?;
        let _grid_pos = c.i64()?;
        let _block_pos = c.i64()?;
        let end_pos = c.i64()?;
        let entry = GridEntry {
            unique_name,
            name,
            kind: ValueKind::of(&tree_type),
            tree_type,
            half,
            instance_parent,
            start: c.pos,
        };
        if !entry.instance_parent.is_empty()
            && !grids.iter().any(|g| g.unique_name == entry.instance_parent)
        {
            return damaged(format!(
                "grid '{}' is an instance of '{}', which is not before it",
                entry.name, entry.instance_parent
            ));
        }
        let found = stop(&entry);
        if !found {
            if has_offsets {
                match usize::try_from(end_pos) {
                    Ok(end) if end >= c.pos && end <= data.len() => c.pos = end,
                    _ => return damaged(format!("grid '{}' ends outside the file", entry.name)),
                }
            } else if entry.kind == ValueKind::Opaque && grids.len() + 1 == count as usize {
                // Nothing follows a last grid the reader cannot step over: list it anyway.
            } else {
                skip_grid(&mut c, &entry)?;
            }
        }
        grids.push(entry);
        if found {
            break;
        }
    }
    Ok(grids)
}

/// One metadata entry: name, type name and the value's bytes.
type Metadatum<'a> = (String, String, &'a [u8]);

fn read_metadata<'a>(c: &mut Cursor<'a>) -> Parse<Vec<Metadatum<'a>>> {
    let count = c.u32()?;
    let mut entries = Vec::new();
    for _ in 0..count {
        let name = c.string()?;
        let type_name = c.string()?;
        let size = c.u32()? as usize;
        entries.push((name, type_name, c.take(size)?));
    }
    Ok(entries)
}

/// A grid's compression flags, active bounding box (from its metadata, when written) and
/// transform; `tree_start` is where its tree's topology begins.
struct GridHeader {
    compression: u32,
    metadata_box: Option<[[i64; 3]; 2]>,
    index_to_local: glam::Mat4,
    tree_start: usize,
}

fn read_grid_header(data: &[u8], entry: &GridEntry) -> Parse<GridHeader> {
    let mut c = Cursor::at(data, entry.start);
    let compression = c.u32()?;
    let unknown = compression & !(COMPRESS_ZIP | COMPRESS_ACTIVE_MASK | COMPRESS_BLOSC);
    if unknown != 0 {
        return Err(Fault::Unsupported(format!(
            "compression flags {compression:#x}"
        )));
    }
    let metadata = read_metadata(&mut c)?;
    let vec3i = |key: &str| {
        metadata
            .iter()
            .find(|(name, type_name, bytes)| {
                name == key && type_name == "vec3i" && bytes.len() == 12
            })
            .map(|(_, _, b)| {
                let component = |i: usize| {
                    i32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]]) as i64
                };
                [component(0), component(1), component(2)]
            })
    };
    let metadata_box = vec3i("file_bbox_min")
        .zip(vec3i("file_bbox_max"))
        .map(|(a, b)| [a, b]);
    let index_to_local = read_transform(&mut c)?;
    Ok(GridHeader {
        compression,
        metadata_box,
        index_to_local,
        tree_start: c.pos,
    })
}

/// The grid's map as a column-major matrix taking index space to the grid's space.
fn read_transform(c: &mut Cursor) -> Parse<glam::Mat4> {
    let map = c.string()?;
    let vec3 = |c: &mut Cursor| -> Parse<glam::DVec3> {
        Ok(glam::DVec3::new(c.f64()?, c.f64()?, c.f64()?))
    };
    // Scale maps store the scale, the voxel size and three derived reciprocals after it.
    const SCALE_TAIL: usize = 4 * 24;
    let matrix = match map.as_str() {
        "UniformScaleMap" | "ScaleMap" => {
            let scale = vec3(c)?;
            c.take(SCALE_TAIL)?;
            glam::DMat4::from_scale(scale)
        }
        "UniformScaleTranslateMap" | "ScaleTranslateMap" => {
            let translation = vec3(c)?;
            let scale = vec3(c)?;
            c.take(SCALE_TAIL)?;
            glam::DMat4::from_translation(translation) * glam::DMat4::from_scale(scale)
        }
        "TranslationMap" => glam::DMat4::from_translation(vec3(c)?),
        "AffineMap" => {
            // Row-major for row vectors (translation in the last row): the same sixteen
            // numbers, read column-major, are the matrix for column vectors.
            let mut m = [0.0; 16];
            for v in &mut m {
                *v = c.f64()?;
            }
            glam::DMat4::from_cols_array(&m)
        }
        other => return Err(Fault::Unsupported(format!("the transform {other}"))),
    };
    let matrix = matrix.as_mat4();
    if !matrix.is_finite() || matrix.determinant() == 0.0 {
        return damaged(format!("the grid's {map} is not invertible"));
    }
    Ok(matrix)
}

/// A tile: a box of `1 << log2_extent` voxels per axis holding one value.
#[derive(Debug)]
struct Tile {
    origin: [i64; 3],
    log2_extent: u32,
    value: [f32; 3],
    active: bool,
}

/// A leaf node's origin and value mask (8³ voxels).
struct Leaf {
    origin: [i64; 3],
    mask: [u64; LEAF_WORDS],
}

/// A tree's structure: tiles at every level and the leaves, in the order their buffers follow.
struct Topology {
    background: [f32; 3],
    tiles: Vec<Tile>,
    leaves: Vec<Leaf>,
}

const LEAF_LOG2: u32 = 3;
const LEAF_VOXELS: usize = 1 << (3 * LEAF_LOG2);
const LEAF_WORDS: usize = LEAF_VOXELS / 64;
/// log2 of the voxels per axis of the lower and upper internal nodes (4 and 5 levels of
/// children, each child 8³ or 16³ voxels…).
const LOWER_LOG2: u32 = 4;
const UPPER_LOG2: u32 = 5;
const UPPER_EXTENT_LOG2: u32 = UPPER_LOG2 + LOWER_LOG2 + LEAF_LOG2;

/// Reads a tree's topology and buffers, decoding values (float and vec3 trees) or only
/// stepping over them.
struct TreeReader<'a, 'c> {
    c: &'c mut Cursor<'a>,
    kind: ValueKind,
    half: bool,
    compression: u32,
    decode: bool,
    background: [f32; 3],
    /// Decoded bytes of one array (reused).
    bytes: Vec<u8>,
    /// Decoded values of one array, `channels` per value (reused).
    values: Vec<f32>,
}

impl<'a, 'c> TreeReader<'a, 'c> {
    fn new(c: &'c mut Cursor<'a>, kind: ValueKind, half: bool, compression: u32) -> Self {
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

    fn topology(&mut self) -> Parse<(Topology, Vec<Range<usize>>)> {
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
    fn buffers(
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

fn bit(mask: &[u64], i: usize) -> bool {
    mask[i / 64] >> (i % 64) & 1 != 0
}

/// Steps over a grid's data in a file without grid offsets.
fn skip_grid(c: &mut Cursor, entry: &GridEntry) -> Parse<()> {
    let header = read_grid_header(c.data, entry)?;
    c.pos = header.tree_start;
    if !entry.instance_parent.is_empty() {
        return Ok(());
    }
    if entry.kind == ValueKind::Opaque {
        return Err(Fault::Unsupported(format!(
            "reading past grid '{}' of type {} in a file written without grid offsets",
            entry.name, entry.tree_type
        )));
    }
    let mut reader = TreeReader::new(c, entry.kind, entry.half, header.compression);
    reader.decode = false;
    let (topology, order) = reader.topology()?;
    reader.buffers(&topology, &order, |_, _| {})
}

fn read_entry(
    data: &[u8],
    grids: &[GridEntry],
    entry: &GridEntry,
    max_bytes: u64,
) -> Parse<VdbGrid> {
    let header = read_grid_header(data, entry)?;
    // An instance shares its parent's tree (and its compression) under its own transform.
    let (source, tree_header) = if entry.instance_parent.is_empty() {
        (entry, None)
    } else {
        let parent = grids
            .iter()
            .find(|g| g.unique_name == entry.instance_parent)
            .ok_or_else(|| Fault::Damaged("the instance parent is missing".into()))?;
        if !parent.instance_parent.is_empty() {
            return damaged("an instance of an instance");
        }
        (parent, Some(read_grid_header(data, parent)?))
    };
    if !matches!(source.kind, ValueKind::Float | ValueKind::Vec3) {
        return Err(Fault::Unsupported(format!(
            "grid type {} (only float and vec3 grids are read)",
            source.tree_type
        )));
    }
    let channels = source.kind.channels();
    if let Some([lo, hi]) = header
        .metadata_box
        .filter(|[lo, hi]| (0..3).all(|k| lo[k] <= hi[k]))
    {
        dense_bytes(lo, hi, channels, max_bytes)?;
    }
    let tree_header = tree_header.as_ref().unwrap_or(&header);
    let mut c = Cursor::at(data, tree_header.tree_start);
    let mut reader = TreeReader::new(&mut c, source.kind, source.half, tree_header.compression);
    let (topology, order) = reader.topology()?;
    let Some([lo, hi]) = active_box(&topology) else {
        return Ok(VdbGrid {
            name: entry.name.clone(),
            channels,
            origin: [0; 3],
            size: [0; 3],
            values: Vec::new(),
            index_to_local: header.index_to_local,
        });
    };
    dense_bytes(lo, hi, channels, max_bytes)?;
    let mut dense = Dense::new(lo, hi, channels, &topology.background);
    for tile in &topology.tiles {
        let extent = (1i64 << tile.log2_extent) - 1;
        let top = tile.origin.map(|o| o + extent);
        dense.fill(tile.origin, top, &tile.value[..channels]);
    }
    reader.buffers(&topology, &order, |leaf, values| {
        dense.leaf(leaf.origin, values)
    })?;
    Ok(VdbGrid {
        name: entry.name.clone(),
        channels,
        origin: lo.map(|v| v as i32),
        size: dense.size,
        values: dense.values,
        index_to_local: header.index_to_local,
    })
}

/// The inclusive index box of the active voxels and tiles, if any.
fn active_box(topology: &Topology) -> Option<[[i64; 3]; 2]> {
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
fn dense_bytes(lo: [i64; 3], hi: [i64; 3], channels: usize, max_bytes: u64) -> Parse<u64> {
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
struct Dense {
    lo: [i64; 3],
    hi: [i64; 3],
    size: [usize; 3],
    channels: usize,
    values: Vec<f32>,
}

impl Dense {
    fn new(lo: [i64; 3], hi: [i64; 3], channels: usize, background: &[f32; 3]) -> Dense {
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
    fn fill(&mut self, a: [i64; 3], b: [i64; 3], value: &[f32]) {
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
    fn leaf(&mut self, origin: [i64; 3], values: &[f32]) {
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
