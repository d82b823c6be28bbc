//! The scene planner: "skip what a scene doesn't need". Before rendering, `plan`
//! looks at the scene (materials by kind, lights by kind, bounds) and decides which passes are
//! worth their cost, with the reason for each decision, the method `auto` uses, the sample and
//! photon budgets of a quality preset, and an estimate of the memory the render needs.
//!
//! The plan is plain data; `Display` prints it for `photon info`. The rules are a first version,
//! deliberately simple and conservative (a pass is skipped only when it provably adds nothing):
//!
//! - **caustic map**: needed when a mesh uses a material with a delta or near-specular lobe
//!   (perceptual roughness below `SPECULAR_ROUGHNESS`), or a dielectric without a Lambertian
//!   part at any roughness (`classify`), and the scene has a light. Whether light
//!   actually reaches that surface is not traced yet.
//! - **global map + final gather**: needed when indirect diffuse light is possible: there is a light,
//!   some mesh has a non-black diffuse material, and the geometry is not a single convex mesh lit
//!   only from outside (light leaving a convex surface never meets the scene again).
//! - **subsurface**: needed when a mesh uses a translucent material of Subsurface Method
//!   Christensen–Burley and the scene has a light: the photon method then traces subsurface
//!   photons and evaluates the dipole (`integrator::photon::subsurface`). Random Walk materials
//!   (Blender's default) need no pass: both methods walk them (`integrator::random_walk`).
//! - **method for `auto`**: no light → the path tracer (there is nothing to trace: the image is
//!   the background); Christensen–Burley materials → photon mapping (subsurface photons); otherwise,
//!   when caustics or indirect light are possible, two pilots measure them and predict both
//!   methods' cost at the render's budget (`Cost`, in rays): photon mapping when the caustics
//!   of lamps and emitting meshes carry a visible share of what the camera sees
//!   (`HARD_CAUSTIC_SHARE_FOR_PHOTONS`; caustics are where path tracing is noisiest) and the
//!   photon method costs at most `CAUSTIC_COST_RATIO` times the path tracer, or when much of
//!   the reflected light in a small path-traced image is indirect (`INDIRECT_SHARE_FOR_PHOTONS`)
//!   and the photon method should reach less error in the render's time
//!   (`Cost::photons_win`), the path tracer otherwise. The photons scale with the samples
//!   per pixel and the square root of the pixels, at most 5000 per sample per pixel
//!   (`photon_share`), the volume photons too. Scenes with participating media are
//!   planned alike: their light samples in media are the same in both methods, the photon
//!   method trades the noise of indirect light for its maps, and volume photons are traced only
//!   where camera paths gather them (`stores_volume_photons`).

use crate::accel::Accel;
use crate::integrator::classify::{bsdf_is_specular, classifying_bsdf};
use crate::integrator::photon::settings::PhotonSettings;
use crate::integrator::photon::tracing::stores_volume_photons;
use crate::math::Vec3;
use crate::render::{photon_growth, Method, GENERATION_SPP};
use crate::scene::{Bounds, Light, Mesh, Scene};
use std::fmt;

/// Stored photon record size (position, RGBE power, packed direction, flags).
pub const PHOTON_BYTES: u64 = 20;
/// Acceleration structure bytes per triangle (vertices, ids, flags and about two BVH nodes).
pub const BVH_BYTES_PER_TRIANGLE: u64 = 128;
/// Film bytes per pixel: RGBA, albedo, normal (f32) and depth.
pub const IMAGE_BYTES_PER_PIXEL: u64 = 44;
/// Bytes per subsurface sample (position, flux, material) and its share of the octree; about
/// one sample per emitted subsurface photon.
const SUBSURFACE_SAMPLE_BYTES: u64 = 40;
/// Photons stored per emitted global photon (one per diffuse bounce; a rough average).
const GLOBAL_STORED_PER_EMITTED: u64 = 3;
/// Largest (faces × vertices) product for which the convexity test is run.
const CONVEXITY_TEST_LIMIT: usize = 20_000_000;

/// A quality preset: what a user asks for instead of internal parameters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Quality {
    /// Quick look: few samples and photons.
    Preview,
    /// The default.
    #[default]
    Default,
    /// Final frames: many samples and photons.
    Final,
}

impl Quality {
    /// Camera samples per pixel.
    pub fn spp(self) -> u32 {
        match self {
            Quality::Preview => 16,
            Quality::Default => 64,
            Quality::Final => 256,
        }
    }

    /// Factor applied to the default photon counts.
    pub fn photon_scale(self) -> f32 {
        match self {
            Quality::Preview => 0.25,
            Quality::Default => 1.0,
            Quality::Final => 4.0,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Quality::Preview => "preview",
            Quality::Default => "default",
            Quality::Final => "final",
        }
    }
}

/// Materials used by meshes, by kind. A material counts once per kind it has (a diffuse base
/// with a smooth coat is diffuse and specular); unused materials are not counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MaterialKinds {
    pub used: usize,
    /// A Lambertian part with non-zero reflectance.
    pub diffuse: usize,
    /// Rough metal or glass lobes without a diffuse part (shaded from the photon maps).
    pub glossy: usize,
    /// A delta or near-specular lobe (mirror, smooth glass or smooth coat): casts caustics.
    pub specular: usize,
    /// Of the specular ones, those that refract.
    pub refractive: usize,
    pub emissive: usize,
    /// Translucent materials (subsurface weight > 0).
    pub translucent: usize,
    /// Of those, the Christensen–Burley ones (the photon method's dipole).
    pub dipole: usize,
    /// Non-emissive materials that reflect nothing.
    pub black: usize,
    /// Materials with a volume (a medium inside their objects), and of those the
    /// heterogeneous ones (a node tree evaluated at points).
    pub volumes: usize,
    pub heterogeneous_volumes: usize,
}

/// Emitters by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LightKinds {
    pub emissive_triangles: usize,
    pub point: usize,
    pub spot: usize,
    pub sun: usize,
    /// The world background emits (non-black colour).
    pub world: bool,
}

impl LightKinds {
    pub fn any(&self) -> bool {
        self.emissive_triangles + self.point + self.spot + self.sun > 0 || self.world
    }
}

/// What the scene holds.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneSummary {
    pub meshes: usize,
    pub triangles: usize,
    pub materials: MaterialKinds,
    pub lights: LightKinds,
    pub bounds: Bounds,
    /// The world's volume: "homogeneous", "heterogeneous" or none.
    pub world_volume: Option<&'static str>,
}

/// Whether a pass runs, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Decision {
    pub needed: bool,
    pub reason: String,
}

impl Decision {
    fn new(needed: bool, reason: impl Into<String>) -> Self {
        Decision {
            needed,
            reason: reason.into(),
        }
    }
}

/// Estimated memory of a render, in bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MemoryEstimate {
    pub photon_maps: u64,
    pub bvh: u64,
    pub image: u64,
}

impl MemoryEstimate {
    pub fn total(&self) -> u64 {
        self.photon_maps + self.bvh + self.image
    }
}

