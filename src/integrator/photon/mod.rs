//! Two-pass photon mapping (Jensen 2000, "Photon maps" and "Rendering equation solution"; Jensen
//! 2001, ch. 9). Pass 1 (`tracing`) stores photons in a global and a caustic map; pass 2 renders
//! each camera path by the notes' decomposition of the reflected radiance at the first
//! non-specular surface x (the first surface where `stores_photons` holds):
//!
//! L(x) = Le + L_direct + L_specular + L_caustic + L_indirect, where
//! - **direct** (paths L D(x) E): one light sample with MIS against the BSDF-sampled gather rays,
//!   which add the emission they hit with the complementary weight (as in `path.rs`);
//! - **specular** (E S* x): specular and glossy-only surfaces before x are ray traced as in the
//!   path tracer, and a delta lobe of x itself (a smooth coat) is traced recursively;
//! - **caustics** (L S+ D(x)): the caustic map's estimate at x, cone-filtered (k = 1);
//! - **indirect** (L (S|D)* D S* D(x)): final gathering: `gather_rays` BSDF-sampled rays from x
//!   (stratified); each follows specular surfaces without adding emission (L S+ paths arriving
//!   that way are caustics, already counted) and reads the global map's radiance estimate at the
//!   first non-specular hit y. The global map holds *every* stored photon (direct, caustic and
//!   indirect), so the estimate at y is y's full reflected radiance, and emission at gather hits
//!   is counted only through the MIS-weighted direct term above.
//!
//! Each light path is counted once: by the first diffuse vertex from the eye it is direct (no
//! diffuse vertex between it and the light, no specular either), caustic (only specular between),
//! or indirect (some diffuse vertex between). A gather sample that picks a delta lobe of x follows
//! the mirror direction and, at the next non-specular hit, adds its emission and the global
//! estimate (no second gather: Jensen's "less accurate" path for secondary rays).
//!
//! Light passes (`super::LightPass`), as seen from x: its light sample and the emission its
//! gather rays find are Direct, emission through its delta lobes Emission, the global estimates
//! and the cache Indirect, the caustic estimate Caustic, the dipole term Subsurface; glossy
//! vertices on the camera chain before x move Emission and Direct one step further.
//!
//! "Specular" means a delta lobe, or a surface without Lambertian part whose perceptual roughness
//! is below `SPECULAR_ROUGHNESS` = 0.049 (LuxCore's glossiness threshold): such surfaces are ray
//! traced; all others store photons and are shaded from the maps.
//!
//! **Irradiance cache** (`integrator::ic`, on by default): at a Lambertian opaque x, the indirect
//! term is ρ/π × E interpolated from Ward's records (each gathered once by stratified rays into
//! the global map, as `gather_ray` reads it but without emission), and direct light is one light
//! sample, MIS-weighted with one BSDF ray that counts only emission wherever a ray can meet a
//! light (`direct_without_gather`). A diffuse lobe under a glossy layer takes ρ_d/π × E from
//! the cache while the gather rays still run and count their global estimates with f − ρ_d/π
//! (emission as before). Other surfaces, and points no record covers, keep the plain gather rays. Cornell
//! 96 × 96 against the 4096-spp path reference, wall time of `photon render` in one session:
//! 256 spp 6.7 s relMSE 0.0011 (1991 records in 1.1 s; 64 spp 4.3 s 0.0028), vs the path
//! tracer 256 spp 8.7 s 0.0020 and plain gather 64 spp × 4 rays 7.7 s 0.0031. At 640 × 480,
//! 16 spp: 8.7 s with the cache (9606 records, 3.8 s) instead of 34 s.
//!
//! **Precomputed irradiance** (Christensen 1999, "Faster photon map global illumination"): after
//! pass 1, irradiance is estimated at every `irradiance_stride`-th global photon (default 4) from
//! its k nearest photons on the same surface side (the photon records its normal at trace time)
//! and stored as records in a kd-tree of their own. A final-gather hit on an opaque surface that
//! is Lambertian, or whose glossy lobe is rough (`ROUGH_AS_DIFFUSE`), reads the nearest record
//! whose normal agrees (cos > 0.9): L = albedo(wo)/π · E, instead of a full k-nearest estimate;
//! other surfaces, and the `photon-global` view, keep the full estimate.
//! Measured on the Cornell box (96 × 96, 4 spp, 32 gather rays, 200 000 photons, 2 cores):
//! pass 2 takes 1.31 s instead of 6.54 s (5.0×), the whole render 2.2 s instead of 6.9 s, and
//! the 90 829 records take 0.52 s; against a 4096-spp path reference relMSE is 0.013359 with
//! records and 0.013368 without, the mean −0.44 % instead of −0.34 %. It is the default.
//!
//! **Gather rays vs samples per pixel**: the Cornell box's photon-method error at moderate spp is
//! pixel noise (the lamp's edge pixels and the one light sample per pixel sample), not the map's
//! bias (about −0.3 % in the mean), so a few gather rays per pixel sample and more pixel samples
//! win at equal time. Cornell, 96 × 96 vs the 4096-spp path reference, wall time on 2 cores:
//! 16 spp × 32 gather rays 6.5 s relMSE 0.0160; 64 × 8 7.4 s 0.0027; 128 × 4 7.3 s 0.0018;
//! 256 × 2 8.5 s 0.0011 (the path tracer: 256 spp, 5.0 s, 0.0020). Hence 4 gather rays by default.
//!
//! **Glass caustic** (`scenes/glass_caustic.glb`): path references are the hard part. Two
//! independent 8192-spp path renders at 96 × 96 differ by relMSE 0.045 (a small light seen
//! through glass from a diffuse floor is the path tracer's worst case), so the 0.02 "floor"
//! measured against a 4096-spp reference was the reference's own error. Against a 131 072-spp
//! reference at 48 × 48 (`photon bench --width 48 --reference-spp 131072`): photon 3.2 s relMSE
//! 0.023, 12.9 s 0.0067; path 5.4 s 0.34, 48 s (8192 spp) 0.024: about 24× lower error at
//! equal time. What remains is pixel noise at the lamp's tiny reflection in the sphere, common
//! to both methods.
//!
//! Radiance estimates use the k nearest photons within a maximum radius (relative to the scene's
//! bounding radius), `L ≈ Σ f_r ΔΦ / (π r²)`, where r is the k-th distance (or the maximum radius
//! when fewer are found), discarding photons off the tangent plane (more than a quarter of r away
//! along the normal) and, through f_r, photons from the wrong side.

