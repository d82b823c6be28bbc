//! `EXT_meshopt_compression` and `KHR_meshopt_compression`: buffer views stored compressed by
//! meshoptimizer's codecs (as gltfpack writes them) are decoded once, after the buffers load,
//! into plain bytes that every accessor then reads as an ordinary view. The codecs are the
//! extensions' own (their bitstream appendices, after Kapoulkine's meshoptimizer; no paper),
//! decoded by the `meshopt` crate: the three modes (ATTRIBUTES, TRIANGLES, INDICES) and the
//! filters (OCTAHEDRAL, QUATERNION, EXPONENTIAL, and KHR's COLOR). The Khronos extension
//! (Kapoulkine, St. Pierre, Knyazev & McCurdy, 2025) differs from the EXT one in three ways,
//! each checked here: its attribute streams may be version 1 (header 0xa1, control and channel
//! modes; EXT allows only version 0, 0xa0), it has the COLOR filter, and a view or a buffer may
//! carry only one of the two extensions (a file may use both on different views). Every rule
//! the extensions set on stride, count, filter, fallback buffers and the stream's version and
//! channel modes is checked before the decoder runs (the decoder asserts some and silently
//! accepts others), the COLOR filter's bit counts before the filter runs, and the decoded size
//! is bounded before anything is allocated: by the compressed bytes (no codec expands a byte
//! into more than `MAX_EXPANSION`) and by `MAX_DECODED_BYTES` for the whole file.

use super::container::{named, Loader};
use crate::error::Result;
use serde_json::Value;
use std::collections::HashMap;

/// Bytes all of a file's compressed buffer views may decode to together.
pub(super) const MAX_DECODED_BYTES: u64 = 8 << 30;

/// The largest ratio of decoded to compressed bytes any of the three codecs can produce: an
/// attribute block of at most 256 elements costs at least one control byte per four bytes of
/// stride (1024 : 1); a triangle at least one byte (12 : 1); an index at least one byte (4 : 1).
const MAX_EXPANSION: u64 = 1024;

/// The two extensions that store buffer views compressed by meshoptimizer's codecs.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Extension {
    Ext,
    Khr,
}

impl Extension {
    const BOTH: [Extension; 2] = [Extension::Ext, Extension::Khr];

    fn name(self) -> &'static str {
        match self {
            Extension::Ext => "EXT_meshopt_compression",
            Extension::Khr => "KHR_meshopt_compression",
        }
    }

    /// The newest attribute stream version the extension allows.
    fn max_attribute_version(self) -> u8 {
        match self {
            Extension::Ext => 0,
            Extension::Khr => 1,
        }
    }
}

/// Whether `name` is one of the two extensions.
fn is_meshopt_extension(name: &str) -> bool {
    Extension::BOTH.iter().any(|e| e.name() == name)
}

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
    Color,
}

/// One buffer view's extension object, read and checked against its extension's rules.
#[derive(Debug, PartialEq)]
struct Compressed {
    extension: Extension,
    buffer: usize,
    offset: usize,
    length: usize,
    stride: usize,
    count: usize,
    mode: Mode,
    filter: Filter,
}

