//! glTF meshes become the scene's meshes (flattened to world space) or prototypes placed by
//! instances: triangles from lists, strips and fans, vertex attributes, mirrored transforms
//! (winding and tangent handedness flipped), flat shading where normals are missing, the
//! Blender object space node trees read, and true displacement (`crate::scene::displace`).

use super::container::Loader;
use super::hierarchy::{MAX_TRIANGLES, MAX_VERTICES};
use crate::error::Result;
use crate::math::{Affine3A, Mat3, Mat4, Vec2, Vec3, Vec4};
use crate::scene::displace::displace_object;
use crate::scene::{Bounds, Instance, Mesh, ObjectSpace};
use gltf::mesh::Mode;
use std::rc::Rc;

impl Loader {
    /// Place `mesh` by `world` as instances of its prototypes (built on first use).
    /// `motion` holds its poses over the shutter (empty: still).
    pub(super) fn add_instance(
        &mut self,
        node: &gltf::Node,
        mesh: &gltf::Mesh,
        world: &Mat4,
        motion: &[Affine3A],
    ) -> Result<()> {
        if !self.prototype_ids.contains_key(&mesh.index()) {
            let first = self.scene.prototypes.len() as u32;
            self.add_mesh(node, mesh, &Mat4::IDENTITY, true)?;
            // Displaced as placed by its first instance, as Cycles displaces a shared mesh.
            let scene = &mut self.scene;
            let placed = Affine3A::from_mat4(*world);
            let prototypes = &mut scene.prototypes[first as usize..];
            displace_object(prototypes, &placed, &scene.materials, &scene.textures);
            let ids = (first..self.scene.prototypes.len() as u32).collect();
            self.prototype_ids.insert(mesh.index(), ids);
        }
        let to_world = Affine3A::from_mat4(*world);
        let object = &self.node_extensions[node.index()].object;
        let (camera_visible, casts_shadows, holdout) =
            (object.camera_visible, object.casts_shadows, object.holdout);
        for &prototype in &self.prototype_ids[&mesh.index()] {
            let mut instance = Instance::new(prototype, to_world);
            instance.motion = motion.to_vec();
            instance.camera_visible = camera_visible;
            instance.casts_shadows = casts_shadows;
            instance.holdout = holdout;
            instance.links = object.links;
            instance.shadow_catcher = object.shadow_catcher;
            instance.object_info = object.info;
            self.scene.instances.push(instance);
        }
        Ok(())
    }