pub mod subsurface;
pub mod tracing;

use super::{CameraSample, Context, LightPass, Passes};
use crate::accel::{Hit, Ray, Visibility};
use crate::bsdf::{Bsdf, BsdfSample, ViewedBsdf};
use crate::error::{Error, Result};
use crate::interaction::SurfaceHit;
use crate::irradiance_cache::{Incoming, IrradianceCache};
use crate::light::emitted_radiance;
use crate::material::{eval_material, SurfaceMaterial};
use crate::math::{max_component, Frame, Vec2, Vec3};
use crate::photon_map::{Neighbors, Photon, PhotonMap};
use crate::render::{Progress, ProgressEvent};
use crate::rng::Rng;
use crate::sampling::power_heuristic;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;
use tracing::{stores_photons, trace_photon, Emitters, Pass};

/// Perceptual roughness below which a surface without Lambertian part counts as specular
/// (LuxCore's glossiness threshold). Such lobes are narrow enough that ray tracing them
/// converges fast, while a photon estimate would blur them.
pub const SPECULAR_ROUGHNESS: f32 = 0.049;

/// Perceptual roughness from which a final-gather hit's glossy lobe is shaded from the
/// precomputed irradiance like its diffuse part (`Pass2::gather_estimate`): Principled materials
/// carry a specular layer (0.5 by default), so without this almost no Blender surface takes the
/// fast path. Rough lobes blur the incident light nearly as a diffuse one does; below this the
/// full estimate sees each photon's direction.
const ROUGH_AS_DIFFUSE: f32 = 0.5;

/// Photons further than this fraction of the search radius from the tangent plane are ignored.
const PLANE_TOLERANCE: f32 = 0.25;

/// Longest chain of specular bounces followed by gather and estimate rays.
const MAX_SPECULAR_CHAIN: u32 = 12;

/// Photons per work item of pass 1 (a batch has its own random stream).
const BATCH: u32 = 4096;

/// Photon-mapping settings; the command line maps onto them.
#[derive(Clone, Debug, PartialEq)]
pub struct PhotonSettings {
    /// Photons emitted for the global map (default 200 000).
    pub global_photons: u32,
    /// Photons emitted for the caustic map (default 100 000, aimed at the specular objects).
    pub caustic_photons: u32,
    /// Nearest photons in a global estimate (default 64).
    pub k_global: u32,
    /// Nearest photons in a caustic estimate (default 64).
    pub k_caustic: u32,
    /// Maximum global search radius as a fraction of the scene's bounding radius (default 0.1).
    pub global_radius: f32,
    /// Maximum caustic search radius as a fraction of the scene's bounding radius (0.02).
    pub caustic_radius: f32,
    /// Final-gather rays per shading point (default 4; 0 reads the global map directly).
    pub gather_rays: u32,
    /// Maximum bounces of a photon (default 16).
    pub max_photon_bounces: u32,
    /// Precompute irradiance at every n-th global photon (Christensen 1999) and let final-gather
    /// hits on Lambertian surfaces read the nearest record; 0 computes a full estimate per hit.
    pub irradiance_stride: u32,
    /// Memory budget of the photon maps and subsurface samples together, in MiB (default
    /// 8192; the command line defaults to half the machine's memory). Tracing stops with a
    /// settings error, naming the budget, as soon as the stored photons would exceed it
    /// (counting the copy made while the batches are joined).
    pub memory_limit_mib: u64,
    /// Photons emitted for the subsurface samples (default 1 000 000; only with a translucent
    /// material).
    pub subsurface_photons: u32,
    /// Jensen & Buhler's error bound: an octree node counts as one sample when the solid angle
    /// its samples' area subtends is below this (default 0.05).
    pub subsurface_accuracy: f32,
    /// Sum every subsurface sample instead of the octree (for tests and measurements).
    pub subsurface_brute_force: bool,
    /// Jensen & Buhler's irradiance points instead of subsurface photons: this many points over
    /// the translucent surfaces (default 0: photons).
    pub subsurface_points: u32,
    /// Shadow rays per irradiance point (default 4).
    pub subsurface_light_samples: u32,
}

impl Default for PhotonSettings {
    fn default() -> Self {
        PhotonSettings {
            global_photons: 200_000,
            caustic_photons: 100_000,
            k_global: 64,
            k_caustic: 64,
            global_radius: 0.1,
            caustic_radius: 0.02,
            gather_rays: 4,
            max_photon_bounces: 16,
            irradiance_stride: 4,
            memory_limit_mib: 8192,
            subsurface_photons: 1_000_000,
            subsurface_accuracy: 0.05,
            subsurface_brute_force: false,
            subsurface_points: 0,
            subsurface_light_samples: 4,
        }
    }
}