/// The render plan of one scene at one quality.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    pub summary: SceneSummary,
    pub quality: Quality,
    /// False when the scene has no light at all: the image is the background.
    pub anything_to_trace: bool,
    pub caustic_map: Decision,
    pub global_map: Decision,
    /// Ward's irradiance cache for the photon method's indirect light (`--irradiance-cache`).
    pub irradiance_cache: Decision,
    pub subsurface: Decision,
    /// Share of the light the camera sees on surfaces that is a caustic of lamps or emitting
    /// meshes, from the pilot (0 when no pilot ran).
    pub caustic_share: f32,
    /// The method `--method auto` renders with, and why.
    pub method: Method,
    pub method_reason: String,
    /// Emission rays per camera sample (`RenderSettings::emission_rays`), from the pilot's
    /// share of noise in emission seen directly; 0 without a pilot.
    pub emission_rays: u32,
    pub spp: u32,
    /// Photon settings for the photon method; counts are zero for skipped maps.
    pub photon: PhotonSettings,
    /// Search radii in scene units (the settings hold fractions of the scene's bounding radius).
    pub global_radius: f32,
    pub caustic_radius: f32,
    /// Estimated memory for `width`×`height`, as given to `plan_for_image`.
    pub memory: MemoryEstimate,
    pub width: u32,
    pub height: u32,
}

/// How one material behaves, from its factors (textures at UV 0; roughness textures count as
/// smooth so a textured mirror is not missed).
struct MaterialTraits {
    diffuse: bool,
    glossy: bool,
    specular: bool,
    refractive: bool,
    emissive: bool,
}

fn material_traits(scene: &Scene, index: usize) -> Option<MaterialTraits> {
    let material = scene.materials.get(index)?;
    let bsdf = classifying_bsdf(scene, index as u32);
    let specular = bsdf_is_specular(&bsdf);
    let diffuse = bsdf
        .viewed_from(Vec3::Z)
        .diffuse_reflectance()
        .max_element()
        > 0.0;
    Some(MaterialTraits {
        diffuse,
        glossy: bsdf.has_specular() && !specular && !diffuse,
        specular,
        refractive: specular && bsdf.is_transmissive(),
        emissive: material.is_emissive(),
    })
}

fn used_materials(scene: &Scene) -> Vec<usize> {
    let mut used: Vec<usize> = scene
        .meshes
        .iter()
        .chain(&scene.prototypes)
        .map(|m| m.material as usize)
        .collect();
    used.sort_unstable();
    used.dedup();
    used
}

fn summarise(scene: &Scene) -> SceneSummary {
    let mut materials = MaterialKinds::default();
    for index in used_materials(scene) {
        let Some(t) = material_traits(scene, index) else {
            continue;
        };
        materials.used += 1;
        materials.diffuse += t.diffuse as usize;
        materials.glossy += t.glossy as usize;
        materials.specular += t.specular as usize;
        materials.refractive += t.refractive as usize;
        materials.emissive += t.emissive as usize;
        materials.translucent += scene.materials[index].is_translucent() as usize;
        materials.dipole += scene.materials[index].uses_dipole() as usize;
        materials.black += (!t.emissive && !t.diffuse && !t.glossy && !t.specular) as usize;
        if let Some(volume) = &scene.materials[index].volume {
            materials.volumes += 1;
            materials.heterogeneous_volumes += volume.constant.is_none() as usize;
        }
    }
    let mut lights = LightKinds {
        world: scene.world.emits(),
        ..LightKinds::default()
    };
    for mesh in &scene.meshes {
        if scene
            .materials
            .get(mesh.material as usize)
            .is_some_and(|m| m.is_emissive())
        {
            lights.emissive_triangles += mesh.indices.len();
        }
    }
    for instance in &scene.instances {
        let mesh = &scene.prototypes[instance.prototype as usize];
        if scene.materials[mesh.material as usize].is_emissive() {
            lights.emissive_triangles += mesh.indices.len();
        }
    }
    for light in &scene.lights {
        match light {
            Light::Point { .. } => lights.point += 1,
            Light::Spot { .. } => lights.spot += 1,
            Light::Sun { .. } => lights.sun += 1,
        }
    }
    SceneSummary {
        meshes: scene.meshes.len(),
        triangles: scene.triangle_count(),
        materials,
        lights,
        bounds: scene.bounds(),
        world_volume: scene.world.volume.as_ref().map(|v| {
            if v.constant.is_some() {
                "homogeneous"
            } else {
                "heterogeneous"
            }
        }),
    }
}

/// True when every vertex of `mesh` lies on or behind the plane of every face (a closed or open
/// convex surface). Scale-aware tolerance; `None` when the test would be too slow.
fn is_convex(mesh: &Mesh) -> Option<bool> {
    if mesh.indices.len().saturating_mul(mesh.positions.len()) > CONVEXITY_TEST_LIMIT {
        return None;
    }
    let mut bounds = Bounds::EMPTY;
    mesh.positions.iter().for_each(|&p| bounds.grow(p));
    let tolerance = 1e-4 * bounds.diagonal();
    let mut sides = (false, false);
    for tri in &mesh.indices {
        let [a, b, c] = tri.map(|i| mesh.positions.get(i as usize).copied());
        let (Some(a), Some(b), Some(c)) = (a, b, c) else {
            return Some(false);
        };
        let normal = (b - a).cross(c - a).normalize_or_zero();
        if normal == Vec3::ZERO {
            continue;
        }
        for &p in &mesh.positions {
            let d = normal.dot(p - a);
            sides.0 |= d > tolerance;
            sides.1 |= d < -tolerance;
            // Consistent winding is not guaranteed, so a face may see everything on either side,
            // but one face seeing vertices on both sides proves a concavity.
            if sides.0 && sides.1 {
                return Some(false);
            }
        }
        sides = (false, false);
    }
    Some(true)
}

/// True when a point or spot light sits inside `bounds` (so it may light the inside of a shell).
fn light_inside(scene: &Scene, bounds: &Bounds) -> bool {
    scene.lights.iter().any(|l| match l {
        Light::Point { position, .. } | Light::Spot { position, .. } => {
            position.cmpge(bounds.min).all() && position.cmple(bounds.max).all()
        }
        Light::Sun { .. } => false,
    })
}

fn caustic_decision(summary: &SceneSummary) -> Decision {
    let m = &summary.materials;
    if !summary.lights.any() {
        Decision::new(false, "no light: nothing to focus")
    } else if m.specular == 0 {
        Decision::new(
            false,
            "no mirror, smooth glass or smooth coat: light cannot be focused",
        )
    } else {
        Decision::new(
            true,
            format!(
                "{} specular material(s) ({} refractive) and a light: caustics possible",
                m.specular, m.refractive
            ),
        )
    }
}

fn global_decision(scene: &Scene, summary: &SceneSummary) -> Decision {
    let m = &summary.materials;
    if !summary.lights.any() {
        return Decision::new(false, "no light: no indirect light");
    }
    if m.diffuse == 0 {
        return Decision::new(
            false,
            "no diffuse surface: indirect light has nothing to land on",
        );
    }
    if let ([mesh], true) = (scene.meshes.as_slice(), scene.instances.is_empty()) {
        let self_lit = m.emissive > 0 || light_inside(scene, &summary.bounds);
        if !self_lit && is_convex(mesh) == Some(true) {
            return Decision::new(
                false,
                "a single convex object lit from outside: light never bounces back onto it",
            );
        }
    }
    Decision::new(
        true,
        format!(
            "{} diffuse material(s) and a light: indirect diffuse light possible",
            m.diffuse
        ),
    )
}

