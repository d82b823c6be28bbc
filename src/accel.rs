//! Ray–scene intersection: the only user of `obvhs`. One `Accel` holds a compressed wide BVH
//! (CWBVH) over every triangle of the scene, with the triangles copied in BVH leaf order, and
//! answers closest-hit and occlusion queries.
//!
//! Triangles are intersected with the watertight algorithm of Woop, Benthin and Wald (2013,
//! "Watertight Ray/Triangle Intersection"), which never lets a ray slip between two triangles
//! that share an edge and gives the barycentric coordinates directly.
//!
//! obvhs works in absolute units in two places (its node test ignores boxes left before t = 1e-4,
//! and near-zero direction components are clamped), so the BVH lives in its own space: the scene
//! centred on the origin and scaled to a diagonal of 1000. Triangle tests stay in world space.
//!
//! Masked and blended materials (glTF alphaMode) are decided during traversal: a triangle whose
//! material needs an alpha test is accepted only where its texture's alpha says so.
//!
//! Instances (`Scene::instances` of `Scene::prototypes`) form a second level: one BVH per
//! prototype over its object-space triangles, and one over the instances' world bounds. A ray
//! reaching an instance's box is carried into the prototype's space (same parameter t, the
//! direction left unnormalised) and tested there, so a mesh is stored and built once however
//! many times it is placed. A prototype's material may need the alpha test, and an instance's
//! object may be hidden from camera or shadow rays: both are decided per triangle as for
//! world-space meshes. A deforming prototype (`Mesh::deformation`, Cycles' deformation blur)
//! bounds each triangle over all its steps and is tested with the triangle interpolated at the
//! ray's moment.

use crate::math::{gamma, Vec2, Vec3, Vec3A, Vec3Swizzles};
use crate::rng::hash_combine;
use crate::scene::{AlphaMode, Scene};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray as BvhRay, RayHit};
use obvhs::{Boundable, BvhBuildParams};
use std::time::Duration;

/// A ray with its valid parameter interval.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Vec3,
    /// Not necessarily unit length; `t` is measured in units of `direction`.
    pub direction: Vec3,
    pub t_max: f32,
    /// The moment within the shutter, in [0, 1], at which moving instances are met
    /// (`Instance::motion`); rays spawned from a surface keep their path's moment.
    pub time: f32,
}

/// `Ray::time` of rays in a scene without motion (and of its camera's still pose).
pub const FRAME_TIME: f32 = 0.5;

/// Which query a ray serves: camera rays skip geometry hidden from the camera, shadow rays
/// (`Accel::unoccluded`) geometry that casts no shadows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Visibility {
    Camera,
    Secondary,
    Shadow,
}

/// `Hit::instance` of a hit on a world-space mesh.
pub const NO_INSTANCE: u32 = u32::MAX;

/// The closest intersection found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Index into `Scene::meshes`, or into `Scene::prototypes` when `instance` is set.
    pub mesh: u32,
    pub triangle: u32,
    /// Index into `Scene::instances`, or `NO_INSTANCE`.
    pub instance: u32,
    /// Barycentric coordinates of vertices 1 and 2; vertex 0 has 1 − b1 − b2.
    pub b1: f32,
    pub b2: f32,
}

const FLAG_ALPHA_TEST: u8 = 1;
const FLAG_CAMERA_HIDDEN: u8 = 2;
const FLAG_SHADOW_HIDDEN: u8 = 4;

/// The acceleration structure over all scene triangles.
pub struct Accel {
    bvh: Option<CwBvh>,
    /// BVH space = (world − `center`) × `scale`.
    center: Vec3,
    scale: f32,
    /// Triangle vertices in BVH primitive order.
    vertices: Vec<[Vec3A; 3]>,
    /// (mesh, triangle) for each BVH primitive slot.
    ids: Vec<(u32, u32)>,
    flags: Vec<u8>,
    instanced: Option<Instanced>,
}

