//! The surface hit as shading sees it, and the one routine that spawns rays off a surface.
//!
//! Ray origins are offset out of the floating-point error box of the intersection point along the
//! geometric normal, then rounded one ulp further away, following pbrt-v4 §6.8.6 ("Robust
//! Spawned Ray Origins"). The point is reconstructed from barycentrics, whose error is bounded by
//! γ₇·(|b0·p0| + |b1·p1| + |b2·p2|) (pbrt-v4 §6.8.5). There is no global epsilon: every offset
//! scales with the coordinates involved, which the reintersection test checks from 1e-4 to 1e5.

use crate::accel::{hit_mesh, hit_uv, interpolate, Hit, Ray};
use crate::math::{gamma, Affine3A, Frame, Mat3, Quat, Vec2, Vec3, Vec4};
use crate::scene::{blender_axes, Mesh, Scene, TextureRef, BLENDER_AXES};
use crate::shader::{
    PointInputs, RayPath, ShadingInputs, READS_ALL, READS_COLOR, READS_COORDS, READS_FIBRE,
    READS_OBJECT_NORMAL, READS_TANGENT, READS_TRIANGLE, READS_UV,
};

/// Everything shading needs about a surface point.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    pub p: Vec3,
    /// Conservative absolute error bound of `p` per axis.
    pub p_error: Vec3,
    /// Unit geometric normal from the triangle's winding (p1 − p0) × (p2 − p0).
    pub ng: Vec3,
    /// Shading frame: interpolated (and normal-mapped) normal, on the same side as `ng`.
    pub frame: Frame,
    pub uv: Vec2,
    pub mesh: u32,
    pub triangle: u32,
    pub material: u32,
    /// Distance along the ray that found this hit (in units of the ray's direction).
    pub t: f32,
    /// The intersection this point was reconstructed from.
    pub hit: Hit,
    /// The moment within the shutter of the ray that found it, kept by rays spawned here.
    pub time: f32,
}