impl PhotonSettings {
    /// The memory budget in bytes.
    pub fn memory_budget_bytes(&self) -> u64 {
        self.memory_limit_mib.saturating_mul(1 << 20)
    }
}

/// What pass 2 shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    /// The full solution (direct + specular + caustics + final gather).
    Full,
    /// The global map's radiance estimate at the first non-specular hit, plus emission.
    Global,
    /// The caustic map's radiance estimate at the first non-specular hit.
    Caustic,
    /// Photon positions: white dots for global photons, orange for caustic ones.
    Photons,
}

/// The plan and statistics of pass 1.
#[derive(Clone, Debug, Default)]
pub struct PhotonInfo {
    pub global_emitted: u64,
    pub global_stored: usize,
    pub caustic_emitted: u64,
    pub caustic_stored: usize,
    /// Why the caustic map was skipped, if it was.
    pub caustic_skipped: Option<String>,
    pub trace_seconds: f64,
    pub kdtree_seconds: f64,
    /// Precomputed irradiance records (Christensen 1999) and the time they took.
    pub irradiance_records: usize,
    pub irradiance_seconds: f64,
    pub subsurface_emitted: u64,
    pub subsurface_stored: usize,
    /// Why the subsurface pass was skipped, if it was.
    pub subsurface_skipped: Option<String>,
    /// Tracing the subsurface photons and building their octrees.
    pub subsurface_seconds: f64,
}

/// Both maps and the lookup parameters.
pub struct PhotonMaps {
    pub global: Option<PhotonMap>,
    pub caustic: Option<PhotonMap>,
    /// Precomputed irradiance records: position, irradiance as `power`, normal as `incoming`.
    pub irradiance: Option<PhotonMap>,
    /// Subsurface samples of translucent materials.
    pub subsurface: Option<subsurface::SubsurfaceMaps>,
    /// Ward's irradiance cache for the indirect term on Lambertian surfaces (`integrator::ic`),
    /// set after the maps are built; `None` shades with plain final gather rays.
    pub cache: Option<IrradianceCache>,
    pub settings: PhotonSettings,
    global_radius2: f32,
    caustic_radius2: f32,
    dot_radius2: f32,
}

/// A surface hit prepared for shading, with the path tracer's frame convention: opaque surfaces
/// turn the frame (and `ng`) to the viewer's side, transmissive ones keep the winding side.
#[derive(Clone, Copy)]
pub struct Shading {
    pub sh: SurfaceHit,
    pub surface: SurfaceMaterial,
    pub frame: Frame,
    pub ng: Vec3,
    pub opaque: bool,
    /// The BSDF seen from `wo`.
    pub bsdf: ViewedBsdf,
    /// Unit direction towards the viewer (or where the photon came from).
    pub wo: Vec3,
    pub wo_local: Vec3,
}

impl Shading {
    pub fn new(ctx: &Context, ray: &Ray, hit: &Hit) -> Shading {
        let sh = SurfaceHit::new(ctx.scene, ray, hit);
        let wo = -ray.direction.normalize();
        let surface = eval_material(ctx.scene, &ctx.scene.materials[sh.material as usize], sh.uv);
        let mut frame = sh.frame;
        let opaque = surface.transmission <= 0.0;
        let mut ng = sh.ng;
        if opaque && wo.dot(ng) < 0.0 {
            frame.n = -frame.n;
            frame.t = -frame.t;
            ng = -ng;
        }
        let wo_local = frame.to_local(wo);
        Shading {
            sh,
            frame,
            ng,
            opaque,
            bsdf: Bsdf::new(&surface).viewed_from(wo_local),
            wo,
            wo_local,
            surface,
        }
    }

    /// Absorption coefficient of the medium a ray leaving along `wi` by `bs` travels through.
    pub fn absorption_after(&self, bs: &BsdfSample, wi: Vec3, current: Vec3) -> Vec3 {
        if !bs.transmitted {
            current
        } else if wi.dot(self.sh.ng) < 0.0 {
            self.surface.absorption
        } else {
            Vec3::ZERO
        }
    }

    /// Sample the BSDF and turn the sample into a world direction; `None` when the path ends.
    pub(crate) fn sample(&self, u_lobe: f32, u: Vec2) -> Option<(BsdfSample, Vec3)> {
        let bs = self.bsdf.sample(u_lobe, u)?;
        let wi = self.frame.to_world(bs.wi).normalize();
        if self.opaque && wi.dot(self.ng) <= 0.0 {
            return None;
        }
        Some((bs, wi))
    }
}

/// The BSDF that classifies material `m` for photon tracing and the scene planner: its value at
/// texture coordinate 0, with roughness textures counted as smooth (a texture may reach 0).
pub fn classifying_bsdf(scene: &crate::scene::Scene, m: u32) -> Bsdf {
    let material = &scene.materials[m as usize];
    let mut s = eval_material(scene, material, Vec2::ZERO);
    if material.metallic_roughness_texture.is_some() {
        s.roughness = 0.0;
    }
    Bsdf::new(&s)
}

/// True when `b` has a delta or glossy-only lobe: a photon may scatter specularly off it.
pub fn bsdf_is_specular(b: &Bsdf) -> bool {
    b.has_delta() || (b.has_specular() && b.roughness() < SPECULAR_ROUGHNESS)
}

/// True when material `m` (classified by `classifying_bsdf`) scatters photons specularly.
pub fn is_specular(scene: &crate::scene::Scene, m: u32) -> bool {
    bsdf_is_specular(&classifying_bsdf(scene, m))
}

