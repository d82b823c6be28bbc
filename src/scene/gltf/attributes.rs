//! The named vertex attributes a primitive's node tree reads (`NodeProgram::attributes`):
//! Blender's glTF exporter writes a mesh attribute the add-on asks for as `_NAME` (the name
//! upper-cased, an underscore in front unless it had one), so a tree's name matches the glTF
//! attribute of the same name, case and one leading underscore aside.

use super::container::Loader;
use super::meshes::check_length;
use crate::error::Result;
use crate::math::Vec4;
use crate::scene::attributes::NodeAttributes;

/// Whether the glTF attribute `_gltf_name` (`gltf_name` without its underscore) is what Blender
/// wrote for the attribute `blender_name`.
fn same_attribute(gltf_name: &str, blender_name: &str) -> bool {
    let name = blender_name.strip_prefix('_').unwrap_or(blender_name);
    gltf_name.eq_ignore_ascii_case(name)
}

impl Loader {
    /// The attributes of `primitive` that `material`'s node tree names, per vertex.
    pub(super) fn node_attributes(
        &self,
        primitive: &gltf::Primitive,
        material: u32,
        object: &str,
        vertex_count: usize,
    ) -> Result<NodeAttributes> {
        let names = match &self.scene.materials[material as usize].nodes {
            Some(program) if !program.attributes.is_empty() => &program.attributes,
            _ => return Ok(NodeAttributes::default()),
        };
        let mut slots = Vec::with_capacity(names.len());
        for name in names {
            let accessor = primitive
                .attributes()
                .find_map(|(semantic, accessor)| match semantic {
                    gltf::Semantic::Extras(n) if same_attribute(&n, name) => Some(accessor),
                    _ => None,
                });
            let Some(accessor) = accessor else {
                slots.push(None);
                continue;
            };
            let n = accessor.dimensions().multiplicity();
            let flat = self.read_accessor(&accessor, super::accessors::component_as_f32)?;
            let values: Vec<Vec4> = flat
                .chunks_exact(n.max(1))
                .map(|c| match *c {
                    [f] => Vec4::new(f, f, f, 1.0),
                    [x, y] => Vec4::new(x, y, 0.0, 1.0),
                    [x, y, z] => Vec4::new(x, y, z, 1.0),
                    [x, y, z, w, ..] => Vec4::new(x, y, z, w),
                    [] => Vec4::ZERO,
                })
                .collect();
            let what = format!("attribute _{name}");
            check_length(&values, vertex_count)
                .map_err(|m| self.err(object, format!("{what} {m}")))?;
            if values.iter().any(|v| !v.is_finite()) {
                return Err(self.err(object, format!("a value of {what} is NaN or infinite")));
            }
            slots.push(Some(values));
        }
        Ok(NodeAttributes { slots })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blender_names_match_the_exporters_upper_case_names() {
        assert!(same_attribute("HEIGHT", "height"));
        assert!(same_attribute("HEIGHT", "_height"));
        assert!(same_attribute("MY_COL", "my_col"));
        assert!(!same_attribute("HEIGHT", "heights"));
    }
}
