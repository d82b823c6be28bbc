//! True displacement, as Cycles' "Displacement Only" and "Displacement and Bump" methods move a
//! mesh when the scene is built: the material's displacement tree (`NodeProgram::
//! displacement_at`) is evaluated once at every vertex of the object's triangles that use it,
//! with the vertex's position, smooth normal, UVs, colours, attributes and object, and the
//! vertex moves by the world-space vector it gives, taken to the mesh's stored space. The
//! surface gains no vertex (flat triangles that moved get copies of their own three, as a flat
//! mesh without normals has them, bounded as those by three per triangle).
//!
//! An object's primitives (one per material) are displaced together, as Cycles displaces one
//! mesh: copies of a vertex split by the file (seams, flat faces, material borders) move as one
//! vertex, by the first triangle in order whose material displaces it. Afterwards the smooth
//! normals of the vertices of "Displacement Only" triangles are the normalised sum of the unit
//! normals of those triangles (Cycles' vertex normals of a displaced mesh); "Displacement and
//! Bump" keeps the normals, its bump bending them at shading time; flat triangles take the
//! normal of their displaced face, or, where the material says so (Blender 5's Cycles under
//! "Displacement and Bump"), are shaded smooth by their vertices' normals before the move. Generated coordinates keep reading the undisplaced vertices
//! (`Mesh::undisplaced`).

use super::{Material, Mesh, Texture, BLENDER_AXES};
use crate::math::{Affine3A, Mat3, Vec2, Vec3, Vec4};
use crate::shader::{NodeProgram, PointInputs, ShadingInputs};
use std::collections::HashMap;

/// Displace the primitives `meshes` of one object. `placed` takes their stored positions to
/// world space (glTF's axes): the identity for world-space meshes, the first instance's
/// transform for prototypes (Cycles evaluates a shared mesh with its first object).
pub fn displace_object(
    meshes: &mut [Mesh],
    placed: &Affine3A,
    materials: &[Material],
    textures: &[Texture],
) {
    let programs: Vec<Option<&NodeProgram>> = meshes
        .iter()
        .map(|mesh| {
            materials
                .get(mesh.material as usize)
                .and_then(|m| m.nodes.as_deref())
                .filter(|p| p.displaces())
        })
        .collect();
    if programs.iter().all(Option::is_none) {
        return;
    }
    let welded = Welded::new(meshes);
    let normals = welded.evaluation_normals(meshes);
    let linear = Mat3::from(placed.matrix3);
    let normal_matrix = linear.inverse().transpose();
    let to_stored = linear.inverse() * BLENDER_AXES.transpose();

    // One offset per welded vertex, from the first triangle whose material displaces it.
    let mut offsets: Vec<Option<Vec3>> = vec![None; welded.count];
    for (k, mesh) in meshes.iter().enumerate() {
        let Some(program) = programs[k] else { continue };
        for (t, tri) in mesh.indices.iter().enumerate() {
            for (corner, &v) in tri.iter().enumerate() {
                let group = welded.group[k][v as usize];
                if offsets[group].is_some() {
                    continue;
                }
                let normal = (normal_matrix * normals[group]).normalize_or_zero();
                let at = vertex_inputs(mesh, t, corner, placed, normal);
                let moved = program.displacement_at(&at, textures).unwrap_or_default();
                offsets[group] = Some(to_stored * moved);
            }
        }
    }

    // Which triangles are flat (their corners carry their face's normal), before moving.
    let flat: Vec<Vec<bool>> = meshes.iter().map(flat_triangles).collect();
    for (k, mesh) in meshes.iter_mut().enumerate() {
        let moved = |v: usize| offsets[welded.group[k][v]];
        if (0..mesh.positions.len()).all(|v| moved(v).is_none()) {
            continue;
        }
        mesh.undisplaced = mesh.positions.clone();
        for v in 0..mesh.positions.len() {
            if let Some(offset) = moved(v) {
                mesh.positions[v] += offset;
                for step in &mut mesh.deformation {
                    step[v] += offset;
                }
            }
        }
    }

    // "Displacement Only": smooth normals from the displaced faces around each vertex.
    let mut sums: Vec<Option<Vec3>> = vec![None; welded.count];
    for (k, mesh) in meshes.iter().enumerate() {
        if programs[k].is_none_or(|p| p.bumps_displaced_surface()) {
            continue;
        }
        for tri in &mesh.indices {
            let face = face_normal(mesh, tri);
            for &v in tri {
                let sum = &mut sums[welded.group[k][v as usize]];
                *sum = Some(sum.unwrap_or(Vec3::ZERO) + face);
            }
        }
    }
    for (k, mesh) in meshes.iter_mut().enumerate() {
        if mesh.normals.len() != mesh.positions.len() {
            continue;
        }
        for v in 0..mesh.positions.len() {
            if let Some(sum) = sums[welded.group[k][v]] {
                mesh.normals[v] = sum.normalize_or(mesh.normals[v]);
            }
        }
    }

    // Flat triangles that moved take their displaced face's normal, on vertices of their own;
    // where the material shades them smooth under its bump, their vertices' normals before
    // the displacement instead.
    for (k, mesh) in meshes.iter_mut().enumerate() {
        let smooth = programs[k].is_some_and(|p| p.smooths_flat_faces());
        let mut copied: Vec<u32> = Vec::new();
        let mut copied_normals: Vec<Vec3> = Vec::new();
        let first = mesh.positions.len() as u32;
        for (t, &is_flat) in flat[k].iter().enumerate() {
            let tri = mesh.indices[t];
            let groups = tri.map(|v| welded.group[k][v as usize]);
            if is_flat && groups.iter().any(|&g| offsets[g].is_some()) {
                let face = face_normal(mesh, &tri);
                let next = first + copied.len() as u32;
                mesh.indices[t] = [next, next + 1, next + 2];
                copied.extend(tri);
                copied_normals.extend(groups.map(|g| if smooth { normals[g] } else { face }));
            }
        }
        append_copies(mesh, &copied, &copied_normals);
    }
}