/// Which photons a pass emits: its name in progress messages, the tag that separates its random
/// stream from the other passes', and whether its photons are aimed at the specular meshes.
struct Stream<'a> {
    label: &'a str,
    tag: u64,
    aimed: bool,
    /// Bytes the pass may store (what the memory budget leaves after the earlier passes).
    budget_bytes: u64,
}

/// Trace `count` photons in parallel batches with `trace(ray, power, rng, out)` (power already
/// divided by the count), concatenated in batch order.
fn trace_pass<T: Send + Clone>(
    ctx: &Context,
    emitters: &Emitters,
    stream: Stream,
    count: u32,
    seed: u64,
    progress: &Progress,
    trace: impl Fn(Ray, Vec3, &mut Rng, &mut Vec<T>) + Sync,
) -> Result<Vec<T>> {
    let batches = count.div_ceil(BATCH);
    let done = AtomicU64::new(0);
    let stored = AtomicU64::new(0);
    // Batches are joined into one vector at the end: both exist for a moment.
    let bytes_per_item = 2 * std::mem::size_of::<T>() as u64;
    let scale = 1.0 / count.max(1) as f32;
    let parts: Vec<Vec<T>> = (0..batches)
        .into_par_iter()
        .map(|b| {
            progress.check()?;
            let mut rng = Rng::for_item(seed ^ stream.tag, b as u64, 0);
            let n = BATCH.min(count - b * BATCH);
            let mut out = Vec::with_capacity(n as usize * 2);
            for _ in 0..n {
                if let Some(e) = emitters.emit(ctx, stream.aimed, &mut rng) {
                    trace(e.ray, e.power * scale, &mut rng, &mut out);
                }
            }
            // Partial sums never exceed the final count, so whether this fails does not depend
            // on the order the batches finish in.
            let total = stored.fetch_add(out.len() as u64, Ordering::Relaxed) + out.len() as u64;
            if total * bytes_per_item > stream.budget_bytes {
                return Err(Error::Settings(format!(
                    "the {} photons need more than the {} MiB left of the photon memory limit \
                     ({total} stored so far); emit fewer photons or raise --memory-limit",
                    stream.label,
                    stream.budget_bytes >> 20
                )));
            }
            let finished = done.fetch_add(1, Ordering::Relaxed) + 1;
            (progress.report)(&ProgressEvent {
                stage: "photons",
                fraction: finished as f32 / batches as f32,
                message: format!("{} photons: batch {finished}/{batches}", stream.label),
            });
            Ok(out)
        })
        .collect::<Result<_>>()?;
    Ok(parts.concat())
}

/// `trace_pass` for the global and caustic maps.
fn trace_map_pass(
    ctx: &Context,
    emitters: &Emitters,
    settings: &PhotonSettings,
    pass: Pass,
    used_bytes: u64,
    seed: u64,
    progress: &Progress,
) -> Result<Vec<Photon>> {
    let (tag, count) = match pass {
        Pass::Global => (0x9b0a_1c5e_u64, settings.global_photons),
        Pass::Caustic => (0x3c4f_77d1_u64, settings.caustic_photons),
    };
    let max = settings.max_photon_bounces;
    let label = format!("{pass:?}");
    let stream = Stream {
        label: &label,
        tag,
        aimed: pass == Pass::Caustic,
        budget_bytes: settings.memory_budget_bytes().saturating_sub(used_bytes),
    };
    trace_pass(
        ctx,
        emitters,
        stream,
        count,
        seed,
        progress,
        |ray, power, rng, out| trace_photon(ctx, ray, power, pass, max, rng, out),
    )
}

/// Pass 1: trace and balance the maps.
pub fn build_maps(
    ctx: &Context,
    settings: &PhotonSettings,
    seed: u64,
    progress: &Progress,
) -> Result<(PhotonMaps, PhotonInfo)> {
    let emitters = Emitters::new(ctx);
    let mut info = PhotonInfo::default();
    let start = Instant::now();
    let global = trace_map_pass(ctx, &emitters, settings, Pass::Global, 0, seed, progress)?;
    info.global_emitted = settings.global_photons as u64;
    let caustic = if settings.caustic_photons == 0 {
        info.caustic_skipped = Some("no caustic photons requested".into());
        Vec::new()
    } else if !emitters.has_caustic_targets() {
        info.caustic_skipped = Some("no mesh has a delta or glossy-only material".into());
        Vec::new()
    } else {
        info.caustic_emitted = settings.caustic_photons as u64;
        trace_map_pass(
            ctx,
            &emitters,
            settings,
            Pass::Caustic,
            (global.len() * std::mem::size_of::<Photon>()) as u64,
            seed,
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
            let records =
                precompute_irradiance(g, n, settings.k_global, sq(settings.global_radius));
            info.irradiance_records = records.len();
            (!records.is_empty()).then(|| PhotonMap::build(records))
        }
        _ => None,
    };
    info.irradiance_seconds = start.elapsed().as_secs_f64();
    let subsurface = subsurface::build(
        ctx,
        &emitters,
        settings,
        global.as_ref(),
        sq(settings.global_radius),
        seed,
        progress,
        &mut info,
    )?;
    Ok((
        PhotonMaps {
            global,
            caustic,
            irradiance,
            subsurface,
            cache: None,
            settings: settings.clone(),
            global_radius2: sq(settings.global_radius),
            caustic_radius2: sq(settings.caustic_radius),
            dot_radius2: sq(0.004),
        },
        info,
    ))
}