/// The instances' level: a BVH over their world bounds (in the `Accel`'s BVH space) and one
/// per prototype.
struct Instanced {
    top: CwBvh,
    /// Instance index per slot of `top`.
    slots: Vec<u32>,
    /// Per prototype; `None` for one without triangles.
    prototypes: Vec<Option<Prototype>>,
}

/// One prototype's BVH, in its own BVH space ((object − `center`) × `scale`).
struct Prototype {
    bvh: CwBvh,
    center: Vec3,
    scale: f32,
    /// Object-space triangle vertices in BVH primitive order.
    vertices: Vec<[Vec3A; 3]>,
    /// A deforming mesh's (`Mesh::deformation`) triangle vertices at each step, in BVH
    /// primitive order; its BVH bounds each triangle at every step. Empty: still.
    steps: Vec<Vec<[Vec3A; 3]>>,
    /// Triangle index per slot.
    triangles: Vec<u32>,
    /// Its material needs the alpha test (`FLAG_ALPHA_TEST` or 0).
    flag: u8,
}

impl Prototype {
    fn new(scene: &Scene, mesh: &crate::scene::Mesh) -> Option<Prototype> {
        let tris: Vec<[Vec3A; 3]> = mesh
            .indices
            .iter()
            .map(|idx| idx.map(|i| Vec3A::from(mesh.positions[i as usize])))
            .collect();
        let bounds = mesh.bounds();
        if tris.is_empty() || bounds.is_empty() {
            return None;
        }
        let (center, scale) = bvh_space(bounds);
        let steps: Vec<Vec<[Vec3A; 3]>> = mesh
            .deformation
            .iter()
            .map(|step| {
                mesh.indices
                    .iter()
                    .map(|idx| idx.map(|i| Vec3A::from(step[i as usize])))
                    .collect()
            })
            .collect();
        let boxes: Vec<BvhTriangle> = tris
            .iter()
            .enumerate()
            .map(|(t, v)| {
                let mut b = BvhTriangle::new(v, center.into(), scale);
                for step in &steps {
                    b.0 =
                        b.0.union(&BvhTriangle::new(&step[t], center.into(), scale).0);
                }
                b
            })
            .collect();
        let bvh = build(&boxes);
        let order = &bvh.primitive_indices;
        Some(Prototype {
            center,
            scale,
            steps: steps
                .iter()
                .map(|step| order.iter().map(|&i| step[i as usize]).collect())
                .collect(),
            vertices: order.iter().map(|&i| tris[i as usize]).collect(),
            triangles: order.to_vec(),
            flag: alpha_flag(&scene.materials[mesh.material as usize]),
            bvh,
        })
    }

    /// The vertices of the triangle in BVH slot `slot` at `time` (linearly between the two
    /// nearest deformation steps, as `Mesh::triangle_at`).
    #[inline]
    fn triangle(&self, slot: usize, time: f32) -> [Vec3A; 3] {
        let last = self.steps.len().saturating_sub(1);
        if last == 0 {
            return self.vertices[slot];
        }
        let x = time.clamp(0.0, 1.0) * last as f32;
        let k = (x.floor() as usize).min(last - 1);
        let f = x - k as f32;
        let (a, b) = (&self.steps[k][slot], &self.steps[k + 1][slot]);
        [0, 1, 2].map(|i| a[i].lerp(b[i], f))
    }

