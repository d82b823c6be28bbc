//! Compressed glTF data: `EXT_meshopt_compression` and `KHR_meshopt_compression` files written
//! here with meshoptimizer's encoders (the `meshopt` crate; gltfpack lays its files out the same
//! way: the compressed bytes in the binary chunk, the decoded views in a placeholder buffer with no
//! bytes; version 0 attribute streams for EXT, version 1 for KHR) load to the same scene as the
//! uncompressed file and render the same image: bit for bit without filters, within the filters'
//! quantization with them. Files breaking the KHR extension's rules (a view or buffer with both
//! extensions, version 1 streams or the COLOR filter under EXT, fallback buffers read) are
//! refused. `KHR_texture_basisu` textures (KTX2 files in
//! `tests/data/ktx2`) render as the PNG they were encoded from. Damaged or oversized compressed
//! data is a scene error (exit code 2), never a panic.

use crate::support::binary::{render_tiny, temp_dir};
use crate::support::gltf;
use crate::support::scenes;
use crate::support::scenes::render_small as render;

use photon::error::Error;
use photon::metrics;
use photon::render::RenderSettings;
use photon::rng::Rng;
use photon::scene::gltf::{load_slice, LoadOptions};
use photon::scene::Scene;
use serde_json::{json, Value};

/// How a buffer view is stored in the compressed file.
#[derive(Clone, Copy, PartialEq)]
enum Store {
    /// As in the uncompressed file.
    Plain,
    /// ATTRIBUTES, no filter.
    Attributes,
    /// TRIANGLES (32-bit or 16-bit indices of a triangle list).
    Triangles,
    /// INDICES (any index sequence).
    Indices,
    /// ATTRIBUTES with the EXPONENTIAL filter (float vectors, 15-bit mantissas).
    Exponential,
    /// ATTRIBUTES with the OCTAHEDRAL filter (unit vectors as four normalized signed bytes).
    Octahedral,
    /// ATTRIBUTES with the QUATERNION filter (rotations as four normalized signed shorts).
    Quaternion,
    /// ATTRIBUTES with the COLOR filter (`KHR_meshopt_compression` only: RGBA as four
    /// normalized unsigned bytes, 8-bit YCoCg).
    Color,
}

const EXT: &str = "EXT_meshopt_compression";
const KHR: &str = "KHR_meshopt_compression";

/// Which extension compresses each buffer view of a test file.
#[derive(Clone, Copy, PartialEq)]
enum Extensions {
    /// `EXT_meshopt_compression`, version 0 attribute streams.
    Ext,
    /// `KHR_meshopt_compression`, version 1 attribute streams.
    Khr,
    /// KHR on the even views, EXT on the odd ones, each with its own placeholder buffer.
    Both,
}

impl Extensions {
    fn of_view(self, view: usize) -> &'static str {
        match self {
            Extensions::Ext => EXT,
            Extensions::Khr => KHR,
            Extensions::Both if view.is_multiple_of(2) => KHR,
            Extensions::Both => EXT,
        }
    }
}

/// One buffer view of the test file: the values it holds, as floats or indices.
enum Data {
    Floats { values: Vec<f32>, width: usize },
    Indices32(Vec<u32>),
    Indices16(Vec<u16>),
}

struct View {
    data: Data,
    store: Store,
}

impl View {
    /// The view's uncompressed bytes and stride as the file stores them (after the filter's
    /// quantization, for filtered views).
    fn bytes(&self) -> (Vec<u8>, usize) {
        match (&self.data, self.store) {
            (Data::Floats { values, width }, Store::Octahedral) => {
                let rows: Vec<[f32; 4]> = values
                    .chunks(*width)
                    .map(|v| [v[0], v[1], v[2], 0.0])
                    .collect();
                let encoded = ::meshopt::encode_filter_oct::<i8>(&rows, 8);
                (encoded.iter().flatten().map(|&b| b as u8).collect(), 4)
            }
            (Data::Floats { values, .. }, Store::Quaternion) => {
                let rows: Vec<[f32; 4]> =
                    values.chunks(4).map(|v| [v[0], v[1], v[2], v[3]]).collect();
                let encoded = ::meshopt::encode_filter_quat(&rows, 12);
                let bytes = encoded.iter().flatten().flat_map(|v| v.to_le_bytes());
                (bytes.collect(), 8)
            }
            (Data::Floats { values, width }, Store::Exponential) => {
                assert_eq!(*width, 3);
                let rows: Vec<[f32; 3]> = values.chunks(3).map(|v| [v[0], v[1], v[2]]).collect();
                let encoded =
                    ::meshopt::encode_filter_exp(&rows, 15, ::meshopt::EncodeExpMode::SharedVector);
                let bytes = encoded.iter().flatten().flat_map(|v| v.to_le_bytes());
                (bytes.collect(), 12)
            }
            (Data::Floats { values, .. }, Store::Color) => {
                let rows: Vec<[f32; 4]> =
                    values.chunks(4).map(|v| [v[0], v[1], v[2], v[3]]).collect();
                let encoded = ::meshopt::encode_filter_color::<u8>(&rows, 8);
                (encoded.iter().flatten().copied().collect(), 4)
            }
            (Data::Floats { values, width }, _) => {
                let bytes = values.iter().flat_map(|v| v.to_le_bytes()).collect();
                (bytes, 4 * width)
            }
            (Data::Indices32(v), _) => (v.iter().flat_map(|i| i.to_le_bytes()).collect(), 4),
            (Data::Indices16(v), _) => (v.iter().flat_map(|i| i.to_le_bytes()).collect(), 2),
        }
    }

