//! `EXT_mesh_gpu_instancing`: a node whose mesh is drawn once per row of its TRANSLATION,
//! ROTATION and SCALE accessors, each row a transform applied before the node's own (world =
//! node world × T × R × S). The mesh becomes a prototype placed by one instance per row, as
//! meshes placed by several nodes are; the node's mesh is not drawn by itself.

use super::container::{named, Loader};
use crate::error::Result;
use crate::math::{Mat4, Quat, Vec3};
use serde_json::Value;

const EXTENSION: &str = "EXT_mesh_gpu_instancing";

impl Loader {
    /// The number of instances `node`'s extension places (`None`: it has none), from its
    /// accessors' counts, read before any geometry is.
    pub(super) fn gpu_instance_count(&self, node: &gltf::Node) -> Result<Option<usize>> {
        let Some(attributes) = self.gpu_instance_attributes(node)? else {
            return Ok(None);
        };
        let counts: Vec<usize> = attributes.iter().map(|(_, a)| a.count()).collect();
        Ok(counts.first().copied())
    }

    /// The transform of each instance `node`'s extension places, before the node's own.
    pub(super) fn gpu_instances(&self, node: &gltf::Node) -> Result<Option<Vec<Mat4>>> {
        let Some(attributes) = self.gpu_instance_attributes(node)? else {
            return Ok(None);
        };
        let object = format!("{} {EXTENSION}", named("node", node.index(), node.name()));
        let count = attributes[0].1.count();
        let mut translations = vec![Vec3::ZERO; count];
        let mut rotations = vec![Quat::IDENTITY; count];
        let mut scales = vec![Vec3::ONE; count];
        for (name, accessor) in &attributes {
            let components = if name == "ROTATION" { 4 } else { 3 };
            let what = format!("{object} {name}");
            let values = self.read_instance_attribute(accessor, &what, components)?;
            for (i, v) in values.chunks_exact(components).enumerate() {
                match name.as_str() {
                    "TRANSLATION" => translations[i] = Vec3::new(v[0], v[1], v[2]),
                    "SCALE" => scales[i] = Vec3::new(v[0], v[1], v[2]),
                    _ => rotations[i] = Quat::from_xyzw(v[0], v[1], v[2], v[3]).normalize(),
                }
            }
        }
        let transforms: Vec<Mat4> = (0..count)
            .map(|i| {
                Mat4::from_scale_rotation_translation(scales[i], rotations[i], translations[i])
            })
            .collect();
        if let Some(bad) = transforms.iter().position(|m| !m.is_finite()) {
            return Err(self.err(
                &object,
                format!("instance {bad} has a NaN or infinite transform"),
            ));
        }
        Ok(Some(transforms))
    }

    /// The extension's attributes with their accessors (TRANSLATION, ROTATION, SCALE, in that
    /// order when present), all of the same count; `None` without the extension.
    fn gpu_instance_attributes(
        &self,
        node: &gltf::Node,
    ) -> Result<Option<Vec<(String, gltf::Accessor<'_>)>>> {
        let Some(extension) = node.extension_value(EXTENSION) else {
            return Ok(None);
        };
        let object = format!("{} {EXTENSION}", named("node", node.index(), node.name()));
        let attributes = extension
            .get("attributes")
            .and_then(Value::as_object)
            .ok_or_else(|| self.err(&object, "'attributes' must be an object"))?;
        let mut found = Vec::new();
        for name in ["TRANSLATION", "ROTATION", "SCALE"] {
            let Some(index) = attributes.get(name) else {
                continue;
            };
            let accessor = index
                .as_u64()
                .and_then(|i| self.document.accessors().nth(i as usize))
                .ok_or_else(|| {
                    self.err(
                        &object,
                        format!("{name} must name an accessor, found {index}"),
                    )
                })?;
            self.check_accessor_fits(&accessor)?;
            found.push((name.to_string(), accessor));
        }
        if found.is_empty() {
            return Ok(None);
        }
        let count = found[0].1.count();
        if let Some((name, a)) = found.iter().find(|(_, a)| a.count() != count) {
            return Err(self.err(
                &object,
                format!(
                    "{name} has {} elements, {} has {count}",
                    a.count(),
                    found[0].0
                ),
            ));
        }
        Ok(Some(found))
    }

    /// An instancing attribute as floats: `components` per element, floats or (rotations)
    /// normalized signed bytes or shorts, as the extension allows.
    fn read_instance_attribute(
        &self,
        accessor: &gltf::Accessor,
        object: &str,
        components: usize,
    ) -> Result<Vec<f32>> {
        use gltf::accessor::DataType::{F32, I16, I8};
        let allowed = match accessor.data_type() {
            F32 => !accessor.normalized(),
            I8 | I16 => components == 4 && accessor.normalized(),
            _ => false,
        };
        if !allowed || accessor.dimensions().multiplicity() != components {
            return Err(self.err(
                object,
                format!(
                    "accessor {} must hold {} floats per element{}",
                    accessor.index(),
                    components,
                    if components == 4 {
                        " (or normalized signed bytes or shorts)"
                    } else {
                        ""
                    }
                ),
            ));
        }
        self.read_accessor(accessor, super::accessors::component_as_f32)
    }
}

impl Loader {
    /// Place `mesh` once per transform of `transforms` (each before the node's `world`) as
    /// instances of its prototype; a singular transform places nothing, with a warning.
    pub(super) fn add_gpu_instances(
        &mut self,
        node: &gltf::Node,
        mesh: &gltf::Mesh,
        world: &Mat4,
        transforms: &[Mat4],
    ) -> Result<()> {
        let object = named("node", node.index(), node.name());
        self.node_instances = self.node_instances.saturating_add(transforms.len());
        if self.node_instances > super::hierarchy::MAX_NODE_INSTANCES {
            return Err(self.err(
                &object,
                format!(
                    "the hierarchy instances more than {} nodes",
                    super::hierarchy::MAX_NODE_INSTANCES
                ),
            ));
        }
        let mut singular = 0;
        for transform in transforms {
            let placed = *world * *transform;
            let det = crate::math::Mat3::from_mat4(placed).determinant();
            if det == 0.0 || !det.is_finite() {
                singular += 1;
                continue;
            }
            self.add_instance(node, mesh, &placed, &[])?;
        }
        if singular > 0 {
            self.scene.warnings.push(format!(
                "{object} {EXTENSION}: {singular} instance(s) with a singular transform are not drawn"
            ));
        }
        Ok(())
    }
}
