//! Draco's prediction schemes and their transforms (Draco bitstream specification 2.2,
//! "Prediction decoders" and "Prediction scheme transforms"): each stored integer value is a
//! correction to a prediction from values decoded before it. Difference (the previous value),
//! parallelogram (Touma & Gotsman 1998, "Triangle mesh compression"), multi-parallelogram
//! and its constrained form with crease flags (Cohen-Or, Cohen & Irony 2002, "Multi-way
//! geometry encoding"), the portable texture coordinate predictor (the opposite triangle's
//! shape carried into UV space), and the geometric normal predictor (area-weighted face normals
//! from the positions); the wrap transform keeps values in their range and the canonicalized
//! octahedron transform works on normals' octahedral coordinates. Integer arithmetic wraps
//! as Draco's does, so damaged values stay wrong values, never a panic.

use super::buffer::{Decoded, Reader};
use super::corner_table::{CornerTable, NONE};
use super::octahedron::Octahedron;
use super::rans::BitDecoder;
use super::traversal::Sequence;

/// How corrections map back to values.
pub(super) enum Transform {
    Wrap { min: i32, max: i32 },
    Octahedron(Octahedron),
}

impl Transform {
    fn read_data(kind: i8, r: &mut Reader<'_>) -> Decoded<Transform> {
        match kind {
            1 => {
                let min = r.i32("a wrap transform")?;
                let max = r.i32("a wrap transform")?;
                if min > max || i64::from(max) - i64::from(min) >= i64::from(i32::MAX) {
                    return Err(format!(
                        "a wrap transform's range {min}..{max} is invalid: the file is damaged"
                    ));
                }
                Ok(Transform::Wrap { min, max })
            }
            3 => {
                let max_quantized = r.i32("an octahedron transform")?;
                let _center = r.i32("an octahedron transform")?;
                let bits = if max_quantized > 0 {
                    32 - (max_quantized as u32).leading_zeros()
                } else {
                    0
                };
                Octahedron::new(bits)
                    .map(Transform::Octahedron)
                    .ok_or_else(|| {
                        format!("an octahedron transform of {bits} bits: the file is damaged")
                    })
            }
            2 => Err(
                "the octahedron normal transform without canonicalization is not decoded".into(),
            ),
            other => Err(format!(
                "prediction transform {other} is unknown: the file is damaged"
            )),
        }
    }

    fn original(&self, pred: &[i32], corr: &[i32], out: &mut [i32]) {
        match self {
            Transform::Wrap { min, max } => {
                let dif = max.wrapping_sub(*min).wrapping_add(1);
                for ((o, &p), &c) in out.iter_mut().zip(pred).zip(corr) {
                    let v = p.clamp(*min, *max).wrapping_add(c);
                    *o = if v > *max {
                        v.wrapping_sub(dif)
                    } else if v < *min {
                        v.wrapping_add(dif)
                    } else {
                        v
                    };
                }
            }
            Transform::Octahedron(o) => {
                let c = o.center;
                // Out-of-range values come only from damaged data; keep them in the square.
                let clampv = |v: i32| v.clamp(0, 2 * c);
                let mut p = (clampv(pred[0]) - c, clampv(pred[1]) - c);
                let in_diamond = o.in_diamond(p.0, p.1);
                if !in_diamond {
                    o.invert_diamond(&mut p.0, &mut p.1);
                }
                let bottom_left = (p.0 == 0 && p.1 == 0) || (p.0 < 0 && p.1 <= 0);
                let rotation = rotation_count(p);
                if !bottom_left {
                    p = rotate(p, rotation);
                }
                let mut v = (
                    o.mod_max(p.0 + clampv(corr[0])),
                    o.mod_max(p.1 + clampv(corr[1])),
                );
                if !bottom_left {
                    v = rotate(v, (4 - rotation) % 4);
                }
                if !in_diamond {
                    o.invert_diamond(&mut v.0, &mut v.1);
                }
                out[0] = v.0 + c;
                out[1] = v.1 + c;
            }
        }
    }
}

fn rotation_count((x, y): (i32, i32)) -> u32 {
    match (x.signum(), y) {
        (0, 0) => 0,
        (0, y) if y > 0 => 3,
        (0, _) => 1,
        (1, y) if y >= 0 => 2,
        (1, _) => 1,
        (_, y) if y <= 0 => 0,
        _ => 3,
    }
}

fn rotate((x, y): (i32, i32), count: u32) -> (i32, i32) {
    match count {
        1 => (y, -x),
        2 => (-x, -y),
        3 => (-y, x),
        _ => (x, y),
    }
}

