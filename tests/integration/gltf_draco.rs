//! `KHR_draco_mesh_compression`: the files of `tests/data/draco` (Blender's glTF exporter with
//! its bundled Draco encoder, `make_draco.py`) load to the same meshes as the uncompressed
//! export, within each attribute's quantization step: every decoded triangle matches one of
//! the uncompressed file's (Draco reorders faces and vertices and may rotate a triangle's
//! corners, never its winding), corner for corner in position, normal, UV and colour. The
//! levels cover the sequential connectivity (level 0), Edgebreaker's standard traversal (3)
//! and its valence traversal (6, 10: parallelogram, constrained multi-parallelogram,
//! portable UV and geometric normal prediction, prediction-degree order), quantized and not;
//! glTF Transform's files (positions merged, so UVs and normals split along interior seams:
//! per-corner attribute connectivity) cover the seams.
//! The files render as the uncompressed one (relMSE at most 1e-4 at 48 × 32 pixels, 16 spp).
//! Damaged, cut or oversized Draco data is a scene error (exit code 2), never a
//! panic.

use crate::support::binary::{photon, temp_dir};
use crate::support::scenes::render_small as render;
use photon::error::Error;
use photon::math::{Vec2, Vec3, Vec4};
use photon::metrics;
use photon::rng::Rng;
use photon::scene::gltf::{load_slice, LoadOptions};
use photon::scene::{Mesh, Scene};
use std::path::PathBuf;

