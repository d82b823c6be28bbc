//! The irradiance cache (`crate::irradiance_cache`, Ward 1988 with Ward & Heckbert 1992
//! gradients) wired to the integrators: where records go, what their gather rays read, and the
//! cache's debug views.
//!
//! Records are placed at the surface each pixel centre sees first through specular surfaces
//! (the surfaces the photon renderer ray traces, `!stores_photons`), when that surface is opaque
//! with a diffuse lobe. A Lambertian surface takes all its indirect light from the cache. On a
//! mixed one (diffuse under a glossy layer, Principled's default) the photon renderer keeps its
//! gather rays but counts their global estimates for the other lobes only, f − ρ_d/π, and adds
//! ρ_d/π · E from the cache (`shading::CachedDiffuse`); the path tracer's cache mode serves
//! Lambertian surfaces only. Metals, glass and glossy-only surfaces have no records. A record
//! gathers *indirect* irradiance only: emission found by the gather rays is left out, since the shading point samples its lights itself when it
//! reads the cache (MIS-weighted with one BSDF ray that counts only emission, wherever a ray can
//! meet a light); each gather ray's light is held to Clamp Indirect as one sample of the
//! diffuse bounce of a camera path that sees the record. Two gather sources:
//! - `Source::Photon`: final gathering into the global photon map, as the photon renderer's own
//!   gather rays do (`photon::shade::cache_gather`: the global estimate behind specular surfaces);
//! - `Source::Path`: path-traced rays (`path::incident_radiance`), so the cache is used and tested
//!   without photons (`--method path-cache`).
//!
//! The cache is built over the full frame even for a region render, so a region is still the crop
//! of the full image bit for bit. Shading points no record covers fall back to the integrator's
//! own estimate (see `irradiance_cache`).

use super::classify::diffuse_reflectance;
use super::media::MediumStack;
use super::photon::build::PhotonMaps;
use super::photon::shade::cache_gather;
use super::shading::Shading;
use super::walk::{follow_specular, Chain, Clamp};
use super::{path, CameraSample, Context};
use crate::accel::{Ray, Visibility};
use crate::camera::CameraRays;
use crate::error::Result;
use crate::irradiance_cache::{self, IcSettings, Incoming, IrradianceCache, Site};
use crate::math::{Vec2, Vec3};
use crate::progress::{Progress, ProgressEvent};
use crate::rng::Rng;
use std::f32::consts::PI;
use std::sync::atomic::Ordering;
use std::time::Instant;

/// What a record's gather rays read.
#[derive(Clone, Copy)]
pub enum Source<'a> {
    /// Final gathering into the global photon map.
    Photon(&'a PhotonMaps),
    /// Path-traced rays.
    Path,
}

/// What the cache-based integrator shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CacheView {
    /// The path tracer with the cache at its first diffuse bounce.
    PathCache,
    /// The interpolated indirect irradiance at the first cached surface (black elsewhere).
    Irradiance,
    /// Record positions: white dots over a dimmed irradiance view.
    Records,
}

/// The cache's statistics for the render summary.
#[derive(Clone, Debug, Default)]
pub struct IcInfo {
    pub records: usize,
    pub seconds: f64,
    /// Strata per record (T × P).
    pub strata: (u32, u32),
    /// The build stopped at its ray budget (`IcSettings::max_rays_per_pixel`).
    pub budget_reached: bool,
}

impl IcInfo {
    /// Add another generation's records and time.
    pub fn add(&mut self, other: &IcInfo) {
        self.records += other.records;
        self.seconds += other.seconds;
        self.strata = other.strata;
        self.budget_reached |= other.budget_reached;
    }
}

/// The first surface that stores photons seen along camera ray `ray` through specular ones
/// (`walk::follow_specular`), with the path length to it.
fn first_surface(ctx: &Context, ray: Ray, rng: &mut Rng) -> Option<(Shading, f32)> {
    let hit = ctx.accel.intersect(ctx.scene, &ray, Visibility::Camera)?;
    let s = Shading::new(ctx, &ray, &hit, true);
    let mut chain = Chain {
        length: hit.t * ray.direction.length(),
        ..Chain::new(Vec3::ZERO)
    };
    let s = follow_specular(ctx, s, &mut chain, rng, &mut 0, None)?;
    Some((s, chain.length))
}

