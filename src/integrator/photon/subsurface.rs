//! The photon renderer's subsurface term ("diffusion photon mode", Jensen & Buhler 2002 §3 with
//! photons as the irradiance samples, Jensen 2000 "Subsurface scattering"): a dedicated photon
//! pass stores the flux entering each translucent surface (after the specular layer's Fresnel
//! transmission, times the subsurface weight), one octree of those samples per translucent
//! material, and at a shading point x the radiance T(ω_o) M(x)/π, where M is the dipole
//! exitance of `crate::subsurface` and T(ω_o) the layer's transmission out (the same factor a
//! Lambertian base gets, so a translucent surface under uniform light shows R_d E/π exactly as
//! the diffuse surface it replaces). Light diffuses only within one material's samples.
//!
//! The dipole assumes a flat semi-infinite medium, so on thick-kernel materials it loses light
//! where the kernel reaches past the object's surface (measured against Cycles' random walk in
//! `docs/bench/measurements.md`). With `subsurface_points` > 0 the samples are instead Jensen &
//! Buhler's irradiance points, uniform by area over the translucent triangles; photons are the
//! default.

use super::estimate::PLANE_TOLERANCE;
use super::settings::{PhotonInfo, PhotonSettings};
use super::tracing::{trace_photons, trace_subsurface_photon, Emitters, Stream};
use crate::accel::{Hit, Ray};
use crate::error::Result;
use crate::integrator::shading::Shading;
use crate::integrator::Context;
use crate::math::Vec3;
use crate::photon_map::{Neighbors, PhotonMap};
use crate::progress::Progress;
use crate::rng::Rng;
use crate::sampling::{square_to_triangle, Distribution1D};
use crate::scene::Scene;
use crate::subsurface::{Dipole, Sample, SampleTree};
use rayon::prelude::*;
use std::f32::consts::PI;
use std::time::Instant;

/// The kernel's smoothing radius covers this many samples' areas (`SampleTree::build`).
const SMOOTHING_SAMPLES: f32 = 16.0;

/// Subsurface samples per translucent material.
pub struct SubsurfaceMaps {
    /// Indexed by material; `None` for opaque materials or ones no photon reached.
    trees: Vec<Option<SampleTree>>,
    accuracy: f32,
    brute_force: bool,
}

/// Surface area of each material's meshes (scene units²).
fn material_areas(scene: &Scene) -> Vec<f32> {
    let mut area = vec![0.0f32; scene.materials.len()];
    for m in &scene.meshes {
        let p = &m.positions;
        let a: f32 = m
            .indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| p[i as usize]);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum();
        if let Some(slot) = area.get_mut(m.material as usize) {
            *slot += a;
        }
    }
    area
}

/// True when some mesh uses a translucent material.
pub fn has_translucent(scene: &Scene) -> bool {
    scene.meshes.iter().any(|m| {
        scene
            .materials
            .get(m.material as usize)
            .is_some_and(|mat| mat.is_translucent())
    })
}

/// Jensen & Buhler's irradiance samples instead of photons: `count` points uniformly over the
/// translucent triangles (by area), each carrying the flux entering there,
/// ΔΦ = w·T(ω_i)·E·A/count: direct light from `light_samples` shadow rays (MIS-free light
/// sampling) plus indirect light from the global map's non-direct photons within `radius2`.
fn point_samples(
    ctx: &Context,
    global: Option<&PhotonMap>,
    settings: &PhotonSettings,
    radius2: f32,
    seed: u64,
) -> Vec<(u32, Sample)> {
    let scene = ctx.scene;
    let mut triangles = Vec::new();
    let mut areas = Vec::new();
    for (mi, m) in scene.meshes.iter().enumerate() {
        if !scene.materials[m.material as usize].is_translucent() {
            continue;
        }
        for (ti, t) in m.indices.iter().enumerate() {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            triangles.push((mi as u32, ti as u32, (b - a).cross(c - a)));
            areas.push(0.5 * (b - a).cross(c - a).length());
        }
    }
    let select = Distribution1D::new(&areas);
    let total = select.total() as f32;
    let count = settings.subsurface_points;
    let share = total / count.max(1) as f32;
    let k = settings.k_global as usize;
    (0..count)
        .into_par_iter()
        .map_init(Neighbors::default, |buf, i| {
            let mut rng = Rng::for_item(seed ^ 0x77e1_5a3d, i as u64, 0);
            let (index, _) = select.sample(rng.uniform())?;
            let (mesh, triangle, cross) = triangles[index];
            let b = square_to_triangle(rng.uniform2());
            let hit = Hit {
                t: 1.0,
                mesh,
                triangle,
                b1: b.x,
                b2: b.y,
            };
            let direction = -cross.normalize_or_zero();
            let ray = Ray {
                origin: Vec3::ZERO,
                direction,
                t_max: f32::INFINITY,
            };
            let s = Shading::new(ctx, &ray, &hit);
            let w = s.surface.subsurface.weight;
            let enter = |wi: Vec3| {
                w * s
                    .bsdf
                    .viewed_from(s.frame.to_local(wi))
                    .base_transmittance()
            };
            let mut flux = Vec3::ZERO;
            let m = settings.subsurface_light_samples.max(1);
            for _ in 0..m {
                let Some(ls) = ctx
                    .lights
                    .sample(scene, s.sh.p, rng.uniform(), rng.uniform2())
                else {
                    continue;
                };
                let cos = ls.wi.dot(s.ng);
                if cos <= 0.0 || ls.li == Vec3::ZERO {
                    continue;
                }
                if ctx.accel.unoccluded(scene, &s.sh.spawn_to(&ls.target)) {
                    flux += ls.li * (enter(ls.wi) * cos / (ls.pdf * m as f32));
                }
            }
            if let Some(map) = global {
                map.nearest(s.sh.p, k, radius2, buf);
                let r2 = buf.radius2;
                let mut sum = Vec3::ZERO;
                for nb in buf.iter() {
                    let ph = &map.photons()[nb.index as usize];
                    let off_plane = (ph.position() - s.sh.p).dot(s.ng).abs();
                    if ph.is_direct()
                        || ph.incoming().dot(s.ng) <= 0.0
                        || off_plane > PLANE_TOLERANCE * r2.sqrt()
                    {
                        continue;
                    }
                    sum += ph.power() * enter(ph.incoming());
                }
                if r2 > 0.0 {
                    flux += sum / (PI * r2);
                }
            }
            let flux = flux * share;
            let position = s.sh.p;
            (flux.is_finite()).then_some((s.sh.material, Sample { position, flux }))
        })
        .flatten()
        .collect()
}