    /// The closest triangle along the object-space ray (`origin`, `dir`) at moment `time` with
    /// 0 < t < `t_max` that `accepts` (triangle, b1, b2): (t, triangle, b1, b2). With `any`,
    /// the first one found.
    #[allow(clippy::too_many_arguments)]
    fn intersect(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
        time: f32,
        any: bool,
        mut accepts: impl FnMut(u32, f32, f32) -> bool,
    ) -> Option<(f32, u32, f32, f32)> {
        let length = dir.length();
        if !(length > 0.0 && length.is_finite() && origin.is_finite()) {
            return None;
        }
        let sheared = ShearedRay::new(origin, dir);
        let k = length * self.scale;
        let bvh_ray = BvhRay::new(
            ((origin - self.center) * self.scale).into(),
            (dir / length + Vec3::ZERO).into(),
            0.0,
            t_max * k,
        );
        let mut best: Option<(f32, u32, f32, f32)> = None;
        if any {
            self.bvh.ray_traverse_miss(bvh_ray, |_, slot| {
                match sheared.intersect(&self.triangle(slot, time), 0.0, t_max) {
                    Some((t, b1, b2)) if accepts(self.triangles[slot], b1, b2) => {
                        best = Some((t, self.triangles[slot], b1, b2));
                        t * k
                    }
                    _ => f32::INFINITY,
                }
            });
        } else {
            let mut hit = RayHit::none();
            self.bvh.ray_traverse(bvh_ray, &mut hit, |r, slot| {
                let limit = best.map_or(t_max, |b| b.0).min(r.tmax / k);
                match sheared.intersect(&self.triangle(slot, time), 0.0, limit) {
                    Some((t, b1, b2)) if accepts(self.triangles[slot], b1, b2) => {
                        best = Some((t, self.triangles[slot], b1, b2));
                        t * k
                    }
                    _ => f32::INFINITY,
                }
            });
        }
        best
    }
}

/// The BVH space of `bounds`: its centre, and the scale that gives it a diagonal of
/// `BVH_SPACE_SIZE`.
fn bvh_space(bounds: crate::scene::Bounds) -> (Vec3, f32) {
    let diagonal = bounds.diagonal();
    let scale = if diagonal > 0.0 && diagonal.is_finite() {
        BVH_SPACE_SIZE / diagonal
    } else {
        1.0
    };
    (bounds.center(), scale)
}

/// A CWBVH over `boxes`, with less search effort for large inputs (start-up time).
fn build<T: Boundable>(boxes: &[T]) -> CwBvh {
    let mut build_time = Duration::ZERO;
    obvhs::cwbvh::builder::build_cwbvh(
        boxes,
        // Large scenes build faster with a lower search effort, with no measurable change in
        // traversal speed (docs/bench/build_and_cpu.md, "The BVH's build effort").
        if boxes.len() > LARGE_SCENE_TRIANGLES {
            BvhBuildParams::fast_build()
        } else {
            BvhBuildParams::medium_build()
        },
        &mut build_time,
    )
}

/// Per-ray constants of the watertight test: the axis permutation and the shear.
struct ShearedRay {
    origin: Vec3A,
    /// Which axis becomes z (the direction's largest component) and whether x and y swap to
    /// keep the winding; applied by `permute`.
    axes: Axes,
    /// The shear (sx, sy, sz): x' = x − sx·z, y' = y − sy·z, z' = sz·z.
    shear: Vec3A,
}

/// The six axis permutations of the watertight test, as swizzles (no per-vertex indexing).
#[derive(Clone, Copy)]
enum Axes {
    Yzx,
    Zyx,
    Zxy,
    Xzy,
    Xyz,
    Yxz,
}

