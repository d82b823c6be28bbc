//! Building what the photon method reads: the global and caustic maps (Jensen 2001, ch. 5–6:
//! traced, then balanced into kd-trees), the precomputed irradiance (Christensen 1999), the
//! subsurface samples (`super::subsurface`) and, in scenes with media, the volume photon map
//! (Jensen & Christensen 1998, `crate::volume_photon_map`).

use super::estimate::precompute_irradiance;
use super::settings::{PhotonInfo, PhotonSettings};
use super::subsurface::{self, SubsurfaceMaps};
use super::tracing::{
    stores_volume_photons, trace_photon, trace_photons, trace_volume_photon, Emitters, MapKind,
    Stream,
};
use crate::error::Result;
use crate::integrator::Context;
use crate::photon_map::{Photon, PhotonMap};
use crate::progress::Progress;
use crate::rng::Sampler;
use crate::volume_photon_map::VolumePhotonMap;
use std::time::Instant;

/// The photon maps, the precomputed irradiance, the subsurface samples and the lookup
/// parameters: everything photon tracing builds for rendering to read.
pub struct PhotonMaps {
    pub global: Option<PhotonMap>,
    pub caustic: Option<PhotonMap>,
    /// Precomputed irradiance records: position, irradiance as `power`, normal as `incoming`.
    pub irradiance: Option<PhotonMap>,
    /// Subsurface samples of translucent materials.
    pub subsurface: Option<SubsurfaceMaps>,
    /// Photons scattered in media (only in scenes with media).
    pub volume: Option<VolumePhotonMap>,
    pub settings: PhotonSettings,
    /// Squared maximum search radii (scene units) of the global and caustic estimates, and of
    /// the `photons` view's dots.
    pub global_radius2: f32,
    pub caustic_radius2: f32,
    pub dot_radius2: f32,
}

/// `trace_photons` for the global or the caustic map.
#[allow(clippy::too_many_arguments)]
fn trace_map(
    ctx: &Context,
    emitters: &Emitters,
    settings: &PhotonSettings,
    map: MapKind,
    used_bytes: u64,
    seed: u64,
    sampler: Sampler,
    progress: &Progress,
) -> Result<Vec<Photon>> {
    let (tag, count) = match map {
        MapKind::Global => (0x9b0a_1c5e_u64, settings.global_photons),
        MapKind::Caustic => (0x3c4f_77d1_u64, settings.caustic_photons),
    };
    // Photons bounce as far as the render's bounce limit (Blender's Max Bounces): photons past
    // it could light nothing the render counts, and a lower cap of their own made the photon
    // method darker than the path tracer wherever light bounces often.
    let max = ctx.max_depth;
    let label = format!("{map:?}");
    let stream = Stream {
        label: &label,
        tag,
        aimed: map == MapKind::Caustic,
        budget_bytes: settings.memory_budget_bytes().saturating_sub(used_bytes),
        sampler,
    };
    trace_photons(
        ctx,
        emitters,
        stream,
        count,
        seed,
        progress,
        |e, rng, out| trace_photon(ctx, e, map, max, rng, out),
    )
}

/// Trace the photons from `emitters` (built once per render, `Emitters::guided`) and build the
/// maps, the precomputed irradiance and the subsurface samples.
pub fn build_maps(
    ctx: &Context,
    emitters: &Emitters,
    settings: &PhotonSettings,
    seed: u64,
    sampler: Sampler,
    progress: &Progress,
) -> Result<(PhotonMaps, PhotonInfo)> {
    let mut info = PhotonInfo {
        guided: emitters.is_guided(),
        ..PhotonInfo::default()
    };
    let start = Instant::now();
    let global = trace_map(
        ctx,
        emitters,
        settings,
        MapKind::Global,
        0,
        seed,
        sampler,
        progress,
    )?;
    info.global_emitted = settings.global_photons as u64;
    let caustic = if settings.caustic_photons == 0 {
        info.caustic_skipped = Some("no caustic photons requested".into());
        Vec::new()
    } else if !emitters.has_caustic_targets() {
        info.caustic_skipped = Some("no mesh has a delta or glossy-only material".into());
        Vec::new()
    } else {
        info.caustic_emitted = settings.caustic_photons as u64;
        trace_map(
            ctx,
            emitters,
            settings,
            MapKind::Caustic,
            (global.len() * std::mem::size_of::<Photon>()) as u64,
            seed,
            sampler,
            progress,
        )?
    };
    info.trace_seconds = start.elapsed().as_secs_f64();
    info.global_stored = global.len();
    info.caustic_stored = caustic.len();
    let start = Instant::now();
    let (global, caustic) = rayon::join(
        || (!global.is_empty()).then(|| PhotonMap::build(global)),
        || (!caustic.is_empty()).then(|| PhotonMap::build(caustic)),
    );
    info.kdtree_seconds = start.elapsed().as_secs_f64();
    let (_, radius) = ctx.lights.scene_sphere();
    let sq = |f: f32| (f * radius) * (f * radius);
    let start = Instant::now();
    let irradiance = match (&global, settings.irradiance_stride) {
        (Some(g), n) if n > 0 => {
            let max_radius2 = sq(settings.global_radius);
            let records = precompute_irradiance(g, n, settings.k_global, max_radius2, progress)?;
            info.irradiance_records = records.len();
            (!records.is_empty()).then(|| PhotonMap::build(records))
        }
        _ => None,
    };
    info.irradiance_seconds = start.elapsed().as_secs_f64();
    let subsurface =
        subsurface::build(ctx, emitters, settings, seed, sampler, progress, &mut info)?;
    let start = Instant::now();
    let volume = if settings.volume_photons > 0 && stores_volume_photons(ctx.scene) {
        let stored = info.global_stored + info.caustic_stored;
        let budget = settings.memory_budget_bytes();
        let stream = Stream::unaimed("Volume", 0x5e1f_0a7d, budget, stored, sampler);
        let max = ctx.max_depth;
        let photons = trace_photons(
            ctx,
            emitters,
            stream,
            settings.volume_photons,
            seed,
            progress,
            |e, rng, out| trace_volume_photon(ctx, e, max, rng, out),
        )?;
        info.volume_emitted = settings.volume_photons as u64;
        info.volume_stored = photons.len();
        VolumePhotonMap::new(photons, settings.volume_radius * radius)
    } else {
        None
    };
    info.volume_seconds = start.elapsed().as_secs_f64();
    Ok((
        PhotonMaps {
            global,
            caustic,
            irradiance,
            subsurface,
            volume,
            settings: settings.clone(),
            global_radius2: sq(settings.global_radius),
            caustic_radius2: sq(settings.caustic_radius),
            dot_radius2: sq(0.004),
        },
        info,
    ))
}