/// Trace the subsurface photons (or compute the irradiance points) and build the octrees;
/// `None` (with the reason in `info`) when nothing is translucent or no samples are requested.
#[allow(clippy::too_many_arguments)]
pub fn build(
    ctx: &Context,
    emitters: &Emitters,
    settings: &PhotonSettings,
    global: Option<&PhotonMap>,
    global_radius2: f32,
    seed: u64,
    progress: &Progress,
    info: &mut PhotonInfo,
) -> Result<Option<SubsurfaceMaps>> {
    if !has_translucent(ctx.scene) {
        info.subsurface_skipped = Some("no translucent material".into());
        return Ok(None);
    }
    if settings.subsurface_photons == 0 && settings.subsurface_points == 0 {
        info.subsurface_skipped = Some("no subsurface photons requested".into());
        return Ok(None);
    }
    let start = Instant::now();
    let max = settings.max_photon_bounces;
    let samples = if settings.subsurface_points > 0 {
        point_samples(ctx, global, settings, global_radius2, seed)
    } else {
        trace_photons(
            ctx,
            emitters,
            Stream {
                label: "Subsurface",
                tag: 0x5ab5_0f7e,
                aimed: false,
                budget_bytes: settings.memory_budget_bytes().saturating_sub(
                    ((info.global_stored + info.caustic_stored)
                        * std::mem::size_of::<crate::photon_map::Photon>())
                        as u64,
                ),
            },
            settings.subsurface_photons,
            seed,
            progress,
            |ray, power, rng, out| trace_subsurface_photon(ctx, ray, power, max, rng, out),
        )?
    };
    if settings.subsurface_points == 0 {
        info.subsurface_emitted = settings.subsurface_photons as u64;
    }
    info.subsurface_stored = samples.len();
    let areas = material_areas(ctx.scene);
    let mut per_material: Vec<Vec<Sample>> = vec![Vec::new(); ctx.scene.materials.len()];
    for (m, s) in samples {
        if let Some(list) = per_material.get_mut(m as usize) {
            list.push(s);
        }
    }
    let trees = per_material
        .into_iter()
        .zip(areas)
        .map(|(list, area)| {
            (!list.is_empty()).then(|| SampleTree::build(list, area, SMOOTHING_SAMPLES))
        })
        .collect();
    info.subsurface_seconds = start.elapsed().as_secs_f64();
    Ok(Some(SubsurfaceMaps {
        trees,
        accuracy: settings.subsurface_accuracy,
        brute_force: settings.subsurface_brute_force,
    }))
}

impl SubsurfaceMaps {
    /// The subsurface radiance leaving `s` towards its viewer, T(ω_o) M(x)/π; `None` when the
    /// surface is not translucent. `s` carries the full BSDF (the layer's transmission out).
    pub fn radiance(&self, s: &Shading) -> Option<Vec3> {
        let sub = &s.surface.subsurface;
        if !(sub.weight > 0.0) {
            return None;
        }
        let Some(Some(tree)) = self.trees.get(s.sh.material as usize) else {
            return Some(Vec3::ZERO);
        };
        let reflectance = s.surface.base_color.clamp(Vec3::ZERO, Vec3::ONE);
        let dipole = Dipole::new(reflectance, sub.mean_free_path(), sub.ior, tree.smoothing());
        let m = if self.brute_force {
            tree.exitance_brute_force(s.sh.p, &dipole)
        } else {
            tree.exitance(s.sh.p, &dipole, self.accuracy).0
        };
        let l = m * (s.bsdf.base_transmittance() / PI);
        Some(if l.is_finite() { l } else { Vec3::ZERO })
    }
}