    /// Read `mesh`'s primitives placed by `world` into `Scene::meshes`, or with the identity
    /// into `Scene::prototypes` when `prototype`.
    pub(super) fn add_mesh(
        &mut self,
        node: &gltf::Node,
        mesh: &gltf::Mesh,
        world: &Mat4,
        prototype: bool,
    ) -> Result<()> {
        let mesh_name = mesh.name().map_or_else(
            || format!("mesh {}", mesh.index()),
            |n| format!("mesh '{n}'"),
        );
        // A skinned mesh's vertices are placed by its joints (`deform_vertices`), not its node.
        let world = if node.skin().is_some() {
            &Mat4::IDENTITY
        } else {
            world
        };
        let linear = Mat3::from_mat4(*world);
        let normal_matrix = linear.inverse().transpose();
        let mirrored = linear.determinant() < 0.0;
        let extensions = Rc::clone(&self.node_extensions);
        let extension = &extensions[node.index()].object;
        let first_mesh = self.scene.meshes.len();
        for primitive in mesh.primitives() {
            let object = format!("{mesh_name} primitive {}", primitive.index());
            let mode = primitive.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                self.scene.warnings.push(format!(
                    "{object}: {mode:?} primitives are not rendered, skipped"
                ));
                continue;
            }
            let Some(position_accessor) = primitive.get(&gltf::Semantic::Positions) else {
                self.scene
                    .warnings
                    .push(format!("{object}: no POSITION attribute, skipped"));
                continue;
            };
            // Reading is bounded by the buffer sizes; the total is bounded here.
            let mut positions = self.read_vec3(&position_accessor, &object, "POSITION")?;
            self.vertex_total = self.vertex_total.saturating_add(positions.len());
            if self.vertex_total > MAX_VERTICES {
                return Err(self.err(
                    &object,
                    format!("the scene exceeds Photon's limit of {MAX_VERTICES} vertices"),
                ));
            }
            if let Some(bad) = positions.iter().position(|p| !p.is_finite()) {
                return Err(self.err(
                    &object,
                    format!("vertex {bad} has a NaN or infinite position"),
                ));
            }
            let vertex_count = positions.len();
            let mut indices = self.primitive_triangles(&primitive, vertex_count, &object)?;
            for (t, tri) in indices.iter().enumerate() {
                if let Some(&i) = tri.iter().find(|&&i| i as usize >= vertex_count) {
                    return Err(self.err(
                        &object,
                        format!(
                            "triangle {t} uses vertex {i}, past the vertex count {vertex_count}"
                        ),
                    ));
                }
            }

            let mut normals = match primitive.get(&gltf::Semantic::Normals) {
                Some(a) => Some(self.read_vec3(&a, &object, "NORMAL")?),
                None => None,
            };
            let uvs = match primitive.get(&gltf::Semantic::TexCoords(0)) {
                Some(a) => {
                    let flat = self.read_float_attribute(&a, &object, "TEXCOORD_0", 2)?;
                    flat.chunks_exact(2)
                        .map(|c| Vec2::new(c[0], c[1]))
                        .collect()
                }
                None => Vec::new(),
            };
            let mut extra_uvs = Vec::new();
            for set in 1..crate::shader::UV_SETS as u32 {
                let Some(a) = primitive.get(&gltf::Semantic::TexCoords(set)) else {
                    break;
                };
                let label = format!("TEXCOORD_{set}");
                let flat = self.read_float_attribute(&a, &object, &label, 2)?;
                let uvs: Vec<Vec2> = flat
                    .chunks_exact(2)
                    .map(|c| Vec2::new(c[0], c[1]))
                    .collect();
                check_length(&uvs, vertex_count)
                    .map_err(|m| self.err(&object, format!("{label} {m}")))?;
                extra_uvs.push(uvs);
            }
            let mut tangents = match primitive.get(&gltf::Semantic::Tangents) {
                Some(a) => {
                    let flat = self.read_float_attribute(&a, &object, "TANGENT", 4)?;
                    flat.chunks_exact(4)
                        .map(|c| Vec4::new(c[0], c[1], c[2], c[3]))
                        .collect()
                }
                None => Vec::new(),
            };
            let colors = match primitive.get(&gltf::Semantic::Colors(0)) {
                Some(a) => {
                    let n = a.dimensions().multiplicity();
                    let flat = self.read_float_attribute(&a, &object, "COLOR_0", n.clamp(3, 4))?;
                    if n == 4 {
                        flat.chunks_exact(4)
                            .map(|c| Vec4::new(c[0], c[1], c[2], c[3]))
                            .collect()
                    } else {
                        flat.chunks_exact(3)
                            .map(|c| Vec4::new(c[0], c[1], c[2], 1.0))
                            .collect()
                    }
                }
                None => Vec::new(),
            };
            check_length(&colors, vertex_count)
                .map_err(|m| self.err(&object, format!("COLOR_0 {m}")))?;
            if colors.iter().any(|c: &Vec4| !c.is_finite()) {
                return Err(self.err(&object, "a COLOR_0 value is NaN or infinite"));
            }
            check_length(&tangents, vertex_count)
                .map_err(|m| self.err(&object, format!("TANGENT {m}")))?;
            if let Some(normals) = &normals {
                check_length(normals, vertex_count)
                    .map_err(|m| self.err(&object, format!("NORMAL {m}")))?;
            }
            self.deform_vertices(
                node,
                &primitive,
                &mut positions,
                &mut normals,
                &mut tangents,
                &object,
            )?;
            let object_space = Some(self.object_space(node, &positions, world));
            check_length(&uvs, vertex_count)
                .map_err(|m| self.err(&object, format!("TEXCOORD_0 {m}")))?;

            let world_positions: Vec<Vec3> = positions
                .iter()
                .map(|&p| world.transform_point3(p))
                .collect();
            if mirrored {
                for tri in &mut indices {
                    tri.swap(1, 2);
                }
            }
            let world_tangents: Vec<Vec4> = tangents
                .iter()
                .map(|t| {
                    let xyz = (linear * t.truncate()).normalize_or_zero();
                    // A mirror flips the handedness of the tangent frame.
                    let w = if mirrored { -t.w } else { t.w };
                    xyz.extend(w)
                })
                .collect();

            let material = self.variant_material(&primitive)?;
            let material = self.material_index(material, !colors.is_empty())?;
            let mut out = Mesh {
                name: format!(
                    "{}/{} primitive {}",
                    node.name().unwrap_or("node"),
                    mesh.name().unwrap_or("mesh"),
                    primitive.index()
                ),
                positions: world_positions,
                normals: Vec::new(),
                uvs,
                extra_uvs,
                tangents: world_tangents,
                indices,
                material,
                camera_visible: extension.camera_visible,
                holdout: extension.holdout,
                emission_spread: None,
                casts_shadows: extension.casts_shadows,
                colors,
                object_space,
                deformation: Vec::new(),
                volume_grids: None,
                links: extension.links,
                shadow_catcher: extension.shadow_catcher,
                object_info: extension.info,
                node_attributes: self.node_attributes(
                    &primitive,
                    material,
                    &object,
                    vertex_count,
                )?,
                undisplaced: Vec::new(),
            };
            if let Some(file) = &extension.volume {
                out.volume_grids = self.volume_grids(&object, file, material)?;
            }
            match normals {
                Some(normals) => {
                    out.normals = normals
                        .iter()
                        .map(|&n| (normal_matrix * n).normalize_or_zero())
                        .collect();
                    if out.normals.iter().any(|n| !n.is_finite()) {
                        return Err(self.err(&object, "a vertex normal is NaN or infinite"));
                    }
                }
                None => make_flat(&mut out),
            }
            if prototype {
                if let Some(deform) = &extension.deform {
                    match deform.of(&positions) {
                        Some(deformation) => out.deformation = deformation,
                        None => self.scene.warnings.push(format!(
                            "{object}: its deformation is not blurred (its vertices are not \
                             those of PHOTON_object's \"deform\" frame)"
                        )),
                    }
                }
                self.scene.prototypes.push(out);
            } else {
                self.scene.meshes.push(out);
            }
        }
        if !prototype {
            let scene = &mut self.scene;
            let meshes = &mut scene.meshes[first_mesh..];
            displace_object(
                meshes,
                &Affine3A::IDENTITY,
                &scene.materials,
                &scene.textures,
            );
        }
        Ok(())
    }

    /// The Blender object of `node` for node trees: stored positions (placed by `world`) →
    /// Blender object coordinates (glTF (x, y, z) is Blender (x, −z, y)), and the texture space
    /// from `PHOTON_object`'s `texture_space` or else the bounds of `local` (object-space glTF
    /// positions), as Blender's automatic texture space.
    pub(super) fn object_space(
        &self,
        node: &gltf::Node,
        local: &[Vec3],
        world: &Mat4,
    ) -> ObjectSpace {
        let axes = Affine3A::from_cols_array(&[
            1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0,
        ]);
        let inverse = world.inverse();
        let to_object = if inverse.is_finite() {
            axes * Affine3A::from_mat4(inverse)
        } else {
            axes
        };
        let (location, size) = match self.node_extensions[node.index()].object.texture_space {
            Some(given) => given,
            None => {
                let mut bounds = Bounds::EMPTY;
                for &p in local {
                    bounds.grow(axes.transform_point3(p));
                }
                if bounds.is_empty() {
                    (Vec3::ZERO, Vec3::ONE)
                } else {
                    (bounds.center(), 0.5 * (bounds.max - bounds.min))
                }
            }
        };
        ObjectSpace {
            to_object,
            texspace_location: location,
            texspace_size: size,
        }
    }

    /// The primitive's triangles as index triples (strips and fans converted), or `None` when
    /// the primitive is not made of triangles. Refuses primitives that would take the scene over
    /// `MAX_TRIANGLES` before allocating them.
    pub(super) fn primitive_triangles(
        &mut self,
        primitive: &gltf::Primitive,
        vertex_count: usize,
        object: &str,
    ) -> Result<Vec<[u32; 3]>> {
        let mode = primitive.mode();
        let index_count = primitive.indices().map_or(vertex_count, |a| a.count());
        let new_triangles = match mode {
            Mode::Triangles => index_count / 3,
            _ => index_count.saturating_sub(2),
        };
        self.triangle_total = self.triangle_total.saturating_add(new_triangles);
        if self.triangle_total > MAX_TRIANGLES {
            return Err(self.err(
                object,
                format!("the scene exceeds Photon's limit of {MAX_TRIANGLES} triangles"),
            ));
        }
        let list: Vec<u32> = match primitive.indices() {
            Some(accessor) => self.read_indices(&accessor, object)?,
            None => {
                let count = u32::try_from(vertex_count)
                    .map_err(|_| self.err(object, "too many vertices for 32-bit indices"))?;
                (0..count).collect()
            }
        };
        let triangles = match mode {
            Mode::Triangles => list.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
            Mode::TriangleStrip => list
                .windows(3)
                .enumerate()
                .map(|(i, w)| {
                    if i % 2 == 0 {
                        [w[0], w[1], w[2]]
                    } else {
                        [w[1], w[0], w[2]]
                    }
                })
                .collect(),
            _ => match list.split_first() {
                Some((&centre, rest)) => rest.windows(2).map(|w| [centre, w[0], w[1]]).collect(),
                None => Vec::new(),
            },
        };
        Ok(triangles)
    }
}

