//! The photon renderer's subsurface term for Christensen–Burley materials (random-walk ones are
//! walked by the camera paths, `crate::integrator::random_walk`; nothing here is built for
//! them): the "diffusion photon mode", Jensen & Buhler 2002 §3 with photons as the irradiance
//! samples, Jensen 2000 "Subsurface scattering". Dedicated photon
//! tracing stores the flux entering each translucent surface (after the specular layer's Fresnel
//! transmission, times the subsurface weight), one octree of those samples per translucent
//! material, and at a shading point x the radiance T(ω_o) M(x)/π, where M is the dipole
//! exitance of `crate::subsurface` and T(ω_o) the layer's transmission out (the same factor a
//! Lambertian base gets, so a translucent surface under uniform light shows R_d E/π exactly as
//! the diffuse surface it replaces). Light diffuses only within one material's samples. M is
//! summed at the points of a lattice over each triangle (`Lattice`), once each, and
//! interpolated between them at the shading points.
//!
//! The dipole assumes a flat semi-infinite medium, so on thick-kernel materials it loses light
//! where the kernel reaches past the object's surface (measured against Cycles' random walk in
//! `docs/bench/subsurface.md`). Photons stand in for Jensen & Buhler's irradiance points:
//! points over the surface with their irradiance from the global map measured darker at the
//! object's edges (the same page).

use super::settings::{PhotonInfo, PhotonSettings};
use super::tracing::{trace_photons, trace_subsurface_photon, Emitters, Stream};
use crate::error::Result;
use crate::integrator::shading::Shading;
use crate::integrator::Context;
use crate::math::Vec3;
use crate::progress::Progress;
use crate::rng::Sampler;
use crate::scene::{Scene, SubsurfaceMethod};
use crate::subsurface::{Dipole, ExitanceCache, Sample, SampleTree};
use std::f32::consts::PI;
use std::time::Instant;

/// The kernel's smoothing radius covers this many samples' areas (`SampleTree::build`).
const SMOOTHING_SAMPLES: f32 = 16.0;
/// Spacing of the exitance lattice over each triangle, in smoothing radii.
const LATTICE_SPACING: f32 = 0.5;
/// Most lattice intervals along a triangle's edge.
const MAX_LATTICE: f32 = 1024.0;
/// Lattice points kept per material (about 48 bytes each with the map's overhead: 48 MiB at
/// most; a render needs about π/4 per sample on the surfaces it sees: 4/h² points against
/// 16/(πh²) samples per unit area).
const LATTICE_POINTS: usize = 1 << 20;
/// The third word of a cache key that names a mesh vertex (shared by the triangles around it)
/// instead of a triangle's lattice point.
const VERTEX_KEY: u32 = u32::MAX;

/// Subsurface samples per translucent material.
pub struct SubsurfaceMaps {
    /// Indexed by material; `None` for opaque materials or ones no photon reached.
    trees: Vec<Option<SampleTree>>,
    /// Indexed by material, alongside `trees`: the lattice of a material whose dipole is the
    /// same at every point that has the material's own factors.
    lattices: Vec<Option<Lattice>>,
    accuracy: f32,
    brute_force: bool,
}

/// The exitance at the points of a lattice over each triangle of one translucent material,
/// interpolated linearly between them (Jensen & Buhler evaluate M once per irradiance-sample
/// spacing of the surface too; here the points are made on the triangles the camera sees).
/// A triangle whose longest edge is e gets n = ⌈e/δ⌉ intervals along each edge, lattice points
/// at barycentric coordinates (i/n, j/n), i + j ≤ n; its corners are the mesh's vertices,
/// shared by the triangles around them. The points lie on the surface, so the interpolation only
/// smooths M along it (spacing δ = `LATTICE_SPACING` × h, under the kernel's own smoothing
/// radius h). It serves the points whose base colour, mean free path and IOR are the
/// material's own factors (no texture, vertex colour or node changed them there) on meshes that
/// do not move or deform; other points sum the octree themselves.
struct Lattice {
    reflectance: Vec3,
    mean_free_path: Vec3,
    ior: f32,
    dipole: Dipole,
    spacing: f32,
    cache: ExitanceCache,
}