impl ShearedRay {
    fn new(origin: Vec3, dir: Vec3) -> Self {
        let a = dir.abs();
        let kz = if a.x > a.y {
            if a.x > a.z {
                0
            } else {
                2
            }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let swap = dir[kz] < 0.0;
        let axes = match (kz, swap) {
            (0, false) => Axes::Yzx,
            (0, true) => Axes::Zyx,
            (1, false) => Axes::Zxy,
            (1, true) => Axes::Xzy,
            (_, false) => Axes::Xyz,
            (_, true) => Axes::Yxz,
        };
        let d = permute(axes, dir.into());
        ShearedRay {
            origin: origin.into(),
            axes,
            shear: Vec3A::new(d.x / d.z, d.y / d.z, 1.0 / d.z),
        }
    }

    /// Returns (t, b1, b2) when the ray crosses the triangle with t in (t_min, t_max).
    fn intersect(&self, v: &[Vec3A; 3], t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
        let a = permute(self.axes, v[0] - self.origin);
        let b = permute(self.axes, v[1] - self.origin);
        let c = permute(self.axes, v[2] - self.origin);
        let (sx, sy) = (self.shear.x, self.shear.y);
        let ax = a.x - sx * a.z;
        let ay = a.y - sy * a.z;
        let bx = b.x - sx * b.z;
        let by = b.y - sy * b.z;
        let cx = c.x - sx * c.z;
        let cy = c.y - sy * c.z;
        let mut u = cx * by - cy * bx;
        let mut vv = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        // On an edge in single precision: decide in double precision so neighbours agree.
        if u == 0.0 || vv == 0.0 || w == 0.0 {
            u = (cx as f64 * by as f64 - cy as f64 * bx as f64) as f32;
            vv = (ax as f64 * cy as f64 - ay as f64 * cx as f64) as f32;
            w = (bx as f64 * ay as f64 - by as f64 * ax as f64) as f32;
        }
        if (u < 0.0 || vv < 0.0 || w < 0.0) && (u > 0.0 || vv > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + vv + w;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let az = self.shear.z * a.z;
        let bz = self.shear.z * b.z;
        let cz = self.shear.z * c.z;
        let t_scaled = u * az + vv * bz + w * cz;
        let inv_det = 1.0 / det;
        let t = t_scaled * inv_det;
        if !(t > t_min && t < t_max) {
            return None;
        }
        // Reject t within its own rounding error of zero (pbrt-v4 §6.8.7): a ray that starts on
        // the surface — possible when the origin's error bound along the normal is zero, e.g. a
        // floor at exactly y = 0 — must not find that surface again at t ≈ 1e-9.
        let max_x = ax.abs().max(bx.abs()).max(cx.abs());
        let max_y = ay.abs().max(by.abs()).max(cy.abs());
        let max_z = az.abs().max(bz.abs()).max(cz.abs());
        // The shear x' = x − sx·z rounds in units of the unscaled z (|sx| ≤ 1). pbrt uses the
        // z already divided by the direction's length, which is dimensionless for the
        // unnormalised directions of shadow rays and loosens the bound at small scene scales.
        let max_z_raw = a.z.abs().max(b.z.abs()).max(c.z.abs());
        let delta_x = gamma(5) * (max_x + max_z_raw);
        let delta_y = gamma(5) * (max_y + max_z_raw);
        let delta_z = gamma(3) * max_z;
        let delta_e = 2.0 * (gamma(2) * max_x * max_y + delta_y * max_x + delta_x * max_y);
        let max_e = u.abs().max(vv.abs()).max(w.abs());
        let delta_t =
            3.0 * (gamma(3) * max_e * max_z + delta_e * max_z + delta_z * max_e) * inv_det.abs();
        if t <= delta_t {
            return None;
        }
        Some((t, vv * inv_det, w * inv_det))
    }
}

/// `v` with its axes reordered so that the ray's dominant axis is z.
#[inline(always)]
fn permute(axes: Axes, v: Vec3A) -> Vec3A {
    match axes {
        Axes::Yzx => v.yzx(),
        Axes::Zyx => v.zyx(),
        Axes::Zxy => v.zxy(),
        Axes::Xzy => v.xzy(),
        Axes::Xyz => v,
        Axes::Yxz => v.yxz(),
    }
}

/// Above this many triangles the BVH is built with less search effort (start-up time).
const LARGE_SCENE_TRIANGLES: usize = 1 << 18;

/// Diagonal of the scene in BVH space.
const BVH_SPACE_SIZE: f32 = 1000.0;

/// A triangle's bounds in BVH space, padded to cover the rounding of the change of space (and so
/// that no box is flat). The exact triangle test decides hits; padding costs a few box tests.
struct BvhTriangle(Aabb);

impl BvhTriangle {
    fn new(v: &[Vec3A; 3], center: Vec3A, scale: f32) -> Self {
        let world_max = v[0].abs().max(v[1].abs()).max(v[2].abs());
        let t = v.map(|p| (p - center) * scale);
        let min = t[0].min(t[1]).min(t[2]);
        let max = t[0].max(t[1]).max(t[2]);
        let magnitude = world_max * scale + min.abs().max(max.abs());
        let pad = (magnitude * 1e-6).max(Vec3A::splat(1e-20));
        BvhTriangle(Aabb::new(min - pad, max + pad))
    }
}

impl Boundable for BvhTriangle {
    fn aabb(&self) -> Aabb {
        self.0
    }
}

impl Accel {
    /// Build the BVH over every triangle of `scene`.
    pub fn new(scene: &Scene) -> Self {
        let mut tris = Vec::with_capacity(scene.triangle_count());
        let mut ids = Vec::with_capacity(scene.triangle_count());
        let mut flags = Vec::with_capacity(scene.triangle_count());
        for (mi, mesh) in scene.meshes.iter().enumerate() {
            let mut flag = alpha_flag(&scene.materials[mesh.material as usize]);
            if !mesh.camera_visible {
                flag |= FLAG_CAMERA_HIDDEN;
            }
            if !mesh.casts_shadows {
                flag |= FLAG_SHADOW_HIDDEN;
            }
            for (ti, idx) in mesh.indices.iter().enumerate() {
                let p = |k: usize| Vec3A::from(mesh.positions[idx[k] as usize]);
                tris.push([p(0), p(1), p(2)]);
                ids.push((mi as u32, ti as u32));
                flags.push(flag);
            }
        }
        let bounds = scene.bounds();
        if bounds.is_empty() {
            return Accel {
                bvh: None,
                center: Vec3::ZERO,
                scale: 1.0,
                vertices: Vec::new(),
                ids: Vec::new(),
                flags: Vec::new(),
                instanced: None,
            };
        }
        let (center, scale) = bvh_space(bounds);
        let instanced = Instanced::new(scene, center, scale);
        if tris.is_empty() {
            return Accel {
                bvh: None,
                center,
                scale,
                vertices: Vec::new(),
                ids: Vec::new(),
                flags: Vec::new(),
                instanced,
            };
        }
        let boxes: Vec<BvhTriangle> = tris
            .iter()
            .map(|v| BvhTriangle::new(v, center.into(), scale))
            .collect();
        let bvh = build(&boxes);
        let order = &bvh.primitive_indices;
        let vertices = order.iter().map(|&i| tris[i as usize]).collect();
        let ids = order.iter().map(|&i| ids[i as usize]).collect();
        let flags = order.iter().map(|&i| flags[i as usize]).collect();
        Accel {
            bvh: Some(bvh),
            center,
            scale,
            vertices,
            ids,
            flags,
            instanced,
        }
    }

    /// Whether a ray may stop at this triangle at (b1, b2): visibility and alpha.
    fn accepts(
        &self,
        scene: &Scene,
        slot: usize,
        b1: f32,
        b2: f32,
        ray: &Ray,
        visibility: Visibility,
    ) -> bool {
        let flag = self.flags[slot];
        if flag == 0 {
            return true;
        }
        let (mi, ti) = self.ids[slot];
        accepts(
            scene,
            &scene.meshes[mi as usize],
            flag,
            (ti, b1, b2),
            (ray.origin, ray.direction),
            mi as u64 | ((ti as u64) << 32),
            visibility,
        )
    }

    /// The ray in BVH space with a unit direction, and the factor k with t_bvh = k · t_world.
    /// obvhs culls boxes before t = 1e-4 in its own units, so its rays must have unit length in a
    /// space of known size: otherwise a shadow ray with a long direction skips nearby occluders.
    fn bvh_ray(&self, ray: &Ray) -> Option<(BvhRay, f32)> {
        let length = ray.direction.length();
        if !(length > 0.0 && length.is_finite() && ray.origin.is_finite()) {
            return None;
        }
        // obvhs takes a component's sign from a comparison but its reciprocal from `signum`, which
        // disagree for −0.0: an axis-aligned ray such as −Y = (−0, −1, −0) then misses everything.
        // Adding +0.0 turns −0.0 into +0.0 and leaves every other value unchanged.
        let direction = ray.direction / length + Vec3::ZERO;
        let origin = (ray.origin - self.center) * self.scale;
        let k = length * self.scale;
        Some((
            BvhRay::new(origin.into(), direction.into(), 0.0, ray.t_max * k),
            k,
        ))
    }

    /// The closest surface along `ray` with 0 < t < `ray.t_max`.
    pub fn intersect(&self, scene: &Scene, ray: &Ray, visibility: Visibility) -> Option<Hit> {
        let (bvh_ray, k) = self.bvh_ray(ray)?;
        let mut found: Option<Hit> = None;
        if let Some(bvh) = self.bvh.as_ref() {
            let sheared = ShearedRay::new(ray.origin, ray.direction);
            let mut best: Option<(usize, f32, f32, f32)> = None;
            let mut hit = RayHit::none();
            bvh.ray_traverse(bvh_ray, &mut hit, |r, slot| {
                let t_max = best.map_or(ray.t_max, |b| b.1).min(r.tmax / k);
                match sheared.intersect(&self.vertices[slot], 0.0, t_max) {
                    Some((t, b1, b2)) if self.accepts(scene, slot, b1, b2, ray, visibility) => {
                        best = Some((slot, t, b1, b2));
                        t * k
                    }
                    _ => f32::INFINITY,
                }
            });
            if let Some((slot, t, b1, b2)) = best {
                let (mesh, triangle) = self.ids[slot];
                found = Some(Hit {
                    t,
                    mesh,
                    triangle,
                    instance: NO_INSTANCE,
                    b1,
                    b2,
                });
            }
        }
        if let Some(instanced) = &self.instanced {
            let limit = found.map_or(ray.t_max, |h| h.t);
            let mut top_ray = bvh_ray;
            top_ray.tmax = limit * k;
            let mut hit = RayHit::none();
            instanced.top.ray_traverse(top_ray, &mut hit, |r, slot| {
                let index = instanced.slots[slot];
                let t_max = found.map_or(limit, |h| h.t).min(r.tmax / k);
                let instance = &scene.instances[index as usize];
                match instanced.intersect(scene, index, ray, t_max, false, visibility) {
                    Some((t, triangle, b1, b2)) => {
                        found = Some(Hit {
                            t,
                            mesh: instance.prototype,
                            triangle,
                            instance: index,
                            b1,
                            b2,
                        });
                        t * k
                    }
                    None => f32::INFINITY,
                }
            });
        }
        found
    }

    /// True when nothing blocks `ray` on 0 < t < `ray.t_max`.
    pub fn unoccluded(&self, scene: &Scene, ray: &Ray) -> bool {
        let Some((bvh_ray, k)) = self.bvh_ray(ray) else {
            return true;
        };
        if let Some(bvh) = self.bvh.as_ref() {
            let sheared = ShearedRay::new(ray.origin, ray.direction);
            let clear = bvh.ray_traverse_miss(bvh_ray, |_, slot| {
                match sheared.intersect(&self.vertices[slot], 0.0, ray.t_max) {
                    Some((t, b1, b2))
                        if self.accepts(scene, slot, b1, b2, ray, Visibility::Shadow) =>
                    {
                        t * k
                    }
                    _ => f32::INFINITY,
                }
            });
            if !clear {
                return false;
            }
        }
        let Some(instanced) = &self.instanced else {
            return true;
        };
        instanced.top.ray_traverse_miss(bvh_ray, |_, slot| {
            let index = instanced.slots[slot];
            match instanced.intersect(scene, index, ray, ray.t_max, true, Visibility::Shadow) {
                Some((t, ..)) => t * k,
                None => f32::INFINITY,
            }
        })
    }

    /// Number of triangles in the structure.
    pub fn triangle_count(&self) -> usize {
        self.ids.len()
    }
}

impl Instanced {
    /// `ray` (world space) against instance `index`'s prototype where the instance is at the
    /// ray's moment, up to `t_max`: (t, triangle, b1, b2) as `Prototype::intersect`, with the
    /// alpha test and the instance's ray visibility for `visibility`.
    fn intersect(
        &self,
        scene: &Scene,
        index: u32,
        ray: &Ray,
        t_max: f32,
        any: bool,
        visibility: Visibility,
    ) -> Option<(f32, u32, f32, f32)> {
        let instance = &scene.instances[index as usize];
        let prototype = self.prototypes[instance.prototype as usize].as_ref()?;
        let to_object = instance.to_object_at(ray.time);
        let origin = to_object.transform_point3(ray.origin);
        let dir = to_object.transform_vector3(ray.direction);
        let flag = instance_flag(prototype, instance);
        let mesh = &scene.prototypes[instance.prototype as usize];
        let accept = |ti: u32, b1, b2| {
            flag == 0
                || accepts(
                    scene,
                    mesh,
                    flag,
                    (ti, b1, b2),
                    (origin, dir),
                    index as u64 | ((ti as u64) << 32),
                    visibility,
                )
        };
        prototype.intersect(origin, dir, t_max, ray.time, any, accept)
    }

    fn new(scene: &Scene, center: Vec3, scale: f32) -> Option<Instanced> {
        if scene.instances.is_empty() {
            return None;
        }
        let prototypes: Vec<Option<Prototype>> = scene
            .prototypes
            .iter()
            .map(|m| Prototype::new(scene, m))
            .collect();
        let local: Vec<crate::scene::Bounds> =
            scene.prototypes.iter().map(|m| m.bounds()).collect();
        let mut boxes = Vec::with_capacity(scene.instances.len());
        let mut slots = Vec::with_capacity(scene.instances.len());
        for (i, instance) in scene.instances.iter().enumerate() {
            let b = crate::scene::instance_bounds(instance, local[instance.prototype as usize]);
            if b.is_empty() || prototypes[instance.prototype as usize].is_none() {
                continue;
            }
            let lo = (b.min - center) * scale;
            let hi = (b.max - center) * scale;
            let magnitude = b.min.abs().max(b.max.abs()) * scale + lo.abs().max(hi.abs());
            let pad = (magnitude * 1e-6).max(Vec3::splat(1e-20));
            boxes.push(BvhBox(Aabb::new((lo - pad).into(), (hi + pad).into())));
            slots.push(i as u32);
        }
        if boxes.is_empty() {
            return None;
        }
        let top = build(&boxes);
        let slots = top
            .primitive_indices
            .iter()
            .map(|&i| slots[i as usize])
            .collect();
        Some(Instanced {
            top,
            slots,
            prototypes,
        })
    }
}

/// An instance's world bounds in BVH space.
struct BvhBox(Aabb);

impl Boundable for BvhBox {
    fn aabb(&self) -> Aabb {
        self.0
    }
}

/// The flags of `prototype`'s triangles as placed by `instance`: its material's alpha test
/// and the placing object's ray visibility.
fn instance_flag(prototype: &Prototype, instance: &crate::scene::Instance) -> u8 {
    let mut flag = prototype.flag;
    if !instance.camera_visible {
        flag |= FLAG_CAMERA_HIDDEN;
    }
    if !instance.casts_shadows {
        flag |= FLAG_SHADOW_HIDDEN;
    }
    flag
}

/// `FLAG_ALPHA_TEST` when `material`'s alpha can hide parts of its surface, else 0.
fn alpha_flag(material: &crate::scene::Material) -> u8 {
    if material.alpha_mode != AlphaMode::Opaque
        && (material.base_color.w < 1.0 || material.base_color_texture.is_some())
    {
        FLAG_ALPHA_TEST
    } else {
        0
    }
}

/// Whether a ray (`line`: origin and direction, in the mesh's space) for `visibility` may stop
/// on `mesh` (whose flags are `flag`) at `at` = (triangle, b1, b2): the visibility flags, then
/// the material's alpha. `id` names the triangle for the stochastic transparency of blended
/// materials, so the decision is deterministic and the same for a shadow ray and a closest-hit
/// ray along the same line.
fn accepts(
    scene: &Scene,
    mesh: &crate::scene::Mesh,
    flag: u8,
    at: (u32, f32, f32),
    line: (Vec3, Vec3),
    id: u64,
    visibility: Visibility,
) -> bool {
    if flag & FLAG_CAMERA_HIDDEN != 0 && visibility == Visibility::Camera {
        return false;
    }
    if flag & FLAG_SHADOW_HIDDEN != 0 && visibility == Visibility::Shadow {
        return false;
    }
    if flag & FLAG_ALPHA_TEST == 0 {
        return true;
    }
    let (ti, b1, b2) = at;
    let material = &scene.materials[mesh.material as usize];
    let mut alpha = material.base_color.w;
    if let (Some(tex), false) = (&material.base_color_texture, mesh.uvs.is_empty()) {
        let idx = mesh.indices[ti as usize];
        let uv = mesh.uvs[idx[0] as usize] * (1.0 - b1 - b2)
            + mesh.uvs[idx[1] as usize] * b1
            + mesh.uvs[idx[2] as usize] * b2;
        alpha *= scene.textures[tex.texture as usize].sample(tex.apply(uv)).w;
    }
    match material.alpha_mode {
        AlphaMode::Opaque => true,
        AlphaMode::Mask { cutoff } => alpha >= cutoff,
        AlphaMode::Blend => {
            let (origin, direction) = line;
            let h = hash_combine(&[
                origin.x.to_bits() as u64 | ((origin.y.to_bits() as u64) << 32),
                origin.z.to_bits() as u64 | ((direction.x.to_bits() as u64) << 32),
                direction.y.to_bits() as u64 | ((direction.z.to_bits() as u64) << 32),
                id,
            ]);
            ((h >> 40) as f32 * (1.0 / 16_777_216.0)) < alpha
        }
    }
}

/// Barycentric interpolation helper: value at (b1, b2) from the three vertex values.
pub fn interpolate<T>(v: [T; 3], b1: f32, b2: f32) -> T
where
    T: std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>,
{
    let [a, b, c] = v;
    a * (1.0 - b1 - b2) + b * b1 + c * b2
}

/// UV at a hit, or zero when the mesh has none.
pub fn hit_uv(scene: &Scene, hit: &Hit) -> Vec2 {
    let mesh = hit_mesh(scene, hit);
    if mesh.uvs.is_empty() {
        return Vec2::ZERO;
    }
    let idx = mesh.indices[hit.triangle as usize];
    interpolate(idx.map(|i| mesh.uvs[i as usize]), hit.b1, hit.b2)
}

/// Whether the object `hit` belongs to is a holdout (`Mesh::holdout`, `Instance::holdout`).
pub fn hit_holdout(scene: &Scene, hit: &Hit) -> bool {
    if hit.instance == NO_INSTANCE {
        scene.meshes[hit.mesh as usize].holdout
    } else {
        scene.instances[hit.instance as usize].holdout
    }
}

/// The mesh a hit is on: a world-space mesh, or the prototype of the instance hit.
pub fn hit_mesh<'a>(scene: &'a Scene, hit: &Hit) -> &'a crate::scene::Mesh {
    if hit.instance == NO_INSTANCE {
        &scene.meshes[hit.mesh as usize]
    } else {
        &scene.prototypes[hit.mesh as usize]
    }
}