impl SurfaceHit {
    /// Reconstruct the hit of `ray` on the scene: position with its error bound, normals, UV, and
    /// the shading frame (perturbed by the material's normal texture when the mesh has tangents).
    pub fn new(scene: &Scene, ray: &Ray, hit: &Hit) -> SurfaceHit {
        let mesh = hit_mesh(scene, hit);
        let instance = scene.instances.get(hit.instance as usize);
        let idx = mesh.indices[hit.triangle as usize];
        // An instance's triangle is taken to world space first (where it is at the ray's
        // moment); everything below is the same.
        let (to_world, normal_matrix) = match instance {
            Some(inst) => (inst.to_world_at(ray.time), inst.normal_matrix_at(ray.time)),
            None => (Affine3A::IDENTITY, Mat3::IDENTITY),
        };
        let place = |q: Vec3| match instance {
            Some(_) => to_world.transform_point3(q),
            None => q,
        };
        let p = mesh.triangle_at(hit.triangle, ray.time).map(place);
        // A deforming mesh's normals and tangents, stored for the frame, turn with the
        // triangle: by the rotation taking its normal at the frame to its normal now.
        let bend = if mesh.deformation.is_empty() {
            None
        } else {
            let rest = idx.map(|i| place(mesh.positions[i as usize]));
            let n0 = (rest[1] - rest[0])
                .cross(rest[2] - rest[0])
                .normalize_or_zero();
            let n1 = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            (n0 != Vec3::ZERO && n1 != Vec3::ZERO).then(|| Quat::from_rotation_arc(n0, n1))
        };
        let to_world_normal = |n: Vec3| {
            let n = match instance {
                Some(_) => normal_matrix * n,
                None => n,
            };
            bend.map_or(n, |q| q * n)
        };
        let to_world_tangent = |t: Vec4| {
            let v = match instance {
                Some(_) => to_world.transform_vector3(t.truncate()),
                None => t.truncate(),
            };
            let w = match instance {
                Some(inst) if inst.mirrored => -t.w,
                _ => t.w,
            };
            bend.map_or(v, |q| q * v).extend(w)
        };
        let (b1, b2) = (hit.b1, hit.b2);
        let b0 = 1.0 - b1 - b2;
        let pos = interpolate(p, b1, b2);
        let p_error = gamma(7) * ((b0 * p[0]).abs() + (b1 * p[1]).abs() + (b2 * p[2]).abs());
        let mut cross = (p[1] - p[0]).cross(p[2] - p[0]);
        if instance.is_some_and(|inst| inst.mirrored) {
            // A flattened mirrored copy reverses its winding to keep the geometric normal's
            // side; so does a mirrored instance.
            cross = -cross;
        }
        let len = cross.length();
        let ng = if len > 0.0 && len.is_finite() {
            cross / len
        } else {
            // Degenerate triangle: any normal facing the ray keeps shading finite.
            -ray.direction.normalize_or(Vec3::Z)
        };
        let mut n = interpolate(
            idx.map(|i| to_world_normal(mesh.normals[i as usize])),
            b1,
            b2,
        )
        .normalize_or(ng);
        if n.dot(ng) < 0.0 {
            // Shading normals are stored per vertex and can face away from the winding normal
            // (flipped meshes); shading uses the side of the geometry.
            n = -n;
        }
        let uv = hit_uv(scene, hit);
        let material = &scene.materials[mesh.material as usize];
        let frame = match (&material.normal_texture, mesh.tangents.is_empty()) {
            (Some(tex), false) => {
                let t4 = interpolate(
                    idx.map(|i| to_world_tangent(mesh.tangents[i as usize])),
                    b1,
                    b2,
                );
                let base = Frame::from_normal_tangent(n, t4.truncate());
                let bitangent_sign = if t4.w < 0.0 { -1.0 } else { 1.0 };
                let texel = scene.textures[tex.texture as usize].sample(tex.apply(uv));
                let local = Vec3::new(
                    (2.0 * texel.x - 1.0) * material.normal_scale,
                    (2.0 * texel.y - 1.0) * material.normal_scale * bitangent_sign,
                    2.0 * texel.z - 1.0,
                );
                let mapped = base.to_world(local).normalize_or(n);
                // Keep the mapped normal on the geometric side so the frame stays usable.
                let mapped = if mapped.dot(ng) <= 1e-3 { n } else { mapped };
                Frame::from_normal_tangent(mapped, t4.truncate())
            }
            _ => Frame::from_normal(n),
        };
        SurfaceHit {
            p: pos,
            p_error,
            ng,
            frame,
            uv,
            // Hits on instances name no world-space mesh (lights find them by `hit.instance`).
            mesh: if instance.is_some() {
                u32::MAX
            } else {
                hit.mesh
            },
            triangle: hit.triangle,
            material: mesh.material,
            t: hit.t,
            hit: *hit,
            time: ray.time,
        }
    }

    /// The interpolated UV-map tangent (world, unit) and bitangent sign at this point; `None`
    /// when the mesh has no tangents.
    fn tangent4(&self, scene: &Scene) -> Option<Vec4> {
        let mesh = hit_mesh(scene, &self.hit);
        if mesh.tangents.is_empty() {
            return None;
        }
        let idx = mesh.indices[self.hit.triangle as usize];
        let instance = scene.instances.get(self.hit.instance as usize);
        let t4 = interpolate(
            idx.map(|i| {
                let t = mesh.tangents[i as usize];
                match instance {
                    Some(inst) => inst
                        .to_world_at(self.time)
                        .transform_vector3(t.truncate())
                        .extend(t.w),
                    None => t,
                }
            }),
            self.hit.b1,
            self.hit.b2,
        );
        let t = t4.truncate().normalize_or_zero();
        (t != Vec3::ZERO).then(|| t.extend(t4.w))
    }

    /// The UV map's tangent at this point (world, unit); `None` without mesh tangents.
    pub fn uv_tangent(&self, scene: &Scene) -> Option<Vec3> {
        self.tangent4(scene).map(|t| t.truncate())
    }