    /// The extension's compressed bytes, mode and filter for the decoded `bytes`: attribute
    /// streams of `version` 0 (EXT) or 1 (KHR, at the encoder's highest level, which tries
    /// every channel mode).
    fn compress(
        &self,
        bytes: &[u8],
        stride: usize,
        version: i32,
    ) -> Option<(Vec<u8>, &'static str, &str)> {
        let rows =
            |bytes: &[u8]| -> Vec<Vec<u8>> { bytes.chunks(stride).map(<[u8]>::to_vec).collect() };
        let level = if version == 0 { 2 } else { 3 };
        fn encode<const N: usize>(rows: &[Vec<u8>], level: i32, version: i32) -> Vec<u8> {
            ::meshopt::encode_vertex_buffer_level(&as_rows::<N>(rows), level, Some(version))
                .unwrap()
        }
        let attributes = |bytes: &[u8]| match stride {
            4 => encode::<4>(&rows(bytes), level, version),
            8 => encode::<8>(&rows(bytes), level, version),
            12 => encode::<12>(&rows(bytes), level, version),
            16 => encode::<16>(&rows(bytes), level, version),
            _ => unreachable!("no view of this stride"),
        };
        let indices = || -> Vec<u32> {
            match &self.data {
                Data::Indices32(v) => v.clone(),
                Data::Indices16(v) => v.iter().map(|&i| i as u32).collect(),
                Data::Floats { .. } => unreachable!("indices"),
            }
        };
        Some(match self.store {
            Store::Plain => return None,
            Store::Attributes => (attributes(bytes), "ATTRIBUTES", "NONE"),
            Store::Exponential => (attributes(bytes), "ATTRIBUTES", "EXPONENTIAL"),
            Store::Octahedral => (attributes(bytes), "ATTRIBUTES", "OCTAHEDRAL"),
            Store::Quaternion => (attributes(bytes), "ATTRIBUTES", "QUATERNION"),
            Store::Color => (attributes(bytes), "ATTRIBUTES", "COLOR"),
            Store::Triangles | Store::Indices => {
                let i = indices();
                let n = 1 + *i.iter().max().unwrap() as usize;
                if self.store == Store::Triangles {
                    let encoded = ::meshopt::encode_index_buffer(&i, n).unwrap();
                    (encoded, "TRIANGLES", "NONE")
                } else {
                    let encoded = ::meshopt::encode_index_sequence(&i, n).unwrap();
                    (encoded, "INDICES", "NONE")
                }
            }
        })
    }
}

/// A triangle list as meshoptimizer's TRIANGLES codec gives it back: the same triangles in
/// the same order, each perhaps with its corners rotated; the uncompressed file holds these,
/// corner for corner the compressed file's.
fn as_the_codec_returns(indices: &[u32]) -> Vec<u32> {
    let vertices = 1 + *indices.iter().max().unwrap() as usize;
    let encoded = ::meshopt::encode_index_buffer(indices, vertices).unwrap();
    ::meshopt::decode_index_buffer(&encoded, indices.len()).unwrap()
}

fn as_rows<const N: usize>(rows: &[Vec<u8>]) -> Vec<[u8; N]> {
    rows.iter()
        .map(|r| <[u8; N]>::try_from(&r[..]).unwrap())
        .collect()
}