/// The copies of each vertex across an object's primitives: vertices at the same stored
/// position are one vertex of the Blender mesh.
struct Welded {
    /// Per primitive, per vertex: its welded vertex.
    group: Vec<Vec<usize>>,
    count: usize,
}

impl Welded {
    fn new(meshes: &[Mesh]) -> Welded {
        let mut ids: HashMap<[u32; 3], usize> = HashMap::new();
        let group = meshes
            .iter()
            .map(|mesh| {
                mesh.positions
                    .iter()
                    .map(|p| {
                        let next = ids.len();
                        *ids.entry(p.to_array().map(f32::to_bits)).or_insert(next)
                    })
                    .collect()
            })
            .collect();
        Welded {
            group,
            count: ids.len(),
        }
    }

    /// The stored-space normal each welded vertex is displaced along (Cycles' smooth vertex
    /// normal): the file's normal where all its copies agree, else the corner-angle-weighted
    /// sum of its faces' normals (Blender's vertex normal, as where faces are flat).
    fn evaluation_normals(&self, meshes: &[Mesh]) -> Vec<Vec3> {
        let mut given: Vec<Option<Vec3>> = vec![None; self.count];
        let mut agree = vec![true; self.count];
        let mut weighted = vec![Vec3::ZERO; self.count];
        for (k, mesh) in meshes.iter().enumerate() {
            for (v, &n) in mesh.normals.iter().enumerate() {
                let g = self.group[k][v];
                match given[g] {
                    None => given[g] = Some(n),
                    Some(first) => agree[g] &= first.dot(n) > 1.0 - 1e-5,
                }
            }
            for tri in &mesh.indices {
                let p = tri.map(|v| mesh.positions[v as usize]);
                let face = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
                for c in 0..3 {
                    let a = (p[(c + 1) % 3] - p[c]).normalize_or_zero();
                    let b = (p[(c + 2) % 3] - p[c]).normalize_or_zero();
                    let angle = a.dot(b).clamp(-1.0, 1.0).acos();
                    weighted[self.group[k][tri[c] as usize]] += angle * face;
                }
            }
        }
        (0..self.count)
            .map(|g| match given[g] {
                Some(n) if agree[g] => n,
                _ => weighted[g].normalize_or(Vec3::Y),
            })
            .collect()
    }
}

/// The unit normal of `tri`'s winding.
fn face_normal(mesh: &Mesh, tri: &[u32; 3]) -> Vec3 {
    let [a, b, c] = tri.map(|v| mesh.positions[v as usize]);
    (b - a).cross(c - a).normalize_or_zero()
}

