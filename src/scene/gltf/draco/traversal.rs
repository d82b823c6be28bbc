//! The order in which Draco stores a mesh's attribute values (Draco bitstream specification
//! 2.2, "Mesh traversal sequencer", "EdgeBreaker traverser" and "Prediction degree
//! traverser"): the faces are walked from each unvisited face in turn, depth first or by the
//! prediction degree of the next vertex, and each vertex is given the next value index when it
//! is first reached. The walk also records the corner each value was reached from, which the
//! mesh prediction schemes predict across.

use super::corner_table::{CornerTable, NONE};

/// Where each stored value sits on the mesh.
pub(super) struct Sequence {
    /// The point of each stored value, in stored order.
    pub(super) points: Vec<u32>,
    /// The corner each stored value was reached from.
    pub(super) corners: Vec<u32>,
    /// The stored value index of each vertex.
    pub(super) vertex_to_value: Vec<u32>,
    /// The point of each corner of the mesh.
    corner_to_point: Vec<u32>,
}

impl Sequence {
    fn visit(&mut self, table: &CornerTable, corner: u32) {
        let v = table.vertex(corner);
        self.vertex_to_value[v as usize] = self.points.len() as u32;
        self.points.push(self.corner_to_point[corner as usize]);
        self.corners.push(corner);
    }

    /// The stored value index of each point (through the corners of `table`).
    pub(super) fn point_to_value(&self, table: &CornerTable, points: usize) -> Option<Vec<u32>> {
        let mut out = vec![NONE; points];
        for (c, &p) in self.corner_to_point.iter().enumerate() {
            let value = *self.vertex_to_value.get(table.vertex(c as u32) as usize)?;
            *out.get_mut(p as usize)? = value;
        }
        out.iter().all(|&v| v != NONE).then_some(out)
    }
}

struct Visited {
    faces: Vec<bool>,
    vertices: Vec<bool>,
}

impl Visited {
    fn face(&self, corner: u32) -> bool {
        corner == NONE || self.faces[(corner / 3) as usize]
    }
}

/// The stored order of a mesh's values: depth first (Edgebreaker order) or, with
/// `by_degree`, by prediction degree.
pub(super) fn sequence(
    table: &CornerTable,
    by_degree: bool,
    corner_to_point: Vec<u32>,
) -> Sequence {
    let vertices = table.vertices();
    let mut seq = Sequence {
        points: Vec::with_capacity(vertices),
        corners: Vec::with_capacity(vertices),
        vertex_to_value: vec![NONE; vertices],
        corner_to_point,
    };
    let mut visited = Visited {
        faces: vec![false; table.faces()],
        vertices: vec![false; vertices],
    };
    let mut degree = vec![0u32; if by_degree { vertices } else { 0 }];
    for f in 0..table.faces() as u32 {
        let corner = 3 * f;
        if visited.face(corner) {
            continue;
        }
        // The first face's other two corners.
        for c in [CornerTable::next(corner), CornerTable::previous(corner)] {
            let v = table.vertex(c) as usize;
            if !visited.vertices[v] {
                visited.vertices[v] = true;
                seq.visit(table, c);
            }
        }
        if by_degree {
            by_prediction_degree(table, corner, &mut visited, &mut seq, &mut degree);
        } else {
            depth_first(table, corner, &mut visited, &mut seq);
        }
    }
    seq
}

/// Draco's Edgebreaker traverser from one face.
fn depth_first(table: &CornerTable, start: u32, visited: &mut Visited, seq: &mut Sequence) {
    let mut stack = vec![start];
    while let Some(&top) = stack.last() {
        if visited.face(top) {
            stack.pop();
            continue;
        }
        let mut corner = top;
        loop {
            visited.faces[(corner / 3) as usize] = true;
            let v = table.vertex(corner) as usize;
            if !visited.vertices[v] {
                let boundary = table.on_boundary(v as u32);
                visited.vertices[v] = true;
                seq.visit(table, corner);
                if !boundary {
                    corner = table.right_corner(corner);
                    // A face reached again ends this branch, as a boundary does.
                    if visited.face(corner) {
                        stack.pop();
                        break;
                    }
                    continue;
                }
            }
            let right = table.right_corner(corner);
            let left = table.left_corner(corner);
            match (visited.face(right), visited.face(left)) {
                (true, true) => {
                    stack.pop();
                    break;
                }
                (true, false) => corner = left,
                (false, true) => corner = right,
                (false, false) => {
                    *stack.last_mut().unwrap() = left;
                    stack.push(right);
                    break;
                }
            }
        }
    }
}

/// Draco's prediction degree traverser from one face: corners whose tip vertex has more
/// visited neighbours are taken first.
fn by_prediction_degree(
    table: &CornerTable,
    start: u32,
    visited: &mut Visited,
    seq: &mut Sequence,
    degree: &mut [u32],
) {
    const PRIORITIES: usize = 3;
    let mut stacks: [Vec<u32>; PRIORITIES] = Default::default();
    stacks[0].push(start);
    let mut best = 0usize;
    let tip = table.vertex(start) as usize;
    if !visited.vertices[tip] {
        visited.vertices[tip] = true;
        seq.visit(table, start);
    }
    let priority = |corner: u32, visited: &Visited, degree: &mut [u32]| -> usize {
        let v = table.vertex(corner) as usize;
        let mut p = 0;
        if !visited.vertices[v] {
            degree[v] += 1;
            p = if degree[v] > 1 { 1 } else { 2 };
        }
        p.min(PRIORITIES - 1)
    };
    while let Some(level) = (best..PRIORITIES).find(|&i| !stacks[i].is_empty()) {
        best = level;
        let mut corner = stacks[level].pop().unwrap();
        if visited.face(corner) {
            continue;
        }
        loop {
            visited.faces[(corner / 3) as usize] = true;
            let v = table.vertex(corner) as usize;
            if !visited.vertices[v] {
                visited.vertices[v] = true;
                seq.visit(table, corner);
            }
            let right = table.right_corner(corner);
            let left = table.left_corner(corner);
            let right_visited = visited.face(right);
            if !visited.face(left) {
                let p = priority(left, visited, degree);
                if right_visited && p <= best {
                    corner = left;
                    continue;
                }
                stacks[p].push(left);
                best = best.min(p);
            }
            if !right_visited {
                let p = priority(right, visited, degree);
                if p <= best {
                    corner = right;
                    continue;
                }
                stacks[p].push(right);
                best = best.min(p);
            }
            break;
        }
    }
}