/// A sphere with vertex colours placed three times by `EXT_mesh_gpu_instancing` (rotated
/// instances) over a floor, lit by a sun and seen by a camera. `stores` says how each of the
/// seven views is stored: sphere positions, normals, indices, floor positions, floor indices
/// (16-bit), instance rotations, sphere colours. All plain gives the uncompressed file; any
/// other puts the compressed bytes in the binary chunk and the decoded views in a placeholder
/// buffer per extension (tagged as that extension's fallback when `tag_fallback`).
fn scene_file(stores: [Store; 7], tag_fallback: bool, extensions: Extensions) -> Vec<u8> {
    let (rings, sides) = (12usize, 20usize);
    let (mut positions, mut normals, mut indices) = (Vec::new(), Vec::new(), Vec::new());
    let mut colors = Vec::new();
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..=sides {
            let phi = std::f32::consts::TAU * s as f32 / sides as f32;
            let n = [
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ];
            normals.extend(n);
            positions.extend(n.map(|c| 0.6 * c));
            let (u, v) = (s as f32 / sides as f32, r as f32 / rings as f32);
            colors.extend([0.2 + 0.8 * u, 1.0 - 0.7 * v, 0.3 + 0.5 * u * v, 1.0]);
        }
    }
    let row = sides as u32 + 1;
    for r in 0..rings as u32 {
        for s in 0..sides as u32 {
            let (a, b) = (r * row + s, (r + 1) * row + s);
            indices.extend([a, a + 1, b, a + 1, b + 1, b]);
        }
    }
    let indices = as_the_codec_returns(&indices);
    // A stretched sphere: the instances' rotations show in the image.
    let positions: Vec<f32> = positions
        .chunks(3)
        .flat_map(|p| [1.5 * p[0], p[1], 0.7 * p[2]])
        .collect();
    let floor = vec![
        -4.0, -0.8, -4.0, 4.0, -0.8, -4.0, 4.0, -0.8, 4.0, -4.0, -0.8, 4.0,
    ];
    let rotation = |axis: [f32; 3], angle: f32| {
        let (s, c) = ((0.5 * angle).sin(), (0.5 * angle).cos());
        [axis[0] * s, axis[1] * s, axis[2] * s, c]
    };
    let rotations: Vec<f32> = [
        rotation([0.0, 1.0, 0.0], 0.3),
        rotation([0.0, 0.6, 0.8], 1.1),
        rotation([1.0, 0.0, 0.0], -0.7),
    ]
    .concat();
    let views = [
        (
            Data::Floats {
                values: positions,
                width: 3,
            },
            stores[0],
        ),
        (
            Data::Floats {
                values: normals,
                width: 3,
            },
            stores[1],
        ),
        (Data::Indices32(indices), stores[2]),
        (
            Data::Floats {
                values: floor,
                width: 3,
            },
            stores[3],
        ),
        (
            Data::Indices16(
                as_the_codec_returns(&[0, 2, 1, 0, 3, 2])
                    .iter()
                    .map(|&i| i as u16)
                    .collect(),
            ),
            stores[4],
        ),
        (
            Data::Floats {
                values: rotations,
                width: 4,
            },
            stores[5],
        ),
        (
            Data::Floats {
                values: colors,
                width: 4,
            },
            stores[6],
        ),
    ]
    .map(|(data, store)| View { data, store });

    // The extensions the file uses, each with its placeholder buffer (1, then 2).
    let mut used_extensions: Vec<&str> = Vec::new();
    for (i, &store) in stores.iter().enumerate() {
        let name = extensions.of_view(i);
        if store != Store::Plain && !used_extensions.contains(&name) {
            used_extensions.push(name);
        }
    }
    used_extensions.sort();
    // Buffer 0: the binary chunk (plain views, compressed bytes); buffers 1 and 2: the decoded
    // views of each extension.
    let mut bin = Vec::<u8>::new();
    let mut decoded_len = vec![0usize; used_extensions.len()];
    let mut buffer_views = Vec::new();
    let pad = |v: &mut Vec<u8>| v.resize(v.len().next_multiple_of(4), 0);
    for (i, view) in views.iter().enumerate() {
        let (bytes, stride) = view.bytes();
        let name = extensions.of_view(i);
        let version = if name == KHR { 1 } else { 0 };
        let mut json = match view.compress(&bytes, stride, version) {
            None => {
                pad(&mut bin);
                let at = bin.len();
                bin.extend(&bytes);
                json!({"buffer": 0, "byteOffset": at, "byteLength": bytes.len()})
            }
            Some((encoded, mode, filter)) => {
                pad(&mut bin);
                let at = bin.len();
                bin.extend(&encoded);
                let placeholder = used_extensions.iter().position(|&e| e == name).unwrap();
                let end = &mut decoded_len[placeholder];
                *end = end.next_multiple_of(4);
                let json = json!({"buffer": 1 + placeholder, "byteOffset": *end,
                    "byteLength": bytes.len(),
                    "extensions": {name: {
                        "buffer": 0, "byteOffset": at, "byteLength": encoded.len(),
                        "byteStride": stride, "mode": mode, "filter": filter,
                        "count": bytes.len() / stride}}});
                *end += bytes.len();
                json
            }
        };
        if matches!(view.data, Data::Floats { width: 3, .. }) && stride != 12 {
            json["byteStride"] = json!(stride);
        }
        if matches!(view.store, Store::Quaternion | Store::Color) {
            json["byteStride"] = json!(stride);
        }
        buffer_views.push(json);
    }
    let count = |i: usize| match &views[i].data {
        Data::Floats { values, width } => values.len() / width,
        Data::Indices32(v) => v.len(),
        Data::Indices16(v) => v.len(),
    };
    let normal_accessor = if stores[1] == Store::Octahedral {
        json!({"bufferView": 1, "componentType": 5120, "normalized": true, "count": count(1), "type": "VEC3"})
    } else {
        json!({"bufferView": 1, "componentType": 5126, "count": count(1), "type": "VEC3"})
    };
    let color_accessor = if stores[6] == Store::Color {
        json!({"bufferView": 6, "componentType": 5121, "normalized": true, "count": count(6), "type": "VEC4"})
    } else {
        json!({"bufferView": 6, "componentType": 5126, "count": count(6), "type": "VEC4"})
    };
    let rotation_accessor = if stores[5] == Store::Quaternion {
        json!({"bufferView": 5, "componentType": 5122, "normalized": true, "count": 3, "type": "VEC4"})
    } else {
        json!({"bufferView": 5, "componentType": 5126, "count": 3, "type": "VEC4"})
    };
    let translations: Vec<u8> = [-1.6f32, 0.0, 0.0, 0.0, 0.2, -0.5, 1.6, 0.0, 0.3]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    pad(&mut bin);
    buffer_views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": 36}));
    bin.extend(translations);

    let mut used = vec!["KHR_lights_punctual", "EXT_mesh_gpu_instancing"];
    let mut required = vec!["EXT_mesh_gpu_instancing"];
    used.extend(&used_extensions);
    required.extend(&used_extensions);
    if stores[1] == Store::Octahedral {
        used.push("KHR_mesh_quantization");
        required.push("KHR_mesh_quantization");
    }
    let mut buffers = vec![json!({"byteLength": bin.len()})];
    for (name, length) in used_extensions.iter().zip(decoded_len) {
        let mut placeholder = json!({"byteLength": length});
        if tag_fallback {
            placeholder["extensions"] = json!({*name: {"fallback": true}});
        }
        buffers.push(placeholder);
    }
    let document = json!({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0, 1, 2, 3]}],
        "extensionsUsed": used, "extensionsRequired": required,
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "directional", "intensity": 1500.0}]}},
        "materials": [
            {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.35, 0.2, 1.0],
                "metallicFactor": 0.0, "roughnessFactor": 0.5}},
            {"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1.0],
                "metallicFactor": 0.0, "roughnessFactor": 0.9}}],
        "buffers": buffers,
        "bufferViews": buffer_views,
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": count(0), "type": "VEC3",
             "min": [-0.9, -0.6, -0.42], "max": [0.9, 0.6, 0.42]},
            normal_accessor,
            {"bufferView": 2, "componentType": 5125, "count": count(2), "type": "SCALAR"},
            {"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [-4.0, -0.8, -4.0], "max": [4.0, -0.8, 4.0]},
            {"bufferView": 4, "componentType": 5123, "count": 6, "type": "SCALAR"},
            rotation_accessor,
            {"bufferView": 7, "componentType": 5126, "count": 3, "type": "VEC3"},
            color_accessor],
        "meshes": [
            {"name": "Egg", "primitives": [
                {"attributes": {"POSITION": 0, "NORMAL": 1, "COLOR_0": 7}, "indices": 2,
                 "material": 0}]},
            {"name": "Floor", "primitives": [
                {"attributes": {"POSITION": 3}, "indices": 4, "material": 1}]}],
        "nodes": [
            {"name": "Eggs", "mesh": 0, "extensions": {"EXT_mesh_gpu_instancing": {
                "attributes": {"TRANSLATION": 6, "ROTATION": 5}}}},
            {"name": "Floor", "mesh": 1},
            {"name": "Sun", "rotation": [-0.45, 0.25, 0.1, 0.85],
             "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "Camera", "camera": 0, "translation": [0.0, 2.2, 4.5],
             "rotation": [-0.22, 0.0, 0.0, 0.975]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "aspectRatio": 1.5,
            "znear": 0.1}}],
    });
    gltf::glb(&document, &bin)
}