impl Compressed {
    /// The `extension` object `ext` of a buffer view of `view_length` bytes and optional
    /// `view_stride`.
    fn read(
        extension: Extension,
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
        let filter = match (ext.get("filter").map(|f| f.as_str()), extension) {
            (None | Some(Some("NONE")), _) => Filter::None,
            (Some(Some("OCTAHEDRAL")), _) => Filter::Octahedral,
            (Some(Some("QUATERNION")), _) => Filter::Quaternion,
            (Some(Some("EXPONENTIAL")), _) => Filter::Exponential,
            (Some(Some("COLOR")), Extension::Khr) => Filter::Color,
            (Some(Some("COLOR")), Extension::Ext) => {
                return Err(
                    "'filter' is \"COLOR\", which only KHR_meshopt_compression defines".into(),
                )
            }
            (Some(_), Extension::Ext) => {
                return Err(format!(
                    "'filter' is {}, not NONE, OCTAHEDRAL, QUATERNION or EXPONENTIAL",
                    ext["filter"]
                ))
            }
            (Some(_), Extension::Khr) => {
                return Err(format!(
                    "'filter' is {}, not NONE, OCTAHEDRAL, QUATERNION, EXPONENTIAL or COLOR",
                    ext["filter"]
                ))
            }
        };
        let compressed = Compressed {
            extension,
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
            (Mode::Attributes, Filter::Octahedral | Filter::Color) => stride == 4 || stride == 8,
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
                 a multiple of 4 up to 256; OCTAHEDRAL and COLOR: 4 or 8; QUATERNION: 8; \
                 TRIANGLES and INDICES: 2 or 4)",
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

    /// An attribute stream's header and, in version 1, its channel modes (the tail's last
    /// `stride / 4` bytes), which the decoder does not check itself: the low four bits of each
    /// are the mode (0: byte deltas, 1: 2-byte deltas, 2: 4-byte XOR deltas), the high four
    /// the XOR's rotation, which only mode 2 may set.
    fn check_attribute_stream(&self, data: &[u8]) -> std::result::Result<(), String> {
        let Some(&header) = data.first() else {
            return Err("the ATTRIBUTES data is empty: the file is damaged".into());
        };
        let version = header & 0x0f;
        if header & 0xf0 != 0xa0 || version > 1 {
            return Err(format!(
                "the ATTRIBUTES data starts with 0x{header:02x}, not an attribute stream's header \
                 (0xa0 or 0xa1): the file is damaged"
            ));
        }
        let allowed = self.extension.max_attribute_version();
        if version > allowed {
            return Err(format!(
                "the ATTRIBUTES data is a version {version} stream (header 0x{header:02x}), which \
                 {} does not allow (only version {allowed}, 0xa0; KHR_meshopt_compression \
                 allows version 1)",
                self.extension.name()
            ));
        }
        let channels = self.stride / 4;
        // A stream too short to hold its tail is refused by the decoder.
        if version == 1 && data.len() > self.stride + channels {
            for &channel in &data[data.len() - channels..] {
                let valid = match channel & 0x0f {
                    0 | 1 => channel >> 4 == 0,
                    2 => true,
                    _ => false,
                };
                if !valid {
                    return Err(format!(
                        "the ATTRIBUTES data has the invalid channel mode byte 0x{channel:02x} \
                         (modes 0, 1 and 2; a rotation only with mode 2): the file is damaged"
                    ));
                }
            }
        }
        Ok(())
    }

    /// The COLOR filter's rule on the decoded elements: the fourth component's most
    /// significant bit tells the bit count K (2 ≤ K), so it is at least 2.
    fn check_color_elements(&self, decoded: &[u8]) -> std::result::Result<(), String> {
        let width = self.stride / 4;
        for element in decoded.chunks_exact(self.stride) {
            let alpha = &element[3 * width..];
            let value = match *alpha {
                [a] => a as u16,
                [lo, hi] => u16::from_le_bytes([lo, hi]),
                _ => unreachable!("COLOR strides are 4 or 8, checked when read"),
            };
            if value < 2 {
                return Err(format!(
                    "a COLOR element's fourth component is {value}, which gives no bit count \
                     (its highest set bit must be bit 1 or above): the file is damaged"
                ));
            }
        }
        Ok(())
    }

    /// Decode `data` (exactly the compressed bytes) into `count` elements of `stride` bytes.
    fn decode(&self, data: &[u8]) -> std::result::Result<Vec<u8>, String> {
        let size = self.count * self.stride;
        if self.count == 0 {
            return Ok(Vec::new());
        }
        if self.mode == Mode::Attributes {
            self.check_attribute_stream(data)?;
        }
        let mut out = vec![0u8; size];
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
        if self.filter == Filter::Color {
            self.check_color_elements(&out)?;
        }
        // SAFETY: as above; the filters rewrite `count` elements of `stride` bytes in place,
        // and `check` has enforced their strides (4 or 8, 8, a multiple of 4, 4 or 8).
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
                Filter::Color => {
                    ::meshopt::ffi::meshopt_decodeFilterColor(dst, self.count, self.stride)
                }
            }
        }
        Ok(out)
    }
}