/// Split every triangle's vertices apart and give them the face normal (a mesh without normals
/// is flat shaded in glTF); every per-vertex attribute follows its vertex.
pub(super) fn make_flat(mesh: &mut Mesh) {
    let corners: Vec<u32> = mesh.indices.iter().flatten().copied().collect();
    fn spread<T: Copy>(values: &[T], corners: &[u32]) -> Vec<T> {
        if values.is_empty() {
            return Vec::new();
        }
        corners.iter().map(|&i| values[i as usize]).collect()
    }
    mesh.normals = mesh
        .indices
        .iter()
        .flat_map(|tri| {
            let [a, b, c] = tri.map(|i| mesh.positions[i as usize]);
            [(b - a).cross(c - a).normalize_or_zero(); 3]
        })
        .collect();
    mesh.positions = spread(&mesh.positions, &corners);
    mesh.uvs = spread(&mesh.uvs, &corners);
    mesh.extra_uvs = mesh
        .extra_uvs
        .iter()
        .map(|set| spread(set, &corners))
        .collect();
    mesh.tangents = spread(&mesh.tangents, &corners);
    mesh.colors = spread(&mesh.colors, &corners);
    mesh.node_attributes.spread(&corners);
    mesh.indices = (0..mesh.indices.len() as u32)
        .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
        .collect();
}