const PLAIN: [Store; 7] = [Store::Plain; 7];

/// The test scene with every filter and both index modes, for the fuzzer (`fuzz_gltf`).
pub fn filtered_file() -> Vec<u8> {
    scene_file(FILTERED, true, Extensions::Ext)
}

/// Every view compressed without a filter.
const LOSSLESS: [Store; 7] = [
    Store::Attributes,
    Store::Attributes,
    Store::Triangles,
    Store::Attributes,
    Store::Indices,
    Store::Attributes,
    Store::Attributes,
];

/// Every filter of `EXT_meshopt_compression`, and each index mode.
const FILTERED: [Store; 7] = [
    Store::Exponential,
    Store::Octahedral,
    Store::Triangles,
    Store::Exponential,
    Store::Indices,
    Store::Quaternion,
    Store::Attributes,
];

/// Every filter of `KHR_meshopt_compression` (COLOR on the vertex colours), and each index
/// mode.
const FILTERED_KHR: [Store; 7] = {
    let mut stores = FILTERED;
    stores[6] = Store::Color;
    stores
};

fn load(bytes: &[u8]) -> Scene {
    load_slice(bytes, "compressed.glb", &LoadOptions::default()).expect("the file loads")
}

#[test]
fn gltf_compression_meshopt_without_filters_renders_bit_for_bit_as_uncompressed() {
    let plain = scene_file(PLAIN, false, Extensions::Ext);
    let reference = render(&load(&plain));
    println!("uncompressed file: {} bytes", plain.len());
    for extensions in [Extensions::Ext, Extensions::Khr, Extensions::Both] {
        for tag_fallback in [false, true] {
            let file = scene_file(LOSSLESS, tag_fallback, extensions);
            if !tag_fallback {
                println!(
                    "without filters (KHR: {}, EXT: {}): {} bytes",
                    extensions != Extensions::Ext,
                    extensions != Extensions::Khr,
                    file.len()
                );
            }
            let image = render(&load(&file));
            assert!(
                image == reference,
                "a lossless compressed file renders differently (KHR: {}, EXT: {}, fallback \
                 tagged: {tag_fallback})",
                extensions != Extensions::Ext,
                extensions != Extensions::Khr,
            );
        }
    }
    // 16-bit triangle lists too (TRIANGLES with a stride of 2).
    let mut stores = PLAIN;
    stores[4] = Store::Triangles;
    assert!(render(&load(&scene_file(stores, true, Extensions::Ext))) == reference);
    assert!(render(&load(&scene_file(stores, true, Extensions::Khr))) == reference);
}

