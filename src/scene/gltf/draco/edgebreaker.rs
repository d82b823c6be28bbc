//! Draco's Edgebreaker mesh connectivity (Rossignac 1999, "Edgebreaker: connectivity
//! compression for triangle meshes"; Draco bitstream specification 2.2, "EdgeBreaker decoder"
//! and "EdgeBreaker valence decoder"): the CLERS symbols are read back in reverse, each adding
//! one face to the corner table, with the standard traversal (symbols as 1 or 3 bits) or the
//! valence traversal (symbols rANS-coded in six contexts chosen by the valence of the active
//! vertex). Topology split events reconnect faces across S symbols; start faces close the
//! components. Every count is bounded before the table is allocated, and every walk around a
//! vertex by the number of corners.

use super::buffer::{Decoded, Reader};
use super::corner_table::{CornerTable, NONE};
use super::rans::{decode_symbols, BitDecoder};
use std::collections::HashMap;

const C: u32 = 0;
const S: u32 = 1;
const L: u32 = 3;
const R: u32 = 5;
const E: u32 = 7;

/// The decoded connectivity: the corner table, whose vertices are the mesh's points.
pub(super) struct Connectivity {
    pub(super) table: CornerTable,
    /// The number of vertices with corners (the points, when no attribute has seams).
    pub(super) vertices: usize,
    /// Whether each vertex lies on an open boundary.
    pub(super) holes: Vec<bool>,
    /// For each attribute connectivity, the corners opposite its seam edges.
    pub(super) seams: Vec<Vec<u32>>,
}

fn damaged(what: &str) -> String {
    format!("the Edgebreaker connectivity is inconsistent ({what}): the file is damaged")
}

/// A topology split event: the split symbol's face reconnects to an edge of the source
/// symbol's face.
struct Split {
    source: u32,
    split: u32,
    right_edge: bool,
}

/// How the CLERS symbols are stored.
enum Symbols<'a> {
    Standard(super::buffer::BitReader<'a>),
    Valence {
        contexts: Vec<Vec<u32>>,
        valences: Vec<u32>,
        active: Option<usize>,
    },
}

impl Symbols<'_> {
    fn next(&mut self) -> Decoded<u32> {
        match self {
            Symbols::Standard(bits) => {
                if bits.read(1) == C {
                    Ok(C)
                } else {
                    Ok(1 | (bits.read(2) << 1))
                }
            }
            Symbols::Valence {
                contexts, active, ..
            } => match active {
                None => Ok(E),
                Some(ctx) => {
                    let symbol = contexts[*ctx]
                        .pop()
                        .ok_or_else(|| damaged("a context runs out of symbols"))?;
                    [C, S, L, R, E]
                        .get(symbol as usize)
                        .copied()
                        .ok_or_else(|| damaged("an unknown valence symbol"))
                }
            },
        }
    }

    /// The valence traversal's bookkeeping after `symbol` set the active corner `corner`.
    fn reached(&mut self, table: &CornerTable, symbol: u32, corner: u32) -> Decoded<()> {
        let Symbols::Valence {
            valences, active, ..
        } = self
        else {
            return Ok(());
        };
        let next = CornerTable::next(corner);
        let prev = CornerTable::previous(corner);
        let mut add = |c: u32, n: u32| -> Decoded<()> {
            let v = table.vertex(c) as usize;
            let slot = valences
                .get_mut(v)
                .ok_or_else(|| damaged("a vertex out of range"))?;
            *slot += n;
            Ok(())
        };
        match symbol {
            C | S => {
                add(next, 1)?;
                add(prev, 1)?;
            }
            R => {
                add(corner, 1)?;
                add(next, 1)?;
                add(prev, 2)?;
            }
            L => {
                add(corner, 1)?;
                add(next, 2)?;
                add(prev, 1)?;
            }
            _ => {
                add(corner, 2)?;
                add(next, 2)?;
                add(prev, 2)?;
            }
        }
        let valence = *valences
            .get(table.vertex(next) as usize)
            .ok_or_else(|| damaged("a vertex out of range"))?;
        *active = Some(valence.clamp(2, 7) as usize - 2);
        Ok(())
    }

    fn merge(&mut self, dest: u32, source: u32) {
        if let Symbols::Valence { valences, .. } = self {
            let add = valences.get(source as usize).copied().unwrap_or(0);
            if let Some(d) = valences.get_mut(dest as usize) {
                *d += add;
            }
        }
    }
}

