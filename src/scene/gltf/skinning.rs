//! Vertices moved before a mesh is placed: morph targets at the node's weights (the pose's at
//! `LoadOptions::time`, else the node's or the mesh's defaults), their POSITION, NORMAL and
//! TANGENT deltas added in the mesh's space; then skins, each vertex carried to world space by
//! its joints' matrices (joint world × inverse bind matrix) blended by its weights (divided by
//! their sum, as Blender's armature deform does), the skinned node's own transform ignored as
//! glTF specifies.

use super::container::{named, Loader};
use super::hierarchy::MAX_NODE_DEPTH;
use crate::error::Result;
use crate::math::{Mat3, Mat4, Vec3, Vec4};

impl Loader {
    /// Apply `node`'s morph targets, then its skin, to one primitive's local `positions`,
    /// `normals` and `tangents`. Returns whether they are now in world space (skinned).
    pub(super) fn deform_vertices(
        &mut self,
        node: &gltf::Node,
        primitive: &gltf::Primitive,
        positions: &mut [Vec3],
        normals: &mut Option<Vec<Vec3>>,
        tangents: &mut [Vec4],
        object: &str,
    ) -> Result<bool> {
        self.morph(node, primitive, positions, normals, tangents, object)?;
        let Some(skin) = node.skin() else {
            return Ok(false);
        };
        let joints = self.joint_matrices(&skin)?;
        let blended = self.vertex_skin_matrices(primitive, &joints, positions.len(), object)?;
        for (i, m) in blended.iter().enumerate() {
            positions[i] = m.transform_point3(positions[i]);
            let linear = Mat3::from_mat4(*m);
            if let Some(normals) = normals {
                normals[i] = (linear.inverse().transpose() * normals[i]).normalize_or_zero();
            }
            if let Some(t) = tangents.get_mut(i) {
                *t = (linear * t.truncate()).extend(t.w);
            }
        }
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(self.err(object, "a skinned vertex is NaN or infinite"));
        }
        Ok(true)
    }

    /// Add each morph target's deltas × its weight.
    fn morph(
        &self,
        node: &gltf::Node,
        primitive: &gltf::Primitive,
        positions: &mut [Vec3],
        normals: &mut Option<Vec<Vec3>>,
        tangents: &mut [Vec4],
        object: &str,
    ) -> Result<()> {
        let weights = self.morph_weights(node);
        let vertices = positions.len();
        for (t, target) in primitive.morph_targets().enumerate() {
            let weight = weights.get(t).copied().unwrap_or(0.0);
            if weight == 0.0 {
                continue;
            }
            let label = |what: &str| format!("{object} morph target {t} {what}");
            let deltas = |accessor: Option<gltf::Accessor>, what: &str| -> Result<Vec<Vec3>> {
                let Some(accessor) = accessor else {
                    return Ok(Vec::new());
                };
                let values = self.read_vec3(&accessor, object, what)?;
                if values.len() != vertices {
                    return Err(self.err(
                        label(what),
                        format!("has {} deltas for {vertices} vertices", values.len()),
                    ));
                }
                Ok(values)
            };
            for (p, d) in positions
                .iter_mut()
                .zip(deltas(target.positions(), "POSITION")?)
            {
                *p += weight * d;
            }
            if let Some(normals) = normals {
                for (n, d) in normals.iter_mut().zip(deltas(target.normals(), "NORMAL")?) {
                    *n = (*n + weight * d).normalize_or_zero();
                }
            }
            for (t, d) in tangents
                .iter_mut()
                .zip(deltas(target.tangents(), "TANGENT")?)
            {
                *t = (t.truncate() + weight * d).normalize_or_zero().extend(t.w);
            }
        }
        Ok(())
    }

    /// Each joint's matrix: its world transform × its inverse bind matrix.
    fn joint_matrices(&self, skin: &gltf::Skin) -> Result<Vec<Mat4>> {
        let object = named("skin", skin.index(), skin.name());
        let joints: Vec<gltf::Node> = skin.joints().collect();
        let inverse_binds = match skin.inverse_bind_matrices() {
            Some(accessor) => {
                if accessor.dimensions() != gltf::accessor::Dimensions::Mat4
                    || accessor.data_type() != gltf::accessor::DataType::F32
                    || accessor.count() < joints.len()
                {
                    return Err(self.err(
                        &object,
                        format!(
                            "inverseBindMatrices must hold a float MAT4 per joint ({})",
                            joints.len()
                        ),
                    ));
                }
                self.check_accessor_fits(&accessor)?;
                let flat = self.read_accessor(&accessor, super::accessors::component_as_f32)?;
                flat.chunks_exact(16)
                    .map(Mat4::from_cols_slice)
                    .collect::<Vec<_>>()
            }
            None => vec![Mat4::IDENTITY; joints.len()],
        };
        let matrices: Vec<Mat4> = joints
            .iter()
            .zip(&inverse_binds)
            .map(|(joint, bind)| self.node_world(joint) * *bind)
            .collect();
        if matrices.iter().any(|m| !m.is_finite()) {
            return Err(self.err(&object, "a joint matrix is NaN or infinite"));
        }
        Ok(matrices)
    }

    /// `node`'s world transform through its parents (whether or not the scene shows them).
    fn node_world(&self, node: &gltf::Node) -> Mat4 {
        let mut world = self.local_matrix(node);
        let mut index = node.index();
        for _ in 0..MAX_NODE_DEPTH {
            let Some(parent) = self
                .document
                .nodes()
                .find(|n| n.children().any(|c| c.index() == index))
            else {
                break;
            };
            world = self.local_matrix(&parent) * world;
            index = parent.index();
        }
        world
    }

    /// Each vertex's blend of its joints' matrices (JOINTS_n and WEIGHTS_n, every set).
    fn vertex_skin_matrices(
        &self,
        primitive: &gltf::Primitive,
        joints: &[Mat4],
        vertices: usize,
        object: &str,
    ) -> Result<Vec<Mat4>> {
        let mut sums = vec![Mat4::ZERO; vertices];
        let mut totals = vec![0.0f32; vertices];
        for set in 0.. {
            let indices = primitive.get(&gltf::Semantic::Joints(set));
            let weights = primitive.get(&gltf::Semantic::Weights(set));
            let (Some(indices), Some(weights)) = (indices, weights) else {
                break;
            };
            let label = format!("{object} JOINTS_{set}/WEIGHTS_{set}");
            if indices.count() != vertices || weights.count() != vertices {
                return Err(self.err(&label, format!("must have {vertices} elements")));
            }
            let indices = self.read_accessor(&indices, super::accessors::component_as_u32)?;
            let weights = self.read_accessor(&weights, super::accessors::component_as_f32)?;
            if indices.len() != 4 * vertices || weights.len() != 4 * vertices {
                return Err(self.err(&label, "must be VEC4 accessors"));
            }
            for (v, (js, ws)) in indices
                .chunks_exact(4)
                .zip(weights.chunks_exact(4))
                .enumerate()
            {
                for (&j, &w) in js.iter().zip(ws) {
                    if w == 0.0 {
                        continue;
                    }
                    let matrix = joints.get(j as usize).ok_or_else(|| {
                        self.err(
                            &label,
                            format!("joint {j} is not one of the skin's {}", joints.len()),
                        )
                    })?;
                    sums[v] += *matrix * w;
                    totals[v] += w;
                }
            }
        }
        Ok(sums
            .into_iter()
            .zip(totals)
            .map(|(m, total)| {
                if total > 0.0 {
                    m * (1.0 / total)
                } else {
                    Mat4::IDENTITY
                }
            })
            .collect())
    }
}