/// Which of the two extensions a buffer or a buffer view carries (`values`: its EXT and KHR
/// objects), if any; both is an error.
fn extension_of(
    values: [Option<&Value>; 2],
) -> std::result::Result<Option<(Extension, &Value)>, String> {
    match values {
        [Some(_), Some(_)] => Err(
            "has both EXT_meshopt_compression and KHR_meshopt_compression, which \
             KHR_meshopt_compression forbids"
                .into(),
        ),
        [Some(ext), None] => Ok(Some((Extension::Ext, ext))),
        [None, Some(khr)] => Ok(Some((Extension::Khr, khr))),
        [None, None] => Ok(None),
    }
}

impl Loader {
    /// Whether `buffer` holds no bytes of its own, only the decoded views: marked as an
    /// extension's fallback (only compressed views refer to it), or, in a file that uses either
    /// extension, a buffer with neither a URI nor a binary chunk left for it (the placeholder).
    pub(super) fn is_meshopt_placeholder(
        &self,
        buffer: &gltf::Buffer,
        binary_chunk_left: bool,
    ) -> bool {
        let fallback = Extension::BOTH.iter().any(|e| {
            buffer
                .extension_value(e.name())
                .and_then(|e| e.get("fallback"))
                .and_then(Value::as_bool)
                .unwrap_or(false)
        });
        let placeholder = matches!(buffer.source(), gltf::buffer::Source::Bin)
            && !binary_chunk_left
            && self.document.extensions_used().any(is_meshopt_extension);
        fallback || placeholder
    }

    /// The extension that marks `buffer` as a fallback, if any, after checking that the buffer
    /// carries at most one of the two.
    fn fallback_of(&self, buffer: &gltf::Buffer) -> Result<Option<Extension>> {
        let values = Extension::BOTH.map(|e| buffer.extension_value(e.name()));
        let object = named("buffer", buffer.index(), buffer.name());
        let extension = extension_of(values).map_err(|m| self.err(&object, m))?;
        Ok(extension
            .filter(|(_, v)| v.get("fallback").and_then(Value::as_bool) == Some(true))
            .map(|(e, _)| e))
    }