/// Decode the connectivity; `max_faces` bounds the number of faces before allocation.
pub(super) fn decode<'a>(r: &mut Reader<'a>, max_faces: usize) -> Decoded<Connectivity> {
    let traversal = r.u8("the Edgebreaker traversal type")?;
    if traversal == 1 {
        return Err(
            "the predictive Edgebreaker traversal (Draco before 1.0) is not decoded".into(),
        );
    }
    if traversal != 0 && traversal != 2 {
        return Err(format!(
            "Edgebreaker traversal type {traversal} is unknown: the file is damaged"
        ));
    }
    let encoded_vertices = r.varint("the number of encoded vertices")? as usize;
    let faces = r.count("the number of faces", max_faces)?;
    if encoded_vertices > 3 * faces {
        return Err(damaged("more vertices than corners"));
    }
    let attribute_data = r.u8("the number of attribute connectivities")?;
    let num_symbols = r.count("the number of Edgebreaker symbols", faces)?;
    let num_splits = r.count("the number of split symbols", num_symbols)?;
    let max_vertices = encoded_vertices + num_splits;

    // Topology split events.
    let num_events = r.count("the number of topology splits", faces)?;
    let mut splits = Vec::with_capacity(num_events);
    let mut last_source = 0u32;
    for _ in 0..num_events {
        let source = last_source
            .checked_add(r.varint("a topology split")?)
            .ok_or_else(|| damaged("a split symbol id overflows"))?;
        let delta = r.varint("a topology split")?;
        if delta > source {
            return Err(damaged("a split before the first symbol"));
        }
        splits.push(Split {
            source,
            split: source - delta,
            right_edge: false,
        });
        last_source = source;
    }
    if num_events > 0 {
        let mut bits = r.bits();
        for s in &mut splits {
            s.right_edge = bits.read(1) == 1;
        }
        r.finish_bits(&bits);
    }

    let seam_decoders = |r: &mut Reader<'a>| -> Decoded<Vec<BitDecoder<'a>>> {
        (0..attribute_data).map(|_| BitDecoder::start(r)).collect()
    };
    let (mut symbols, mut start_faces, mut seam_bits) = if traversal == 0 {
        let bits = r.sized_bits("the Edgebreaker symbols")?;
        let start = BitDecoder::start(r)?;
        let seams = seam_decoders(r)?;
        (Symbols::Standard(bits), start, seams)
    } else {
        let start = BitDecoder::start(r)?;
        let seams = seam_decoders(r)?;
        let mut contexts = Vec::with_capacity(6);
        for _ in 0..6 {
            let n = r.count("a valence context's size", num_symbols)?;
            let mut list = decode_symbols(r, n, 1)?;
            // Symbols are taken from the back, as Draco stores them.
            list.shrink_to_fit();
            contexts.push(list);
        }
        let symbols = Symbols::Valence {
            contexts,
            valences: vec![0; max_vertices],
            active: None,
        };
        (symbols, start, seams)
    };

    let mut table = CornerTable::new(faces);
    let new_vertex = |table: &mut CornerTable| -> Decoded<u32> {
        if table.vertices() >= max_vertices {
            return Err(damaged("more vertices than announced"));
        }
        Ok(table.add_vertex())
    };
    let corners = table.corners();
    let mut stack: Vec<u32> = Vec::new();
    let mut split_corners: HashMap<u32, u32> = HashMap::new();
    let mut invalid_vertices = Vec::new();
    let mut holes = vec![true; max_vertices];
    let mut face = 0u32;
    for symbol_id in 0..num_symbols as u32 {
        let corner = 3 * face;
        face += 1;
        let symbol = symbols.next()?;
        let mut check_split = false;
        match symbol {
            C => {
                let a = *stack
                    .last()
                    .ok_or_else(|| damaged("C without an active edge"))?;
                let x = table.vertex(CornerTable::next(a));
                let b = CornerTable::next(table.left_most(x));
                if b == NONE {
                    return Err(damaged("C at a vertex without corners"));
                }
                table.set_opposite(a, corner + 1);
                table.set_opposite(b, corner + 2);
                table.map(corner, x);
                table.map(corner + 1, table.vertex(CornerTable::next(b)));
                let a_prev = table.vertex(CornerTable::previous(a));
                table.map(corner + 2, a_prev);
                table.set_left_most(a_prev, corner + 2);
                if let Some(h) = holes.get_mut(x as usize) {
                    *h = false;
                }
                *stack.last_mut().unwrap() = corner;
            }
            R | L => {
                let a = *stack
                    .last()
                    .ok_or_else(|| damaged("R or L without an active edge"))?;
                let (opp, l, r_) = if symbol == R {
                    (corner + 2, corner + 1, corner)
                } else {
                    (corner + 1, corner, corner + 2)
                };
                table.set_opposite(opp, a);
                let v = new_vertex(&mut table)?;
                table.map(opp, v);
                table.set_left_most(v, opp);
                let vr = table.vertex(CornerTable::previous(a));
                table.map(r_, vr);
                table.set_left_most(vr, r_);
                table.map(l, table.vertex(CornerTable::next(a)));
                *stack.last_mut().unwrap() = corner;
                check_split = true;
            }
            S => {
                let b = stack
                    .pop()
                    .ok_or_else(|| damaged("S without an active edge"))?;
                if let Some(&c) = split_corners.get(&symbol_id) {
                    stack.push(c);
                }
                let a = *stack
                    .last()
                    .ok_or_else(|| damaged("S without a second active edge"))?;
                table.set_opposite(a, corner + 2);
                table.set_opposite(b, corner + 1);
                let vp = table.vertex(CornerTable::previous(a));
                table.map(corner, vp);
                table.map(corner + 1, table.vertex(CornerTable::next(a)));
                let b_prev = table.vertex(CornerTable::previous(b));
                table.map(corner + 2, b_prev);
                table.set_left_most(b_prev, corner + 2);
                let mut n = CornerTable::next(b);
                let vn = table.vertex(n);
                if vp == NONE || vn == NONE {
                    return Err(damaged("S at an unset vertex"));
                }
                symbols.merge(vp, vn);
                table.set_left_most(vp, table.left_most(vn));
                let mut steps = 0;
                while n != NONE {
                    table.map(n, vp);
                    n = table.swing_left(n);
                    steps += 1;
                    if steps > corners {
                        return Err(damaged("a vertex fan without end"));
                    }
                }
                table.set_left_most(vn, NONE);
                invalid_vertices.push(vn);
                *stack.last_mut().unwrap() = corner;
            }
            E => {
                let first = new_vertex(&mut table)?;
                let second = new_vertex(&mut table)?;
                let third = new_vertex(&mut table)?;
                table.map(corner, first);
                table.map(corner + 1, second);
                table.map(corner + 2, third);
                table.set_left_most(first, corner);
                table.set_left_most(second, corner + 1);
                table.set_left_most(third, corner + 2);
                stack.push(corner);
                check_split = true;
            }
            _ => return Err(damaged("an unknown symbol")),
        }
        let active = *stack.last().unwrap();
        symbols.reached(&table, symbol, active)?;

        if check_split {
            let encoder_id = num_symbols as u32 - symbol_id - 1;
            while let Some(last) = splits.last() {
                if last.source > encoder_id {
                    return Err(damaged("a topology split was skipped"));
                }
                if last.source != encoder_id {
                    break;
                }
                let event = splits.pop().unwrap();
                let top = *stack.last().unwrap();
                let corner = if event.right_edge {
                    CornerTable::next(top)
                } else {
                    CornerTable::previous(top)
                };
                let decoder_split = (num_symbols as u32)
                    .checked_sub(event.split + 1)
                    .ok_or_else(|| damaged("a split symbol past the last symbol"))?;
                split_corners.insert(decoder_split, corner);
            }
        }
    }

    // Start faces close what is left on the stack.
    while let Some(corner) = stack.pop() {
        if !start_faces.next() {
            continue;
        }
        if face as usize >= faces {
            return Err(damaged("more faces than announced"));
        }
        let a = corner;
        let vn = table.vertex(CornerTable::next(a));
        let b = CornerTable::next(table.left_most(vn));
        let vx = table.vertex(CornerTable::next(b));
        let c = CornerTable::next(table.left_most(vx));
        let vp = table.vertex(CornerTable::next(c));
        if b == NONE || c == NONE || vp == NONE {
            return Err(damaged("an interior start face without neighbours"));
        }
        let new = 3 * face;
        face += 1;
        table.set_opposite(new, a);
        table.set_opposite(new + 1, b);
        table.set_opposite(new + 2, c);
        table.map(new, vx);
        table.map(new + 1, vp);
        table.map(new + 2, vn);
        for v in [vx, vp, vn] {
            if let Some(h) = holes.get_mut(v as usize) {
                *h = false;
            }
        }
    }
    if face as usize != faces {
        return Err(damaged("fewer faces than announced"));
    }

    // Vertices merged away by S symbols: without attribute seams, move the last valid vertex
    // into each hole; with them, the holes stay (points are assigned per corner later).
    let mut vertices = table.vertices();
    if attribute_data == 0 {
        for hole in invalid_vertices {
            while vertices > 0 && table.left_most(vertices as u32 - 1) == NONE {
                vertices -= 1;
            }
            if vertices == 0 {
                break;
            }
            let src = vertices as u32 - 1;
            if src < hole {
                continue;
            }
            for c in table.corners_around(table.left_most(src)) {
                table.map(c, hole);
            }
            table.set_left_most(hole, table.left_most(src));
            table.set_left_most(src, NONE);
            holes[hole as usize] = holes[src as usize];
            vertices -= 1;
        }
    }
    if table.vertex.iter().any(|&v| v as usize >= vertices) {
        return Err(damaged("a face at a vertex that does not exist"));
    }
    table.left_most.truncate(vertices);
    holes.truncate(vertices);

    // Attribute seams: one flag per interior edge (read from the face that comes first) and
    // attribute connectivity; every boundary edge is a seam.
    let mut seams = vec![Vec::new(); usize::from(attribute_data)];
    for f in 0..table.faces() as u32 {
        for c in [3 * f, 3 * f + 1, 3 * f + 2] {
            let opposite = table.opposite(c);
            if opposite == NONE {
                seams.iter_mut().for_each(|s| s.push(c));
                continue;
            }
            if opposite / 3 < f {
                continue;
            }
            for (list, bits) in seams.iter_mut().zip(&mut seam_bits) {
                if bits.next() {
                    list.push(c);
                }
            }
        }
    }
    Ok(Connectivity {
        table,
        vertices,
        holes,
        seams,
    })
}
