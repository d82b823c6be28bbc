//! Deformation blur's input (Cycles' deformation blur): a deforming object's vertex positions
//! at the frame and at evenly spaced steps of the shutter, and each glTF vertex of its mesh found
//! among them. Rigid motion (poses over the shutter) is read with `PHOTON_object` in
//! `extensions`.

use super::encoding::decode_base64;
use crate::math::Vec3;
use serde_json::Value;
use std::collections::HashMap;

/// `PHOTON_object`'s "deform": the positions of the object's vertices at the frame, and at
/// two or more steps of the shutter (glTF axes, object space).
pub(super) struct Deformation {
    frame: Vec<Vec3>,
    steps: Vec<Vec<Vec3>>,
}

impl Deformation {
    /// `{"frame": b64, "steps": [b64, ...]}`, each base64 of little-endian f32 triples.
    pub(super) fn read(value: &Value) -> std::result::Result<Deformation, String> {
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
        Ok(Deformation { frame, steps })
    }

    /// A primitive's deformation: each of its vertices (`positions`) found by its exact
    /// position among the object's vertices at the frame, then its place at each step; `None`
    /// when a vertex is not among them.
    pub(super) fn of(&self, positions: &[Vec3]) -> Option<Vec<Vec<Vec3>>> {
        // −0.0 + 0.0 is +0.0: both zeros are one key.
        let key = |p: Vec3| (p + Vec3::ZERO).to_array().map(f32::to_bits);
        let mut index: HashMap<[u32; 3], usize> = HashMap::with_capacity(self.frame.len());
        for (i, &p) in self.frame.iter().enumerate() {
            index.entry(key(p)).or_insert(i);
        }
        let found: Vec<usize> = positions
            .iter()
            .map(|&p| index.get(&key(p)).copied())
            .collect::<Option<_>>()?;
        Some(
            self.steps
                .iter()
                .map(|step| found.iter().map(|&i| step[i]).collect())
                .collect(),
        )
    }
}