#[test]
fn gltf_compression_meshopt_filters_render_within_their_quantization() {
    let reference = render(&load(&scene_file(PLAIN, false, Extensions::Ext)));
    for (name, stores, extensions) in [
        (EXT, FILTERED, Extensions::Ext),
        (KHR, FILTERED_KHR, Extensions::Khr),
    ] {
        let file = scene_file(stores, true, extensions);
        let image = render(&load(&file));
        let error = metrics::compare(&image, &reference);
        println!(
            "{name} filtered ({} bytes): relMSE {:.2e}, mean {:+.2e} (reference mean {:.3})",
            file.len(),
            error.rel_mse,
            error.mean_relative_difference,
            error.mean_reference
        );
        assert!(
            error.rel_mse < 2e-3 && error.mean_relative_difference.abs() < 2e-3,
            "{name}: {error:?}"
        );
        // Each filter alone changes the image, so each is decoded (undecoded data would be
        // garbage).
        assert!(image != reference);
    }
    // The COLOR filter alone: the 8-bit YCoCg colours are within their quantization, and
    // differ from the exact ones, so the filter ran.
    let mut stores = PLAIN;
    stores[6] = Store::Color;
    let image = render(&load(&scene_file(stores, true, Extensions::Khr)));
    let error = metrics::compare(&image, &reference);
    println!(
        "COLOR filter alone: relMSE {:.2e}, mean {:+.2e}",
        error.rel_mse, error.mean_relative_difference
    );
    assert!(
        error.rel_mse < 2e-5 && error.mean_relative_difference.abs() < 1e-3,
        "{error:?}"
    );
    assert!(image != reference);
}

/// The compressed file's JSON and binary chunk, and the file rebuilt from them.
fn split(file: &[u8]) -> (Value, Vec<u8>) {
    let json_len = u32::from_le_bytes(file[12..16].try_into().unwrap()) as usize;
    let json: Value = serde_json::from_slice(&file[20..20 + json_len]).unwrap();
    let bin = file[20 + json_len + 8..].to_vec();
    (json, bin)
}