    /// The shading normal a tangent-space normal texture gives at this point (glTF's
    /// normalTexture convention, `scale` on x and y), on the geometric side; `None` when the
    /// mesh has no tangents.
    pub fn normal_from_texture(&self, scene: &Scene, tex: &TextureRef, scale: f32) -> Option<Vec3> {
        let t4 = self.tangent4(scene)?;
        let n = self.frame.n;
        let base = Frame::from_normal_tangent(n, t4.truncate());
        let sign = if t4.w < 0.0 { -1.0 } else { 1.0 };
        let texel = scene
            .textures
            .get(tex.texture as usize)?
            .sample(tex.apply(self.uv));
        let local = Vec3::new(
            (2.0 * texel.x - 1.0) * scale,
            (2.0 * texel.y - 1.0) * scale * sign,
            2.0 * texel.z - 1.0,
        );
        let mapped = base.to_world(local).normalize_or(n);
        Some(if mapped.dot(self.ng) <= 1e-3 {
            n
        } else {
            mapped
        })
    }

    /// The direction of the fibre at this point (world, unit), from root to tip: the
    /// gradient of the first UV map's u over the triangle, which the add-on sets to the curve's
    /// parameter along each tube; without UVs (a hair BSDF on a mesh that is not a tube), the
    /// direction the triangle's three vertex normals are most nearly perpendicular to (a tube's
    /// axis, of either sense).
    pub fn fibre_tangent(&self, scene: &Scene) -> Vec3 {
        let mesh = hit_mesh(scene, &self.hit);
        let idx = mesh.indices[self.hit.triangle as usize];
        let p = mesh.triangle_at(self.hit.triangle, self.time);
        let along_u = (!mesh.uvs.is_empty()).then(|| {
            let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
            let uv = idx.map(|i| mesh.uvs[i as usize]);
            let (du1, du2) = (uv[1].x - uv[0].x, uv[2].x - uv[0].x);
            // The in-plane gradient g of u: g·e1 = du1, g·e2 = du2 (up to a positive factor).
            let (a, b, c) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
            (du1 * c - du2 * b) * e1 + (du2 * a - du1 * b) * e2
        });
        let local = along_u
            .filter(|g| g.length_squared() > 0.0 && g.is_finite())
            .unwrap_or_else(|| {
                let n = idx.map(|i| mesh.normals[i as usize]);
                [n[0].cross(n[1]), n[1].cross(n[2]), n[2].cross(n[0])]
                    .into_iter()
                    .max_by(|x, y| x.length_squared().total_cmp(&y.length_squared()))
                    .unwrap_or(Vec3::ZERO)
            });
        let world = match scene.instances.get(self.hit.instance as usize) {
            Some(inst) => inst.to_world_at(self.time).transform_vector3(local),
            None => local,
        };
        world.normalize_or(self.frame.t)
    }