/// Christensen's precomputation: irradiance at every `stride`-th photon of `map` (in heap
/// order, which is spatially well mixed) from its k nearest photons, counting only photons on
/// the same side of the same surface (normal within ~60°, within a quarter radius of the
/// tangent plane, arriving from the normal's side). Each record is a photon whose `power` is the
/// irradiance and whose `incoming` direction is the surface normal.
fn precompute_irradiance(map: &PhotonMap, stride: u32, k: u32, max_radius2: f32) -> Vec<Photon> {
    let photons = map.photons();
    let step = stride.max(1) as usize;
    let ids: Vec<usize> = (0..photons.len()).step_by(step).collect();
    ids.par_chunks(1024)
        .map_init(Neighbors::default, |buf, chunk| {
            let mut out = Vec::with_capacity(chunk.len());
            for &i in chunk {
                let ph = &photons[i];
                let (p, n) = (ph.position(), ph.normal());
                map.nearest(p, k as usize, max_radius2, buf);
                let r2 = buf.radius2;
                let r = r2.sqrt();
                let mut sum = Vec3::ZERO;
                for nb in buf.iter() {
                    let q = &photons[nb.index as usize];
                    if on_surface(q, p, n, r) && q.incoming().dot(n) > 0.0 {
                        sum += q.power();
                    }
                }
                let e = if r2 > 0.0 {
                    sum / (PI * r2)
                } else {
                    Vec3::ZERO
                };
                out.push(Photon::new(p, e, n, 0, false));
            }
            out
        })
        .collect::<Vec<_>>()
        .concat()
}

/// Whether photon `ph`, found within radius `r` of point `p` with normal `n`, lies on the same
/// side of the same surface: near the tangent plane, its recorded normal within ~60° of `n`. The
/// normal test keeps photons on the far side of a thin or strongly curved object (the outside of
/// a small sphere, seen from within) out of the estimate: without it light leaks through walls.
fn on_surface(ph: &Photon, p: Vec3, n: Vec3, r: f32) -> bool {
    (ph.position() - p).dot(n).abs() <= PLANE_TOLERANCE * r && ph.normal().dot(n) > 0.5
}

/// The nearest precomputed irradiance record to `s` whose normal agrees with the surface's
/// (cos > 0.9) and that lies near its tangent plane; `None` when there is none within
/// `max_radius2`.
fn nearest_irradiance(map: &PhotonMap, max_radius2: f32, s: &Shading) -> Option<Vec3> {
    let accept = |rec: &Photon, dist2: f32| {
        let d = rec.position() - s.sh.p;
        rec.incoming().dot(s.ng) >= 0.9 && d.dot(s.ng).abs() <= PLANE_TOLERANCE * dist2.sqrt()
    };
    map.nearest_accepted(s.sh.p, max_radius2, accept)
        .map(|(i, _)| map.photons()[i as usize].power())
}

/// Radiance leaving `s` towards its viewer estimated from `map`: Σ f_r ΔΦ / (π r²), with a cone
/// filter (k = 1, normalised by 1 − 2/3) when `cone` is set.
fn radiance_estimate(
    map: &PhotonMap,
    k: u32,
    max_radius2: f32,
    cone: bool,
    s: &Shading,
    buf: &mut Neighbors,
) -> Vec3 {
    map.nearest(s.sh.p, k as usize, max_radius2, buf);
    if buf.is_empty() {
        return Vec3::ZERO;
    }
    let r2 = buf.radius2;
    let r = r2.sqrt();
    // Pure Lambertian opaque surfaces: f_r = ρ/π on the viewer's side, no per-photon BSDF call.
    let rho = s.bsdf.diffuse_reflectance();
    let lambert = s.opaque && max_component(s.bsdf.albedo() - rho) < 1e-4;
    let mut sum = Vec3::ZERO;
    for nb in buf.iter() {
        let ph = &map.photons()[nb.index as usize];
        if !on_surface(ph, s.sh.p, s.ng, r) {
            continue;
        }
        let wi = ph.incoming();
        let f = if lambert {
            if wi.dot(s.ng) > 0.0 {
                rho * (1.0 / PI)
            } else {
                continue;
            }
        } else {
            let wl = s.frame.to_local(wi);
            if wl.z.abs() < 1e-6 {
                continue;
            }
            s.bsdf.eval(wl) / wl.z.abs()
        };
        let w = if cone { 1.0 - nb.dist2.sqrt() / r } else { 1.0 };
        sum += f * ph.power() * w;
    }
    let area = if cone { PI * r2 / 3.0 } else { PI * r2 };
    sum / area
}

/// Per-sample state shared by the pass-2 routines.
struct Pass2<'a> {
    ctx: &'a Context<'a>,
    maps: &'a PhotonMaps,
    buf: Neighbors,
    rays: u32,
}

