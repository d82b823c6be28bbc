//! The corner table of a triangle mesh (Rossignac, Safonova & Szymczak 2001, "3D compression
//! made simple: Edgebreaker on a corner-table"; Draco bitstream specification 2.2, "Corner
//! table"): corner `c` belongs to face `c / 3`, and each corner knows its vertex and the corner
//! opposite it across the shared edge. Every walk around a vertex stops after as many steps as
//! there are corners, so a damaged table cannot make a walk endless.

/// "No corner" / "no vertex".
pub(super) const NONE: u32 = u32::MAX;

pub(super) struct CornerTable {
    /// The vertex of each corner.
    pub(super) vertex: Vec<u32>,
    /// The opposite corner of each corner, `NONE` on a boundary edge.
    pub(super) opposite: Vec<u32>,
    /// A corner of each vertex: the left-most one for a vertex on a boundary.
    pub(super) left_most: Vec<u32>,
    /// For an attribute's table (`seams`): whether each vertex counts as on a boundary (on
    /// an attribute seam); `None` for the mesh's own table, where a vertex is on a boundary
    /// when nothing lies left of its left-most corner.
    pub(super) boundary: Option<Vec<bool>>,
}

impl CornerTable {
    pub(super) fn new(faces: usize) -> CornerTable {
        CornerTable {
            vertex: vec![NONE; 3 * faces],
            opposite: vec![NONE; 3 * faces],
            left_most: Vec::new(),
            boundary: None,
        }
    }

    pub(super) fn corners(&self) -> usize {
        self.vertex.len()
    }

    pub(super) fn faces(&self) -> usize {
        self.vertex.len() / 3
    }

    pub(super) fn vertices(&self) -> usize {
        self.left_most.len()
    }

    pub(super) fn next(c: u32) -> u32 {
        if c == NONE {
            NONE
        } else if c % 3 == 2 {
            c - 2
        } else {
            c + 1
        }
    }

    pub(super) fn previous(c: u32) -> u32 {
        if c == NONE {
            NONE
        } else if c.is_multiple_of(3) {
            c + 2
        } else {
            c - 1
        }
    }

    pub(super) fn vertex(&self, c: u32) -> u32 {
        self.vertex.get(c as usize).copied().unwrap_or(NONE)
    }

    pub(super) fn opposite(&self, c: u32) -> u32 {
        self.opposite.get(c as usize).copied().unwrap_or(NONE)
    }

    pub(super) fn left_most(&self, v: u32) -> u32 {
        self.left_most.get(v as usize).copied().unwrap_or(NONE)
    }

    pub(super) fn set_left_most(&mut self, v: u32, c: u32) {
        if let Some(slot) = self.left_most.get_mut(v as usize) {
            *slot = c;
        }
    }

    pub(super) fn map(&mut self, c: u32, v: u32) {
        if let Some(slot) = self.vertex.get_mut(c as usize) {
            *slot = v;
        }
    }

    pub(super) fn set_opposite(&mut self, a: u32, b: u32) {
        if (a as usize) < self.opposite.len() && (b as usize) < self.opposite.len() {
            self.opposite[a as usize] = b;
            self.opposite[b as usize] = a;
        }
    }

    pub(super) fn add_vertex(&mut self) -> u32 {
        self.left_most.push(NONE);
        (self.left_most.len() - 1) as u32
    }

    /// The corner on the face to the left of `c`'s vertex, turning counter-clockwise.
    pub(super) fn swing_left(&self, c: u32) -> u32 {
        Self::next(self.opposite(Self::next(c)))
    }

    /// The corner on the face to the right of `c`'s vertex, turning clockwise.
    pub(super) fn swing_right(&self, c: u32) -> u32 {
        Self::previous(self.opposite(Self::previous(c)))
    }

    /// The corner opposite the edge to the left of `c` (the edge from `c` to its previous).
    pub(super) fn left_corner(&self, c: u32) -> u32 {
        self.opposite(Self::previous(c))
    }

    /// The corner opposite the edge to the right of `c`.
    pub(super) fn right_corner(&self, c: u32) -> u32 {
        self.opposite(Self::next(c))
    }

    /// Whether vertex `v` lies on an open boundary.
    pub(super) fn on_boundary(&self, v: u32) -> bool {
        match &self.boundary {
            Some(flags) => flags.get(v as usize).copied().unwrap_or(true),
            None => self.swing_left(self.left_most(v)) == NONE,
        }
    }

    /// The corners around the vertex of `start`: counter-clockwise from it, then, at an open
    /// boundary, clockwise from it; at most as many as the table has.
    pub(super) fn corners_around(&self, start: u32) -> Vec<u32> {
        let mut out = vec![start];
        let limit = self.corners();
        let mut c = self.swing_left(start);
        while c != NONE && c != start && out.len() <= limit {
            out.push(c);
            c = self.swing_left(c);
        }
        if c == NONE {
            let mut c = self.swing_right(start);
            while c != NONE && c != start && out.len() <= limit {
                out.push(c);
                c = self.swing_right(c);
            }
        }
        out
    }
}
