//! The `KHR_draco_mesh_compression` extension (Khronos, 2017): a primitive whose extension
//! names a buffer view of Draco bytes and, for each glTF attribute, the Draco attribute's
//! unique id. Each such primitive is decoded once, after the buffers load, into the bytes of
//! its accessors (indices and the named attributes), which are then read as any accessor. The
//! accessors' count, type and component type in the JSON are the contract the decoded mesh
//! must meet; their sizes are checked against the compressed bytes (at most `MAX_EXPANSION`
//! decoded bytes per compressed byte) and the file-wide `MAX_DECODED_BYTES` before decoding.
//! A primitive whose accessors all have buffer views (an uncompressed fallback) is read from
//! them and not decoded.

use super::super::container::{named, Loader};
use super::super::meshopt::MAX_DECODED_BYTES;
use super::attributes::Values;
use super::decoder::decode;
use crate::error::Result;
use crate::scene::gltf::{MAX_TRIANGLES, MAX_VERTICES};
use gltf::accessor::{DataType, Dimensions};
use serde_json::Value;
use std::collections::HashMap;

const EXTENSION: &str = "KHR_draco_mesh_compression";

/// The most decoded bytes Photon accepts per compressed byte (Draco meshes compress 5-30 to
/// one; a constant attribute costs nearly nothing, so the bound is generous).
const MAX_EXPANSION: u64 = 1024;

/// One compressed primitive: where its bytes are and which accessors it fills.
struct Compressed {
    object: String,
    view: usize,
    indices: usize,
    /// (glTF attribute name, accessor index, Draco unique id).
    attributes: Vec<(String, usize, u32)>,
}

impl Loader {
    /// Decode every primitive compressed with `KHR_draco_mesh_compression` into
    /// `decoded_accessors`, after checking the extension and the decoded sizes.
    pub(in super::super) fn decode_draco_primitives(&mut self) -> Result<()> {
        let mut jobs = Vec::new();
        let mut total = 0u64;
        for mesh in self.document.meshes() {
            for primitive in mesh.primitives() {
                let Some(ext) = primitive.extension_value(EXTENSION) else {
                    continue;
                };
                let object = format!(
                    "{} primitive {} {EXTENSION}",
                    named("mesh", mesh.index(), mesh.name()),
                    primitive.index()
                );
                let job = self.read_extension(&primitive, ext, &object)?;
                let Some(job) = job else { continue };
                let bytes = self.decoded_size(&job)?;
                let view = self
                    .document
                    .views()
                    .nth(job.view)
                    .map_or(0, |v| v.length());
                if bytes > MAX_EXPANSION.saturating_mul(view as u64) {
                    return Err(self.err(
                        &object,
                        format!(
                            "the accessors declare {bytes} bytes, more than {MAX_EXPANSION} per \
                             compressed byte of the {view} in buffer view {}: the file is damaged",
                            job.view
                        ),
                    ));
                }
                total = total.saturating_add(bytes);
                if total > MAX_DECODED_BYTES {
                    return Err(self.err(
                        &object,
                        format!(
                            "the Draco primitives decode to more than Photon's limit of {} GiB",
                            MAX_DECODED_BYTES >> 30
                        ),
                    ));
                }
                jobs.push(job);
            }
        }
        let mut sources: HashMap<usize, usize> = HashMap::new();
        for job in jobs {
            let decoded = self.decode_job(&job)?;
            for (accessor, bytes) in decoded {
                match sources.insert(accessor, job.view) {
                    Some(view) if view != job.view => {
                        return Err(self.err(
                            &job.object,
                            format!(
                                "accessor {accessor} is decoded from two Draco buffer views \
                                 ({view} and {})",
                                job.view
                            ),
                        ))
                    }
                    _ => {
                        self.decoded_accessors.insert(accessor, bytes);
                    }
                }
            }
        }
        Ok(())
    }

