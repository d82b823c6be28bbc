//! Draco's sequential mesh connectivity (Draco bitstream specification 2.2, "Sequential
//! connectivity"): the triangles' point indices stored one after another, either plainly (8,
//! 16 or 32 bits, or varints, by the number of points) or as rANS-coded differences.

use super::buffer::{Decoded, Reader};
use super::rans::decode_symbols;

/// The faces (point indices) and the number of points; `max_faces` and `max_points` bound
/// the counts before anything is allocated.
pub(super) fn decode(
    r: &mut Reader<'_>,
    max_faces: usize,
    max_points: usize,
) -> Decoded<(Vec<[u32; 3]>, usize)> {
    let faces = r.count("the number of faces", max_faces)?;
    let points = r.count("the number of points", max_points)?;
    let method = r.u8("the connectivity method")?;
    let mut out = Vec::with_capacity(faces);
    match method {
        0 => {
            let symbols = decode_symbols(r, 3 * faces, 1)?;
            let mut last = 0i64;
            for tri in symbols.chunks_exact(3) {
                let mut face = [0u32; 3];
                for (slot, &s) in face.iter_mut().zip(tri) {
                    let diff = i64::from(s >> 1);
                    last += if s & 1 == 1 { -diff } else { diff };
                    *slot = u32::try_from(last)
                        .ok()
                        .filter(|&v| (v as usize) < points)
                        .ok_or_else(|| {
                            format!("a face index {last} is not one of the {points} points: the file is damaged")
                        })?;
                }
                out.push(face);
            }
        }
        1 => {
            let width = match points {
                p if p < 256 => 1,
                p if p < 1 << 16 => 2,
                p if p < 1 << 21 => 0,
                _ => 4,
            };
            for _ in 0..faces {
                let mut face = [0u32; 3];
                for slot in &mut face {
                    let v = match width {
                        1 => u32::from(r.u8("the face indices")?),
                        2 => u32::from(r.u16("the face indices")?),
                        4 => r.u32("the face indices")?,
                        _ => r.varint("the face indices")?,
                    };
                    if v as usize >= points {
                        return Err(format!(
                            "a face index {v} is not one of the {points} points: the file is damaged"
                        ));
                    }
                    *slot = v;
                }
                out.push(face);
            }
        }
        other => {
            return Err(format!(
                "sequential connectivity method {other} is not 0 (compressed) or 1 (plain): the \
                 file is damaged"
            ))
        }
    }
    Ok((out, points))
}