    /// What a node tree reads at this point (`shader::ShadingInputs`), and with
    /// `offsets` at the points a small step along the frame's two tangents (for Bump nodes;
    /// else copies of the point).
    /// Seen from behind its winding (`view`), the surface's normal is turned to the viewer, as
    /// Cycles does.
    /// Only what `reads` (`shader::READS_*`) names of the position-dependent inputs is
    /// set (besides the position); the rest is left at its default.
    pub fn node_inputs(
        &self,
        scene: &Scene,
        offsets: bool,
        reads: u8,
        view: View,
    ) -> ShadingInputs {
        let mesh = hit_mesh(scene, &self.hit);
        let (tri, b1, b2) = (self.hit.triangle, self.hit.b1, self.hit.b2);
        let n = if view.backfacing {
            -self.frame.n
        } else {
            self.frame.n
        };
        let instance = scene.instances.get(self.hit.instance as usize);
        let placed = instance.map(|inst| Mat3::from(inst.to_world_at(self.time).matrix3));
        let mut inputs = node_inputs_reading(mesh, tri, b1, b2, self.p, n, view, placed, reads);
        if let Some(inst) = instance {
            inputs.object = inst.object_info;
        }
        if reads & READS_FIBRE != 0 {
            inputs.fibre = blender_axes(self.fibre_tangent(scene));
        }
        if reads & READS_TRIANGLE != 0 {
            let to_world = instance.map(|inst| inst.to_world_at(self.time));
            let corners = mesh.triangle_at(tri, self.time);
            inputs.triangle =
                corners.map(|q| blender_axes(to_world.map_or(q, |m| m.transform_point3(q))));
            // Cycles' camera rays carry their footprint from the camera, not the near plane.
            let from_camera = if view.path.is(RayPath::CAMERA) {
                scene.camera.near_clip_distance(-view.wo)
            } else {
                0.0
            };
            inputs.pixel_width = pixel_width(scene, view.wo, view.ray_length + from_camera);
        }
        if !offsets {
            return inputs;
        }
        let w = mesh.triangle_at(tri, self.time).map(|q| match instance {
            Some(inst) => inst.to_world_at(self.time).transform_point3(q),
            None => q,
        });
        let (e1, e2) = (w[1] - w[0], w[2] - w[0]);
        let (a, b, c) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let det = a * c - b * b;
        if !(det.abs() > 0.0 && det.is_finite()) {
            return inputs;
        }
        // A step small against the surface's features, large against float precision.
        let step = BUMP_STEP * self.p.abs().max_element().max(1.0);
        for (k, d) in [(1, step * self.frame.s), (2, step * self.frame.t)] {
            // The barycentric step whose position step is d projected on the triangle.
            let (r1, r2) = (d.dot(e1), d.dot(e2));
            let (db1, db2) = ((c * r1 - b * r2) / det, (a * r2 - b * r1) / det);
            let (nb1, nb2) = (b1 + db1, b2 + db2);
            let p = self.p + db1 * e1 + db2 * e2;
            move_point(&mut inputs.points[k], mesh, tri, nb1, nb2, p, reads);
        }
        inputs
    }

    /// A ray leaving this surface in direction `dir`.
    pub fn spawn(&self, dir: Vec3) -> Ray {
        Ray {
            origin: offset_origin(self.p, self.p_error, self.ng, dir),
            direction: dir,
            t_max: f32::INFINITY,
            time: self.time,
        }
    }

    /// A shadow ray from this surface towards a point on a light (see `spawn_to`).
    pub fn spawn_to(&self, target: &LightPoint) -> Ray {
        Ray {
            time: self.time,
            ..spawn_to(self.p, self.p_error, self.ng, target)
        }
    }
}

/// Next representable float towards +∞.
pub fn next_float_up(v: f32) -> f32 {
    if v.is_infinite() && v > 0.0 {
        return v;
    }
    let v = if v == -0.0 { 0.0 } else { v };
    let bits = v.to_bits();
    f32::from_bits(if v >= 0.0 { bits + 1 } else { bits - 1 })
}

/// Next representable float towards −∞.
pub fn next_float_down(v: f32) -> f32 {
    if v.is_infinite() && v < 0.0 {
        return v;
    }
    let v = if v == 0.0 { -0.0 } else { v };
    let bits = v.to_bits();
    f32::from_bits(if v > 0.0 { bits - 1 } else { bits + 1 })
}

/// Move `p` out of its error box along the geometric normal, to the side `dir` leaves on.
pub fn offset_origin(p: Vec3, p_error: Vec3, ng: Vec3, dir: Vec3) -> Vec3 {
    let d = ng.abs().dot(p_error);
    let mut offset = ng * d;
    if dir.dot(ng) < 0.0 {
        offset = -offset;
    }
    let mut po = p + offset;
    for i in 0..3 {
        if offset[i] > 0.0 {
            po[i] = next_float_up(po[i]);
        } else if offset[i] < 0.0 {
            po[i] = next_float_down(po[i]);
        }
    }
    po
}

/// Fraction of the distance a shadow ray covers, so it stops short of the light's surface.
pub const SHADOW_EPSILON: f32 = 1e-4;

/// A point a shadow ray aims at: on a light's surface (with its error bound and normal) or a
/// point light (zero error, zero normal).
#[derive(Clone, Copy, Debug)]
pub struct LightPoint {
    pub p: Vec3,
    pub p_error: Vec3,
    pub n: Vec3,
    /// A distant light's stand-in point (a sun, the world): the light itself is infinitely
    /// far, which media that fill all space (the world's volume) attenuate to nothing.
    pub distant: bool,
}