/// How many times the final gather's rays `auto` lets the irradiance cache spend. A record
/// costs `--ic-gather-rays` (256) where final gathering costs a few rays per camera sample, so
/// a scene needing many records (the Cornell box's corners: 0.1 per pixel at 128 px) is cheaper
/// without most of them at a few samples, and one needing few (the furnace: 0.008 per pixel)
/// gains from the cache at any count. The build stops before a level of records that would
/// pass the budget; the points its records cover take their indirect light from the cache,
/// the others gather it. Swept with `photon-ic` at 1–16 spp (5000 photons per spp, one
/// thread) against 4096-spp path references, relMSE × seconds (lower is better) at budgets of
/// 0 (no cache), ½, 1, 1½, 2, 3 × and unlimited: 1 × was best or within the noise of the best on
/// the Cornell box (1 spp 0.0067 against 0.0083 without the cache and 0.019 for the whole
/// cache; 4 spp 0.0050 / 0.0097 / 0.0061), the fractal Cornell box (4 spp 0.0058 / 0.0084 /
/// 0.016) and the furnace (the whole cache from 1 spp); the window-lit interior, where the
/// cache brings speed rather than accuracy, ties at low counts.
pub const CACHE_RAYS_PER_GATHER_RAY: f32 = 1.0;

/// The irradiance cache's gather rays per pixel for `auto` at `spp` samples per pixel of
/// `gather_rays` final-gather rays each.
pub fn cache_ray_budget(spp: u32, gather_rays: u32) -> f32 {
    // Each generation of `GENERATION_SPP` samples builds its own cache.
    CACHE_RAYS_PER_GATHER_RAY * spp.min(GENERATION_SPP) as f32 * gather_rays as f32
}

/// Gather rays per irradiance record for `auto`, per camera sample per pixel of a generation:
/// a record's noise is read by every pixel it covers, in every sample, so it need only stay
/// below the pixels' own noise, which falls as the samples grow. The count grows with the
/// samples from `MIN_CACHE_GATHER_RAYS` to the cache's default (256) at 32 spp. Measured with
/// `photon-ic` on the Cornell box at 256 px (5000 photons per spp, against a 4096-spp path
/// reference; docs/bench/photon_method.md, "Gather rays per record"): 64 rays instead of 256
/// cost +2 % relMSE at 4 spp, +8 % at 8 and +22 % at 16, for a quarter of the cache's time,
/// which at 8 spp is half the render's.
const CACHE_GATHER_RAYS_PER_SAMPLE: u32 = 8;
const MIN_CACHE_GATHER_RAYS: u32 = 64;

/// The irradiance cache's gather rays per record for `auto` at `spp` samples per pixel, at most
/// `full` (the cache's setting).
pub fn cache_gather_rays(spp: u32, full: u32) -> u32 {
    (CACHE_GATHER_RAYS_PER_SAMPLE * spp.min(GENERATION_SPP))
        .clamp(MIN_CACHE_GATHER_RAYS.min(full), full)
}

/// Samples per pixel of a generation from which `auto` places irradiance records as densely as
/// the cache's settings say; below, Ward's accuracy and the smallest record spacing grow as
/// √(`DENSE_CACHE_SPP` / spp), up to `COARSE_CACHE_FACTOR` times: with a few samples the
/// records' interpolation error hides under the pixels' noise. `photon-ic` at 4 and 8 spp,
/// accuracy 0.3 and spacing 5 px against 0.2 and 3 px (docs/bench/photon_method.md, "Coarser
/// records at a few samples"): the Cornell box at 256 px 1338 records instead of 2954, −50 ms,
/// relMSE +2 % / +6 %; at 96 px the window-lit room +1 % for −7..−12 % time, the interior
/// +0.4 / +3 % for −11 %, the fractal Cornell box +0.2 / +1 % for −32 %.
const DENSE_CACHE_SPP: f32 = 16.0;
const COARSE_CACHE_FACTOR: f32 = 1.5;
const COARSE_CACHE_SPACING_FACTOR: f32 = 5.0 / 3.0;

/// Ward's accuracy and the smallest record spacing (pixels) for `auto` at `spp` samples per
/// pixel, from the cache's settings `accuracy` and `min_spacing`.
pub fn cache_density(spp: u32, accuracy: f32, min_spacing: f32) -> (f32, f32) {
    let coarse = (DENSE_CACHE_SPP / spp.clamp(1, GENERATION_SPP) as f32).sqrt();
    (
        accuracy * coarse.clamp(1.0, COARSE_CACHE_FACTOR),
        min_spacing * coarse.clamp(1.0, COARSE_CACHE_SPACING_FACTOR),
    )
}

/// The pilots at full size: photons of each of the caustic pilot's two passes (global, and
/// aimed at the specular meshes), and the path-traced image's width in pixels (the height
/// follows the aspect ratio) and samples per pixel: 4096 paths for a square image.
const PILOT_PHOTONS: u32 = 4096;
const PILOT_WIDTH: u32 = 32;
const PILOT_SPP: u32 = 4;

/// The photon pilots shrink on small renders, to about this many of the render's camera samples
/// per pilot photon, down to `MIN_PILOT_SCALE` of their full size: at full size the pilots cost
/// about a quarter of a 128-pixel render at 1 spp (the furnace: 0.05 s of 0.20 s). At a quarter
/// (1024 photons) the shares still decide every scene in scenes/ and the gallery as at full
/// size (tests/integration/plan.rs).
const RENDER_SAMPLES_PER_PILOT_SAMPLE: f32 = 32.0;
pub const MIN_PILOT_SCALE: f32 = 0.25;

/// The fraction of the full pilots run for a render of `render_samples` camera samples.
fn pilot_scale(render_samples: u64) -> f32 {
    let full = (PILOT_WIDTH * PILOT_WIDTH * PILOT_SPP) as f32;
    (render_samples as f32 / (RENDER_SAMPLES_PER_PILOT_SAMPLE * full)).clamp(MIN_PILOT_SCALE, 1.0)
}

/// Share of the pilot image's reflected light that is indirect (averaged over pixels) above
/// which `auto` picks photon mapping with the irradiance cache. Measured with `photon bench`
/// (docs/bench): the Cornell box (0.52), the furnace (0.48) and the window-lit interior (0.74)
/// render to a lower error at equal time with photons + cache; lights.glb (0.07) and
/// materials.glb (0.12), lit mostly directly, render faster with the path tracer.
const INDIRECT_SHARE_FOR_PHOTONS: f32 = 0.3;

/// Share of the light the camera sees on surfaces that is a caustic of a lamp or an emitting
/// mesh, above which `auto` renders with the caustic map. glass_caustic (3.4 %), the cognac
/// glass (5.7 %), the other gallery caustic scenes (5–20 %) and the open mirror ring of
/// scenes/blender (1.9 %: against a photon-method reference that resolves its small lamp's
/// caustic, photon-ic reaches relMSE 0.0053 in 0.10 s where the path tracer stalls near 0.008,
/// docs/bench/caustics_photon_reference_48px) lie above; materials.glb (0.3 %: the sun's
/// caustic under its glass ball, hidden from the camera) and the glass cube (0.7 %: its
/// caustic is seen only through the glass) below.
const HARD_CAUSTIC_SHARE_FOR_PHOTONS: f32 = 0.01;

/// A photon ray's share of the photon method's preparation, in path-tracer rays: tracing,
/// the kd-trees, the precomputed irradiance and the irradiance cache together, per ray of
/// photon tracing. Measured on the Cornell box at 64 px and 64 spp (preparation 1.55 s for
/// 563 000 photon rays; the path tracer's render 0.87 s for 1.39 million rays).
const PREPARATION_PER_PHOTON_RAY: f32 = 4.0;