/// The mesh and the already decoded positions a mesh prediction reads.
pub(super) struct MeshData<'a> {
    pub(super) table: &'a CornerTable,
    pub(super) seq: &'a Sequence,
    /// Integer positions (three per value) and the value of each point, when decoded.
    pub(super) positions: Option<(&'a [i64], &'a [u32])>,
}

enum Method<'a> {
    Difference,
    Parallelogram,
    MultiParallelogram,
    Constrained { creases: Vec<Vec<bool>> },
    TexCoords { orientations: Vec<bool> },
    GeometricNormal { flips: BitDecoder<'a> },
}

/// A prediction scheme with its transform and data, read from the stream.
pub(super) struct Scheme<'a> {
    method: Method<'a>,
    pub(super) transform: Transform,
}

/// The method and transform ids before an attribute's values; `None` for no prediction.
pub(super) fn read_ids(r: &mut Reader<'_>) -> Decoded<Option<(i8, i8)>> {
    let method = r.u8("a prediction method")? as i8;
    if method == -2 {
        return Ok(None);
    }
    let transform = r.u8("a prediction transform")? as i8;
    Ok(Some((method, transform)))
}

impl<'a> Scheme<'a> {
    /// The scheme's data after the values; `mesh` is `None` for sequential connectivity,
    /// where Draco predicts every mesh method as a difference.
    pub(super) fn read(
        (method, transform): (i8, i8),
        r: &mut Reader<'a>,
        mesh: Option<&MeshData<'_>>,
    ) -> Decoded<Scheme<'a>> {
        let is_mesh = mesh.is_some();
        let method = match method {
            -1 | 0 => Method::Difference,
            1..=6 if !is_mesh => Method::Difference,
            1 => Method::Parallelogram,
            2 => Method::MultiParallelogram,
            3 => return Err(
                "the deprecated texture coordinate prediction (Draco before 1.2) is not decoded"
                    .into(),
            ),
            4 => {
                let corners = mesh.map_or(0, |m| m.table.corners());
                let mut creases = Vec::with_capacity(4);
                for _ in 0..4 {
                    let n = r.count("crease flags", corners)?;
                    let mut flags = Vec::with_capacity(n);
                    if n > 0 {
                        let mut bits = BitDecoder::start(r)?;
                        flags.extend((0..n).map(|_| bits.next()));
                    }
                    creases.push(flags);
                }
                Method::Constrained { creases }
            }
            5 => {
                let n = r.i32("texture coordinate orientations")?;
                let limit = mesh.map_or(0, |m| m.table.corners());
                if n < 0 || n as usize > limit {
                    return Err(format!(
                        "{n} texture coordinate orientations: the file is damaged"
                    ));
                }
                let mut bits = BitDecoder::start(r)?;
                let mut last = true;
                let orientations = (0..n)
                    .map(|_| {
                        if !bits.next() {
                            last = !last;
                        }
                        last
                    })
                    .collect();
                Method::TexCoords { orientations }
            }
            6 => {
                let transform = Transform::read_data(transform, r)?;
                let flips = BitDecoder::start(r)?;
                return Ok(Scheme {
                    method: Method::GeometricNormal { flips },
                    transform,
                });
            }
            other => {
                return Err(format!(
                    "prediction method {other} is unknown: the file is damaged"
                ))
            }
        };
        let transform = Transform::read_data(transform, r)?;
        Ok(Scheme { method, transform })
    }

    /// Turn `corr` (corrections, `components` per value) into the values, in place.
    pub(super) fn apply(
        &mut self,
        values: &mut [i32],
        components: usize,
        mesh: Option<&MeshData<'_>>,
    ) -> Decoded<()> {
        let corr = values.to_vec();
        let n = values.len() / components;
        let zeros = vec![0i32; components];
        let mut pred = vec![0i32; components];
        let t = &self.transform;
        // Values predicted from the previous one (and the first from zero).
        let delta = |values: &mut [i32], p: usize| {
            let (done, rest) = values.split_at_mut(p * components);
            let prev = if p == 0 {
                &zeros[..]
            } else {
                &done[(p - 1) * components..]
            };
            t.original(
                prev,
                &corr[p * components..(p + 1) * components],
                &mut rest[..components],
            );
        };
        let mesh = match (&self.method, mesh) {
            (Method::Difference, _) | (_, None) => {
                for p in 0..n {
                    delta(values, p);
                }
                return Ok(());
            }
            (_, Some(m)) => m,
        };
        if mesh.seq.corners.len() != n {
            return Err(
                "the predicted values do not match the mesh's vertices: the file is damaged".into(),
            );
        }
        let table = mesh.table;
        let v2d = &mesh.seq.vertex_to_value;
        // The parallelogram prediction at corner `c` for value `p`, if its three vertices
        // were decoded before it.
        let parallelogram = |values: &[i32], p: usize, c: u32, out: &mut [i32]| -> bool {
            let o = table.opposite(c);
            if o == NONE {
                return false;
            }
            let entry = |corner: u32| {
                v2d.get(table.vertex(corner) as usize)
                    .copied()
                    .unwrap_or(NONE) as usize
            };
            let (vo, vn, vp) = (
                entry(o),
                entry(CornerTable::next(o)),
                entry(CornerTable::previous(o)),
            );
            if vo >= p || vn >= p || vp >= p {
                return false;
            }
            for k in 0..components {
                out[k] = values[vn * components + k]
                    .wrapping_add(values[vp * components + k])
                    .wrapping_sub(values[vo * components + k]);
            }
            true
        };
        match &mut self.method {
            Method::Difference => unreachable!("handled above"),
            Method::Parallelogram => {
                delta(values, 0);
                for p in 1..n {
                    if parallelogram(values, p, mesh.seq.corners[p], &mut pred) {
                        let (done, rest) = values.split_at_mut(p * components);
                        let _ = done;
                        t.original(
                            &pred,
                            &corr[p * components..(p + 1) * components],
                            &mut rest[..components],
                        );
                    } else {
                        delta(values, p);
                    }
                }
            }
            Method::MultiParallelogram => {
                delta(values, 0);
                let mut sum = vec![0i64; components];
                for p in 1..n {
                    let start = mesh.seq.corners[p];
                    let mut corner = start;
                    let mut used = 0i64;
                    sum.iter_mut().for_each(|s| *s = 0);
                    let mut steps = 0;
                    while corner != NONE && steps <= table.corners() {
                        steps += 1;
                        if parallelogram(values, p, corner, &mut pred) {
                            used += 1;
                            for k in 0..components {
                                sum[k] += i64::from(pred[k]);
                            }
                        }
                        corner = table.swing_right(corner);
                        if corner == start {
                            break;
                        }
                    }
                    average_or_delta(
                        values, p, &sum, used, &mut pred, &corr, &delta, t, components,
                    );
                }
            }
            Method::Constrained { creases } => {
                let mut positions = [0usize; 4];
                let mut sum = vec![0i64; components];
                let mut preds = vec![vec![0i32; components]; 4];
                delta(values, 0);
                for p in 1..n {
                    let start = mesh.seq.corners[p];
                    let mut found = 0usize;
                    let mut corner = start;
                    let mut first_pass = true;
                    let mut steps = 0;
                    while corner != NONE && steps <= table.corners() {
                        steps += 1;
                        if parallelogram(values, p, corner, &mut preds[found]) {
                            found += 1;
                            if found == 4 {
                                break;
                            }
                        }
                        corner = if first_pass {
                            table.swing_left(corner)
                        } else {
                            table.swing_right(corner)
                        };
                        if corner == start {
                            break;
                        }
                        if corner == NONE && first_pass {
                            first_pass = false;
                            corner = table.swing_right(start);
                        }
                    }
                    sum.iter_mut().for_each(|s| *s = 0);
                    let mut used = 0i64;
                    for pred_i in preds.iter().take(found) {
                        let context = found - 1;
                        let pos = positions[context];
                        positions[context] += 1;
                        let crease = *creases[context]
                            .get(pos)
                            .ok_or("crease flags run out: the file is damaged")?;
                        if !crease {
                            used += 1;
                            for k in 0..components {
                                sum[k] += i64::from(pred_i[k]);
                            }
                        }
                    }
                    average_or_delta(
                        values, p, &sum, used, &mut pred, &corr, &delta, t, components,
                    );
                }
            }
            Method::TexCoords { orientations } => {
                if components != 2 {
                    return Err("texture coordinate prediction of other than 2 components: the file is damaged".into());
                }
                let (pos, point_to_value) = mesh.positions.ok_or(
                    "texture coordinate prediction needs the positions, which are missing",
                )?;
                for p in 0..n {
                    let c = mesh.seq.corners[p];
                    tex_coord_prediction(
                        values,
                        p,
                        c,
                        mesh,
                        pos,
                        point_to_value,
                        orientations,
                        &mut pred,
                    )?;
                    let (_, rest) = values.split_at_mut(p * 2);
                    t.original(&pred, &corr[p * 2..p * 2 + 2], &mut rest[..2]);
                }
            }
            Method::GeometricNormal { flips } => {
                let Transform::Octahedron(octahedron) = t else {
                    return Err("geometric normal prediction needs the octahedron transform: the file is damaged".into());
                };
                if components != 2 {
                    return Err("geometric normal prediction of other than 2 components: the file is damaged".into());
                }
                let (pos, point_to_value) = mesh
                    .positions
                    .ok_or("normal prediction needs the positions, which are missing")?;
                for p in 0..n {
                    let c = mesh.seq.corners[p];
                    let normal = area_normal(c, mesh, pos, point_to_value);
                    let mut v = octahedron.canonicalize_vector(normal);
                    if flips.next() {
                        v = [-v[0], -v[1], -v[2]];
                    }
                    let (s, tt) = octahedron.vector_to_coords(v);
                    let (_, rest) = values.split_at_mut(p * 2);
                    t.original(&[s, tt], &corr[p * 2..p * 2 + 2], &mut rest[..2]);
                }
            }
        }
        Ok(())
    }
}