    /// The extension object of a primitive, checked; `None` when every accessor it names has
    /// a buffer view of its own (the uncompressed fallback is read instead).
    fn read_extension(
        &self,
        primitive: &gltf::Primitive,
        ext: &Value,
        object: &str,
    ) -> Result<Option<Compressed>> {
        let view = ext
            .get("bufferView")
            .and_then(Value::as_u64)
            .and_then(|v| usize::try_from(v).ok())
            .filter(|&v| v < self.document.views().len())
            .ok_or_else(|| {
                self.err(
                    object,
                    "'bufferView' is missing or not a buffer view of the file",
                )
            })?;
        let Some(map) = ext.get("attributes").and_then(Value::as_object) else {
            return Err(self.err(object, "'attributes' is missing or not an object"));
        };
        if primitive.mode() != gltf::mesh::Mode::Triangles {
            return Err(self.err(
                object,
                format!(
                    "Draco compresses triangle lists, not {:?} primitives",
                    primitive.mode()
                ),
            ));
        }
        let indices = primitive.indices().ok_or_else(|| {
            self.err(
                object,
                "a Draco primitive needs an indices accessor (the glTF extension requires one)",
            )
        })?;
        let mut attributes = Vec::new();
        let mut all_have_views = indices.view().is_some();
        for (name, id) in map {
            let id = id
                .as_u64()
                .and_then(|v| u32::try_from(v).ok())
                .ok_or_else(|| {
                    self.err(
                        object,
                        format!("attribute {name}'s id {id} is not an unsigned integer"),
                    )
                })?;
            let accessor = primitive
                .attributes()
                .find(|(semantic, _)| semantic.to_string() == *name)
                .map(|(_, a)| a)
                .ok_or_else(|| {
                    self.err(object, format!("attribute {name} is compressed but the primitive has no such attribute"))
                })?;
            all_have_views &= accessor.view().is_some();
            attributes.push((name.clone(), accessor.index(), id));
        }
        if !attributes.iter().any(|(n, ..)| n == "POSITION") {
            return Err(self.err(object, "the compressed attributes do not include POSITION"));
        }
        if all_have_views {
            return Ok(None);
        }
        Ok(Some(Compressed {
            object: object.to_string(),
            view,
            indices: indices.index(),
            attributes,
        }))
    }