/// The photon method's camera sample (direct light, a cache or map lookup, the first bounce)
/// against a path-traced one, in time: 0.45 s against 0.87 s on the Cornell box at 64 px.
const PHOTON_SAMPLE_COST: f32 = 0.5;

/// The photon method's relMSE at equal samples per pixel is taken as `NOISE_LEFT_SCALE` ×
/// `PilotShares::noise_left` + `NOISE_LEFT_FLOOR` times the path tracer's: the noise it
/// leaves, and its own noise and bias from the maps and the cache. Fitted to `photon bench` at
/// 48 px on the Cornell boxes, a window-lit room, the furnace and an interior
/// (docs/bench/planner.md, "The planner's cost rule"); the ratio grows with the samples on
/// scenes of fine detail, whose photon-method bias then rules.
const NOISE_LEFT_SCALE: f32 = 1.5;
const NOISE_LEFT_FLOOR: f32 = 0.1;

/// The budget for which `auto` traces the preset's photons: `FULL_PHOTON_SPP` samples per
/// pixel of a generation on an image of `FULL_PHOTON_PIXELS` (the window-lit rooms of
/// `tests/blender` at 48 px and 64 spp need the preset's photons). Other budgets trace the
/// preset's photons times spp / `FULL_PHOTON_SPP` × √(pixels / `FULL_PHOTON_PIXELS`), at most
/// `MAX_PHOTON_SHARE_PER_SPP` × spp, between `MIN_PHOTON_SHARE` and 1 (`photon_share`).
///
/// Why the samples count fully and the pixels by their square root: the photon maps' error in
/// a pixel (the blotches of their density estimates, read through the records and gather rays)
/// falls as 1/photons whatever the image's size, and the camera samples' as 1/spp, while a
/// photon costs the same at any size and a sample per pixel costs as many camera paths as the
/// image has pixels. Error a/photons + b/spp at cost c·photons + d·pixels·spp is least for
/// photons ∝ spp·√pixels. Counting the pixels fully traced 200 000 photons at 256 px from 3 spp
/// on, where the Cornell box's preparation took twice its camera samples' time. The cap: past
/// 5000 photons per sample per pixel the Cornell box at 256 px and 2–4 spp gains 2–3 % relMSE
/// for 13–24 % more time (docs/bench/cornell_and_methods.md, "Preparation sized to the
/// budget"), so the maps follow the samples alone there, as `photon bench`'s budgets scale them.
const FULL_PHOTON_SPP: f32 = 64.0;
const FULL_PHOTON_PIXELS: f32 = 48.0 * 48.0;
const MAX_PHOTON_SHARE_PER_SPP: f32 = 1.0 / 40.0;
const MIN_PHOTON_SHARE: f32 = 0.05;

/// The share of the preset's photons `auto` traces per generation for a `pixels` image at `spp`
/// samples per pixel (`FULL_PHOTON_SPP`).
pub fn photon_share(pixels: f32, spp: u32) -> f32 {
    let spp = spp.min(GENERATION_SPP) as f32;
    let balanced = spp / FULL_PHOTON_SPP * (pixels / FULL_PHOTON_PIXELS).sqrt();
    balanced
        .min(MAX_PHOTON_SHARE_PER_SPP * spp)
        .clamp(MIN_PHOTON_SHARE, 1.0)
}

/// Caustics of lamps and emitting meshes, which the path tracer finds by chance or never: the
/// photon method renders them unless it costs more than this many times the path tracer's
/// render. The path tracer's error then falls slower than its time grows (rare bright paths);
/// at 48 px, the gallery's caustic scenes cost the photon method 4–6 times the path tracer and
/// render to far less error, except at 4 spp, where the path tracer's noise exceeds the light it
/// misses on three of eight (docs/bench/planner.md, "The planner's cost rule").
const CAUSTIC_COST_RATIO: f32 = 16.0;

/// Emission rays per camera sample of the photon method when the camera sees emitters, and the
/// least share of the path-traced pilot's noise in emission seen directly that counts as
/// seeing them. The photon method leaves little noise but the edges of what the camera sees
/// emit (its camera samples are Sobol points, which smooth light integrals far better than
/// edges), and its preparation outweighs its camera samples, so emission rays cost it little:
/// `photon-ic` at 8 spp and 96 px, 3 rays against none (docs/bench/photon_method.md, "Emission
/// rays"): the Cornell box relMSE 0.0145 → 0.0020 for 10 % more CPU time, the fractal Cornell
/// box 0.0192 → 0.0029 for 8 %, Cornell spheres (16 spp, 48 px) 0.071 → 0.057; scenes whose
/// error is elsewhere (the interior: seen share 1.1 %; sphereflake, glossy caustic) unchanged
/// for 5–10 %. The path tracer, whose noise is everywhere, gained nothing on materials.glb and
/// 1.3× on the Cornell box at 96 px for 35–50 % more time: it traces none. The method is
/// chosen without them (counting their cost but not their gain turned the Cornell box at 64 px
/// and 64 spp to the path tracer, 4× the error).
/// Their gain shrinks with the samples while their share of the time grows: on the Cornell box
/// at 256 px, relMSE ÷ 2.5 at 16 spp and ÷ 1.6 at 32 for +40 % CPU time, and at 64 px and 64 spp
/// ÷ 1.25 for +45 %, so only renders of at most `EMISSION_RAYS_MAX_SPP` get them, unless the
/// emitters cover at most `EMISSION_RAYS_FEW_PIXELS` of the image: only pixels that may see
/// one trace them (`EmitterPixels`), and then they cost little (docs/bench/photon_method.md,
/// "Emission rays where an emitter can be seen"), so then any emission the pilot sees directly
/// earns them: a lamp seen edge-on under a ceiling is a strip a pixel high in the 32-pixel
/// pilot, whose share of the noise (1 % on a Blender-built Cornell box) says little of its
/// edges' share at 256 px (docs/bench/cornell_and_methods.md, "Emission rays for a lamp seen
/// edge-on"). Pixels that may see an emitter only by way of smooth mirrors and glass earn them
/// the same way when they are few, whatever the pilot saw: a lamp hidden from the camera whose
/// image in a glass sphere covers a few pixels is met by no ray of the small pilot
/// (docs/bench/volumes.md, "Emission rays and Filter Glossy in glass_fog").
const PHOTON_EMISSION_RAYS: u32 = 3;
const SEEN_SHARE_FOR_EMISSION_RAYS: f32 = 0.02;
const EMISSION_RAYS_MAX_SPP: u32 = 32;
const EMISSION_RAYS_FEW_PIXELS: f64 = 0.25;

/// The share of a `width` × `height` image whose pixels may see an emitter itself, or with
/// `mirrors` also by way of smooth mirrors and glass (`EmitterPixels`, with the scene's pixel
/// filter).
fn emitter_pixel_share(
    scene: &Scene,
    accel: &Accel,
    width: u32,
    height: u32,
    mirrors: bool,
) -> f64 {
    use crate::camera::CameraRays;
    use crate::emitter_pixels::EmitterPixels;
    use crate::integrator::Context;
    use crate::light::Lights;
    let lights = Lights::new(scene);
    let ctx = Context {
        scene,
        accel,
        lights: &lights,
        max_depth: 0,
        transparent_background: scene.render_settings.transparent_film,
    };
    let camera = CameraRays::new(&scene.camera, width, height);
    let radius = scene.render_settings.filter.unwrap_or_default().radius();
    EmitterPixels::new(&ctx, &camera, radius, (width, height), mirrors).share()
}