/// Value `p` from the mean of `used` parallelogram predictions summed in `sum`, or from the
/// previous value when none was used.
#[allow(clippy::too_many_arguments)]
fn average_or_delta(
    values: &mut [i32],
    p: usize,
    sum: &[i64],
    used: i64,
    pred: &mut [i32],
    corr: &[i32],
    delta: &dyn Fn(&mut [i32], usize),
    t: &Transform,
    components: usize,
) {
    if used == 0 {
        delta(values, p);
        return;
    }
    for k in 0..components {
        pred[k] = (sum[k] / used) as i32;
    }
    let (_, rest) = values.split_at_mut(p * components);
    t.original(
        pred,
        &corr[p * components..(p + 1) * components],
        &mut rest[..components],
    );
}

/// The integer position of the vertex at corner `c`.
fn position_at(c: u32, mesh: &MeshData<'_>, pos: &[i64], point_to_value: &[u32]) -> [i64; 3] {
    let point = mesh
        .seq
        .vertex_to_value
        .get(mesh.table.vertex(c) as usize)
        .and_then(|&d| mesh.seq.points.get(d as usize))
        .copied()
        .unwrap_or(NONE);
    point_position(point, pos, point_to_value)
}

fn point_position(point: u32, pos: &[i64], point_to_value: &[u32]) -> [i64; 3] {
    let value = point_to_value.get(point as usize).copied().unwrap_or(NONE) as usize;
    match pos.get(3 * value..3 * value + 3) {
        Some(p) => [p[0], p[1], p[2]],
        None => [0; 3],
    }
}