fn data(name: &str) -> Vec<u8> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/draco")
        .join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn load(name: &str) -> Scene {
    load_slice(&data(name), name, &LoadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The largest differences between matched corners: position, normal, uv, colour.
#[derive(Debug, Default)]
struct Errors {
    position: f32,
    normal: f32,
    uv: f32,
    color: f32,
}

fn corner(mesh: &Mesh, v: u32) -> (Vec3, Vec3, Vec2, Vec4) {
    let v = v as usize;
    (
        mesh.positions[v],
        mesh.normals[v],
        mesh.uvs.get(v).copied().unwrap_or(Vec2::ZERO),
        mesh.colors.get(v).copied().unwrap_or(Vec4::ZERO),
    )
}

/// Match every triangle of `decoded` to one of `plain` (any rotation of its corners) by
/// positions, and measure the differences of every attribute at the matched corners.
fn compare(decoded: &Mesh, plain: &Mesh) -> Errors {
    assert_eq!(decoded.indices.len(), plain.indices.len(), "{}", plain.name);
    assert_eq!(decoded.uvs.is_empty(), plain.uvs.is_empty());
    assert_eq!(decoded.colors.is_empty(), plain.colors.is_empty());
    let mut used = vec![false; plain.indices.len()];
    let mut errors = Errors::default();
    for tri in &decoded.indices {
        let mut best = (f32::INFINITY, 0, 0);
        for (j, other) in plain.indices.iter().enumerate() {
            for rot in 0..3 {
                let d = (0..3)
                    .map(|k| {
                        (decoded.positions[tri[k] as usize]
                            - plain.positions[other[(k + rot) % 3] as usize])
                            .abs()
                            .max_element()
                    })
                    .fold(0.0, f32::max);
                if d < best.0 {
                    best = (d, j, rot);
                }
            }
        }
        let (_, j, rot) = best;
        assert!(
            !used[j],
            "{}: two decoded triangles match triangle {j}",
            plain.name
        );
        used[j] = true;
        for (k, &v) in tri.iter().enumerate() {
            let (p, n, uv, c) = corner(decoded, v);
            let (p0, n0, uv0, c0) = corner(plain, plain.indices[j][(k + rot) % 3]);
            errors.position = errors.position.max((p - p0).abs().max_element());
            errors.normal = errors.normal.max((n - n0).abs().max_element());
            errors.uv = errors.uv.max((uv - uv0).abs().max_element());
            errors.color = errors.color.max((c - c0).abs().max_element());
        }
    }
    errors
}

/// Every mesh of the Draco file against the uncompressed file's, within the tolerances.
fn check(name: &str, tolerance: &Errors) {
    let plain = load("plain.glb");
    let decoded = load(name);
    assert_eq!(decoded.meshes.len(), plain.meshes.len());
    for (d, p) in decoded.meshes.iter().zip(&plain.meshes) {
        let e = compare(d, p);
        eprintln!("{name} {}: {e:?}", p.name);
        assert!(
            e.position <= tolerance.position
                && e.normal <= tolerance.normal
                && e.uv <= tolerance.uv
                && e.color <= tolerance.color,
            "{name} {}: {e:?} exceeds {tolerance:?}",
            p.name
        );
    }
}

/// Half a quantization step over the scene's extent (about 3.6 m for positions, the unit
/// square for UVs and colours) plus rounding, for 14-bit positions, 10-bit normals, 12-bit UVs
/// and 10-bit colours; octahedral normals of `n` bits are within about 3 / 2^n per component
/// (4 / 2^n at 8 bits).
fn default_bits() -> Errors {
    Errors {
        position: 3.6 / 16383.0,
        normal: 3.0 / 1024.0,
        uv: 1.0 / 4095.0,
        color: 1.0 / 1023.0,
    }
}

#[test]
fn gltf_draco_sequential_connectivity_matches_the_uncompressed_file() {
    check("level0.glb", &default_bits());
}

#[test]
fn gltf_draco_unquantized_values_are_exact() {
    let exact = Errors {
        position: 0.0,
        normal: 0.0,
        uv: 0.0,
        color: 0.0,
    };
    check("level0_raw.glb", &exact);
    check("level6_raw.glb", &exact);
}

#[test]
fn gltf_draco_edgebreaker_standard_traversal_matches_the_uncompressed_file() {
    check("level3.glb", &default_bits());
}

#[test]
fn gltf_draco_edgebreaker_valence_traversal_matches_the_uncompressed_file() {
    check("level6.glb", &default_bits());
    // 11-bit positions, 8-bit normals, 10-bit UVs and 8-bit colours.
    check(
        "level10.glb",
        &Errors {
            position: 3.6 / 2047.0,
            normal: 4.0 / 256.0,
            uv: 1.0 / 1023.0,
            color: 1.0 / 255.0,
        },
    );
}

#[test]
fn gltf_draco_gltf_transform_files_with_merged_positions_match_the_uncompressed_file() {
    // glTF Transform's defaults: 14-bit positions, 10-bit normals, 12-bit UVs, 8-bit colours.
    let bits = Errors {
        color: 1.0 / 255.0,
        ..default_bits()
    };
    check("gltf_transform.glb", &bits);
    check("gltf_transform_speed0.glb", &bits);
    check("gltf_transform_sequential.glb", &bits);
}

/// The Draco bytes of the file's first primitive: (offset in the file, length).
fn first_draco_view(glb: &[u8]) -> (usize, usize) {
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let json: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let view_index = json["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]
        ["bufferView"]
        .as_u64()
        .unwrap() as usize;
    let view = &json["bufferViews"][view_index];
    let offset = view["byteOffset"].as_u64().unwrap_or(0) as usize;
    (
        20 + json_len + 8 + offset,
        view["byteLength"].as_u64().unwrap() as usize,
    )
}

#[test]
fn gltf_draco_damaged_bytes_are_scene_errors_never_panics() {
    for name in [
        "level0.glb",
        "level3.glb",
        "level6.glb",
        "level10.glb",
        "gltf_transform.glb",
        "gltf_transform_speed0.glb",
    ] {
        let glb = data(name);
        let (start, len) = first_draco_view(&glb);
        let mut rng = Rng::new(7 + name.len() as u64);
        for trial in 0..300 {
            let mut bytes = glb.clone();
            let flips = 1 + (rng.uniform() * 4.0) as usize;
            for _ in 0..flips {
                let at = start + ((rng.uniform() * len as f32) as usize).min(len - 1);
                bytes[at] ^= 1 << ((rng.uniform() * 8.0) as u32).min(7);
            }
            // Loading either succeeds (a flip that only changes values) or is a scene error
            // (the Draco data refused, or the values it gave refused by the loader).
            let result =
                std::panic::catch_unwind(|| load_slice(&bytes, name, &LoadOptions::default()));
            match result {
                Ok(Ok(_)) => {}
                Ok(Err(e)) => assert!(matches!(e, Error::Scene { .. }), "{e}"),
                Err(_) => panic!("{name}: trial {trial} panicked"),
            }
        }
        // Every cut of the Draco bytes (the view shortened, the bytes after it kept).
        for cut in [0, 1, 5, 11, len / 3, len / 2, len - 1] {
            let mut bytes = glb.clone();
            for b in &mut bytes[start + cut..start + len] {
                *b = 0;
            }
            let result =
                std::panic::catch_unwind(|| load_slice(&bytes, name, &LoadOptions::default()));
            assert!(result.is_ok(), "{name}: zeroing from {cut} panicked");
            if let Ok(Err(e)) = result {
                assert!(matches!(e, Error::Scene { .. }), "{e}");
            }
        }
    }
}

#[test]
fn gltf_draco_oversized_counts_and_views_exit_with_code_2() {
    let glb = data("level6.glb");
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let json: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let rebuild = |json: &serde_json::Value| -> Vec<u8> {
        let mut text = serde_json::to_vec(json).unwrap();
        while !text.len().is_multiple_of(4) {
            text.push(b' ');
        }
        let bin = &glb[20 + json_len..];
        let mut out = Vec::new();
        out.extend(b"glTF");
        out.extend(2u32.to_le_bytes());
        out.extend(((12 + 8 + text.len() + bin.len()) as u32).to_le_bytes());
        out.extend((text.len() as u32).to_le_bytes());
        out.extend(b"JSON");
        out.extend(&text);
        out.extend(bin);
        out
    };
    let dir = temp_dir("oversized");
    type Change = Box<dyn Fn(&mut serde_json::Value)>;
    let cases: Vec<(&str, Change)> = vec![
        (
            "a huge vertex count",
            Box::new(|j| j["accessors"][0]["count"] = 4_000_000_000u64.into()),
        ),
        (
            "a count the data do not hold",
            Box::new(|j| j["accessors"][0]["count"] = 90.into()),
        ),
        (
            "a view past the buffer",
            Box::new(|j| j["bufferViews"][0]["byteLength"] = 1_000_000.into()),
        ),
        (
            "an unknown Draco attribute id",
            Box::new(|j| {
                j["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]
                    ["attributes"]["NORMAL"] = 9.into()
            }),
        ),
        (
            "a missing buffer view",
            Box::new(|j| {
                j["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]
                    ["bufferView"] = 99.into()
            }),
        ),
    ];
    for (what, change) in cases {
        let mut j = json.clone();
        change(&mut j);
        let file = dir.join("bad.glb");
        std::fs::write(&file, rebuild(&j)).unwrap();
        let out = photon()
            .args(["info", file.to_str().unwrap()])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{what}: {stderr}");
        assert!(!stderr.contains("panicked"), "{what}: {stderr}");
    }
}

#[test]
fn gltf_draco_files_render_as_the_uncompressed_file() {
    let reference = render(&load("plain.glb"));
    for (name, max_rel_mse) in [
        ("level0_raw.glb", 1e-4),
        ("level0.glb", 1e-4),
        ("level3.glb", 1e-4),
        ("level6.glb", 1e-4),
        ("level6_raw.glb", 1e-4),
        ("level10.glb", 1e-4),
        ("gltf_transform.glb", 1e-4),
        ("gltf_transform_speed0.glb", 1e-4),
    ] {
        let error = metrics::compare(&render(&load(name)), &reference);
        println!(
            "{name}: relMSE {:.2e}, mean {:+.2e} (reference mean {:.3})",
            error.rel_mse, error.mean_relative_difference, error.mean_reference
        );
        assert!(error.mean_reference > 0.01, "the reference is lit");
        assert!(error.rel_mse <= max_rel_mse, "{name}: {error:?}");
    }
}
