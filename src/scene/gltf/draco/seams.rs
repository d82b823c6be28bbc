//! Attributes whose values split apart where the positions' vertices do not (a UV seam, a
//! hard normal edge), as Draco stores them (Draco bitstream specification 2.2, "Mesh
//! attribute corner table" and "EdgeBreaker decoder", points assigned to corners): each such
//! attribute's corner table is the mesh's with the seam edges cut, its vertices recomputed
//! around each mesh vertex; the mesh's points are then the distinct combinations of all
//! attributes' vertices around each mesh vertex.

use super::corner_table::{CornerTable, NONE};

/// An attribute's connectivity: its own corner table and which mesh vertices lie on a seam.
pub(super) struct AttributeTable {
    pub(super) table: CornerTable,
    /// By mesh vertex.
    on_seam: Vec<bool>,
}

/// The attribute table of `mesh` cut along the edges opposite `seam_corners`.
pub(super) fn attribute_table(mesh: &CornerTable, seam_corners: &[u32]) -> AttributeTable {
    let corners = mesh.corners();
    let mut edge_on_seam = vec![false; corners];
    let mut on_seam = vec![false; mesh.vertices()];
    let mut mark = |c: u32, edge_on_seam: &mut Vec<bool>| {
        if let Some(e) = edge_on_seam.get_mut(c as usize) {
            *e = true;
        }
        for v in [
            mesh.vertex(CornerTable::next(c)),
            mesh.vertex(CornerTable::previous(c)),
        ] {
            if let Some(s) = on_seam.get_mut(v as usize) {
                *s = true;
            }
        }
    };
    for &c in seam_corners {
        mark(c, &mut edge_on_seam);
        let o = mesh.opposite(c);
        if o != NONE {
            mark(o, &mut edge_on_seam);
        }
    }
    let mut table = CornerTable::new(mesh.faces());
    for ((opposite, &seam), &across) in table
        .opposite
        .iter_mut()
        .zip(&edge_on_seam)
        .zip(&mesh.opposite)
    {
        *opposite = if seam { NONE } else { across };
    }
    for v in 0..mesh.vertices() as u32 {
        let c = mesh.left_most(v);
        if c == NONE {
            continue;
        }
        let mut first = c;
        if on_seam[v as usize] {
            let mut act = table.swing_left(first);
            let mut steps = 0;
            while act != NONE && steps < corners {
                first = act;
                act = table.swing_left(act);
                steps += 1;
            }
        }
        let mut vertex = table.add_vertex();
        table.map(first, vertex);
        table.left_most[vertex as usize] = first;
        let mut act = mesh.swing_right(first);
        let mut steps = 0;
        while act != NONE && act != first && steps < corners {
            if edge_on_seam[CornerTable::next(act) as usize] {
                vertex = table.add_vertex();
                table.left_most[vertex as usize] = act;
            }
            table.map(act, vertex);
            act = mesh.swing_right(act);
            steps += 1;
        }
    }
    let boundary = table
        .left_most
        .iter()
        .map(|&c| {
            c == NONE
                || on_seam
                    .get(mesh.vertex(c) as usize)
                    .copied()
                    .unwrap_or(true)
        })
        .collect();
    table.boundary = Some(boundary);
    AttributeTable { table, on_seam }
}

/// The point of every corner and the number of points: around each mesh vertex, a new point
/// wherever any attribute's vertex changes, starting at a boundary or at a seam.
pub(super) fn assign_points(
    mesh: &CornerTable,
    holes: &[bool],
    attributes: &[AttributeTable],
) -> (Vec<u32>, usize) {
    let corners = mesh.corners();
    let mut corner_to_point = vec![NONE; corners];
    let mut points = 0u32;
    for v in 0..mesh.vertices() {
        let c = mesh.left_most(v as u32);
        if c == NONE {
            continue;
        }
        let mut first = c;
        if !holes.get(v).copied().unwrap_or(true) {
            'attributes: for a in attributes {
                if !a
                    .on_seam
                    .get(mesh.vertex(c) as usize)
                    .copied()
                    .unwrap_or(false)
                {
                    continue;
                }
                let vertex = a.table.vertex(c);
                let mut act = mesh.swing_right(c);
                let mut steps = 0;
                while act != c && act != NONE && steps < corners {
                    if a.table.vertex(act) != vertex {
                        first = act;
                        break 'attributes;
                    }
                    act = mesh.swing_right(act);
                    steps += 1;
                }
            }
        }
        corner_to_point[first as usize] = points;
        points += 1;
        let mut prev = first;
        let mut act = mesh.swing_right(first);
        let mut steps = 0;
        while act != NONE && act != first && steps < corners {
            let split = attributes
                .iter()
                .any(|a| a.table.vertex(act) != a.table.vertex(prev));
            corner_to_point[act as usize] = if split {
                points += 1;
                points - 1
            } else {
                corner_to_point[prev as usize]
            };
            prev = act;
            act = mesh.swing_right(act);
            steps += 1;
        }
    }
    (corner_to_point, points as usize)
}