impl Lattice {
    fn new(material: &crate::scene::Material, tree: &SampleTree) -> Option<Lattice> {
        let reflectance = material.base_color.truncate().clamp(Vec3::ZERO, Vec3::ONE);
        let sub = &material.subsurface;
        let h = tree.smoothing();
        (h > 0.0 && h.is_finite()).then(|| Lattice {
            reflectance,
            mean_free_path: sub.mean_free_path(),
            ior: sub.ior,
            dipole: Dipole::new(reflectance, sub.mean_free_path(), sub.ior, h),
            spacing: LATTICE_SPACING * h,
            cache: ExitanceCache::new(LATTICE_POINTS),
        })
    }

    /// True when a point of `reflectance` and subsurface `sub` has this lattice's dipole.
    fn matches(&self, reflectance: Vec3, sub: &crate::scene::Subsurface) -> bool {
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        bits(self.reflectance) == bits(reflectance)
            && bits(self.mean_free_path) == bits(sub.mean_free_path())
            && self.ior.to_bits() == sub.ior.to_bits()
    }

    /// M at `sh` interpolated over its triangle's lattice; `None` on a moving or deforming mesh.
    fn exitance(
        &self,
        scene: &Scene,
        sh: &crate::interaction::SurfaceHit,
        tree: &SampleTree,
        accuracy: f32,
    ) -> Option<Vec3> {
        let hit = &sh.hit;
        let mesh = crate::accel::hit_mesh(scene, hit);
        let instance = scene.instances.get(hit.instance as usize);
        if mesh.deformation.len() > 1 || instance.is_some_and(|i| !i.motion.is_empty()) {
            return None;
        }
        let place = |q: Vec3| instance.map_or(q, |i| i.to_world.transform_point3(q));
        let [p0, p1, p2] = mesh.triangle_at(hit.triangle, 0.0).map(place);
        let (e1, e2) = (p1 - p0, p2 - p0);
        let longest = e1.length().max(e2.length()).max((p2 - p1).length());
        let n = (longest / self.spacing).ceil().clamp(1.0, MAX_LATTICE);
        if !n.is_finite() {
            return None;
        }
        let last = n as u32;
        let (u, v) = (hit.b1.clamp(0.0, 1.0) * n, hit.b2.clamp(0.0, 1.0) * n);
        let i = (u.floor() as u32).min(last - 1);
        let j = (v.floor() as u32).min(last - 1 - i);
        let (fu, fv) = (u - i as f32, v - j as f32);
        // The cell's lower triangle (i, j), (i+1, j), (i, j+1), or its upper one.
        let corners = if fu + fv <= 1.0 || i + j + 1 == last {
            [(i, j, 1.0 - fu - fv), (i + 1, j, fu), (i, j + 1, fv)]
        } else {
            [
                (i + 1, j + 1, fu + fv - 1.0),
                (i, j + 1, 1.0 - fu),
                (i + 1, j, 1.0 - fv),
            ]
        };
        let idx = mesh.indices[hit.triangle as usize];
        let mut sum = Vec3::ZERO;
        for (ci, cj, w) in corners {
            let key = match (ci, cj) {
                (0, 0) => [hit.instance, hit.mesh, VERTEX_KEY, idx[0]],
                (i, 0) if i == last => [hit.instance, hit.mesh, VERTEX_KEY, idx[1]],
                (0, j) if j == last => [hit.instance, hit.mesh, VERTEX_KEY, idx[2]],
                _ => [hit.instance, hit.mesh, hit.triangle, ci << 16 | cj],
            };
            let m = self.cache.get_or_compute(key, || {
                let x = p0 + e1 * (ci as f32 / n) + e2 * (cj as f32 / n);
                tree.exitance(x, &self.dipole, accuracy).0
            });
            sum += w.max(0.0) * m;
        }
        Some(sum)
    }
}

/// Surface area of a mesh's triangles, its positions placed by `to_world` (scene units²).
fn mesh_area(m: &crate::scene::Mesh, to_world: crate::math::Affine3A) -> f32 {
    let p = &m.positions;
    m.indices
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| to_world.transform_point3(p[i as usize]));
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

/// Surface area of each material's meshes, instances included (scene units²).
fn material_areas(scene: &Scene) -> Vec<f32> {
    let mut area = vec![0.0f32; scene.materials.len()];
    let placed = scene
        .meshes
        .iter()
        .map(|m| (m, crate::math::Affine3A::IDENTITY));
    let instances = scene.instances.iter().filter_map(|i| {
        let m = &scene.prototypes[i.prototype as usize];
        let translucent = scene.materials[m.material as usize].is_translucent();
        translucent.then_some((m, i.to_world))
    });
    for (m, to_world) in placed.chain(instances) {
        if let Some(slot) = area.get_mut(m.material as usize) {
            *slot += mesh_area(m, to_world);
        }
    }
    area
}