/// A shadow ray between a surface point and `target`, both ends pushed out of their error boxes,
/// with an unnormalised direction and t in (0, 1 − ε).
pub fn spawn_to(p: Vec3, p_error: Vec3, ng: Vec3, target: &LightPoint) -> Ray {
    let origin = offset_origin(p, p_error, ng, target.p - p);
    let end = offset_origin(target.p, target.p_error, target.n, origin - target.p);
    Ray {
        origin,
        direction: end - origin,
        t_max: 1.0 - SHADOW_EPSILON,
        time: crate::accel::FRAME_TIME,
    }
}

/// The step (relative to the coordinates' magnitude, at least 1) at which Bump nodes read
/// their Height beside the shading point.
const BUMP_STEP: f32 = 1e-4;

/// Where a shading point is seen from, for node trees.
#[derive(Clone, Copy, Debug)]
pub struct View {
    /// Unit direction towards the viewer (world).
    pub wo: Vec3,
    /// Seen from behind the triangle's winding.
    pub backfacing: bool,
    /// The ray's kind and the bounces before it (Light Path's outputs).
    pub path: RayPath,
    /// The distance the ray travelled to the point (Light Path's Ray Length).
    pub ray_length: f32,
}

impl View {
    /// Surface point `sh` seen along unit direction `wo` (towards the viewer) by a ray of
    /// `path` that travelled `ray_length`.
    pub fn new(sh: &SurfaceHit, wo: Vec3, path: RayPath, ray_length: f32) -> View {
        View {
            wo,
            backfacing: wo.dot(sh.ng) < 0.0,
            path,
            ray_length,
        }
    }
}

/// A node tree's inputs at barycentrics (b1, b2) of `triangle` of `mesh`, with world position
/// `p` and unit world normal `n` (facing the viewer), seen from `view`. `placed` is the linear
/// part of the instance's object-to-world transform at that moment when `mesh` is a prototype
/// (`None` for a world-space mesh). UVs are turned to Blender's v-up convention.
#[allow(clippy::too_many_arguments)]
pub fn node_inputs(
    mesh: &Mesh,
    triangle: u32,
    b1: f32,
    b2: f32,
    p: Vec3,
    n: Vec3,
    view: View,
    placed: Option<Mat3>,
) -> ShadingInputs {
    node_inputs_reading(mesh, triangle, b1, b2, p, n, view, placed, READS_ALL)
}

/// `node_inputs`, setting only what `reads` (`shader::READS_*`) names of the
/// position-dependent inputs besides the position.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn node_inputs_reading(
    mesh: &Mesh,
    triangle: u32,
    b1: f32,
    b2: f32,
    p: Vec3,
    n: Vec3,
    view: View,
    placed: Option<Mat3>,
    reads: u8,
) -> ShadingInputs {
    let (object_normal, object_to_world_normal) = match &mesh.object_space {
        _ if reads & READS_OBJECT_NORMAL == 0 => (Vec3::ZERO, Mat3::IDENTITY),
        Some(space) => {
            // Normals go from world to the stored positions' space (by the transpose of an
            // instance's linear part, which takes its normals out by the inverse transpose),
            // then to object space by the inverse transpose, and back by the transposes.
            let (stored_n, stored_to_world) = match placed {
                Some(m) => (m.transpose() * n, m.inverse().transpose()),
                None => (n, Mat3::IDENTITY),
            };
            let linear = Mat3::from(space.to_object.matrix3);
            let on = (linear.inverse().transpose() * stored_n).normalize_or(blender_axes(n));
            let to_world = BLENDER_AXES * stored_to_world * linear.transpose();
            (on, to_world)
        }
        None => (blender_axes(n), Mat3::IDENTITY),
    };
    let mut point = PointInputs::default();
    move_point(&mut point, mesh, triangle, b1, b2, p, reads);
    ShadingInputs {
        points: [point; 3],
        normal: blender_axes(n),
        object_normal,
        incoming: blender_axes(view.wo),
        backfacing: view.backfacing,
        path: view.path,
        ray_length: view.ray_length,
        object_to_world_normal,
        attributes: mesh
            .node_attributes
            .at(mesh.indices[triangle as usize], b1, b2),
        // An instance's own is set by `SurfaceHit::node_inputs`, with its placed triangle.
        object: mesh.object_info,
        triangle: if reads & READS_TRIANGLE != 0 {
            mesh.triangle_at(triangle, crate::accel::FRAME_TIME)
                .map(blender_axes)
        } else {
            [Vec3::ZERO; 3]
        },
        pixel_width: 0.0,
        // Set by `SurfaceHit::node_inputs`, which knows the hit.
        fibre: Vec3::ZERO,
    }
}