impl Pass2<'_> {
    fn intersect(&mut self, ray: &Ray) -> Option<Hit> {
        self.rays += 1;
        self.ctx
            .accel
            .intersect(self.ctx.scene, ray, Visibility::Secondary)
    }

    /// The global estimate at a final-gather hit: on opaque surfaces that are Lambertian or
    /// whose glossy lobe is rough (`ROUGH_AS_DIFFUSE`), albedo(wo)/π × the nearest precomputed
    /// irradiance when records exist (exact for Lambertian surfaces, and for any BSDF under
    /// uniform incident light, by reciprocity); else the full estimate, whose photons keep
    /// their directions for sharper lobes.
    fn gather_estimate(&mut self, s: &Shading) -> Vec3 {
        if let Some(irr) = &self.maps.irradiance {
            if s.opaque && !s.bsdf.has_delta() {
                let albedo = s.bsdf.albedo();
                let lambertian = max_component(albedo - s.bsdf.diffuse_reflectance()) < 1e-4;
                if s.bsdf.roughness() >= ROUGH_AS_DIFFUSE || lambertian {
                    let r2 = self.maps.global_radius2;
                    if let Some(e) = nearest_irradiance(irr, r2, s) {
                        return albedo * e * (1.0 / PI);
                    }
                }
            }
        }
        self.global(s)
    }

    fn global(&mut self, s: &Shading) -> Vec3 {
        let (maps, k) = (self.maps, self.maps.settings.k_global);
        match &maps.global {
            Some(m) => radiance_estimate(m, k, maps.global_radius2, false, s, &mut self.buf),
            None => Vec3::ZERO,
        }
    }

    fn caustic(&mut self, s: &Shading) -> Vec3 {
        let (maps, k) = (self.maps, self.maps.settings.k_caustic);
        match &maps.caustic {
            Some(m) => radiance_estimate(m, k, maps.caustic_radius2, true, s, &mut self.buf),
            None => Vec3::ZERO,
        }
    }

    /// One light sample at `s`, MIS-weighted against BSDF sampling when `mis` is set.
    fn direct(&mut self, s: &Shading, mis: bool, rng: &mut Rng) -> Vec3 {
        let ctx = self.ctx;
        let Some(ls) = ctx
            .lights
            .sample(ctx.scene, s.sh.p, rng.uniform(), rng.uniform2())
        else {
            return Vec3::ZERO;
        };
        // An opaque surface cannot be lit from behind its geometry.
        if ls.li == Vec3::ZERO || (s.opaque && ls.wi.dot(s.ng) <= 0.0) {
            return Vec3::ZERO;
        }
        let wi_local = s.frame.to_local(ls.wi);
        let (f, bsdf_pdf) = s.bsdf.eval_and_pdf(wi_local);
        if f == Vec3::ZERO {
            return Vec3::ZERO;
        }
        self.rays += 1;
        if !ctx.accel.unoccluded(ctx.scene, &s.sh.spawn_to(&ls.target)) {
            return Vec3::ZERO;
        }
        let w = if ls.delta || !mis {
            1.0
        } else {
            power_heuristic(ls.pdf, bsdf_pdf)
        };
        f * ls.li * (w / ls.pdf)
    }

    /// Follow specular surfaces from `s` to the first surface that stores photons; returns it
    /// with the throughput, adding emission met on the way to `le` when `emission` is set.
    fn through_specular(
        &mut self,
        mut s: Shading,
        mut absorption: Vec3,
        emission: bool,
        le: &mut Vec3,
        rng: &mut Rng,
    ) -> Option<(Shading, Vec3)> {
        let mut beta = Vec3::ONE;
        for _ in 0..MAX_SPECULAR_CHAIN {
            if stores_photons(&s.bsdf) {
                return Some((s, beta));
            }
            let (bs, wi) = s.sample(rng.uniform(), rng.uniform2())?;
            beta *= bs.weight;
            absorption = s.absorption_after(&bs, wi, absorption);
            let ray = s.sh.spawn(wi);
            let Some(hit) = self.intersect(&ray) else {
                if emission {
                    self.ctx.lights.escaped(wi, |l, _| *le += beta * l);
                }
                return None;
            };
            if absorption != Vec3::ZERO {
                beta *= (-absorption * (hit.t * ray.direction.length())).exp();
            }
            s = Shading::new(self.ctx, &ray, &hit);
            if emission {
                *le += beta * emitted_radiance(self.ctx.scene, &s.sh, s.wo);
            }
            if beta == Vec3::ZERO || !beta.is_finite() {
                return None;
            }
        }
        None
    }

    /// A non-delta final-gather ray from `from` with BSDF density `pdf`: the emission it finds
    /// (MIS-weighted against light sampling) and, with `estimate`, the global estimate behind
    /// specular surfaces, returned apart (the irradiance cache replaces the diffuse lobe's share
    /// of the second).
    fn gather_ray(
        &mut self,
        from: Vec3,
        ray: Ray,
        pdf: f32,
        absorption: Vec3,
        estimate: bool,
        rng: &mut Rng,
    ) -> (Vec3, Vec3) {
        let ctx = self.ctx;
        let Some(hit) = self.intersect(&ray) else {
            let mut l = Vec3::ZERO;
            ctx.lights.escaped(ray.direction, |le, lpdf| {
                l += le * power_heuristic(pdf, lpdf)
            });
            return (l, Vec3::ZERO);
        };
        let mut t = Vec3::ONE;
        if absorption != Vec3::ZERO {
            t = (-absorption * (hit.t * ray.direction.length())).exp();
        }
        let s = Shading::new(ctx, &ray, &hit);
        let mut l = emitted_radiance(ctx.scene, &s.sh, s.wo);
        if l != Vec3::ZERO {
            l *= power_heuristic(pdf, ctx.lights.triangle_pdf(from, &s.sh));
        }
        if !estimate {
            return (t * l, Vec3::ZERO);
        }
        let mut unused = Vec3::ZERO;
        let mut estimate = Vec3::ZERO;
        if let Some((d, beta)) = self.through_specular(s, absorption, false, &mut unused, rng) {
            estimate = beta * self.gather_estimate(&d);
        }
        (t * l, t * estimate)
    }

    /// Direct light at `s` when no final-gather ray leaves it (its indirect light is cached):
    /// light sampling alone has unbounded variance where an emitting mesh meets the surface
    /// at a concave corner (the 1/d² of nearby light samples), and speckles where a small
    /// opening shows the world (most of its samples blocked, the few through it weighted by
    /// the inverse of the world's small share of the samples). So wherever a ray can meet a
    /// light, one BSDF-sampled ray adds the emission it finds and both are MIS-weighted, as in
    /// the path tracer. Scenes lit only by point, spot and sharp sun lamps keep light sampling
    /// alone.
    fn direct_without_gather(&mut self, s: &Shading, rng: &mut Rng) -> Vec3 {
        if !self.ctx.lights.hittable() {
            return self.direct(s, false, rng);
        }
        let mut l = self.direct(s, true, rng);
        if let Some((bs, wi)) = s.sample(rng.uniform(), rng.uniform2()) {
            if !bs.delta {
                let absorption = s.absorption_after(&bs, wi, Vec3::ZERO);
                let ray = s.sh.spawn(wi);
                let (emission, _) = self.gather_ray(s.sh.p, ray, bs.pdf, absorption, false, rng);
                l += bs.weight * emission;
            }
        }
        l
    }

    /// Radiance along a ray that left a diffuse surface through a delta lobe: emission along the
    /// specular chain and the global estimate at its end, returned apart (for the passes).
    fn estimate_ray(&mut self, ray: Ray, absorption: Vec3, rng: &mut Rng) -> (Vec3, Vec3) {
        let Some(hit) = self.intersect(&ray) else {
            let mut l = Vec3::ZERO;
            self.ctx.lights.escaped(ray.direction, |le, _| l += le);
            return (l, Vec3::ZERO);
        };
        let mut t = Vec3::ONE;
        if absorption != Vec3::ZERO {
            t = (-absorption * (hit.t * ray.direction.length())).exp();
        }
        let s = Shading::new(self.ctx, &ray, &hit);
        let mut l = emitted_radiance(self.ctx.scene, &s.sh, s.wo);
        let mut estimate = Vec3::ZERO;
        if let Some((d, beta)) = self.through_specular(s, absorption, true, &mut l, rng) {
            estimate = beta * self.global(&d);
        }
        (t * l, t * estimate)
    }

    /// Reflected radiance at a non-specular surface: direct + caustics + final gather, by pass
    /// as seen from `s` (emission through its delta lobes is `Emission`, its light samples and
    /// the emission its gather rays find `Direct`, their global estimates `Indirect`).
    fn shade(&mut self, s: &Shading, rng: &mut Rng) -> Passes {
        let mut passes = Passes::default();
        // Irradiance cache: a Lambertian surface takes its indirect light from the records and
        // samples only the lights; on a mixed one the cache replaces the diffuse lobe's share
        // of the gather rays' global estimates.
        let cached = (self.maps.cache.as_ref()).and_then(|c| super::ic::cached_diffuse(c, s));
        if let Some(d) = cached.filter(|d| d.lambertian) {
            passes.add(LightPass::Direct, self.direct_without_gather(s, rng));
            passes.add(LightPass::Caustic, self.caustic(s));
            passes.add(LightPass::Indirect, d.radiance);
            return passes;
        }
        // Where the cache serves the diffuse lobe, the gather rays carry only the rest of the
        // BSDF (a glossy layer's indirect light and emission): one per camera sample, as the
        // path tracer's bounce, instead of a full final gather.
        let m = match cached {
            Some(_) => self.maps.settings.gather_rays.min(1),
            None => self.maps.settings.gather_rays,
        };
        passes.add(LightPass::Direct, self.direct(s, m > 0, rng));
        passes.add(LightPass::Caustic, self.caustic(s));
        if m == 0 {
            passes.add(LightPass::Indirect, self.global(s));
            return passes;
        }
        let n = (m as f32).sqrt() as u32;
        // Sums over the gather rays by pass.
        let mut sum = Passes::default();
        for i in 0..m {
            // Stratify the first n² directions on an n × n grid.
            let u = if i < n * n {
                let j = Vec2::new((i % n) as f32, (i / n) as f32);
                ((j + rng.uniform2()) / n as f32).min(Vec2::splat(0.999_999_94))
            } else {
                rng.uniform2()
            };
            let Some((bs, wi)) = s.sample(rng.uniform(), u) else {
                continue;
            };
            let absorption = s.absorption_after(&bs, wi, Vec3::ZERO);
            let ray = s.sh.spawn(wi);
            if bs.delta {
                let (emission, estimate) = self.estimate_ray(ray, absorption, rng);
                sum.add(LightPass::Emission, bs.weight * emission);
                sum.add(LightPass::Indirect, bs.weight * estimate);
            } else {
                let (emission, estimate) =
                    self.gather_ray(s.sh.p, ray, bs.pdf, absorption, true, rng);
                let w = cached.map_or(bs.weight, |d| d.non_diffuse_weight(&bs));
                sum.add(LightPass::Direct, bs.weight * emission);
                sum.add(LightPass::Indirect, w * estimate);
            }
        }
        sum.scale(1.0 / m as f32);
        passes += sum;
        passes.add(
            LightPass::Indirect,
            cached.map_or(Vec3::ZERO, |d| d.radiance),
        );
        passes
    }

    /// `shade`, where on a translucent surface the subsurface term replaces the subsurface
    /// weight's share of the Lambertian part.
    fn shade_full(&mut self, s: &Shading, rng: &mut Rng) -> Passes {
        let sss = self.maps.subsurface.as_ref().and_then(|m| m.radiance(s));
        match sss {
            None => self.shade(s, rng),
            Some(l) => {
                let weight = s.surface.subsurface.weight;
                let rest = Shading {
                    bsdf: s.bsdf.without_subsurface(weight),
                    ..*s
                };
                let mut passes = self.shade(&rest, rng);
                passes.add(LightPass::Subsurface, l);
                passes
            }
        }
    }

    /// Photon dots: the nearest photon within a small radius, white (global) or orange (caustic).
    fn dots(&mut self, s: &Shading) -> Vec3 {
        let maps = self.maps;
        for (map, colour) in [
            (&maps.caustic, Vec3::new(1.0, 0.5, 0.1)),
            (&maps.global, Vec3::ONE),
        ] {
            if let Some(m) = map {
                m.nearest(s.sh.p, 1, maps.dot_radius2, &mut self.buf);
                if !self.buf.is_empty() {
                    return colour;
                }
            }
        }
        Vec3::ZERO
    }
}