/// The area-weighted normal of the faces around the vertex of corner `c`, bounded as Draco
/// bounds it.
fn area_normal(c: u32, mesh: &MeshData<'_>, pos: &[i64], point_to_value: &[u32]) -> [i64; 3] {
    let centre = position_at(c, mesh, pos, point_to_value);
    let mut normal = [0i64; 3];
    for corner in mesh.table.corners_around(c) {
        let next = position_at(CornerTable::next(corner), mesh, pos, point_to_value);
        let prev = position_at(CornerTable::previous(corner), mesh, pos, point_to_value);
        let a = [
            next[0] - centre[0],
            next[1] - centre[1],
            next[2] - centre[2],
        ];
        let b = [
            prev[0] - centre[0],
            prev[1] - centre[1],
            prev[2] - centre[2],
        ];
        normal[0] = normal[0].wrapping_add(
            a[1].wrapping_mul(b[2])
                .wrapping_sub(a[2].wrapping_mul(b[1])),
        );
        normal[1] = normal[1].wrapping_add(
            a[2].wrapping_mul(b[0])
                .wrapping_sub(a[0].wrapping_mul(b[2])),
        );
        normal[2] = normal[2].wrapping_add(
            a[0].wrapping_mul(b[1])
                .wrapping_sub(a[1].wrapping_mul(b[0])),
        );
    }
    const UPPER: i64 = 1 << 29;
    let sum = normal[0]
        .saturating_abs()
        .saturating_add(normal[1].saturating_abs())
        .saturating_add(normal[2].saturating_abs());
    if sum > UPPER {
        let q = sum / UPPER;
        normal = normal.map(|v| v / q);
    }
    normal
}