/// The width one camera pixel covers at a point seen along `toward_viewer` at `distance`
/// (Cycles' compact ray differential there: a perspective camera's per-pixel
/// angle at that direction times the distance, an orthographic camera's pixel size), from the
/// image height the scene gives (zero without one, and for panoramic cameras).
fn pixel_width(scene: &Scene, toward_viewer: Vec3, distance: f32) -> f32 {
    let camera = &scene.camera;
    let Some(height) = scene.render_settings.height.filter(|&h| h > 0) else {
        return 0.0;
    };
    match camera.projection {
        crate::scene::Projection::Perspective { yfov } => {
            // d(D/|D|) over one pixel's step on the plane at unit distance, averaged over the
            // image's two axes, as Cycles makes its camera rays' differentials compact.
            let step = 2.0 * (0.5 * yfov).tan() / height as f32;
            let to_camera = camera.to_world.inverse();
            let d = to_camera
                .transform_vector3(-toward_viewer)
                .normalize_or_zero();
            let cos = (-d.z).max(0.0);
            let spread = 0.5 * step * cos * ((1.0 - d.x * d.x).sqrt() + (1.0 - d.y * d.y).sqrt());
            spread * distance
        }
        crate::scene::Projection::Orthographic { ymag, .. } => 2.0 * ymag / height as f32,
        _ => 0.0,
    }
}

/// `point` moved to barycentrics (b1, b2) of `triangle` and world position `p`: the position,
/// and of the UVs, the Generated and Object coordinates, the vertex colour and the tangent
/// what `reads` (`shader::READS_*`) names (the rest is left as it was).
#[inline(always)]
fn move_point(
    point: &mut PointInputs,
    mesh: &Mesh,
    triangle: u32,
    b1: f32,
    b2: f32,
    p: Vec3,
    reads: u8,
) {
    let idx = mesh.indices[triangle as usize];
    point.position = blender_axes(p);
    if reads & READS_UV != 0 {
        for (out, set) in point
            .uv
            .iter_mut()
            .zip(std::iter::once(&mesh.uvs).chain(&mesh.extra_uvs))
        {
            if !set.is_empty() {
                let t = interpolate(idx.map(|i| set[i as usize]), b1, b2);
                *out = Vec2::new(t.x, 1.0 - t.y);
            }
        }
    }
    if reads & READS_COORDS != 0 {
        (point.object, point.generated) = match &mesh.object_space {
            Some(space) => {
                let stored = interpolate(idx.map(|i| mesh.positions[i as usize]), b1, b2);
                let o = space.to_object.transform_point3(stored);
                if mesh.undisplaced.is_empty() {
                    (o, space.generated(o))
                } else {
                    let before = interpolate(idx.map(|i| mesh.undisplaced[i as usize]), b1, b2);
                    (o, space.generated(space.to_object.transform_point3(before)))
                }
            }
            None => (blender_axes(p), blender_axes(p)),
        };
    }
    if reads & READS_TANGENT != 0 {
        point.tangent = if mesh.tangents.is_empty() {
            Vec4::ZERO
        } else {
            let t = interpolate(idx.map(|i| mesh.tangents[i as usize]), b1, b2);
            blender_axes(t.truncate()).extend(if t.w < 0.0 { -1.0 } else { 1.0 })
        };
    }
    if reads & READS_COLOR != 0 {
        point.color = if mesh.colors.is_empty() {
            Vec4::ONE
        } else {
            interpolate(idx.map(|i| mesh.colors[i as usize]), b1, b2)
        };
    }
}