/// Buffer view `view`'s `EXT_meshopt_compression` object.
fn extension(json: &mut Value, view: usize) -> &mut Value {
    &mut json["bufferViews"][view]["extensions"][EXT]
}

fn assert_refused(file: &[u8], words: &[&str]) {
    let message = match load_slice(file, "compressed.glb", &LoadOptions::default()) {
        Err(error @ Error::Scene { .. }) => error.to_string(),
        Err(other) => panic!("not a scene error: {other:?}"),
        Ok(_) => panic!("a broken compressed file loaded"),
    };
    for word in words {
        assert!(message.contains(word), "'{word}' missing from: {message}");
    }
}

#[test]
fn gltf_compression_meshopt_damaged_or_oversized_views_are_scene_errors() {
    let stores = FILTERED;
    let file = scene_file(stores, true, Extensions::Ext);
    let (json, bin) = split(&file);
    let edit = |view: usize, f: &dyn Fn(&mut Value)| {
        let mut json = json.clone();
        f(extension(&mut json, view));
        gltf::glb(&json, &bin)
    };
    // Compressed bytes cut short: the decoder runs out.
    let cut = edit(0, &|e| {
        e["byteLength"] = json!(e["byteLength"].as_u64().unwrap() / 2)
    });
    assert_refused(&cut, &["buffer view 0", "does not decode"]);
    // A declared size the compressed bytes cannot hold, refused before anything is allocated.
    let mut huge = json.clone();
    huge["bufferViews"][0]["byteLength"] = json!(12u64 << 34);
    huge["buffers"][1]["byteLength"] = json!(12u64 << 34);
    extension(&mut huge, 0)["count"] = json!(1u64 << 34);
    assert_refused(&gltf::glb(&huge, &bin), &["buffer view 0", "damaged"]);
    // count × byteStride must be the view's length.
    let wrong = edit(3, &|e| e["count"] = json!(5));
    assert_refused(&wrong, &["buffer view 3", "byteLength"]);
    // A filter on index data, and a stride the filter does not allow.
    let filtered = edit(2, &|e| e["filter"] = json!("OCTAHEDRAL"));
    assert_refused(&filtered, &["buffer view 2", "filter"]);
    let stride = edit(0, &|e| e["filter"] = json!("QUATERNION"));
    assert_refused(&stride, &["buffer view 0", "byteStride"]);
    // Compressed bytes outside their buffer.
    let outside = edit(1, &|e| e["byteOffset"] = json!(1u64 << 40));
    assert_refused(&outside, &["buffer view 1", "outside buffer 0"]);
    // A plain view reading the placeholder buffer has no bytes to read; when the placeholder
    // is tagged as the fallback, the view breaks the extension's rule.
    let mut plain = json.clone();
    plain["bufferViews"][0]["extensions"] = json!({});
    assert_refused(
        &gltf::glb(&plain, &bin),
        &["buffer view 0", "fallback buffer"],
    );
    plain["buffers"][1]["extensions"] = json!({});
    assert_refused(
        &gltf::glb(&plain, &bin),
        &["buffer view 0", "outside buffer 1"],
    );
}

/// The file's JSON with every `from` extension name written as `to`.
fn renamed(json: &Value, from: &str, to: &str) -> Value {
    serde_json::from_str(&json.to_string().replace(from, to)).unwrap()
}

