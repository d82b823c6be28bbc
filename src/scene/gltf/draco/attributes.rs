//! Draco's attribute decoding (Draco bitstream specification 2.2, "Attributes decoder",
//! "Sequential integer / quantization / normal attribute decoder"): each group of attributes
//! is stored in one traversal order; each attribute's integer values are rANS-coded
//! corrections of a prediction (`prediction`), then dequantized: positions, texture
//! coordinates and colours from `bits`-bit integers over a bounding box (uniform scalar
//! quantization), normals from octahedral coordinates (`octahedron`). The generic decoder
//! stores values unchanged.

use super::buffer::{Decoded, Reader};
use super::octahedron::Octahedron;
use super::prediction::{read_ids, MeshData, Scheme};
use super::rans::decode_symbols;

/// Draco's position attribute type.
pub(super) const POSITION: u8 = 0;

/// How one attribute is stored, as its group's header says.
#[derive(Clone, Debug)]
pub(super) struct Layout {
    pub(super) kind: u8,
    pub(super) data_type: u8,
    pub(super) components: usize,
    pub(super) normalized: bool,
    pub(super) unique_id: u32,
    decoder: u8,
}

/// An attribute's decoded values, by value index.
pub(super) enum Values {
    Float(Vec<f32>),
    Int(Vec<i64>),
}

/// One decoded attribute.
pub(super) struct Attribute {
    pub(super) layout: Layout,
    pub(super) values: Values,
    /// The value index of each point.
    pub(super) point_to_value: Vec<u32>,
}

/// Bytes of one component of Draco data type `t`, `None` for an invalid type.
pub(super) fn type_size(t: u8) -> Option<usize> {
    Some(match t {
        1 | 2 | 11 => 1,
        3 | 4 => 2,
        5 | 6 | 9 => 4,
        7 | 8 | 10 => 8,
        _ => return None,
    })
}

/// The largest total of components Photon accepts over one Draco mesh's attributes.
const MAX_COMPONENTS: usize = 64;

/// A group's attribute layouts and their decoders' kinds.
pub(super) fn read_layouts(
    r: &mut Reader<'_>,
    components_so_far: &mut usize,
) -> Decoded<Vec<Layout>> {
    let n = r.count("the number of attributes", 256)?;
    if n == 0 {
        return Err("an attribute group without attributes: the file is damaged".into());
    }
    let mut layouts = Vec::with_capacity(n);
    for _ in 0..n {
        let kind = r.u8("an attribute's type")?;
        let data_type = r.u8("an attribute's data type")?;
        let components = usize::from(r.u8("an attribute's components")?);
        let normalized = r.u8("an attribute's normalization")? != 0;
        let unique_id = r.varint("an attribute's unique id")?;
        if kind > 4 || type_size(data_type).is_none() || components == 0 {
            return Err(format!(
                "an attribute of type {kind}, data type {data_type} and {components} components \
                 is not valid: the file is damaged"
            ));
        }
        *components_so_far += components;
        if *components_so_far > MAX_COMPONENTS {
            return Err(format!(
                "the attributes have more than {MAX_COMPONENTS} components together, more than \
                 glTF attributes need: refused"
            ));
        }
        layouts.push(Layout {
            kind,
            data_type,
            components,
            normalized,
            unique_id,
            decoder: 0,
        });
    }
    for layout in &mut layouts {
        layout.decoder = r.u8("an attribute decoder type")?;
        let float = layout.data_type == 9;
        match layout.decoder {
            0 | 1 => {}
            2 if float => {}
            3 if float && layout.components == 3 => {}
            2 | 3 => {
                return Err(format!(
                    "attribute {} cannot be stored with decoder {}: the file is damaged",
                    layout.unique_id, layout.decoder
                ))
            }
            other => {
                return Err(format!(
                    "attribute decoder type {other} is unknown: the file is damaged"
                ))
            }
        }
    }
    Ok(layouts)
}

/// Integer positions of the points, for the predictions that read them.
pub(super) struct Positions {
    pub(super) values: Vec<i64>,
    pub(super) point_to_value: Vec<u32>,
}

/// An attribute between its stored integers and its final values.
enum Portable {
    Raw(Values),
    Quantized(Vec<i32>),
    Octahedral(Vec<i32>),
}