/// The predicted cost of a render, in path-tracer rays, from the pilots.
#[derive(Clone, Copy, Debug)]
struct Cost {
    /// The path tracer's render.
    path: f32,
    /// The photon method's render, preparation included.
    photon: f32,
    /// The photon method's preparation: photon tracing, maps and caches of every generation.
    preparation: f32,
}

impl Cost {
    /// For `samples` camera samples at `spp` per pixel, with `photons` emitted per generation
    /// (global and caustic).
    fn predict(shares: &PilotShares, samples: u64, spp: u32, photons: f32) -> Cost {
        let path = samples as f32 * shares.rays_per_path.max(1.0);
        let generations = spp.div_ceil(GENERATION_SPP);
        let growth: f32 = (0..generations).map(photon_growth).sum();
        let preparation =
            photons * growth * shares.rays_per_photon.max(1.0) * PREPARATION_PER_PHOTON_RAY;
        Cost {
            path,
            photon: preparation + PHOTON_SAMPLE_COST * path,
            preparation,
        }
    }

    /// Whether the photon method reaches less error than the path tracer in its own time, the
    /// path tracer's relMSE falling as 1/time.
    fn photons_win(&self, shares: &PilotShares) -> bool {
        let error_ratio = NOISE_LEFT_SCALE * shares.noise_left + NOISE_LEFT_FLOOR;
        error_ratio * self.photon < self.path
    }
}

/// What the pilots measure of a scene's light.
#[derive(Clone, Copy, Debug)]
struct PilotShares {
    /// Per-pixel fraction of the reflected light (all but emission seen directly) that is
    /// indirect, averaged over the pixels of a small path-traced image: relMSE weighs every
    /// pixel alike, so a window-lit room whose sunny patches carry most of the power but
    /// cover little of the image counts as indirect-lit.
    indirect: f32,
    /// Power of the caustic photons (light → specular+ → diffuse) of lights other than the
    /// world, as a fraction of the global photons' power, both counted where the camera sees
    /// them (`seen_by_camera`: directly or through slabs of glass): the caustics a path tracer finds only by chance (a small light seen
    /// through glass) or never (a point, spot or sun light). It finds the world's caustics by
    /// BSDF sampling, as it finds any sky light. Zero when no mesh is specular.
    hard_caustic: f32,
    /// Share of the global pilot photons stored where the camera sees them; 1 when no
    /// global pilot ran. Small when most of the light lands where the camera does not look (a
    /// room lit by the sun through a window, the sun's photons spread over the ground outside).
    seen: f32,
    /// Photons of each caustic pilot pass.
    photons: u32,
    /// Rays the path tracer casts per camera sample (closest-hit and shadow), in the pilot image.
    rays_per_path: f32,
    /// Of a path-traced pixel's relative variance (averaged over the pilot image's pixels), the
    /// share that is not indirect light: the noise left when photon maps and the cache carry the
    /// indirect light smoothly. The light media scatter straight from the lights counts with the
    /// noise the photon method's light samples along each segment leave in it, not the path
    /// tracer's free flights'. 1 without a pilot image.
    noise_left: f32,
    /// The share of that variance that is emission the camera sees directly: the edges of lamps,
    /// windows, emitting screens against what lies around them, which emission rays average
    /// (`RenderSettings::emission_rays`).
    noise_seen: f32,
    /// Rays cast per emitted global photon in the pilot (its emission and one per stored
    /// photon); 0 when no global pilot ran.
    rays_per_photon: f32,
}

/// Most smooth transmissive surfaces (`seen_by_camera`) a segment to the eye may cross.
const MAX_GLASS_CROSSINGS: u32 = 8;

/// Least |cos| between the faces where a segment enters and leaves glass for the glass to count
/// as a flat slab (`seen_by_camera`).
const SLAB_COS: f32 = 0.999;

/// A test of whether the camera sees a surface point `p` (normal `n`): inside the view of an
/// image of aspect ratio `aspect`, with nothing on the straight segment to the eye but slabs
/// of smooth glass (the renderers ray trace it and never estimate from photons), entered and
/// left through parallel faces. Behind such a slab a point is seen where it lies, shifted
/// sideways: the caustic under a glass cube. Curved glass (a ball) shows another place
/// altogether, so it occludes: measured on materials.glb, whose sun caustic under a glass
/// ball the path tracer renders at a quarter of photon mapping's error at equal time.
fn seen_by_camera<'a>(
    ctx: &'a crate::integrator::Context<'a>,
    aspect: f32,
) -> impl Fn(Vec3, Vec3) -> bool + 'a {
    use crate::accel::Visibility;
    use crate::integrator::classify::stores_photons;
    use crate::integrator::shading::Shading;
    use crate::scene::Projection;
    let (scene, accel) = (ctx.scene, ctx.accel);
    let camera = &scene.camera;
    let to_camera = camera.to_world.inverse();
    let lift = 1e-4 * scene.bounds().diagonal().max(1e-6);
    move |p: Vec3, n: Vec3| {
        let q = to_camera.transform_point3(p);
        let (x, y, eye) = match camera.projection {
            Projection::Perspective { yfov } => {
                let h = (0.5 * yfov).tan() * -q.z;
                (q.x / h, q.y / h, Vec3::ZERO)
            }
            Projection::Orthographic { ymag, .. } => {
                (q.x / ymag, q.y / ymag, q * Vec3::new(1.0, 1.0, 0.0))
            }
            // A panorama may see any direction: only occlusion decides.
            _ => (0.0, 0.0, Vec3::ZERO),
        };
        let behind = !(q.z < 0.0) && !camera.projection.is_panoramic();
        if behind || x.abs() > aspect || y.abs() > 1.0 {
            return false;
        }
        // A photon is stored on the side of its surface it arrived on (`n`): the eye must be
        // on that side (the sunlit top of a zero-thickness roof is not the ceiling the camera
        // sees). Lift p off its surface on that side, then test the segment to the eye.
        let eye = camera.to_world.transform_point3(eye);
        if n.dot(eye - p) <= 0.0 {
            return false;
        }
        let mut from = p + n * lift;
        // The normal of the face where the segment entered glass it has not left yet.
        let mut entered: Option<Vec3> = None;
        for _ in 0..=MAX_GLASS_CROSSINGS {
            let ray = crate::accel::Ray {
                origin: from,
                direction: eye - from,
                t_max: 1.0 - 1e-4,
                time: crate::accel::FRAME_TIME,
            };
            let Some(hit) = accel.intersect(scene, &ray, Visibility::Camera) else {
                return true;
            };
            let s = Shading::new(ctx, &ray, &hit, false);
            if s.opaque || stores_photons(&s.bsdf) {
                return false;
            }
            entered = match entered {
                None => Some(s.ng),
                Some(m) if m.dot(s.ng).abs() >= SLAB_COS => None,
                Some(_) => return false,
            };
            // Past the glass surface, on towards the eye.
            from = s.sh.spawn(ray.direction).origin;
        }
        false
    }
}