#[test]
fn gltf_compression_khr_meshopt_files_breaking_its_rules_are_scene_errors() {
    // An EXT file read as KHR is the same scene (version 0 streams are KHR's too), as the
    // extension says a renaming converts one to the other.
    let (ext_json, ext_bin) = split(&scene_file(LOSSLESS, true, Extensions::Ext));
    let as_khr = gltf::glb(&renamed(&ext_json, EXT, KHR), &ext_bin);
    assert!(render(&load(&as_khr)) == render(&load(&scene_file(PLAIN, false, Extensions::Ext))));
    // The other way, KHR's version 1 streams and COLOR filter are not EXT's.
    let (json, bin) = split(&scene_file(LOSSLESS, true, Extensions::Khr));
    let as_ext = gltf::glb(&renamed(&json, KHR, EXT), &bin);
    assert_refused(&as_ext, &["buffer view 0", EXT, "version 1"]);
    let (filtered, filtered_bin) = split(&scene_file(FILTERED_KHR, true, Extensions::Khr));
    let as_ext = gltf::glb(&renamed(&filtered, KHR, EXT), &filtered_bin);
    assert_refused(&as_ext, &["buffer view 6", EXT, "COLOR"]);

    let khr = |json: &mut Value, view: usize| json["bufferViews"][view]["extensions"][KHR].clone();
    // A view with both extensions.
    let mut both = json.clone();
    let object = khr(&mut both, 3);
    both["bufferViews"][3]["extensions"][EXT] = object;
    assert_refused(
        &gltf::glb(&both, &bin),
        &["buffer view 3", "both", "forbids"],
    );
    // A buffer tagged by both.
    let mut both = json.clone();
    both["buffers"][1]["extensions"][EXT] = json!({"fallback": true});
    assert_refused(&gltf::glb(&both, &bin), &["buffer 1", "both", "forbids"]);
    // A plain view reading KHR's fallback buffer, and compressed bytes read from it.
    let mut plain = json.clone();
    plain["bufferViews"][5]["extensions"] = json!({});
    assert_refused(
        &gltf::glb(&plain, &bin),
        &["buffer view 5", "KHR_meshopt_compression fallback buffer"],
    );
    let mut source = json.clone();
    source["bufferViews"][5]["extensions"][KHR]["buffer"] = json!(1);
    assert_refused(
        &gltf::glb(&source, &bin),
        &["buffer view 5", KHR, "fallback buffer"],
    );
    // An EXT view whose decoded bytes go to KHR's fallback buffer.
    let mut mixed = json.clone();
    let object = khr(&mut mixed, 5);
    mixed["bufferViews"][5]["extensions"] = json!({EXT: object});
    assert_refused(
        &gltf::glb(&mixed, &bin),
        &["buffer view 5", "fallback buffer"],
    );
    // A channel mode byte (the stream's last bytes) the version 1 stream may not hold.
    let end = |view: usize| {
        let e = khr(&mut json.clone(), view);
        (e["byteOffset"].as_u64().unwrap() + e["byteLength"].as_u64().unwrap()) as usize
    };
    let mut damaged = bin.clone();
    damaged[end(0) - 1] = 0x13;
    assert_refused(
        &gltf::glb(&json, &damaged),
        &["buffer view 0", KHR, "channel mode"],
    );
    // A version the extension does not know.
    let mut damaged = bin.clone();
    let start = khr(&mut json.clone(), 3)["byteOffset"].as_u64().unwrap() as usize;
    damaged[start] = 0xa2;
    assert_refused(&gltf::glb(&json, &damaged), &["buffer view 3", "header"]);
}

#[test]
fn gltf_compression_meshopt_damaged_bytes_never_panic() {
    for (file, seed) in [
        (scene_file(FILTERED, true, Extensions::Ext), 0x3e5d),
        (scene_file(FILTERED_KHR, true, Extensions::Khr), 0x3e5e),
    ] {
        let (json, bin) = split(&file);
        let (mut loaded, mut refused) = (0, 0);
        for i in 0..300u64 {
            let mut rng = Rng::for_item(seed, 0, i);
            let mut damaged = bin.clone();
            for _ in 0..1 + (rng.uniform() * 6.0) as usize {
                let at = (rng.uniform() * damaged.len() as f32) as usize % damaged.len();
                damaged[at] = (rng.uniform() * 256.0) as u8;
            }
            match load_slice(
                &gltf::glb(&json, &damaged),
                "x.glb",
                &LoadOptions::default(),
            ) {
                Ok(scene) => {
                    assert!(scene.validate().is_ok());
                    loaded += 1;
                }
                Err(Error::Scene { .. }) => refused += 1,
                Err(other) => panic!("not a scene error: {other:?}"),
            }
        }
        println!("damaged compressed bytes: {loaded} loaded, {refused} refused");
        assert!(refused > 0);
    }
}

#[test]
fn gltf_compression_meshopt_required_renders_and_damage_exits_with_code_2() {
    let dir = temp_dir("gltf_compression_cli");
    for (name, stores, extensions) in [
        (EXT, FILTERED, Extensions::Ext),
        (KHR, FILTERED_KHR, Extensions::Khr),
    ] {
        let file = scene_file(stores, false, extensions);
        let good = dir.join(format!("{name}.glb"));
        std::fs::write(&good, &file).unwrap();
        let run = |path: &std::path::Path| render_tiny(path, &dir);
        let out = run(&good);
        assert_eq!(
            out.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let (mut json, bin) = split(&file);
        json["bufferViews"][2]["extensions"][name]["byteLength"] = json!(20);
        let bad = dir.join(format!("damaged_{name}.glb"));
        std::fs::write(&bad, gltf::glb(&json, &bin)).unwrap();
        let out = run(&bad);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.contains(name) && stderr.contains("damaged"),
            "{stderr}"
        );
    }
}