pub(super) fn check_length<T>(
    values: &[T],
    vertex_count: usize,
) -> std::result::Result<(), String> {
    if values.is_empty() || values.len() == vertex_count {
        Ok(())
    } else {
        Err(format!(
            "has {} elements for {vertex_count} vertices",
            values.len()
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_meshes_keep_every_attribute_per_corner() {
        let mut mesh = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::Y, Vec2::ONE],
            extra_uvs: vec![vec![Vec2::ONE, Vec2::ZERO, Vec2::X, Vec2::Y]],
            colors: vec![Vec4::X, Vec4::Y, Vec4::Z, Vec4::W],
            indices: vec![[0, 1, 2], [2, 1, 3]],
            ..Mesh::default()
        };
        make_flat(&mut mesh);
        assert_eq!(mesh.positions.len(), 6);
        assert_eq!(mesh.normals.len(), 6);
        assert_eq!(mesh.indices, vec![[0, 1, 2], [3, 4, 5]]);
        assert_eq!(mesh.colors[3], Vec4::Z);
        assert_eq!(mesh.uvs[5], Vec2::ONE);
        assert_eq!(mesh.extra_uvs[0][4], Vec2::ZERO);
        assert!(mesh.tangents.is_empty());
        assert_eq!(mesh.normals[0], Vec3::Z);
    }
}
