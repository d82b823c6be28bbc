//! Motion blur's input: a node's poses over the shutter (rigid motion, as Cycles' motion
//! transforms) and a deforming mesh's vertex positions at steps of the shutter (Cycles'
//! deformation blur), with each glTF vertex found among the object's.

use super::container::decode_base64;
use crate::math::{Affine3A, Mat4, Vec3};
use serde_json::Value;
use std::collections::HashMap;

/// A "motion" of `PHOTON_camera` or `PHOTON_object`: two or more poses, each 16 numbers (a
/// column-major world matrix, glTF axes), finite and invertible.
pub(super) fn read_poses(value: &Value) -> std::result::Result<Vec<Affine3A>, String> {
    let poses = value
        .as_array()
        .filter(|p| p.len() >= 2)
        .ok_or_else(|| format!("'motion' must be a list of two or more matrices, found {value}"))?;
    poses
        .iter()
        .map(|pose| {
            let numbers: Vec<f32> = pose
                .as_array()
                .map(|a| {
                    a.iter()
                        .filter_map(|x| x.as_f64().map(|x| x as f32))
                        .collect()
                })
                .unwrap_or_default();
            let bad = || format!("a 'motion' pose must be 16 finite numbers, found {pose}");
            let array: [f32; 16] = numbers.try_into().map_err(|_| bad())?;
            let matrix = Mat4::from_cols_array(&array);
            if !matrix.is_finite() || matrix.determinant().abs() < 1e-12 {
                return Err(bad());
            }
            Ok(Affine3A::from_mat4(matrix))
        })
        .collect()
}

/// Whether `node` moves or deforms while the shutter is open (`PHOTON_object` "motion" or
/// "deform").
pub(super) fn moves(node: &gltf::Node) -> bool {
    node.extension_value("PHOTON_object")
        .is_some_and(|v| v.get("motion").is_some() || v.get("deform").is_some())
}

/// `PHOTON_object`'s "deform": the positions of the object's vertices at the frame, and at
/// two or more steps of the shutter, each base64 little-endian f32 triples (glTF axes, object
/// space).
pub(super) fn read_deform(
    value: &Value,
) -> std::result::Result<(Vec<Vec3>, Vec<Vec<Vec3>>), String> {
    let positions = |v: &Value| -> std::result::Result<Vec<Vec3>, String> {
        let bytes = v
            .as_str()
            .and_then(decode_base64)
            .filter(|b| b.len() % 12 == 0)
            .ok_or("'deform' positions must be base64 of little-endian float triples")?;
        let floats: Vec<f32> = bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let out: Vec<Vec3> = floats.chunks_exact(3).map(Vec3::from_slice).collect();
        match out.iter().all(|p| p.is_finite()) {
            true => Ok(out),
            false => Err("a 'deform' position is NaN or infinite".into()),
        }
    };
    let frame = positions(value.get("frame").ok_or("'deform' needs its 'frame'")?)?;
    let steps = value
        .get("steps")
        .and_then(Value::as_array)
        .filter(|s| s.len() >= 2)
        .ok_or("'deform' needs 'steps', a list of two or more")?
        .iter()
        .map(positions)
        .collect::<std::result::Result<Vec<_>, _>>()?;
    if steps.iter().any(|s| s.len() != frame.len()) {
        return Err("every 'deform' step must hold as many positions as 'frame'".into());
    }
    Ok((frame, steps))
}

/// A primitive's deformation: each of its vertices (`positions`) found by its exact position
/// among the object's vertices at the frame, then its place at each step; `None` when a
/// vertex is not among them.
pub(super) fn deformation_of(
    positions: &[Vec3],
    frame: &[Vec3],
    steps: &[Vec<Vec3>],
) -> Option<Vec<Vec<Vec3>>> {
    // −0.0 + 0.0 is +0.0: both zeros are one key.
    let key = |p: Vec3| (p + Vec3::ZERO).to_array().map(f32::to_bits);
    let mut index: HashMap<[u32; 3], usize> = HashMap::with_capacity(frame.len());
    for (i, &p) in frame.iter().enumerate() {
        index.entry(key(p)).or_insert(i);
    }
    let found: Vec<usize> = positions
        .iter()
        .map(|&p| index.get(&key(p)).copied())
        .collect::<Option<_>>()?;
    Some(
        steps
            .iter()
            .map(|step| found.iter().map(|&i| step[i]).collect())
            .collect(),
    )
}