/// Draco's portable texture coordinate prediction for value `p` at corner `c`.
#[allow(clippy::too_many_arguments)]
fn tex_coord_prediction(
    values: &[i32],
    p: usize,
    c: u32,
    mesh: &MeshData<'_>,
    pos: &[i64],
    point_to_value: &[u32],
    orientations: &mut Vec<bool>,
    out: &mut [i32],
) -> Decoded<()> {
    let table = mesh.table;
    let v2d = &mesh.seq.vertex_to_value;
    let entry = |corner: u32| {
        v2d.get(table.vertex(corner) as usize)
            .copied()
            .unwrap_or(NONE) as usize
    };
    let next = entry(CornerTable::next(c));
    let prev = entry(CornerTable::previous(c));
    let uv = |d: usize| [i64::from(values[2 * d]), i64::from(values[2 * d + 1])];
    let position = |d: usize| {
        let point = mesh.seq.points.get(d).copied().unwrap_or(NONE);
        point_position(point, pos, point_to_value)
    };
    if prev < p && next < p {
        let (n_uv, p_uv) = (uv(next), uv(prev));
        if n_uv == p_uv {
            out[0] = p_uv[0] as i32;
            out[1] = p_uv[1] as i32;
            return Ok(());
        }
        let (tip, np, pp) = (position(p), position(next), position(prev));
        let pn = [pp[0] - np[0], pp[1] - np[1], pp[2] - np[2]];
        let pn2 = pn[0]
            .wrapping_mul(pn[0])
            .wrapping_add(pn[1].wrapping_mul(pn[1]))
            .wrapping_add(pn[2].wrapping_mul(pn[2]));
        if pn2 != 0 {
            let cn = [tip[0] - np[0], tip[1] - np[1], tip[2] - np[2]];
            let dot = pn[0]
                .wrapping_mul(cn[0])
                .wrapping_add(pn[1].wrapping_mul(cn[1]))
                .wrapping_add(pn[2].wrapping_mul(cn[2]));
            let pn_uv = [p_uv[0] - n_uv[0], p_uv[1] - n_uv[1]];
            let x_uv = [
                n_uv[0]
                    .wrapping_mul(pn2)
                    .wrapping_add(dot.wrapping_mul(pn_uv[0])),
                n_uv[1]
                    .wrapping_mul(pn2)
                    .wrapping_add(dot.wrapping_mul(pn_uv[1])),
            ];
            let x_pos = [
                np[0] + dot.wrapping_mul(pn[0]) / pn2,
                np[1] + dot.wrapping_mul(pn[1]) / pn2,
                np[2] + dot.wrapping_mul(pn[2]) / pn2,
            ];
            let cx = [tip[0] - x_pos[0], tip[1] - x_pos[1], tip[2] - x_pos[2]];
            let cx2 = cx[0]
                .wrapping_mul(cx[0])
                .wrapping_add(cx[1].wrapping_mul(cx[1]))
                .wrapping_add(cx[2].wrapping_mul(cx[2]));
            let norm = int_sqrt((cx2 as u64).wrapping_mul(pn2 as u64)) as i64;
            let cx_uv = [pn_uv[1].wrapping_mul(norm), (-pn_uv[0]).wrapping_mul(norm)];
            let orientation = orientations
                .pop()
                .ok_or("texture coordinate orientations run out: the file is damaged")?;
            let predicted = if orientation {
                [
                    x_uv[0].wrapping_add(cx_uv[0]) / pn2,
                    x_uv[1].wrapping_add(cx_uv[1]) / pn2,
                ]
            } else {
                [
                    x_uv[0].wrapping_sub(cx_uv[0]) / pn2,
                    x_uv[1].wrapping_sub(cx_uv[1]) / pn2,
                ]
            };
            out[0] = predicted[0] as i32;
            out[1] = predicted[1] as i32;
            return Ok(());
        }
    }
    // Draco's fallback: the next corner's value if decoded, else the previous value (even
    // when the previous corner's is decoded), else zero.
    let d = if next < p {
        next
    } else if p > 0 {
        p - 1
    } else {
        out[0] = 0;
        out[1] = 0;
        return Ok(());
    };
    out[0] = values[2 * d];
    out[1] = values[2 * d + 1];
    Ok(())
}

/// The integer square root Draco uses (rounded down).
fn int_sqrt(n: u64) -> u64 {
    if n == 0 {
        return 0;
    }
    let mut x = (n as f64).sqrt() as u64;
    while x.saturating_mul(x) > n {
        x -= 1;
    }
    while (x + 1).saturating_mul(x + 1) <= n {
        x += 1;
    }
    x
}