/// Run the pilots through `accel` (the scene's BVH) for an image of aspect ratio `aspect`: a
/// path-traced image of `PILOT_WIDTH` pixels across at `PILOT_SPP` (the indirect share is 0
/// unless `global`); when `global` or `caustics`, `scale` × `PILOT_PHOTONS` global photons, and
/// when `caustics` as many aimed caustic photons. Milliseconds; deterministic.
fn pilot_shares(
    scene: &Scene,
    accel: &Accel,
    aspect: f32,
    scale: f32,
    (global, caustics): (bool, bool),
) -> PilotShares {
    use crate::camera::CameraRays;
    use crate::integrator::photon::tracing::{trace_photon, Emitters, MapKind};
    use crate::integrator::{path, Context};
    use crate::light::{LightSource, Lights};
    use crate::light_pass::LightPass;
    use crate::math::{luminance, Vec2};
    use crate::photon_map::Photon;
    use crate::rng::Rng;
    use rayon::prelude::*;
    let lights = Lights::new(scene);
    let ctx = Context {
        scene,
        accel,
        lights: &lights,
        max_depth: 16,
        transparent_background: false,
    };

    let photon_count = (PILOT_PHOTONS as f32 * scale).round() as u32;
    // The path-traced pilot image, always at full size (its share of the noise decides close
    // cases): the indirect share, the rays per camera sample and how the noise splits between
    // indirect light and the rest.
    let width = PILOT_WIDTH;
    let height = ((width as f32 / aspect).round() as u32).max(1);
    let camera = CameraRays::new(&scene.camera, width, height);
    let media = scene.has_media();
    // The rows in parallel, each with its own random numbers, summed in order (the same plan
    // on any number of threads).
    let rows: Vec<PilotRow> = (0..height)
        .into_par_iter()
        .map(|y| {
            let mut rng = Rng::for_item(0x0f1a_7e59, y as u64, 0);
            let mut row = PilotRow::default();
            for x in 0..width {
                let (mut indirect, mut reflected) = (0.0f64, 0.0f64);
                // Sums and sums of squares of the pixel's samples: indirect light (on surfaces
                // and in media), emission seen directly, the light media scatter straight from
                // the lights towards the camera, the rest; and that light in media as the
                // photon method estimates it.
                let mut sums = [[0.0f64; 2]; 5];
                let (mut mean, mut other_mean) = (0.0, 0.0);
                for _ in 0..PILOT_SPP {
                    let film = Vec2::new(x as f32, y as f32) + rng.uniform2();
                    let camera_ray = camera.ray(film);
                    let sample = path::trace(&ctx, camera_ray, &mut rng);
                    row.rays += sample.rays as u64;
                    let pass = |p: LightPass| luminance(sample.passes.0[p as usize]) as f64;
                    indirect += pass(LightPass::Indirect);
                    reflected += pass(LightPass::Direct) + pass(LightPass::Indirect);
                    let whole = luminance(sample.radiance) as f64;
                    let seen = luminance(sample.seen_emission) as f64;
                    // With media, the pixel's mean is taken over both estimators' samples: a
                    // few path-traced samples that all miss a lit cone of fog would make the
                    // other's noise there look unbounded.
                    let (scattered, media_direct, segments) = match media {
                        true => {
                            let segments = path::trace_through_media(&ctx, camera_ray, &mut rng);
                            other_mean += luminance(segments.radiance) as f64;
                            let direct = LightPass::VolumeDirect as usize;
                            (
                                pass(LightPass::VolumeIndirect),
                                pass(LightPass::VolumeDirect),
                                luminance(segments.passes.0[direct]) as f64,
                            )
                        }
                        false => (0.0, 0.0, 0.0),
                    };
                    let indirect_light = pass(LightPass::Indirect) + scattered;
                    let rest = whole - indirect_light - seen - media_direct;
                    let parts = [indirect_light, seen, media_direct, rest, segments];
                    for (sum, v) in sums.iter_mut().zip(parts) {
                        *sum = [sum[0] + v, sum[1] + v * v];
                    }
                    mean += whole;
                }
                if reflected > 0.0 {
                    row.share_sum += indirect / reflected;
                    row.pixels += 1;
                }
                let n = PILOT_SPP as f64;
                mean /= n;
                if media {
                    mean = 0.5 * (mean + other_mean / n);
                }
                if mean > 0.0 {
                    let variance = |[sum, squares]: [f64; 2]| (squares - sum * sum / n).max(0.0);
                    for (noise, sum) in row.noise.iter_mut().zip(sums) {
                        *noise += variance(sum) / (mean * mean);
                    }
                }
            }
            row
        })
        .collect();
    let (mut share_sum, mut pixels, mut rays) = (0.0f64, 0u32, 0u64);
    // Relative variance of the pixels' indirect light, of the emission they see directly, of
    // the light media scatter straight from the lights (in the path tracer's free flights), of
    // the rest, and of that light in media in the photon method's light samples along each
    // segment, which it leaves.
    let mut noise = [0.0f64; 5];
    for row in &rows {
        share_sum += row.share_sum;
        pixels += row.pixels;
        rays += row.rays;
        for (total, n) in noise.iter_mut().zip(row.noise) {
            *total += n;
        }
    }
    let [noise_indirect, noise_seen, noise_media, noise_rest, noise_segments] = noise;
    let noise_total = noise_indirect + noise_seen + noise_media + noise_rest;
    let indirect = match global {
        true => (share_sum / pixels.max(1) as f64) as f32,
        false => 0.0,
    };
    let rays_per_path = rays as f32 / (width * height * PILOT_SPP) as f32;
    let (noise_left, noise_seen) = match noise_total > 0.0 {
        true => (
            ((noise_seen + noise_rest + noise_segments) / noise_total) as f32,
            (noise_seen / noise_total) as f32,
        ),
        false => (1.0, 0.0),
    };

    let mut shares = PilotShares {
        indirect,
        hard_caustic: 0.0,
        seen: 1.0,
        photons: photon_count,
        rays_per_path,
        noise_left,
        noise_seen,
        rays_per_photon: 0.0,
    };
    // Guided as the render's photons are, so that `seen` counts what the render will store.
    let emitters = Emitters::guided(&ctx, aspect, 0x0f1a_7e58);
    let caustics = caustics && emitters.has_caustic_targets();
    if !global && !caustics {
        return shares;
    }
    let seen = seen_by_camera(&ctx, aspect);
    let power = |photons: &[Photon]| -> f64 {
        let seen = photons.iter().filter(|p| seen(p.position(), p.normal()));
        seen.map(|p| luminance(p.power()) as f64).sum()
    };
    let mut rng = Rng::for_item(0x0f1a_7e57, 0, 0);
    let mut photons = Vec::new();
    let mut emitted = 0u32;
    for _ in 0..photon_count {
        if let Some(e) = emitters.emit(&ctx, false, &mut rng) {
            emitted += 1;
            trace_photon(&ctx, &e, MapKind::Global, 16, &mut rng, &mut photons);
        }
    }
    if emitted > 0 {
        shares.rays_per_photon = (emitted as usize + photons.len()) as f32 / emitted as f32;
    }
    if !photons.is_empty() {
        let in_view = photons
            .iter()
            .filter(|p| seen(p.position(), p.normal()))
            .count();
        shares.seen = in_view as f32 / photons.len() as f32;
    }
    if !caustics {
        return shares;
    }
    let total = power(&photons);
    photons.clear();
    for _ in 0..photon_count {
        if let Some(e) = emitters.emit(&ctx, true, &mut rng) {
            let world = e.light.map(|l| &lights.sources[l]);
            if !matches!(world, Some(LightSource::World { .. })) {
                trace_photon(&ctx, &e, MapKind::Caustic, 16, &mut rng, &mut photons);
            }
        }
    }
    if total > 0.0 {
        shares.hard_caustic = (power(&photons) / total) as f32;
    }
    shares
}