    /// Decode every buffer view that has `EXT_meshopt_compression` or
    /// `KHR_meshopt_compression` into `decoded_views`, after checking each, the fallback
    /// buffers' rules and the total decoded size.
    pub(super) fn decode_meshopt_views(&mut self) -> Result<()> {
        let fallbacks: Vec<Option<Extension>> = self
            .document
            .buffers()
            .map(|b| self.fallback_of(&b))
            .collect::<Result<_>>()?;
        let mut views = Vec::new();
        let mut total = 0u64;
        for view in self.document.views() {
            let view_name = named("buffer view", view.index(), view.name());
            let values = Extension::BOTH.map(|e| view.extension_value(e.name()));
            let found = extension_of(values).map_err(|m| self.err(&view_name, m))?;
            let parent = view.buffer().index();
            if let Some(marked) = fallbacks.get(parent).copied().flatten() {
                if found.map(|(e, _)| e) != Some(marked) {
                    return Err(self.err(
                        &view_name,
                        format!(
                            "refers to buffer {parent}, a {} fallback buffer, without that \
                             extension (only its compressed views may refer to it)",
                            marked.name()
                        ),
                    ));
                }
            }
            let Some((extension, ext)) = found else {
                continue;
            };
            let object = format!("{view_name} {}", extension.name());
            let compressed = Compressed::read(extension, ext, view.length(), view.stride())
                .map_err(|m| self.err(&object, m))?;
            if let Some(marked) = fallbacks.get(compressed.buffer).copied().flatten() {
                return Err(self.err(
                    &object,
                    format!(
                        "reads its compressed bytes from buffer {}, a {} fallback buffer, which \
                         holds no compressed data",
                        compressed.buffer,
                        marked.name()
                    ),
                ));
            }
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
        Compressed::read(Extension::Ext, &ext, length, None)
    }

    fn read_khr(ext: Value, length: usize) -> std::result::Result<Compressed, String> {
        Compressed::read(Extension::Khr, &ext, length, None)
    }

    #[test]
    fn the_extensions_rules_are_checked_before_decoding() {
        let ok = json!({"buffer": 0, "byteLength": 10, "byteStride": 12, "count": 4, "mode": "ATTRIBUTES"});
        assert_eq!(read(ok.clone(), 48).unwrap().filter, Filter::None);
        // byteLength of the view must be count × stride.
        assert!(read(ok.clone(), 47).unwrap_err().contains("byteLength"));
        // A parent stride must agree.
        assert!(Compressed::read(Extension::Ext, &ok, 48, Some(16)).is_err());
        let bad = [
            json!({"buffer": 0, "byteLength": 10, "byteStride": 6, "count": 8, "mode": "ATTRIBUTES"}),
            json!({"buffer": 0, "byteLength": 10, "byteStride": 260, "count": 1, "mode": "ATTRIBUTES"}),
            json!({"buffer": 0, "byteLength": 10, "byteStride": 12, "count": 4, "mode": "ATTRIBUTES", "filter": "OCTAHEDRAL"}),
            json!({"buffer": 0, "byteLength": 10, "byteStride": 4, "count": 12, "mode": "ATTRIBUTES", "filter": "QUATERNION"}),
            json!({"buffer": 0, "byteLength": 10, "byteStride": 12, "count": 4, "mode": "ATTRIBUTES", "filter": "COLOR"}),
            json!({"buffer": 0, "byteLength": 10, "byteStride": 4, "count": 4, "mode": "TRIANGLES"}),
            json!({"buffer": 0, "byteLength": 10, "byteStride": 4, "count": 12, "mode": "INDICES", "filter": "EXPONENTIAL"}),
            json!({"buffer": 0, "byteLength": 10, "byteStride": 4, "count": 12, "mode": "INDICES", "filter": "COLOR"}),
            json!({"buffer": 0, "byteLength": 10, "byteStride": 12, "count": 4, "mode": "STRIPS"}),
            json!({"buffer": 0, "byteLength": 10, "byteStride": 12, "count": 4, "mode": "ATTRIBUTES", "filter": "COLOUR"}),
            json!({"buffer": -1, "byteLength": 10, "byteStride": 12, "count": 4, "mode": "ATTRIBUTES"}),
            json!({"byteLength": 10, "byteStride": 12, "count": 4, "mode": "ATTRIBUTES"}),
        ];
        for ext in bad {
            let length =
                ext["byteStride"].as_u64().unwrap_or(0) * ext["count"].as_u64().unwrap_or(0);
            assert!(read(ext.clone(), length as usize).is_err(), "{ext}");
            assert!(read_khr(ext.clone(), length as usize).is_err(), "{ext}");
        }
        // COLOR is the Khronos extension's filter only.
        let color = json!({"buffer": 0, "byteLength": 10, "byteStride": 8, "count": 4, "mode": "ATTRIBUTES", "filter": "COLOR"});
        assert_eq!(read_khr(color.clone(), 32).unwrap().filter, Filter::Color);
        assert!(read(color, 32)
            .unwrap_err()
            .contains("only KHR_meshopt_compression"));
    }

    #[test]
    fn a_declared_size_beyond_what_the_bytes_can_hold_is_refused() {
        let ext = json!({"buffer": 0, "byteLength": 16, "byteStride": 16, "count": 1 << 20, "mode": "ATTRIBUTES"});
        assert!(read(ext, 16 << 20).unwrap_err().contains("damaged"));
    }

    fn vertex_bytes(vertices: &[[f32; 3]]) -> Vec<u8> {
        vertices
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect()
    }

    #[test]
    fn the_codecs_round_trip_and_damaged_data_is_an_error() {
        let vertices: Vec<[f32; 3]> = (0..100).map(|i| [i as f32, 0.5 * i as f32, 1.0]).collect();
        let encoded = ::meshopt::encode_vertex_buffer_level(&vertices, 2, Some(0)).unwrap();
        let ext = json!({"buffer": 0, "byteLength": encoded.len(), "byteStride": 12, "count": 100, "mode": "ATTRIBUTES"});
        let compressed = read(ext, 1200).unwrap();
        let decoded = compressed.decode(&encoded).unwrap();
        assert_eq!(decoded, vertex_bytes(&vertices));
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

    #[test]
    fn version_1_attribute_streams_are_the_khronos_extensions_only() {
        // Values whose float bits suit the 2-byte and XOR channel modes as well as byte deltas.
        let vertices: Vec<[f32; 3]> = (0..300)
            .map(|i| [(i as f32 * 0.37).sin(), 0.01 * i as f32, (i / 7) as f32])
            .collect();
        let v1 = ::meshopt::encode_vertex_buffer_level(&vertices, 3, Some(1)).unwrap();
        let v0 = ::meshopt::encode_vertex_buffer_level(&vertices, 2, Some(0)).unwrap();
        assert_eq!((v1[0], v0[0]), (0xa1, 0xa0));
        let ext = |bytes: &[u8]| json!({"buffer": 0, "byteLength": bytes.len(), "byteStride": 12, "count": 300, "mode": "ATTRIBUTES"});
        let expected = vertex_bytes(&vertices);
        // KHR reads both versions; EXT only version 0.
        assert_eq!(
            read_khr(ext(&v1), 3600).unwrap().decode(&v1).unwrap(),
            expected
        );
        assert_eq!(
            read_khr(ext(&v0), 3600).unwrap().decode(&v0).unwrap(),
            expected
        );
        assert_eq!(read(ext(&v0), 3600).unwrap().decode(&v0).unwrap(), expected);
        let refused = read(ext(&v1), 3600).unwrap().decode(&v1).unwrap_err();
        assert!(refused.contains("version 1"), "{refused}");
        // A header of no version, and channel modes the stream may not hold (the decoder itself
        // would read mode 4 as mode 0, and ignore a rotation on mode 1).
        let khr = read_khr(ext(&v1), 3600).unwrap();
        let mut wrong = v1.clone();
        wrong[0] = 0xa2;
        assert!(khr.decode(&wrong).unwrap_err().contains("header"));
        let last = v1.len() - 1;
        for channel in [0x03, 0x04, 0x10, 0x31] {
            let mut wrong = v1.clone();
            wrong[last] = channel;
            let message = khr.decode(&wrong).unwrap_err();
            assert!(message.contains("channel mode"), "{channel:#x}: {message}");
        }
        // The encoder used more than byte deltas, so the channel modes were read.
        assert!(
            v1[v1.len() - 3..].iter().any(|&c| c != 0),
            "{:?}",
            &v1[v1.len() - 3..]
        );
    }

    #[test]
    fn the_color_filter_decodes_ycocg_and_refuses_elements_without_a_bit_count() {
        let colors: Vec<[f32; 4]> = (0..40)
            .map(|i| {
                let t = i as f32 / 39.0;
                [t, 1.0 - t, 0.5 * t + 0.2, 1.0]
            })
            .collect();
        let filtered = ::meshopt::encode_filter_color::<u16>(&colors, 12);
        let bytes: Vec<u8> = filtered
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let rows: Vec<[u8; 8]> = bytes.chunks(8).map(|r| r.try_into().unwrap()).collect();
        let encoded = ::meshopt::encode_vertex_buffer_level(&rows, 2, Some(1)).unwrap();
        let ext = json!({"buffer": 0, "byteLength": encoded.len(), "byteStride": 8, "count": 40, "mode": "ATTRIBUTES", "filter": "COLOR"});
        let compressed = read_khr(ext, 320).unwrap();
        let decoded = compressed.decode(&encoded).unwrap();
        for (color, out) in colors.iter().zip(decoded.chunks(8)) {
            for c in 0..4 {
                let v = u16::from_le_bytes([out[2 * c], out[2 * c + 1]]) as f32 / 65535.0;
                // 12 bits: within a step of 1/2047 (and the YCoCg transform's rounding).
                assert!((v - color[c]).abs() < 2.0 / 2047.0, "{color:?} → {v}");
            }
        }
        // An element whose fourth component is 0 or 1 has no bit count.
        let mut rows = rows;
        rows[5][6] = 1;
        rows[5][7] = 0;
        let encoded = ::meshopt::encode_vertex_buffer_level(&rows, 2, Some(1)).unwrap();
        let ext = json!({"buffer": 0, "byteLength": encoded.len(), "byteStride": 8, "count": 40, "mode": "ATTRIBUTES", "filter": "COLOR"});
        let message = read_khr(ext, 320).unwrap().decode(&encoded).unwrap_err();
        assert!(message.contains("COLOR"), "{message}");
    }

    #[test]
    fn a_view_or_buffer_with_both_extensions_is_refused() {
        let object = json!({});
        assert!(extension_of([Some(&object), Some(&object)]).is_err());
        assert_eq!(
            extension_of([None, Some(&object)]).unwrap().map(|e| e.0),
            Some(Extension::Khr)
        );
        assert!(extension_of([None, None]).unwrap().is_none());
    }
}
