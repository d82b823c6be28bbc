//! The photon renderer's subsurface term ("diffusion photon mode", Jensen & Buhler 2002 §3 with
//! photons as the irradiance samples, Jensen 2000 "Subsurface scattering"): dedicated photon
//! tracing stores the flux entering each translucent surface (after the specular layer's Fresnel
//! transmission, times the subsurface weight), one octree of those samples per translucent
//! material, and at a shading point x the radiance T(ω_o) M(x)/π, where M is the dipole
//! exitance of `crate::subsurface` and T(ω_o) the layer's transmission out (the same factor a
//! Lambertian base gets, so a translucent surface under uniform light shows R_d E/π exactly as
//! the diffuse surface it replaces). Light diffuses only within one material's samples.
//!
//! The dipole assumes a flat semi-infinite medium, so on thick-kernel materials it loses light
//! where the kernel reaches past the object's surface (measured against Cycles' random walk in
//! `docs/bench/measurements.md`). Photons stand in for Jensen & Buhler's irradiance points:
//! points over the surface with their irradiance from the global map measured darker at the
//! object's edges (the same file).

use super::settings::{PhotonInfo, PhotonSettings};
use super::tracing::{trace_photons, trace_subsurface_photon, Emitters, Stream};
use crate::error::Result;
use crate::integrator::shading::Shading;
use crate::integrator::Context;
use crate::math::Vec3;
use crate::photon_map::Photon;
use crate::progress::Progress;
use crate::scene::Scene;
use crate::subsurface::{Dipole, Sample, SampleTree};
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

/// True when some mesh (or instanced prototype) uses a translucent material.
pub fn has_translucent(scene: &Scene) -> bool {
    scene.meshes.iter().chain(&scene.prototypes).any(|m| {
        scene
            .materials
            .get(m.material as usize)
            .is_some_and(|mat| mat.is_translucent())
    })
}

/// Trace the subsurface photons and build the octrees;
/// `None` (with the reason in `info`) when nothing is translucent or no samples are requested.
#[allow(clippy::too_many_arguments)]
pub fn build(
    ctx: &Context,
    emitters: &Emitters,
    settings: &PhotonSettings,
    seed: u64,
    progress: &Progress,
    info: &mut PhotonInfo,
) -> Result<Option<SubsurfaceMaps>> {
    if !has_translucent(ctx.scene) {
        info.subsurface_skipped = Some("no translucent material".into());
        return Ok(None);
    }
    if settings.subsurface_photons == 0 {
        info.subsurface_skipped = Some("no subsurface photons requested".into());
        return Ok(None);
    }
    let start = Instant::now();
    let max = ctx.max_depth;
    let stored = info.global_stored + info.caustic_stored;
    let stream = Stream {
        label: "Subsurface",
        tag: 0x5ab5_0f7e,
        aimed: false,
        budget_bytes: settings
            .memory_budget_bytes()
            .saturating_sub((stored * std::mem::size_of::<Photon>()) as u64),
    };
    let samples = trace_photons(
        ctx,
        emitters,
        stream,
        settings.subsurface_photons,
        seed,
        progress,
        |ray, power, rng, out| trace_subsurface_photon(ctx, ray, power, max, rng, out),
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