/// One row of the path-traced pilot image: its pixels' indirect shares, their relative
/// variances (indirect light, emission seen directly, light in media by free flights, the
/// rest, light in media by segment samples) and the rays it cast.
#[derive(Default)]
struct PilotRow {
    share_sum: f64,
    pixels: u32,
    noise: [f64; 5],
    rays: u64,
}

/// Share of the global photons that should land where the camera sees them; a scene whose
/// pilot shows fewer (`PilotShares::seen`) gets proportionally more global photons, up to
/// `MAX_GLOBAL_PHOTON_BOOST` times the preset's. The global map's noise in what the camera sees
/// follows the photons stored there: a window-lit room with 200 000 sun photons, most of them
/// outside, rendered with a mean ±1.5 % off from one seed to the next (docs/bench/README.md).
const SEEN_SHARE_FOR_FULL_PHOTONS: f32 = 0.1;
const MAX_GLOBAL_PHOTON_BOOST: f32 = 8.0;

/// How many times the preset's global photons a scene whose pilot saw `seen` of them gets.
fn global_photon_boost(seen: f32) -> f32 {
    (SEEN_SHARE_FOR_FULL_PHOTONS / seen.max(1e-6)).clamp(1.0, MAX_GLOBAL_PHOTON_BOOST)
}

/// The plan for a 640×480 image.
pub fn plan(scene: &Scene, quality: Quality) -> Plan {
    plan_for_image(scene, quality, 640, 480)
}

/// The plan for an image of `width`×`height` pixels (which only the memory estimate uses).
pub fn plan_for_image(scene: &Scene, quality: Quality, width: u32, height: u32) -> Plan {
    let accel = Accel::new(scene);
    plan_with_pilot(
        scene,
        quality,
        width,
        height,
        Some(Pilot::new(&accel, None)),
    )
}

/// How the planner's pilots run.
#[derive(Clone, Copy)]
pub struct Pilot<'a> {
    /// The scene's BVH, built once and shared with the render (a second of start-up on a
    /// million triangles).
    pub accel: &'a Accel,
    /// The render's samples per pixel; `None`: the quality preset's. With the image size, they
    /// are the budget the methods' costs are predicted for.
    pub spp: Option<u32>,
    /// The pilots' size as a fraction of their full size; `None`: from the render's camera
    /// samples (`pilot_scale`).
    pub scale: Option<f32>,
    /// Global and caustic photons per generation the render was given (`--photons`,
    /// `--caustic-photons`), which the photon method's predicted cost then counts; `None`: the
    /// plan's own.
    pub photons: [Option<u32>; 2],
}

impl<'a> Pilot<'a> {
    /// Pilots through `accel` for a render of `spp` samples per pixel, sized to the render.
    pub fn new(accel: &'a Accel, spp: Option<u32>) -> Self {
        Pilot {
            accel,
            spp,
            scale: None,
            photons: [None, None],
        }
    }
}

/// `plan_for_image`, with the pilots run as `pilot` says. Without it the auto method is not
/// measured where it would need the pilots: for renders whose method is given explicitly.
pub fn plan_with_pilot(
    scene: &Scene,
    quality: Quality,
    width: u32,
    height: u32,
    pilot: Option<Pilot>,
) -> Plan {
    let summary = summarise(scene);
    let anything_to_trace = summary.lights.any();
    let caustic_map = caustic_decision(&summary);
    let mut global_map = global_decision(scene, &summary);
    let (translucent, dipole) = (summary.materials.translucent, summary.materials.dipole);
    let subsurface = if translucent == 0 {
        Decision::new(false, "no translucent material")
    } else if dipole == 0 {
        Decision::new(
            false,
            format!("{translucent} translucent material(s), walked as Cycles' Random Walk by either method: no subsurface photons"),
        )
    } else if !anything_to_trace {
        Decision::new(false, "translucent materials but no light")
    } else {
        Decision::new(
            true,
            format!(
                "{dipole} Christensen–Burley material(s): dipole diffusion from subsurface photons (photon method; the path tracer walks them as Random Walk)"
            ),
        )
    };
    let volume_needed = stores_volume_photons(scene);
    let defaults = PhotonSettings::default();
    let scale = |count: u32| (count as f32 * quality.photon_scale()).round() as u32;
    // Global photons per preset photon, from the pilot's share seen by the camera.
    let mut global_boost = 1.0;
    // The share of the preset's photons the render's budget calls for.
    let mut budget_share = 1.0;
    let mut caustic_share = 0.0;
    let mut emission_rays = 0;
    let (method, method_reason) = if !anything_to_trace {
        (
            Method::Path,
            "no light: the path tracer only shows emission and background".into(),
        )
    } else if !scene.ray_state_materials().is_empty() {
        (
            Method::Path,
            "node trees read Light Path's ray kind or depths, which only the path tracer's camera paths carry".into(),
        )
    } else if !scene.ray_portal_materials().is_empty() {
        (
            Method::Path,
            "Ray Portal BSDFs: camera paths follow them, photons end on them".into(),
        )
    } else if subsurface.needed {
        (
            Method::Photon,
            "Christensen–Burley materials: the photon method's dipole diffusion is the profile they ask for (the path tracer walks them)".into(),
        )
    } else if !global_map.needed && !caustic_map.needed {
        (
            Method::Path,
            "no caustics and no indirect light: nothing for photon maps to cache".into(),
        )
    } else if let Some(pilot) = pilot {
        let aspect = width as f32 / height.max(1) as f32;
        let spp = pilot.spp.unwrap_or(quality.spp());
        let samples = (width as u64 * height as u64).saturating_mul(spp as u64);
        let shares = pilot_shares(
            scene,
            pilot.accel,
            aspect,
            pilot.scale.unwrap_or_else(|| pilot_scale(samples)),
            (global_map.needed, caustic_map.needed),
        );
        let seen = shares.noise_seen;
        let few = |share: f64| share > 0.0 && share <= EMISSION_RAYS_FEW_PIXELS;
        let photon_emission_rays = match (seen >= SEEN_SHARE_FOR_EMISSION_RAYS
            && spp <= EMISSION_RAYS_MAX_SPP)
            || (seen > 0.0
                && few(emitter_pixel_share(
                    scene,
                    pilot.accel,
                    width,
                    height,
                    false,
                )))
            || few(emitter_pixel_share(scene, pilot.accel, width, height, true))
        {
            true => PHOTON_EMISSION_RAYS,
            false => 0,
        };
        let percent = |x: f32| 100.0 * x;
        caustic_share = shares.hard_caustic;
        global_boost = global_photon_boost(shares.seen);
        if global_boost > 1.0 {
            global_map.reason += &format!(
                "; {global_boost:.1}× the global photons: {:.1} % of a pilot's land where the camera looks",
                percent(shares.seen)
            );
        }
        budget_share = photon_share(width as f32 * height as f32, spp);
        let [global_given, caustic_given] = pilot.photons;
        let global = global_given.map_or(
            budget_share * scale(defaults.global_photons) as f32 * global_boost,
            |n| n as f32,
        );
        let caustic = caustic_given
            .map_or(budget_share * scale(defaults.caustic_photons) as f32, |n| {
                n as f32
            });
        let volume =
            volume_needed as u32 as f32 * budget_share * scale(defaults.volume_photons) as f32;
        let photons = global_map.needed as u32 as f32 * global
            + caustic_map.needed as u32 as f32 * caustic
            + volume;
        let cost = Cost::predict(&shares, samples, spp, photons);
        let cost_note = format!(
            "; predicted cost in rays: path tracer {:.2e}, photon method {:.2e} ({:.2e} of it preparation); {:.0} % of the path tracer's noise is not indirect light, {:.0} % is emission seen directly{}",
            cost.path,
            cost.photon,
            cost.preparation,
            percent(shares.noise_left),
            percent(shares.noise_seen),
            match photon_emission_rays {
                0 => String::new(),
                n => format!(" (the photon method traces {n} emission rays per sample)"),
            }
        );
        let caustic_reason = || {
            format!(
                "caustics: {:.1} % of the light the camera sees on surfaces (a pilot of {} photons) is focused from lamps or emitting meshes, which path tracing finds only by chance; the caustic map resolves it",
                percent(shares.hard_caustic),
                shares.photons
            )
        };
        let (method, reason) = if shares.hard_caustic >= HARD_CAUSTIC_SHARE_FOR_PHOTONS
            && cost.photon <= CAUSTIC_COST_RATIO * cost.path
        {
            (Method::Photon, caustic_reason())
        } else if global_map.needed
            && shares.indirect >= INDIRECT_SHARE_FOR_PHOTONS
            && cost.photons_win(&shares)
        {
            (
                Method::Photon,
                format!(
                    "{:.0} % of the reflected light in a small path-traced pilot image is indirect: the irradiance cache pays off",
                    percent(shares.indirect)
                ),
            )
        } else {
            (
                Method::Path,
                format!(
                    "the path tracer reaches less error in the render's time: {:.0} % of the reflected light in a small path-traced pilot image is indirect, {:.1} % of what the camera sees on surfaces is a caustic of lamps or emitting meshes",
                    percent(shares.indirect),
                    percent(shares.hard_caustic)
                ),
            )
        };
        if method == Method::Photon {
            emission_rays = photon_emission_rays;
        }
        (method, reason + &cost_note)
    } else {
        (
            Method::Path,
            "not measured: the method was given explicitly".into(),
        )
    };
    let photon = PhotonSettings {
        global_photons: if global_map.needed {
            (scale(defaults.global_photons) as f32 * global_boost * budget_share).round() as u32
        } else {
            0
        },
        caustic_photons: if caustic_map.needed {
            (scale(defaults.caustic_photons) as f32 * budget_share).round() as u32
        } else {
            0
        },
        subsurface_photons: if subsurface.needed {
            scale(defaults.subsurface_photons)
        } else {
            0
        },
        volume_photons: if volume_needed {
            (scale(defaults.volume_photons) as f32 * budget_share).round() as u32
        } else {
            0
        },
        ..defaults
    };
    let scene_radius = 0.5 * summary.bounds.diagonal();
    let photon_bytes = if method == Method::Photon {
        (photon.global_photons as u64 * GLOBAL_STORED_PER_EMITTED
            + photon.caustic_photons as u64
            + photon.volume_photons as u64)
            * PHOTON_BYTES
            + photon.subsurface_photons as u64 * SUBSURFACE_SAMPLE_BYTES
    } else {
        0
    };
    let memory = MemoryEstimate {
        photon_maps: photon_bytes,
        bvh: summary.triangles as u64 * BVH_BYTES_PER_TRIANGLE,
        image: width as u64 * height as u64 * IMAGE_BYTES_PER_PIXEL,
    };
    Plan {
        global_radius: photon.global_radius * scene_radius,
        caustic_radius: photon.caustic_radius * scene_radius,
        summary,
        quality,
        anything_to_trace,
        caustic_map,
        irradiance_cache: Decision::new(
            global_map.needed,
            if global_map.needed {
                "photon method: Lambertian surfaces interpolate indirect light from records (auto: as many gather rays as final gathering would spend)"
            } else {
                "no indirect light to gather"
            },
        ),
        global_map,
        subsurface,
        caustic_share,
        method,
        method_reason,
        emission_rays,
        spp: quality.spp(),
        photon,
        memory,
        width,
        height,
    }
}