/// True when some mesh (or instanced prototype) uses a translucent material the dipole renders
/// (Christensen–Burley; random-walk materials are walked by the camera paths).
pub fn has_dipole(scene: &Scene) -> bool {
    scene.meshes.iter().chain(&scene.prototypes).any(|m| {
        scene
            .materials
            .get(m.material as usize)
            .is_some_and(|mat| mat.uses_dipole())
    })
}

/// Trace the subsurface photons and build the octrees;
/// `None` (with the reason in `info`) when no material uses the dipole or no samples are
/// requested.
#[allow(clippy::too_many_arguments)]
pub fn build(
    ctx: &Context,
    emitters: &Emitters,
    settings: &PhotonSettings,
    seed: u64,
    sampler: Sampler,
    progress: &Progress,
    info: &mut PhotonInfo,
) -> Result<Option<SubsurfaceMaps>> {
    if !has_dipole(ctx.scene) {
        info.subsurface_skipped = Some("no Christensen-Burley (dipole) material".into());
        return Ok(None);
    }
    if settings.subsurface_photons == 0 {
        info.subsurface_skipped = Some("no subsurface photons requested".into());
        return Ok(None);
    }
    let start = Instant::now();
    let max = ctx.max_depth;
    let stored = info.global_stored + info.caustic_stored;
    let budget = settings.memory_budget_bytes();
    let stream = Stream::unaimed("Subsurface", 0x5ab5_0f7e, budget, stored, sampler);
    let samples = trace_photons(
        ctx,
        emitters,
        stream,
        settings.subsurface_photons,
        seed,
        progress,
        |e, rng, out| trace_subsurface_photon(ctx, e, max, rng, out),
    )?;
    info.subsurface_emitted = settings.subsurface_photons as u64;
    info.subsurface_stored = samples.len();
    let areas = material_areas(ctx.scene);
    let mut per_material: Vec<Vec<Sample>> = vec![Vec::new(); ctx.scene.materials.len()];
    for (m, s) in samples {
        if let Some(list) = per_material.get_mut(m as usize) {
            list.push(s);
        }
    }
    let trees: Vec<Option<SampleTree>> = per_material
        .into_iter()
        .zip(areas)
        .map(|(list, area)| {
            (!list.is_empty()).then(|| SampleTree::build(list, area, SMOOTHING_SAMPLES))
        })
        .collect();
    let lattices = trees
        .iter()
        .zip(&ctx.scene.materials)
        .map(|(tree, material)| tree.as_ref().and_then(|t| Lattice::new(material, t)))
        .collect();
    info.subsurface_seconds = start.elapsed().as_secs_f64();
    Ok(Some(SubsurfaceMaps {
        trees,
        lattices,
        accuracy: settings.subsurface_accuracy,
        brute_force: settings.subsurface_brute_force,
    }))
}

impl SubsurfaceMaps {
    /// The subsurface radiance leaving `s` towards its viewer, T(ω_o) M(x)/π; `None` when the
    /// surface is not translucent. `s` carries the full BSDF (the layer's transmission out);
    /// `scene` is the one `s` is on.
    pub fn radiance(&self, scene: &Scene, s: &Shading) -> Option<Vec3> {
        let sub = &s.surface.subsurface;
        if !(sub.weight > 0.0) || sub.method != SubsurfaceMethod::ChristensenBurley {
            return None;
        }
        let Some(Some(tree)) = self.trees.get(s.sh.material as usize) else {
            return Some(Vec3::ZERO);
        };
        let reflectance = s.surface.base_color.clamp(Vec3::ZERO, Vec3::ONE);
        let lattice = self
            .lattices
            .get(s.sh.material as usize)
            .and_then(Option::as_ref);
        let interpolated = lattice
            .filter(|l| !self.brute_force && l.matches(reflectance, sub))
            .and_then(|l| l.exitance(scene, &s.sh, tree, self.accuracy));
        let m = match interpolated {
            Some(m) => m,
            None => {
                let dipole =
                    Dipole::new(reflectance, sub.mean_free_path(), sub.ior, tree.smoothing());
                if self.brute_force {
                    tree.exitance_brute_force(s.sh.p, &dipole)
                } else {
                    tree.exitance(s.sh.p, &dipole, self.accuracy).0
                }
            }
        };
        let l = m * (s.bsdf.base_transmittance() / PI);
        Some(if l.is_finite() { l } else { Vec3::ZERO })
    }
}