    fn accessor(&self, index: usize) -> gltf::Accessor<'_> {
        self.document
            .accessors()
            .nth(index)
            .expect("an accessor the primitive named")
    }

    /// The bytes the primitive's accessors declare, after checking their counts.
    fn decoded_size(&self, job: &Compressed) -> Result<u64> {
        let indices = self.accessor(job.indices);
        let points = self.accessor(job.attributes[0].1).count();
        if !indices.count().is_multiple_of(3) || indices.count() / 3 > MAX_TRIANGLES {
            return Err(self.err(
                &job.object,
                format!(
                    "the indices' count {} is not a triangle list Photon accepts",
                    indices.count()
                ),
            ));
        }
        if points > MAX_VERTICES {
            return Err(self.err(
                &job.object,
                format!("{points} vertices exceed Photon's limit of {MAX_VERTICES}"),
            ));
        }
        let mut bytes = (indices.count() as u64) * indices.data_type().size() as u64;
        for (name, index, _) in &job.attributes {
            let a = self.accessor(*index);
            if a.count() != points {
                return Err(self.err(
                    &job.object,
                    format!("attribute {name} has {} elements and another {points}: a Draco mesh has one count", a.count()),
                ));
            }
            let size = a.dimensions().multiplicity() * a.data_type().size();
            bytes = bytes.saturating_add(a.count() as u64 * size as u64);
        }
        Ok(bytes)
    }

    /// Decode one primitive into (accessor index, bytes) pairs.
    fn decode_job(&self, job: &Compressed) -> Result<Vec<(usize, Vec<u8>)>> {
        let view = self.document.views().nth(job.view).expect("checked view");
        let buffer = self
            .buffers
            .get(view.buffer().index())
            .map(Vec::as_slice)
            .unwrap_or(&[]);
        let data = view
            .offset()
            .checked_add(view.length())
            .and_then(|end| buffer.get(view.offset()..end))
            .ok_or_else(|| {
                self.err(
                    &job.object,
                    format!(
                        "buffer view {} lies outside its buffer ({} bytes)",
                        job.view,
                        buffer.len()
                    ),
                )
            })?;
        let indices = self.accessor(job.indices);
        let points = self.accessor(job.attributes[0].1).count();
        let mesh =
            decode(data, indices.count() / 3, points).map_err(|m| self.err(&job.object, m))?;
        let mut out = Vec::with_capacity(job.attributes.len() + 1);
        let flat: Vec<u32> = mesh.faces.iter().flatten().copied().collect();
        let index_bytes = integers(flat.iter().map(|&i| i64::from(i)), indices.data_type())
            .ok_or_else(|| {
                self.err(
                    &job.object,
                    format!("the indices do not fit {:?}", indices.data_type()),
                )
            })?;
        out.push((job.indices, index_bytes));
        for (name, index, id) in &job.attributes {
            let accessor = self.accessor(*index);
            let what = format!("attribute {name} (Draco attribute {id}, accessor {index})");
            let attribute = mesh
                .attributes
                .iter()
                .find(|a| a.layout.unique_id == *id)
                .ok_or_else(|| self.err(&job.object, format!("{what} is not in the Draco data")))?;
            let m = attribute.layout.components;
            if m != accessor.dimensions().multiplicity() {
                return Err(self.err(
                    &job.object,
                    format!(
                        "{what} has {m} components in the Draco data but the accessor is {:?}",
                        accessor.dimensions()
                    ),
                ));
            }
            if accessor.dimensions() == Dimensions::Scalar && m != 1 {
                unreachable!("multiplicity checked");
            }
            let element = |p: usize| -> usize { attribute.point_to_value[p] as usize * m };
            let bytes = match (&attribute.values, accessor.data_type()) {
                (Values::Float(v), DataType::F32) => {
                    let mut b = Vec::with_capacity(mesh.points * m * 4);
                    for p in 0..mesh.points {
                        for k in 0..m {
                            let x = v.get(element(p) + k).copied().unwrap_or(f32::NAN);
                            b.extend(x.to_le_bytes());
                        }
                    }
                    Some(b)
                }
                (Values::Int(v), DataType::F32) => {
                    let scale = if attribute.layout.normalized {
                        normalization(attribute.layout.data_type)
                    } else {
                        1.0
                    };
                    let mut b = Vec::with_capacity(mesh.points * m * 4);
                    for p in 0..mesh.points {
                        for k in 0..m {
                            let x = v.get(element(p) + k).copied().unwrap_or(0) as f32 / scale;
                            b.extend(x.to_le_bytes());
                        }
                    }
                    Some(b)
                }
                (Values::Int(v), t) => integers(
                    (0..mesh.points)
                        .flat_map(|p| (0..m).map(move |k| (p, k)))
                        .map(|(p, k)| v.get(element(p) + k).copied().unwrap_or(-1)),
                    t,
                ),
                (Values::Float(_), _) => None,
            };
            let bytes = bytes.ok_or_else(|| {
                self.err(
                    &job.object,
                    format!(
                        "{what} decodes to values that the accessor's component type {:?} cannot hold",
                        accessor.data_type()
                    ),
                )
            })?;
            out.push((*index, bytes));
        }
        Ok(out)
    }
}

/// The scale of a normalized integer Draco data type.
fn normalization(t: u8) -> f32 {
    match t {
        1 => 127.0,
        2 => 255.0,
        3 => 32767.0,
        4 => 65535.0,
        5 => i32::MAX as f32,
        _ => u32::MAX as f32,
    }
}

/// Integers as little-endian components of `t`, or `None` when one does not fit.
fn integers(values: impl Iterator<Item = i64>, t: DataType) -> Option<Vec<u8>> {
    let mut out = Vec::new();
    for v in values {
        match t {
            DataType::U8 => out.push(u8::try_from(v).ok()?),
            DataType::I8 => out.push(i8::try_from(v).ok()? as u8),
            DataType::U16 => out.extend(u16::try_from(v).ok()?.to_le_bytes()),
            DataType::I16 => out.extend(i16::try_from(v).ok()?.to_le_bytes()),
            DataType::U32 => out.extend(u32::try_from(v).ok()?.to_le_bytes()),
            DataType::F32 => return None,
        }
    }
    Some(out)
}
