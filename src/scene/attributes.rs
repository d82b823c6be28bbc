//! Named vertex attributes of a mesh (Blender's Geometry Nodes attributes and colour
//! attributes, point, face or corner domain, which Blender's glTF exporter writes per vertex as
//! `_NAME`), held for the named attributes of its material's node tree and interpolated at a
//! shading point as Cycles interpolates an attribute over a triangle.

use crate::math::Vec4;
use crate::shader::{NamedAttributes, NAMED_ATTRIBUTES};

/// Per vertex, the value of each named attribute the mesh's node tree reads (slot `k` for
/// `NodeProgram::attributes[k]`), `None` where the mesh has no attribute of that name: a float
/// as (f, f, f, 1), a 2D vector as (x, y, 0, 1), a 3D vector as (x, y, z, 1), a colour with its
/// alpha.
#[derive(Clone, Debug, Default)]
pub struct NodeAttributes {
    pub slots: Vec<Option<Vec<Vec4>>>,
}

impl NodeAttributes {
    /// The attributes at barycentrics (b1, b2) of the triangle of vertices `corners`.
    #[inline]
    pub fn at(&self, corners: [u32; 3], b1: f32, b2: f32) -> NamedAttributes {
        let mut out = NamedAttributes::default();
        for (k, slot) in self.slots.iter().enumerate().take(NAMED_ATTRIBUTES) {
            if let Some(values) = slot {
                let [v0, v1, v2] = corners.map(|i| values[i as usize]);
                out.values[k] = (1.0 - b1 - b2) * v0 + b1 * v1 + b2 * v2;
                out.found |= 1 << k;
            }
        }
        out
    }

    /// One vertex per triangle corner (`corners`: the old vertex of each), as flat shading
    /// splits the mesh.
    pub fn spread(&mut self, corners: &[u32]) {
        for values in self.slots.iter_mut().flatten() {
            *values = corners.iter().map(|&i| values[i as usize]).collect();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn attributes_interpolate_over_the_triangle_and_follow_split_vertices() {
        let mut attributes = NodeAttributes {
            slots: vec![None, Some(vec![Vec4::ZERO, Vec4::X, Vec4::Y, Vec4::ONE])],
        };
        let at = attributes.at([0, 1, 2], 0.25, 0.5);
        assert_eq!(at.found, 0b10);
        assert_eq!(at.get(1), Some(Vec4::new(0.25, 0.5, 0.0, 0.0)));
        assert_eq!(at.get(0), None);
        attributes.spread(&[3, 1, 2]);
        assert_eq!(attributes.at([0, 1, 2], 0.0, 0.0).get(1), Some(Vec4::ONE));
    }
}
