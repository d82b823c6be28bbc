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
//! `format` holds the checked reads and constants, `tree` the topology and value arrays,
//! `dense` the box the grid is made into, `compression` the codecs.
//!
//! Only float and vec3 trees of the standard 5-4-3 configuration are read; files are checked
//! as they are read, so a damaged, truncated or foreign file is an error, never a panic, and
//! no buffer is sized from a length field before the length is checked against the file.

mod compression;
mod dense;
mod format;
#[cfg(test)]
mod tests;
mod tree;

use std::path::{Path, PathBuf};

use dense::{active_box, dense_bytes, Dense};
use format::{
    damaged, Cursor, Fault, Parse, ValueKind, COMPRESS_ACTIVE_MASK, COMPRESS_BLOSC, COMPRESS_ZIP,
    HALF_FLOAT_SUFFIX, MAGIC, NEWEST_VERSION, OLDEST_VERSION, UNIQUE_NAME_SEPARATOR, UUID_BYTES,
};
use tree::TreeReader;

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