/// Build the cache over the full frame of `width` × `height` pixels.
pub fn build_cache(
    ctx: &Context,
    source: Source,
    settings: &IcSettings,
    (width, height): (u32, u32),
    seed: u64,
    progress: &Progress,
) -> Result<(IrradianceCache, IcInfo)> {
    let start = Instant::now();
    let camera = CameraRays::new(&ctx.scene.camera, width, height);
    let find = |x: u32, y: u32, rng: &mut Rng| {
        if progress.cancel.load(Ordering::Relaxed) {
            return None;
        }
        // A site anywhere in the middle half of its pixel, not at its centre: where an edge of
        // the scene runs exactly through pixel centres (the Cornell box's corners, seen from its
        // axis, make a 45° diagonal), centre sites sit on both surfaces at once, half of their
        // gather rays start on the far side of the other surface and leave the room, and the
        // record, reading half the irradiance, darkened a band of its own width along the edge.
        let film = Vec2::new(x as f32, y as f32) + 0.25 + 0.5 * rng.uniform2();
        let (ray, next) = (camera.ray(film), camera.ray(film + Vec2::X));
        let (mut s, length) = first_surface(ctx, ray, rng)?;
        diffuse_reflectance(&s.bsdf, s.opaque)?;
        if ctx.scene.has_media() {
            // The media where the record's gather rays start, found once for all of them (they
            // leave on one side of the surface, from one point).
            let probe = s.sh.spawn(s.ng);
            s.media = MediumStack::at(ctx, probe.origin, probe.time);
        }
        let at = |r: &Ray| r.origin + r.direction * length;
        let site = Site {
            p: s.sh.p,
            n: s.frame.n,
            footprint: (at(&next) - at(&ray)).length(),
        };
        Some((site, s))
    };
    let clamp = Clamp::of(ctx.scene);
    let gather = |s: &Shading, wi: Vec3, rng: &mut Rng| {
        // After a cancel the level's remaining records finish at once; the build then stops.
        if wi.dot(s.ng) <= 0.0 || progress.cancel.load(Ordering::Relaxed) {
            return Incoming::NONE;
        }
        let mut incoming = match source {
            Source::Photon(maps) => cache_gather(ctx, maps, s, wi, rng),
            Source::Path => path::incident_radiance(ctx, s.sh.spawn(wi), rng),
        };
        // Each gather ray is one sample of the diffuse bounce of a camera path that sees the
        // record's surface: its light is held to Clamp Indirect as that path's contribution
        // (the diffuse reflectance times it), as Cycles clamps each sample. Left to the
        // record's average, one bright ray (a lamp's glow in fog, a caustic) would light the
        // record's whole neighbourhood.
        if clamp.is_on() {
            let albedo = diffuse_reflectance(&s.bsdf, s.opaque).unwrap_or(Vec3::ONE);
            incoming.radiance = clamp.behind(albedo, incoming.radiance, false);
        }
        incoming
    };
    let check = |fraction: f32| {
        progress.check()?;
        (progress.report)(&ProgressEvent {
            stage: "cache",
            fraction,
            message: "placing irradiance records".into(),
        });
        Ok(())
    };
    let bounds = ctx.lights.scene_sphere();
    let (cache, built) =
        irradiance_cache::build(width, height, settings, seed, bounds, find, gather, check)?;
    let info = IcInfo {
        records: built.records,
        seconds: start.elapsed().as_secs_f64(),
        strata: settings.strata(),
        budget_reached: built.budget_reached,
    };
    Ok((cache, info))
}

/// One camera sample of a cache view.
pub fn trace(
    ctx: &Context,
    cache: &IrradianceCache,
    view: CacheView,
    ray: Ray,
    rng: &mut Rng,
) -> CameraSample {
    if view == CacheView::PathCache {
        return path::trace_cached(ctx, Some(cache), ray, rng);
    }
    let mut out = CameraSample {
        depth: 1e10,
        rays: 1,
        ..CameraSample::default()
    };
    let Some((s, length)) = first_surface(ctx, ray, rng) else {
        return out;
    };
    out.hit = true;
    out.albedo = s.surface.base_color;
    out.normal = s.sh.frame.n;
    out.depth = length;
    if diffuse_reflectance(&s.bsdf, s.opaque).is_none() {
        return out;
    }
    let e = cache.lookup(s.sh.p, s.frame.n).unwrap_or(Vec3::ZERO);
    out.radiance = match view {
        CacheView::Records if cache.near_record(s.sh.p, s.frame.n) => Vec3::ONE,
        CacheView::Records => 0.25 * e / PI,
        _ => e,
    };
    out
}