/// Radiance arriving at `s` along `wi` for an irradiance-cache record, with the distance of the
/// first hit: the global estimate behind specular surfaces, as a final-gather ray reads it, but
/// without emission (the cached point samples its lights itself).
pub(crate) fn cache_gather(
    ctx: &Context,
    maps: &PhotonMaps,
    s: &Shading,
    wi: Vec3,
    rng: &mut Rng,
) -> Incoming {
    let mut p2 = Pass2 {
        ctx,
        maps,
        buf: Neighbors::default(),
        rays: 0,
    };
    let ray = s.sh.spawn(wi);
    let Some(hit) = p2.intersect(&ray) else {
        return Incoming::NONE;
    };
    let d = Shading::new(ctx, &ray, &hit);
    let normal = d.frame.n;
    let mut unused = Vec3::ZERO;
    let radiance = match p2.through_specular(d, Vec3::ZERO, false, &mut unused, rng) {
        Some((d, beta)) => beta * p2.gather_estimate(&d),
        None => Vec3::ZERO,
    };
    Incoming {
        radiance,
        distance: hit.t * ray.direction.length(),
        normal,
    }
}

/// Pass 2 for one camera ray: specular surfaces are ray traced (as the path tracer does, with
/// light sampling on glossy ones), and the first non-specular surface is shaded by `view`.
pub fn trace(
    ctx: &Context,
    maps: &PhotonMaps,
    view: View,
    camera_ray: Ray,
    rng: &mut Rng,
) -> CameraSample {
    let scene = ctx.scene;
    let mut out = CameraSample {
        depth: 1e10,
        ..CameraSample::default()
    };
    let mut p2 = Pass2 {
        ctx,
        maps,
        buf: Neighbors::default(),
        rays: 0,
    };
    let emission = matches!(view, View::Full | View::Global);
    let mut passes = Passes::default();
    // Non-specular (glossy) vertices on the camera chain so far.
    let mut diffuse = 0u32;
    let mut beta = Vec3::ONE;
    let mut ray = camera_ray;
    let mut prev_pdf = 0.0f32;
    let mut prev_delta = true;
    let mut prev_p = ray.origin;
    let mut absorption = Vec3::ZERO;
    for depth in 0..=ctx.max_depth {
        let visibility = if depth == 0 {
            Visibility::Camera
        } else {
            Visibility::Secondary
        };
        p2.rays += 1;
        let Some(hit) = ctx.accel.intersect(scene, &ray, visibility) else {
            if emission && !(depth == 0 && ctx.transparent_background) {
                ctx.lights.escaped(ray.direction, |le, light_pdf| {
                    let w = if prev_delta {
                        1.0
                    } else {
                        power_heuristic(prev_pdf, light_pdf)
                    };
                    passes.add(LightPass::after(diffuse), beta * le * w);
                });
            }
            break;
        };
        if absorption != Vec3::ZERO {
            beta *= (-absorption * (hit.t * ray.direction.length())).exp();
        }
        let s = Shading::new(ctx, &ray, &hit);
        if depth == 0 {
            out.hit = true;
            out.albedo = s.surface.base_color;
            out.normal = s.sh.frame.n;
            out.depth = hit.t * ray.direction.length();
        }
        let le = emitted_radiance(scene, &s.sh, s.wo);
        if emission && le != Vec3::ZERO {
            let w = if prev_delta {
                1.0
            } else {
                power_heuristic(prev_pdf, ctx.lights.triangle_pdf(prev_p, &s.sh))
            };
            passes.add(LightPass::after(diffuse), beta * le * w);
        }
        if depth == ctx.max_depth {
            break;
        }
        if stores_photons(&s.bsdf) {
            let mut l = Passes::default();
            match view {
                View::Full => l = p2.shade_full(&s, rng),
                View::Global => l.add(LightPass::Indirect, p2.global(&s)),
                View::Caustic => l.add(LightPass::Caustic, p2.caustic(&s)),
                View::Photons => l.add(LightPass::Indirect, p2.dots(&s)),
            };
            passes.add_after(&l, beta, diffuse);
            break;
        }
        // A glossy-only surface: light sampling with MIS, as in the path tracer.
        let glossy_nee = view == View::Full && s.bsdf.has_non_delta();
        if glossy_nee {
            passes.add(
                LightPass::after(diffuse + 1),
                beta * p2.direct(&s, true, rng),
            );
        }
        let Some((bs, wi)) = s.sample(rng.uniform(), rng.uniform2()) else {
            break;
        };
        beta *= bs.weight;
        if beta == Vec3::ZERO || !beta.is_finite() {
            break;
        }
        if !bs.delta {
            diffuse += 1;
        }
        prev_pdf = bs.pdf;
        prev_delta = bs.delta || !glossy_nee;
        prev_p = s.sh.p;
        absorption = s.absorption_after(&bs, wi, absorption);
        ray = s.sh.spawn(wi);
        if depth >= 3 {
            let q = max_component(beta).min(1.0);
            if q < 1.0 {
                if rng.uniform() >= q {
                    break;
                }
                beta /= q;
            }
        }
    }
    out.radiance = passes.total();
    out.passes = passes;
    out.rays = p2.rays;
    out
}