impl Plan {
    /// Whether the pilot found caustics of lamps or emitting meshes that carry a visible share
    /// of what the camera sees: the path tracer resolves them slowly or never.
    pub fn hard_caustics(&self) -> bool {
        self.caustic_share >= HARD_CAUSTIC_SHARE_FOR_PHOTONS
    }

    /// The method `auto` renders with, in words.
    pub fn method_name(&self) -> &'static str {
        match self.method {
            Method::Path => "path tracer",
            _ => "photon mapping",
        }
    }
}

fn mib(bytes: u64) -> f64 {
    bytes as f64 / (1024.0 * 1024.0)
}

fn yes_no(d: &Decision) -> &'static str {
    if d.needed {
        "yes"
    } else {
        "skip"
    }
}

impl fmt::Display for Plan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.summary;
        let m = &s.materials;
        let l = &s.lights;
        writeln!(f, "meshes: {}, triangles: {}", s.meshes, s.triangles)?;
        writeln!(
            f,
            "materials in use: {} ({} diffuse, {} glossy, {} specular of which {} refractive, {} emissive, {} translucent, {} black)",
            m.used, m.diffuse, m.glossy, m.specular, m.refractive, m.emissive, m.translucent, m.black
        )?;
        if m.volumes > 0 || s.world_volume.is_some() {
            writeln!(
                f,
                "volumes: {} material(s) ({} heterogeneous), world volume {}",
                m.volumes,
                m.heterogeneous_volumes,
                s.world_volume.unwrap_or("none")
            )?;
        }
        writeln!(
            f,
            "lights: {} emissive triangles, {} point, {} spot, {} sun, world {}",
            l.emissive_triangles,
            l.point,
            l.spot,
            l.sun,
            if l.world { "emits" } else { "black" }
        )?;
        if !s.bounds.is_empty() {
            writeln!(
                f,
                "bounds: {:?} to {:?} (diagonal {:.4})",
                s.bounds.min.to_array(),
                s.bounds.max.to_array(),
                s.bounds.diagonal()
            )?;
        }
        writeln!(f, "plan ({} quality):", self.quality.name())?;
        if !self.anything_to_trace {
            writeln!(f, "  nothing to trace: the scene has no light")?;
        }
        for (name, d) in [
            ("caustic map", &self.caustic_map),
            ("global map + final gather", &self.global_map),
            ("irradiance cache", &self.irradiance_cache),
            ("subsurface", &self.subsurface),
        ] {
            writeln!(f, "  {name}: {} ({})", yes_no(d), d.reason)?;
        }
        writeln!(
            f,
            "  auto method: {} ({})",
            self.method_name(),
            self.method_reason
        )?;
        writeln!(f, "  samples per pixel: {}", self.spp)?;
        if self.method == Method::Photon {
            writeln!(
                f,
                "  photons: {} global (k {}, radius {:.4}), {} caustic (k {}, radius {:.4}), {} gather rays",
                self.photon.global_photons,
                self.photon.k_global,
                self.global_radius,
                self.photon.caustic_photons,
                self.photon.k_caustic,
                self.caustic_radius,
                self.photon.gather_rays
            )?;
            if self.photon.subsurface_photons > 0 {
                writeln!(
                    f,
                    "  subsurface photons: {} (octree accuracy {})",
                    self.photon.subsurface_photons, self.photon.subsurface_accuracy
                )?;
            }
        }
        write!(
            f,
            "  memory estimate at {}x{}: {:.1} MiB (photon maps {:.1}, BVH {:.1}, image {:.1})",
            self.width,
            self.height,
            mib(self.memory.total()),
            mib(self.memory.photon_maps),
            mib(self.memory.bvh),
            mib(self.memory.image)
        )
    }
}