/// Per triangle: whether it is shaded flat, its three corners carrying its face's normal (as
/// the file writes a flat face's). A mesh without normals is flat throughout.
fn flat_triangles(mesh: &Mesh) -> Vec<bool> {
    mesh.indices
        .iter()
        .map(|tri| {
            let face = face_normal(mesh, tri);
            mesh.normals.len() != mesh.positions.len()
                || tri
                    .iter()
                    .all(|&v| mesh.normals[v as usize].dot(face) > 1.0 - 1e-5)
        })
        .collect()
}

/// New vertices at the end of `mesh`: one copy of vertex `copied[i]` with the normal
/// `normals[i]` for each `i`, every other attribute its source's.
fn append_copies(mesh: &mut Mesh, copied: &[u32], normals: &[Vec3]) {
    if copied.is_empty() {
        return;
    }
    fn extend<T: Copy>(values: &mut Vec<T>, copied: &[u32]) {
        if !values.is_empty() {
            let copies: Vec<T> = copied.iter().map(|&v| values[v as usize]).collect();
            values.extend(copies);
        }
    }
    let count = mesh.positions.len() as u32;
    extend(&mut mesh.positions, copied);
    extend(&mut mesh.undisplaced, copied);
    mesh.normals.extend_from_slice(normals);
    extend(&mut mesh.uvs, copied);
    for set in &mut mesh.extra_uvs {
        extend(set, copied);
    }
    extend(&mut mesh.tangents, copied);
    extend(&mut mesh.colors, copied);
    for step in &mut mesh.deformation {
        extend(step, copied);
    }
    let every: Vec<u32> = (0..count).chain(copied.iter().copied()).collect();
    mesh.node_attributes.spread(&every);
}

/// What the displacement tree reads at corner `corner` of triangle `t` of `mesh` (placed by
/// `placed`): the vertex seen from its front along its smooth world normal `normal` (glTF's
/// axes), as Cycles sets up a displacement's shading point.
fn vertex_inputs(
    mesh: &Mesh,
    t: usize,
    corner: usize,
    placed: &Affine3A,
    normal: Vec3,
) -> ShadingInputs {
    let tri = mesh.indices[t];
    let v = tri[corner] as usize;
    let stored = mesh.positions[v];
    let world = placed.transform_point3(stored);
    let linear = Mat3::from(placed.matrix3);
    let mut point = PointInputs {
        position: BLENDER_AXES * world,
        color: mesh.colors.get(v).copied().unwrap_or(Vec4::ONE),
        ..PointInputs::default()
    };
    let sets = std::iter::once(&mesh.uvs).chain(&mesh.extra_uvs);
    for (out, set) in point.uv.iter_mut().zip(sets) {
        if let Some(uv) = set.get(v) {
            *out = Vec2::new(uv.x, 1.0 - uv.y);
        }
    }
    (point.object, point.generated) = match &mesh.object_space {
        Some(space) => {
            let o = space.to_object.transform_point3(stored);
            (o, space.generated(o))
        }
        None => (point.position, point.position),
    };
    if let Some(t) = mesh.tangents.get(v) {
        let sign = if t.w < 0.0 { -1.0 } else { 1.0 };
        point.tangent = (BLENDER_AXES * (linear * t.truncate())).extend(sign);
    }
    // Normals: world → stored space (the transpose of `placed`'s linear part), → object
    // space (the inverse transpose of `to_object`'s), and back by the transposes.
    let (object_normal, object_to_world_normal) = match &mesh.object_space {
        Some(space) => {
            let to_object = Mat3::from(space.to_object.matrix3);
            let stored_n = linear.transpose() * normal;
            let on = (to_object.inverse().transpose() * stored_n).normalize_or_zero();
            let to_world = BLENDER_AXES * linear.inverse().transpose() * to_object.transpose();
            (on, to_world)
        }
        None => (BLENDER_AXES * normal, Mat3::IDENTITY),
    };
    let corners = [Vec2::ZERO, Vec2::X, Vec2::Y][corner];
    let n = BLENDER_AXES * normal;
    ShadingInputs {
        points: [point; 3],
        normal: n,
        object_normal,
        incoming: n,
        object_to_world_normal,
        attributes: mesh.node_attributes.at(tri, corners.x, corners.y),
        object: mesh.object_info,
        triangle: tri.map(|i| BLENDER_AXES * placed.transform_point3(mesh.positions[i as usize])),
        ..ShadingInputs::default()
    }
}
