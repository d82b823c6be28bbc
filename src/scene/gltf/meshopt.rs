//! `EXT_meshopt_compression`: buffer views stored compressed by meshoptimizer's codecs (as
//! gltfpack writes them) are decoded once, after the buffers load, into plain bytes that every
//! accessor then reads as an ordinary view. The codecs are the extension's own (its bitstream
//! appendix, after Kapoulkine's meshoptimizer; no paper), decoded by the `meshopt` crate: the
//! three modes (ATTRIBUTES, TRIANGLES, INDICES) and the filters (OCTAHEDRAL, QUATERNION,
//! EXPONENTIAL). Every rule the extension sets on stride, count and filter is checked here
//! before the decoder runs (the decoder asserts them), and the decoded size is bounded before
//! anything is allocated: by the compressed bytes (no codec expands a byte into more than
//! `MAX_EXPANSION`) and by `MAX_DECODED_BYTES` for the whole file.

use super::container::{named, Loader};
use crate::error::Result;
use serde_json::Value;
use std::collections::HashMap;

const EXTENSION: &str = "EXT_meshopt_compression";

/// Bytes all of a file's compressed buffer views may decode to together.
pub(super) const MAX_DECODED_BYTES: u64 = 8 << 30;

/// The largest ratio of decoded to compressed bytes any of the three codecs can produce: an
/// attribute block of at most 256 elements costs at least one control byte per four bytes of
/// stride (1024 : 1); a triangle at least one byte (12 : 1); an index at least one byte (4 : 1).
const MAX_EXPANSION: u64 = 1024;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Mode {
    Attributes,
    Triangles,
    Indices,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Filter {
    None,
    Octahedral,
    Quaternion,
    Exponential,
}

/// One buffer view's extension object, read and checked against the extension's rules.
#[derive(Debug, PartialEq)]
struct Compressed {
    buffer: usize,
    offset: usize,
    length: usize,
    stride: usize,
    count: usize,
    mode: Mode,
    filter: Filter,
}

impl Compressed {
    /// The extension object of a buffer view of `view_length` bytes and optional `view_stride`.
    fn read(
        ext: &Value,
        view_length: usize,
        view_stride: Option<usize>,
    ) -> std::result::Result<Compressed, String> {
        let index = |key: &str, required: bool| -> std::result::Result<usize, String> {
            match ext.get(key) {
                None if !required => Ok(0),
                None => Err(format!("'{key}' is missing")),
                Some(v) => v
                    .as_u64()
                    .and_then(|v| usize::try_from(v).ok())
                    .ok_or_else(|| format!("'{key}' is {v}, not a non-negative integer")),
            }
        };
        let mode = match ext.get("mode").and_then(Value::as_str) {
            Some("ATTRIBUTES") => Mode::Attributes,
            Some("TRIANGLES") => Mode::Triangles,
            Some("INDICES") => Mode::Indices,
            _ => {
                return Err(format!(
                    "'mode' is {}, not ATTRIBUTES, TRIANGLES or INDICES",
                    ext.get("mode").unwrap_or(&Value::Null)
                ))
            }
        };
        let filter = match ext.get("filter").map(|f| f.as_str()) {
            None | Some(Some("NONE")) => Filter::None,
            Some(Some("OCTAHEDRAL")) => Filter::Octahedral,
            Some(Some("QUATERNION")) => Filter::Quaternion,
            Some(Some("EXPONENTIAL")) => Filter::Exponential,
            Some(_) => {
                return Err(format!(
                    "'filter' is {}, not NONE, OCTAHEDRAL, QUATERNION or EXPONENTIAL",
                    ext["filter"]
                ))
            }
        };
        let compressed = Compressed {
            buffer: index("buffer", true)?,
            offset: index("byteOffset", false)?,
            length: index("byteLength", true)?,
            stride: index("byteStride", true)?,
            count: index("count", true)?,
            mode,
            filter,
        };
        compressed.check(view_length, view_stride)?;
        Ok(compressed)
    }

    /// The extension's validity rules, and the bound on the decoded size.
    fn check(
        &self,
        view_length: usize,
        view_stride: Option<usize>,
    ) -> std::result::Result<(), String> {
        let stride = self.stride;
        let stride_ok = match (self.mode, self.filter) {
            (Mode::Attributes, Filter::None | Filter::Exponential) => {
                stride > 0 && stride <= 256 && stride.is_multiple_of(4)
            }
            (Mode::Attributes, Filter::Octahedral) => stride == 4 || stride == 8,
            (Mode::Attributes, Filter::Quaternion) => stride == 8,
            (Mode::Triangles | Mode::Indices, Filter::None) => stride == 2 || stride == 4,
            (Mode::Triangles | Mode::Indices, _) => {
                return Err(format!(
                    "the {:?} filter is not allowed with mode {:?} (only with ATTRIBUTES)",
                    self.filter, self.mode
                ))
            }
        };
        if !stride_ok {
            return Err(format!(
                "'byteStride' {stride} is not allowed with mode {:?} and filter {:?} (ATTRIBUTES: \
                 a multiple of 4 up to 256; OCTAHEDRAL: 4 or 8; QUATERNION: 8; TRIANGLES and \
                 INDICES: 2 or 4)",
                self.mode, self.filter
            ));
        }
        if self.mode == Mode::Triangles && !self.count.is_multiple_of(3) {
            return Err(format!(
                "'count' {} is not a multiple of 3, as mode TRIANGLES needs",
                self.count
            ));
        }
        if let Some(view_stride) = view_stride.filter(|&s| s != stride) {
            return Err(format!(
                "'byteStride' {stride} differs from the buffer view's byteStride {view_stride}"
            ));
        }
        let decoded = self.decoded_bytes();
        if decoded != Some(view_length as u64) {
            return Err(format!(
                "'count' {} × 'byteStride' {stride} is not the buffer view's byteLength {view_length}",
                self.count
            ));
        }
        if view_length as u64 > MAX_EXPANSION.saturating_mul(self.length as u64) {
            return Err(format!(
                "{view_length} bytes cannot be decoded from {} compressed bytes (the codecs \
                 expand at most {MAX_EXPANSION}-fold): the file is damaged",
                self.length
            ));
        }
        Ok(())
    }

    fn decoded_bytes(&self) -> Option<u64> {
        (self.count as u64).checked_mul(self.stride as u64)
    }

    /// Decode `data` (exactly the compressed bytes) into `count` elements of `stride` bytes.
    fn decode(&self, data: &[u8]) -> std::result::Result<Vec<u8>, String> {
        let size = self.count * self.stride;
        let mut out = vec![0u8; size];
        if self.count == 0 {
            return Ok(out);
        }
        // SAFETY: `out` holds `count` elements of `stride` bytes, the sizes the decoders write;
        // `check` has enforced every precondition the decoders assert (stride a multiple of 4
        // up to 256 for attributes, 2 or 4 for indices, a count divisible by 3 for triangles,
        // the filters' strides), and the decoders read only `data.len()` bytes of `data`.
        let code = unsafe {
            let dst = out.as_mut_ptr().cast();
            match self.mode {
                Mode::Attributes => ::meshopt::ffi::meshopt_decodeVertexBuffer(
                    dst,
                    self.count,
                    self.stride,
                    data.as_ptr(),
                    data.len(),
                ),
                Mode::Triangles => ::meshopt::ffi::meshopt_decodeIndexBuffer(
                    dst,
                    self.count,
                    self.stride,
                    data.as_ptr(),
                    data.len(),
                ),
                Mode::Indices => ::meshopt::ffi::meshopt_decodeIndexSequence(
                    dst,
                    self.count,
                    self.stride,
                    data.as_ptr(),
                    data.len(),
                ),
            }
        };
        if code != 0 {
            return Err(format!(
                "the {:?} data does not decode (meshoptimizer error {code}): the file is damaged",
                self.mode
            ));
        }
        // SAFETY: as above; the filters rewrite `count` elements of `stride` bytes in place,
        // and `check` has enforced their strides (4 or 8, 8, a multiple of 4).
        unsafe {
            let dst = out.as_mut_ptr().cast();
            match self.filter {
                Filter::None => {}
                Filter::Octahedral => {
                    ::meshopt::ffi::meshopt_decodeFilterOct(dst, self.count, self.stride)
                }
                Filter::Quaternion => {
                    ::meshopt::ffi::meshopt_decodeFilterQuat(dst, self.count, self.stride)
                }
                Filter::Exponential => {
                    ::meshopt::ffi::meshopt_decodeFilterExp(dst, self.count, self.stride)
                }
            }
        }
        Ok(out)
    }
}

impl Loader {
    /// Whether `buffer` holds no bytes of its own, only the decoded views: marked as the
    /// extension's fallback (only compressed views refer to it), or, in a file that uses the
    /// extension, a buffer with neither a URI nor a binary chunk left for it (the placeholder).
    pub(super) fn is_meshopt_placeholder(
        &self,
        buffer: &gltf::Buffer,
        binary_chunk_left: bool,
    ) -> bool {
        let fallback = buffer
            .extension_value(EXTENSION)
            .and_then(|e| e.get("fallback"))
            .and_then(Value::as_bool)
            .unwrap_or(false);
        let placeholder = matches!(buffer.source(), gltf::buffer::Source::Bin)
            && !binary_chunk_left
            && self.document.extensions_used().any(|e| e == EXTENSION);
        fallback || placeholder
    }

    /// Decode every buffer view that has `EXT_meshopt_compression` into `decoded_views`, after
    /// checking each and the total decoded size.
    pub(super) fn decode_meshopt_views(&mut self) -> Result<()> {
        let mut views = Vec::new();
        let mut total = 0u64;
        for view in self.document.views() {
            let Some(ext) = view.extension_value(EXTENSION) else {
                continue;
            };
            let object = format!(
                "{} {EXTENSION}",
                named("buffer view", view.index(), view.name())
            );
            let compressed = Compressed::read(ext, view.length(), view.stride())
                .map_err(|m| self.err(&object, m))?;
            total = total.saturating_add(compressed.decoded_bytes().unwrap_or(u64::MAX));
            if total > MAX_DECODED_BYTES {
                return Err(self.err(
                    &object,
                    format!(
                        "the compressed buffer views decode to more than Photon's limit of {} GiB",
                        MAX_DECODED_BYTES >> 30
                    ),
                ));
            }
            views.push((view.index(), object, compressed));
        }
        let mut decoded = HashMap::new();
        for (index, object, compressed) in views {
            let buffer = self.buffers.get(compressed.buffer).ok_or_else(|| {
                self.err(
                    &object,
                    format!("'buffer' {} is not a buffer of the file", compressed.buffer),
                )
            })?;
            let data = compressed
                .offset
                .checked_add(compressed.length)
                .and_then(|end| buffer.get(compressed.offset..end))
                .ok_or_else(|| {
                    self.err(
                        &object,
                        format!(
                            "compressed bytes {}..{} lie outside buffer {} ({} bytes)",
                            compressed.offset,
                            compressed.offset.saturating_add(compressed.length),
                            compressed.buffer,
                            buffer.len()
                        ),
                    )
                })?;
            let bytes = compressed.decode(data).map_err(|m| self.err(&object, m))?;
            decoded.insert(index, bytes);
        }
        self.decoded_views = decoded;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn read(ext: Value, length: usize) -> std::result::Result<Compressed, String> {
        Compressed::read(&ext, length, None)
    }

    #[test]
    fn the_extensions_rules_are_checked_before_decoding() {
        let ok = json!({"buffer": 0, "byteLength": 10, "byteStride": 12, "count": 4, "mode": "ATTRIBUTES"});
        assert_eq!(read(ok.clone(), 48).unwrap().filter, Filter::None);
        // byteLength of the view must be count × stride.
        assert!(read(ok.clone(), 47).unwrap_err().contains("byteLength"));
        // A parent stride must agree.
        assert!(Compressed::read(&ok, 48, Some(16)).is_err());
        let bad = [
            json!({"buffer": 0, "byteLength": 10, "byteStride": 6, "count": 8, "mode": "ATTRIBUTES"}),
            json!({"buffer": 0, "byteLength": 10, "byteStride": 260, "count": 1, "mode": "ATTRIBUTES"}),
            json!({"buffer": 0, "byteLength": 10, "byteStride": 12, "count": 4, "mode": "ATTRIBUTES", "filter": "OCTAHEDRAL"}),
            json!({"buffer": 0, "byteLength": 10, "byteStride": 4, "count": 12, "mode": "ATTRIBUTES", "filter": "QUATERNION"}),
            json!({"buffer": 0, "byteLength": 10, "byteStride": 4, "count": 4, "mode": "TRIANGLES"}),
            json!({"buffer": 0, "byteLength": 10, "byteStride": 4, "count": 12, "mode": "INDICES", "filter": "EXPONENTIAL"}),
            json!({"buffer": 0, "byteLength": 10, "byteStride": 12, "count": 4, "mode": "STRIPS"}),
            json!({"buffer": 0, "byteLength": 10, "byteStride": 12, "count": 4, "mode": "ATTRIBUTES", "filter": "COLOUR"}),
            json!({"buffer": -1, "byteLength": 10, "byteStride": 12, "count": 4, "mode": "ATTRIBUTES"}),
            json!({"byteLength": 10, "byteStride": 12, "count": 4, "mode": "ATTRIBUTES"}),
        ];
        for ext in bad {
            let length =
                ext["byteStride"].as_u64().unwrap_or(0) * ext["count"].as_u64().unwrap_or(0);
            assert!(read(ext.clone(), length as usize).is_err(), "{ext}");
        }
    }

    #[test]
    fn a_declared_size_beyond_what_the_bytes_can_hold_is_refused() {
        let ext = json!({"buffer": 0, "byteLength": 16, "byteStride": 16, "count": 1 << 20, "mode": "ATTRIBUTES"});
        assert!(read(ext, 16 << 20).unwrap_err().contains("damaged"));
    }

    #[test]
    fn the_codecs_round_trip_and_damaged_data_is_an_error() {
        let vertices: Vec<[f32; 3]> = (0..100).map(|i| [i as f32, 0.5 * i as f32, 1.0]).collect();
        let encoded = ::meshopt::encode_vertex_buffer(&vertices).unwrap();
        let ext = json!({"buffer": 0, "byteLength": encoded.len(), "byteStride": 12, "count": 100, "mode": "ATTRIBUTES"});
        let compressed = read(ext, 1200).unwrap();
        let decoded = compressed.decode(&encoded).unwrap();
        let expected: Vec<u8> = vertices
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        assert_eq!(decoded, expected);
        assert!(compressed.decode(&encoded[..encoded.len() / 2]).is_err());
        assert!(compressed.decode(&[]).is_err());

        let indices: Vec<u32> = vec![0, 1, 2, 2, 1, 3, 3, 1, 4];
        let encoded = ::meshopt::encode_index_buffer(&indices, 5).unwrap();
        let ext = json!({"buffer": 0, "byteLength": encoded.len(), "byteStride": 4, "count": 9, "mode": "TRIANGLES"});
        let decoded = read(ext, 36).unwrap().decode(&encoded).unwrap();
        let expected: Vec<u8> = indices.iter().flat_map(|v| v.to_le_bytes()).collect();
        assert_eq!(decoded, expected);
        let mut broken = encoded.clone();
        broken[0] = 0x00;
        let ext = json!({"buffer": 0, "byteLength": broken.len(), "byteStride": 4, "count": 9, "mode": "TRIANGLES"});
        assert!(read(ext, 36).unwrap().decode(&broken).is_err());
    }
}