/// Decode one group's attributes: `entries` values each (in traversal order, `points` of
/// them mapped by `point_to_value`), predicted over `mesh` when it is given.
#[allow(clippy::too_many_arguments)]
pub(super) fn decode_group<'a>(
    r: &mut Reader<'a>,
    layouts: &[Layout],
    entries: usize,
    point_to_value: &[u32],
    table: Option<(
        &super::corner_table::CornerTable,
        &super::traversal::Sequence,
    )>,
    positions: &mut Option<Positions>,
) -> Decoded<Vec<Attribute>> {
    let mut portable = Vec::with_capacity(layouts.len());
    for layout in layouts {
        let value = match layout.decoder {
            0 => {
                let size = type_size(layout.data_type).unwrap_or(1);
                let n = entries * layout.components;
                let bytes = r.bytes(
                    n.checked_mul(size).ok_or("an attribute too large")?,
                    "an attribute's values",
                )?;
                Portable::Raw(raw_values(bytes, layout.data_type))
            }
            decoder => {
                let components = if decoder == 3 { 2 } else { layout.components };
                let mesh = table.map(|(table, seq)| MeshData {
                    table,
                    seq,
                    positions: positions
                        .as_ref()
                        .map(|p| (&p.values[..], &p.point_to_value[..])),
                });
                let ints = integer_values(r, entries, components, decoder == 3, mesh.as_ref())?;
                match decoder {
                    1 => Portable::Raw(Values::Int(ints.iter().map(|&v| i64::from(v)).collect())),
                    2 => Portable::Quantized(ints),
                    _ => Portable::Octahedral(ints),
                }
            }
        };
        if layout.kind == POSITION && positions.is_none() {
            let values = match &value {
                Portable::Raw(Values::Float(v)) => v.iter().map(|&f| f as i64).collect(),
                Portable::Raw(Values::Int(v)) => v.clone(),
                Portable::Quantized(v) | Portable::Octahedral(v) => {
                    v.iter().map(|&i| i64::from(i)).collect()
                }
            };
            if layout.components == 3 {
                *positions = Some(Positions {
                    values,
                    point_to_value: point_to_value.to_vec(),
                });
            }
        }
        portable.push(value);
    }
    // The dequantization data follow all of the group's values.
    let mut out = Vec::with_capacity(layouts.len());
    for (layout, value) in layouts.iter().zip(portable) {
        let values = match value {
            Portable::Raw(v) => v,
            Portable::Quantized(ints) => {
                let n = layout.components;
                let mut min = Vec::with_capacity(n);
                for _ in 0..n {
                    min.push(r.f32("a quantization's minimum")?);
                }
                let range = r.f32("a quantization's range")?;
                let bits = r.u8("a quantization's bits")?;
                if !range.is_finite() || min.iter().any(|m| !m.is_finite()) {
                    return Err(
                        "a quantization's bounds are not finite: the file is damaged".into(),
                    );
                }
                if !(1..=30).contains(&bits) {
                    return Err(format!(
                        "a quantization of {bits} bits: the file is damaged"
                    ));
                }
                let delta = range / ((1u32 << bits) - 1) as f32;
                Values::Float(
                    ints.iter()
                        .enumerate()
                        .map(|(i, &q)| q as f32 * delta + min[i % n])
                        .collect(),
                )
            }
            Portable::Octahedral(ints) => {
                let bits = r.u8("a normal quantization's bits")?;
                let o = Octahedron::new(u32::from(bits))
                    .ok_or_else(|| format!("normals of {bits} bits: the file is damaged"))?;
                Values::Float(
                    ints.chunks_exact(2)
                        .flat_map(|st| o.unit_vector(st[0], st[1]))
                        .collect(),
                )
            }
        };
        out.push(Attribute {
            layout: layout.clone(),
            values,
            point_to_value: point_to_value.to_vec(),
        });
    }
    Ok(out)
}

/// Stored components of Draco data type `t`, little-endian.
fn raw_values(bytes: &[u8], t: u8) -> Values {
    let size = type_size(t).unwrap_or(1);
    let chunks = bytes.chunks_exact(size);
    match t {
        9 => Values::Float(
            chunks
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect(),
        ),
        10 => Values::Float(
            chunks
                .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])) as f32)
                .collect(),
        ),
        _ => Values::Int(
            chunks
                .map(|c| {
                    let mut b = [0u8; 8];
                    b[..size].copy_from_slice(c);
                    let u = u64::from_le_bytes(b);
                    match t {
                        1 => i64::from(c[0] as i8),
                        3 => i64::from(i16::from_le_bytes([c[0], c[1]])),
                        5 => i64::from(i32::from_le_bytes([c[0], c[1], c[2], c[3]])),
                        _ => u as i64,
                    }
                })
                .collect(),
        ),
    }
}

/// Draco's sequential integer decoding: prediction ids, the coded values, the sign
/// folding, and the prediction undone.
fn integer_values<'a>(
    r: &mut Reader<'a>,
    entries: usize,
    components: usize,
    normals: bool,
    mesh: Option<&MeshData<'_>>,
) -> Decoded<Vec<i32>> {
    let ids = read_ids(r)?;
    // Draco predicts only with the transform its decoder knows; other pairs are stored
    // without prediction.
    let ids = ids.filter(|&(method, transform)| {
        (-1..=6).contains(&method)
            && if normals {
                transform == 2 || transform == 3
            } else {
                transform == 1
            }
    });
    let n = entries * components;
    let mut values: Vec<i32> = match r.u8("an attribute's coding")? {
        0 => {
            let size = usize::from(r.u8("an attribute's value size")?);
            if !(1..=4).contains(&size) {
                return Err(format!("values of {size} bytes: the file is damaged"));
            }
            let bytes = r.bytes(n * size, "an attribute's values")?;
            bytes
                .chunks_exact(size)
                .map(|c| {
                    let mut b = [0u8; 4];
                    b[..size].copy_from_slice(c);
                    u32::from_le_bytes(b) as i32
                })
                .collect()
        }
        _ => decode_symbols(r, n, components)?
            .into_iter()
            .map(|v| v as i32)
            .collect(),
    };
    let positive = ids.is_some_and(|(_, t)| t == 2 || t == 3);
    if !positive {
        for v in &mut values {
            let u = *v as u32;
            *v = ((u >> 1) as i32) ^ -((u & 1) as i32);
        }
    }
    if let Some(ids) = ids {
        if ids.0 >= -1 {
            let mut scheme = Scheme::read(ids, r, mesh)?;
            scheme.apply(&mut values, components, mesh)?;
        }
    }
    Ok(values)
}