/// The stripes image and its KTX2 encodings (`tests/data/ktx2/README.md`).
fn ktx2_data(file: &str) -> Vec<u8> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/ktx2/");
    std::fs::read(format!("{dir}{file}")).unwrap()
}

/// A square facing the camera that shows its emission texture, image 0 (nearest texels):
/// `images` are (bytes, MIME type); `texture` is the glTF texture object.
fn textured_square(images: &[(Vec<u8>, &str)], texture: Value, required: &[&str]) -> Vec<u8> {
    let mut doc = gltf::Doc::new();
    let positions = [
        -1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 1.0, 1.0, 0.0, -1.0, 1.0, 0.0,
    ];
    let normals = [0.0, 0.0, 1.0].repeat(4);
    let mesh = doc.mesh("Square", &positions, &normals, &[0, 1, 2, 0, 2, 3]);
    let uvs = doc.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], "VEC2");
    let primitive = &mut doc.json["meshes"][mesh]["primitives"][0];
    primitive["attributes"]["TEXCOORD_0"] = json!(uvs);
    primitive["material"] = json!(0);
    doc.node(json!({"name": "Square", "mesh": mesh}), true);
    doc.camera("Camera", "CameraData", [0.0, 0.0, 2.6]);
    let images: Vec<Value> = images
        .iter()
        .map(|(bytes, mime)| json!({"bufferView": doc.view(bytes), "mimeType": mime}))
        .collect();
    doc.json["images"] = json!(images);
    doc.json["samplers"] = json!([{"magFilter": 9728, "minFilter": 9728}]);
    doc.json["textures"] = json!([texture]);
    doc.json["materials"] = json!([{"pbrMetallicRoughness": {
        "baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0},
        "emissiveFactor": [1.0, 1.0, 1.0], "emissiveTexture": {"index": 0}}]);
    doc.json["extensionsUsed"] = json!(["KHR_texture_basisu"]);
    doc.json["extensionsRequired"] = json!(required);
    doc.glb()
}

fn render_square(file: &[u8]) -> Vec<[f32; 4]> {
    let settings = RenderSettings {
        width: 32,
        height: 32,
        spp: 4,
        ..RenderSettings::default()
    };
    scenes::render_quietly(&load(file), &settings)
        .unwrap()
        .0
        .rgba
}

#[test]
fn gltf_compression_basisu_textures_render_as_their_png() {
    let png = (ktx2_data("stripes.png"), "image/png");
    let reference = render_square(&textured_square(
        std::slice::from_ref(&png),
        json!({"source": 0, "sampler": 0}),
        &[],
    ));
    let basisu = |image: usize| json!({"sampler": 0, "extensions": {"KHR_texture_basisu": {"source": image}}});
    // UASTC keeps these texels exactly; ETC1S (its lowest quality) darkens them by about 1 %.
    for (file, rel_mse_max, mean_max) in [
        ("stripes_uastc.ktx2", 1e-4, 1e-3),
        ("stripes_etc1s.ktx2", 1e-3, 0.02),
    ] {
        let ktx2 = (ktx2_data(file), "image/ktx2");
        let square = textured_square(&[ktx2], basisu(0), &["KHR_texture_basisu"]);
        let error = metrics::compare(&render_square(&square), &reference);
        println!(
            "{file}: relMSE {:.2e}, mean {:+.2e}",
            error.rel_mse, error.mean_relative_difference
        );
        assert!(
            error.rel_mse < rel_mse_max && error.mean_relative_difference.abs() < mean_max,
            "{file}: {error:?}"
        );
    }
    // With a PNG source as well, the PNG is read (as Blender's importer reads it): a damaged
    // KTX2 image beside it is never decoded.
    let damaged = (ktx2_data("stripes_etc1s.ktx2")[..60].to_vec(), "image/ktx2");
    let mut both = basisu(1);
    both["source"] = json!(0);
    let square = textured_square(&[png, damaged.clone()], both, &[]);
    assert!(render_square(&square) == reference);
    // Alone, the damaged image is refused with exit code 2.
    let dir = temp_dir("gltf_compression_ktx2");
    let path = dir.join("damaged_ktx2.glb");
    std::fs::write(
        &path,
        textured_square(&[damaged], basisu(0), &["KHR_texture_basisu"]),
    )
    .unwrap();
    let out = render_tiny(&path, &dir);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("KTX2"), "{stderr}");
}
