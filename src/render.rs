//! The render driver: prepares the scene (acceleration structure, lights), splits the image into
//! tiles rendered in parallel with rayon, reports progress, honours cancellation and counts
//! non-finite samples (which never reach the film).
//!
//! Determinism: each camera sample draws from its own stream, seeded by (seed, pixel, sample
//! index) — the path tracer's and the photon method's a sample of the pixel's scrambled Sobol
//! sequence, the cache methods' a PCG32 stream — and each sample lands in exactly one pixel (see `film`), so the
//! image is bit-identical for any number of threads. With adaptive sampling (`adaptive`) the
//! pixels are sampled in steps between convergence checks made on the whole window at once,
//! from sums each pixel accumulates in sample order, so which pixels stop does not depend on
//! the threads either.

use crate::accel::Accel;
use crate::adaptive::{is_class_a, spread_active, AdaptiveSettings, Convergence};
use crate::camera::CameraRays;
use crate::emitter_pixels::EmitterPixels;
use crate::error::{Error, Result};
use crate::film::{FilterSettings, Image, PixelFilter, NO_HIT_DEPTH};
use crate::integrator::cache::{self, CacheView, IcInfo, Source};
use crate::integrator::photon::build::{build_maps, PhotonMaps};
use crate::integrator::photon::settings::{PhotonInfo, PhotonSettings};
use crate::integrator::photon::shade::{self, View};
use crate::integrator::photon::tracing::Emitters;
use crate::integrator::{path, walk, CameraSample, Context};
use crate::irradiance_cache::{IcSettings, IrradianceCache};
use crate::light::Lights;
use crate::light_pass::{LightPass, Passes};
use crate::math::{Vec2, Vec3};
use crate::progress::{Progress, ProgressEvent};
use crate::rng::Rng;
pub use crate::rng::Sampler;
use crate::scene::Scene;
use crate::shadow_catcher::{CatcherScene, CatcherSum};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// What to render. The command line and the Blender add-on map onto this struct.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Camera samples per pixel.
    pub spp: u32,
    /// Maximum path length in bounces.
    pub max_depth: u32,
    pub seed: u64,
    /// The rendering algorithm.
    pub method: Method,
    /// Photon-mapping settings (used by the photon methods).
    pub photon: PhotonSettings,
    /// Irradiance-cache settings (the photon method when enabled, and the cache methods).
    pub irradiance_cache: IcSettings,
    /// Render only this window of the `width` × `height` frame (Blender's render region); the
    /// image is the window's size and equals that crop of the full render, bit for bit.
    pub region: Option<Region>,
    /// Keep the light-path passes (`Image::passes`); off, they are summed but not stored.
    pub light_passes: bool,
    /// Where camera samples and photons draw their numbers from.
    pub sampler: Sampler,
    /// The pixel filter; `None`: the scene's (`SceneRenderSettings::filter`), else Blender's
    /// default (Blackman–Harris, 1.5 px).
    pub filter: Option<FilterSettings>,
    /// Adaptive sampling (Cycles' noise threshold, `adaptive`): pixels stop taking samples
    /// once their estimated error is below the threshold; `None`: every pixel takes `spp`.
    pub adaptive: Option<AdaptiveSettings>,
    /// Extra camera rays per sample that only see emission (`walk::seen_emission`): the light
    /// the camera sees directly (a lamp's edge against a dark ceiling, a bright window) is
    /// averaged over these instead of the sample's own ray, whose path keeps the rest. 0: off.
    pub emission_rays: u32,
    /// The first sample of the pixels' sample sequence this render takes (Cycles' Sample
    /// Offset): it renders samples `sample_offset .. sample_offset + spp` of the same sequence
    /// a render from 0 takes, and the photon methods' generations follow the samples, so
    /// renders of disjoint ranges merged by their sample counts (`exr_merge`) are the render of
    /// their union. Only the first round is offset; adaptive sampling needs it 0.
    pub sample_offset: u32,
}

/// A window of the frame in pixels, top-left origin, `x1` and `y1` exclusive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl Region {
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }
}

/// The rendering algorithm, chosen once per render.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Method {
    /// The unbiased path tracer (the reference).
    #[default]
    Path,
    /// Photon mapping: direct + specular + caustic map + final gathering into the global map.
    Photon,
    /// Debug view: the global map's radiance estimate seen directly.
    PhotonGlobal,
    /// Debug view: the caustic map's radiance estimate.
    PhotonCaustic,
    /// Debug view: photon positions.
    Photons,
    /// The path tracer with an irradiance cache (path-traced records) at its first diffuse bounce.
    PathCache,
    /// Debug view: the photon method's cached indirect irradiance.
    IcIrradiance,
    /// Debug view: the photon method's irradiance-record positions.
    IcRecords,
}

impl Method {
    fn photon_view(self) -> Option<View> {
        match self {
            Method::Path => None,
            Method::Photon => Some(View::Full),
            Method::PhotonGlobal => Some(View::Global),
            Method::PhotonCaustic => Some(View::Caustic),
            Method::Photons => Some(View::Photons),
            Method::IcIrradiance | Method::IcRecords => Some(View::Full),
            Method::PathCache => None,
        }
    }

    /// The view of the cache-based methods; `None` for the others.
    fn cache_view(self) -> Option<CacheView> {
        match self {
            Method::PathCache => Some(CacheView::PathCache),
            Method::IcIrradiance => Some(CacheView::Irradiance),
            Method::IcRecords => Some(CacheView::Records),
            _ => None,
        }
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 640,
            height: 480,
            spp: 64,
            max_depth: 32,
            seed: 0,
            method: Method::Path,
            photon: PhotonSettings::default(),
            irradiance_cache: IcSettings::default(),
            region: None,
            light_passes: false,
            filter: None,
            sampler: Sampler::default(),
            adaptive: None,
            emission_rays: 0,
            sample_offset: 0,
        }
    }
}

/// Counters reported at the end of a render.
#[derive(Clone, Debug, Default)]
pub struct RenderStats {
    pub triangles: usize,
    pub lights: usize,
    pub build_seconds: f64,
    pub render_seconds: f64,
    pub camera_samples: u64,
    pub rays: u64,
    /// Samples dropped because their radiance was NaN or infinite.
    pub nonfinite_samples: u64,
    /// Photon tracing of the photon methods: what was traced and skipped (summed over the
    /// generations).
    pub photon: Option<PhotonInfo>,
    /// The irradiance cache, when one was built (summed over the generations).
    pub irradiance_cache: Option<IcInfo>,
    /// Generations of photon maps and irradiance cache built (`GENERATION_SPP`).
    pub generations: u32,
}

const TILE: u32 = 16;

/// Render `scene` with the path tracer.
pub fn render(
    scene: &Scene,
    settings: &RenderSettings,
    progress: &Progress,
) -> Result<(Image, RenderStats)> {
    let mut image = None;
    let stats = render_scheduled(scene, None, settings, progress, &mut |done| match done {
        None => Some((settings.seed, settings.spp)),
        Some((round, _)) => {
            image = Some(round);
            None
        }
    })?;
    Ok((image.expect("one round rendered"), stats))
}

/// What a scheduled render does after its preparation: given the image of the round just
/// rendered and its samples per pixel (`None` before the first), the seed and samples per pixel
/// of the next round, or `None` to finish. With adaptive sampling the render also finishes,
/// after handing over the last round, once every pixel has stopped.
pub type Schedule<'a> = dyn FnMut(Option<(Image, u32)>) -> Option<(u64, u32)> + 'a;

/// Prepare once (BVH unless `accel` is the scene's already built, lights, photon maps and
/// irradiance cache, built with `settings.seed`), then render the rounds `schedule` asks for;
/// the returned statistics cover all of them.
pub fn render_scheduled(
    scene: &Scene,
    accel: Option<&Accel>,
    settings: &RenderSettings,
    progress: &Progress,
    schedule: &mut Schedule,
) -> Result<RenderStats> {
    if settings.width == 0 || settings.height == 0 || settings.spp == 0 {
        return Err(Error::Settings(
            "width, height and samples must be at least 1".into(),
        ));
    }
    if settings.sample_offset.checked_add(settings.spp).is_none() {
        return Err(Error::Settings(format!(
            "sample offset {} plus {} samples passes the last sample number",
            settings.sample_offset, settings.spp
        )));
    }
    if settings.sample_offset > 0 && settings.adaptive.is_some() {
        return Err(Error::Settings(
            "a sample offset cannot be combined with adaptive sampling (which pixels stop \
             depends on the samples before the offset)"
                .into(),
        ));
    }
    let window = settings.region.unwrap_or(Region {
        x0: 0,
        y0: 0,
        x1: settings.width,
        y1: settings.height,
    });
    if window.x0 >= window.x1
        || window.y0 >= window.y1
        || window.x1 > settings.width
        || window.y1 > settings.height
    {
        return Err(Error::Settings(format!(
            "region {}..{} x {}..{} is empty or outside the {}x{} frame",
            window.x0, window.x1, window.y0, window.y1, settings.width, settings.height
        )));
    }
    let mut stats = RenderStats {
        triangles: scene.triangle_count(),
        ..RenderStats::default()
    };
    (progress.report)(&ProgressEvent {
        stage: "build",
        fraction: 0.0,
        message: format!("building BVH over {} triangles", stats.triangles),
    });
    let start = Instant::now();
    let built;
    let accel = match accel {
        Some(accel) => accel,
        None => {
            built = Accel::new(scene);
            &built
        }
    };
    let lights = Lights::new(scene);
    stats.lights = lights.sources.len();
    stats.build_seconds = start.elapsed().as_secs_f64();
    progress.check()?;

    let ctx = Context {
        scene,
        accel,
        lights: &lights,
        max_depth: settings.max_depth,
        transparent_background: scene.render_settings.transparent_film,
    };
    let camera = CameraRays::new(&scene.camera, settings.width, settings.height);
    let filter = PixelFilter::new(
        &settings
            .filter
            .or(scene.render_settings.filter)
            .unwrap_or_default(),
    );
    // Blender's shadow catchers, composed with a transparent film (with an opaque one they
    // render as the objects they are, which the add-on's pre-flight report names).
    let catchers = match ctx.transparent_background {
        true => CatcherScene::new(scene),
        false => None,
    };
    let catcher_ctx = catchers.as_ref().map(|c| c.context(&ctx));
    let emitter_pixels = (settings.emission_rays > 0).then(|| {
        EmitterPixels::new(
            &ctx,
            &camera,
            filter.radius(),
            (settings.width, settings.height),
            true,
        )
    });
    // Methods that read photon maps or an irradiance cache rebuild them every `GENERATION_SPP`
    // samples per pixel with fresh random numbers and smaller radii (`for_generation`).
    let progressive =
        settings.method.photon_view().is_some() || settings.method.cache_view().is_some();
    // Where photons leave the lights (`Emitters::guided`): measured once per render, with the
    // render's seed, and shared by every generation's photons.
    let emitters = settings.method.photon_view().map(|_| {
        let start = Instant::now();
        let emitters = Emitters::guided(
            &ctx,
            settings.width as f32 / settings.height as f32,
            settings.seed,
        );
        let info = stats.photon.get_or_insert_with(PhotonInfo::default);
        info.guide_seconds += start.elapsed().as_secs_f64();
        emitters
    });
    let mut done_spp = settings.sample_offset;
    let mut adaptive = settings
        .adaptive
        .map(|a| AdaptiveFilm::new(&a, settings.spp, window));
    let mut prepared: Option<Prepared> = None;
    let mut previous = None;
    let mut first_round = true;
    while let Some((seed, spp)) = schedule(previous.take()) {
        if spp == 0 {
            return Err(Error::Settings(
                "samples per pixel must be at least 1".into(),
            ));
        }
        // The round, split where a generation ends: the first part keeps the round's seed and
        // takes the pixels' samples from 0, unless the render starts at a sample offset: then
        // from where a render from 0 would have reached, with the seed it would have.
        let (mut part_seed, mut part_first) = match (first_round, progressive) {
            (false, _) => (seed, 0),
            (true, false) => (seed, done_spp),
            (true, true) => {
                let start = done_spp - done_spp % GENERATION_SPP;
                (generation_seed(seed, start), done_spp - start)
            }
        };
        first_round = false;
        let (mut image, mut image_spp): (Option<Image>, u32) = (None, 0);
        while image_spp < spp {
            let generation = if progressive {
                done_spp / GENERATION_SPP
            } else {
                0
            };
            let n = match progressive {
                true => (spp - image_spp).min(GENERATION_SPP - done_spp % GENERATION_SPP),
                false => spp,
            };
            if adaptive.as_ref().is_some_and(AdaptiveFilm::all_converged) {
                // Every pixel has converged: nothing to prepare or render.
                let mut part = Image::new(window.width(), window.height());
                if settings.light_passes {
                    part.passes = vec![Passes::default(); part.rgba.len()];
                }
                image = Some(match image {
                    None => part,
                    Some(sum) => sum.merge(&part),
                });
                image_spp += n;
                done_spp += n;
                continue;
            }
            if prepared
                .as_ref()
                .is_some_and(|p| p.generation != generation)
            {
                // Free the last generation's maps and cache before building the next.
                prepared = None;
            }
            if prepared.is_none() {
                let generation_settings = settings.for_generation(generation);
                let built = prepare(
                    &ctx,
                    emitters.as_ref(),
                    &generation_settings,
                    generation,
                    progress,
                    &mut stats,
                )?;
                prepared = Some(built);
            }
            let p = prepared.as_ref().expect("prepared just above");
            let integrator = match (&p.maps, &p.cache, settings.method.cache_view()) {
                (_, Some(cache), Some(view)) => Integrator::Cache(cache, view),
                (Some((maps, view)), cache, _) => Integrator::Photon(maps, cache.as_ref(), *view),
                _ => Integrator::Path,
            };
            let round_settings = RenderSettings {
                seed: part_seed,
                spp: n,
                ..settings.clone()
            };
            let round = RoundSetup {
                ctx: &ctx,
                integrator,
                first_sample: part_first,
                camera: &camera,
                filter: &filter,
                emitter_pixels: emitter_pixels.as_ref(),
                settings: &round_settings,
                window,
                moving: camera.moves() || ctx.scene.has_motion(),
                catcher: catcher_ctx.as_ref(),
            };
            let part = render_round(&round, progress, &mut stats, adaptive.as_mut())?;
            image = Some(match image {
                None => part,
                Some(sum) => sum.merge(&part),
            });
            image_spp += n;
            done_spp += n;
            part_seed = generation_seed(seed, done_spp);
            part_first = 0;
        }
        previous = image.map(|image| (image, spp));
        if adaptive.as_ref().is_some_and(AdaptiveFilm::all_converged) {
            // Nothing is left to sample: hand over the last round and finish.
            schedule(previous.take());
            break;
        }
    }
    Ok(stats)
}

/// What every tile of one round shares.
struct RoundSetup<'a> {
    ctx: &'a Context<'a>,
    integrator: Integrator<'a>,
    /// The number of the pixels' first sample in this round (`RenderSettings::sample_offset`).
    first_sample: u32,
    camera: &'a CameraRays,
    filter: &'a PixelFilter,
    /// Where emission rays can meet an emitter; `None` without emission rays.
    emitter_pixels: Option<&'a EmitterPixels>,
    /// The round's seed and samples per pixel.
    settings: &'a RenderSettings,
    window: Region,
    /// Something moves while the shutter is open (the camera or an instance): samples take a
    /// moment within it.
    moving: bool,
    /// The scene with its shadow catchers alone, when it has some and the film is transparent
    /// (`crate::shadow_catcher`).
    catcher: Option<&'a Context<'a>>,
}

/// Render `settings.spp` samples per pixel of the window with `settings.seed`, adding the time,
/// samples and rays to `stats`. With `adaptive`, only the pixels it leaves active take samples,
/// in steps that end where it checks them.
fn render_round(
    round: &RoundSetup,
    progress: &Progress,
    stats: &mut RenderStats,
    mut adaptive: Option<&mut AdaptiveFilm>,
) -> Result<Image> {
    let (scene, settings, window) = (round.ctx.scene, round.settings, round.window);
    let tiles_x = window.width().div_ceil(TILE);
    let tiles_y = window.height().div_ceil(TILE);
    let tile_count = tiles_x * tiles_y;
    let rays = AtomicU64::new(0);
    let nonfinite = AtomicU64::new(0);
    let start = Instant::now();

    let mut tiles: Vec<Tile> = (0..tile_count)
        .map(|t| {
            let (x0, y0) = (
                window.x0 + t % tiles_x * TILE,
                window.y0 + t / tiles_x * TILE,
            );
            let (x1, y1) = ((x0 + TILE).min(window.x1), (y0 + TILE).min(window.y1));
            let mut pixels = vec![PixelSum::default(); ((x1 - x0) * (y1 - y0)) as usize];
            for (i, px) in pixels.iter_mut().enumerate() {
                let (x, y) = (x0 + i as u32 % (x1 - x0), y0 + i as u32 / (x1 - x0));
                px.active = adaptive.as_ref().is_none_or(|a| a.active[a.index(x, y)]);
            }
            Tile { x0, y0, x1, pixels }
        })
        .collect();

    let mut done_spp = 0;
    while done_spp < settings.spp {
        let remaining = settings.spp - done_spp;
        let step = adaptive
            .as_ref()
            .map_or(remaining, |a| a.schedule.step(a.taken, remaining));
        let converged = adaptive.as_ref().map(|a| a.converged_fraction());
        let finished = AtomicU64::new(0);
        tiles
            .par_iter_mut()
            .map(|tile| {
                render_tile(round, tile, step, progress, &rays, &nonfinite)?;
                let finished = finished.fetch_add(1, Ordering::Relaxed) + 1;
                let fraction = (done_spp as f32
                    + step as f32 * finished as f32 / tile_count as f32)
                    / settings.spp as f32;
                let message = match converged {
                    None => format!("tile {finished}/{tile_count}"),
                    Some(c) => format!(
                        "tile {finished}/{tile_count}, {:.0} % of pixels converged",
                        100.0 * c
                    ),
                };
                (progress.report)(&ProgressEvent {
                    stage: "render",
                    fraction,
                    message,
                });
                Ok(())
            })
            .collect::<Result<()>>()?;
        done_spp += step;
        if let Some(a) = adaptive.as_deref_mut() {
            a.taken += step;
            if a.schedule.check_due(a.taken) {
                a.check(&mut tiles);
            }
        }
    }
    if let Some(a) = adaptive {
        a.absorb(&tiles);
    }

    let mut image = Image::new(window.width(), window.height());
    if settings.light_passes {
        image.passes = vec![Passes::default(); image.rgba.len()];
    }
    image.camera_rotation = crate::math::Mat3::from(scene.camera.to_world.matrix3);
    if round.catcher.is_some() {
        image.shadow_catcher = vec![Vec3::ONE; image.rgba.len()];
    }
    // Alpha as Cycles writes it: the coverage with a transparent film, else 1 less the
    // samples that met a Holdout.
    let alpha = |px: &PixelSum| match round.ctx.transparent_background {
        true => px.coverage / px.n as f32,
        false => 1.0 - px.holdouts / px.n as f32,
    };
    for tile in &tiles {
        let width = tile.x1 - tile.x0;
        for (i, px) in tile.pixels.iter().enumerate() {
            let x = tile.x0 + i as u32 % width;
            let y = tile.y0 + i as u32 / width;
            let k = ((y - window.y0) * window.width() + (x - window.x0)) as usize;
            stats.camera_samples += px.n as u64;
            image.samples[k] = px.n;
            if px.n == 0 {
                image.depth[k] = NO_HIT_DEPTH;
                continue;
            }
            let n = px.n as f32;
            let c = px.sum / n;
            image.rgba[k] = match round.catcher {
                None => [c.x, c.y, c.z, alpha(px)],
                Some(_) => {
                    let (rgba, shadow) = px.catcher.compose(px.sum, px.coverage, n);
                    image.shadow_catcher[k] = shadow;
                    rgba
                }
            };
            image.albedo[k] = px.albedo / n;
            image.normal[k] = px.normal.normalize_or_zero();
            // Depth as Cycles writes it: distance along the camera's axis, averaged over the
            // samples that hit something (1e10 when none did), never mixed with the background.
            image.depth[k] = if px.coverage > 0.0 {
                px.depth_sum / px.coverage
            } else {
                NO_HIT_DEPTH
            };
            if settings.light_passes {
                let mut passes = px.passes;
                passes.scale(1.0 / n);
                image.passes[k] = passes;
            }
        }
    }
    stats.render_seconds += start.elapsed().as_secs_f64();
    stats.rays += rays.into_inner();
    stats.nonfinite_samples += nonfinite.into_inner();
    Ok(image)
}

/// What one pixel has gathered in one round (or part of a round).
#[derive(Clone, Default)]
struct PixelSum {
    sum: Vec3,
    /// The sum of the class-A samples (`adaptive::is_class_a`).
    sum_a: Vec3,
    passes: Passes,
    coverage: f32,
    /// Samples whose camera ray met a Holdout.
    holdouts: f32,
    /// Samples whose camera ray met a shadow catcher.
    catcher: CatcherSum,
    albedo: Vec3,
    normal: Vec3,
    depth_sum: f32,
    /// Samples taken.
    n: u32,
    /// The pixel takes the next step's samples.
    active: bool,
}

/// The pixels of one tile, row by row, from (`x0`, `y0`) to column `x1` (exclusive).
struct Tile {
    x0: u32,
    y0: u32,
    x1: u32,
    pixels: Vec<PixelSum>,
}

/// Adaptive sampling over a whole render, all rounds and generations: each pixel's sums so far
/// and whether it still takes samples (`adaptive`).
struct AdaptiveFilm {
    schedule: Convergence,
    window: Region,
    /// (sum, class-A sum, samples) of each pixel of the window over the finished rounds.
    totals: Vec<(Vec3, Vec3, u32)>,
    /// Whether each pixel of the window takes the next samples.
    active: Vec<bool>,
    /// Samples taken by the pixels that were never stopped.
    taken: u32,
}

impl AdaptiveFilm {
    fn new(settings: &AdaptiveSettings, spp: u32, window: Region) -> Self {
        let n = (window.width() * window.height()) as usize;
        AdaptiveFilm {
            schedule: settings.resolve(spp),
            window,
            totals: vec![(Vec3::ZERO, Vec3::ZERO, 0); n],
            active: vec![true; n],
            taken: 0,
        }
    }

    fn index(&self, x: u32, y: u32) -> usize {
        ((y - self.window.y0) * self.window.width() + (x - self.window.x0)) as usize
    }

    fn converged_fraction(&self) -> f32 {
        self.active.iter().filter(|&&a| !a).count() as f32 / self.active.len() as f32
    }

    fn all_converged(&self) -> bool {
        !self.active.contains(&true)
    }

    /// Each tile pixel with its window index.
    fn pixels<'t>(&self, tiles: &'t [Tile]) -> impl Iterator<Item = (usize, &'t PixelSum)> + 't {
        let window = self.window;
        tiles.iter().flat_map(move |tile| {
            let width = tile.x1 - tile.x0;
            tile.pixels.iter().enumerate().map(move |(i, px)| {
                let (x, y) = (tile.x0 + i as u32 % width, tile.y0 + i as u32 / width);
                (
                    ((y - window.y0) * window.width() + (x - window.x0)) as usize,
                    px,
                )
            })
        })
    }

    /// Check the active pixels with their sums so far (the finished rounds' and `tiles'`),
    /// wake the neighbours of those still active, and tell the tiles.
    fn check(&mut self, tiles: &mut [Tile]) {
        let mut active = std::mem::take(&mut self.active);
        for (k, px) in self.pixels(tiles) {
            let (sum, sum_a, n) = self.totals[k];
            active[k] = active[k]
                && !self
                    .schedule
                    .converged(sum + px.sum, sum_a + px.sum_a, n + px.n);
        }
        let (w, h) = (self.window.width(), self.window.height());
        spread_active(&mut active, w as usize, h as usize);
        self.active = active;
        let window = self.window;
        for tile in tiles {
            let width = tile.x1 - tile.x0;
            for (i, px) in tile.pixels.iter_mut().enumerate() {
                let (x, y) = (tile.x0 + i as u32 % width, tile.y0 + i as u32 / width);
                px.active =
                    self.active[((y - window.y0) * window.width() + (x - window.x0)) as usize];
            }
        }
    }

    /// Add a finished round's (or part's) sums to the totals.
    fn absorb(&mut self, tiles: &[Tile]) {
        let sums: Vec<(usize, Vec3, Vec3, u32)> = self
            .pixels(tiles)
            .map(|(k, px)| (k, px.sum, px.sum_a, px.n))
            .collect();
        for (k, sum, sum_a, n) in sums {
            let t = &mut self.totals[k];
            *t = (t.0 + sum, t.1 + sum_a, t.2 + n);
        }
    }
}

/// The integrator of this render, chosen once.
#[derive(Clone, Copy)]
enum Integrator<'a> {
    Path,
    Photon(&'a PhotonMaps, Option<&'a IrradianceCache>, View),
    Cache(&'a IrradianceCache, CacheView),
}

impl Integrator<'_> {
    fn trace(self, ctx: &Context, ray: crate::accel::Ray, rng: &mut Rng) -> CameraSample {
        match self {
            Integrator::Path => path::trace(ctx, ray, rng),
            Integrator::Photon(maps, cache, view) => shade::trace(ctx, maps, cache, view, ray, rng),
            Integrator::Cache(cache, view) => cache::trace(ctx, cache, view, ray, rng),
        }
    }
}

/// Samples per pixel rendered with one generation of photon maps and irradiance cache.
pub const GENERATION_SPP: u32 = 64;

/// Knaus & Zwicker's α (2011): each generation's squared radii are (g + α)/(g + 1) of the one
/// before, so the bias falls while the variance added per generation stays bounded.
const RADIUS_ALPHA: f32 = 2.0 / 3.0;

/// Most photons a generation traces, as a multiple of the first generation's.
const MAX_PHOTON_GROWTH: f32 = 4.0;

/// The factor generation `g`'s squared radii get: Π_{j=1..g} (j + α)/(j + 1), 1 for g = 0.
pub fn radius2_factor(generation: u32) -> f32 {
    (1..=generation).fold(1.0, |f, j| f * (j as f32 + RADIUS_ALPHA) / (j as f32 + 1.0))
}

/// How many times the first generation's photons generation `generation` traces: its radii
/// shrink by tracing more photons for the same k, up to `MAX_PHOTON_GROWTH` times.
pub fn photon_growth(generation: u32) -> f32 {
    (1.0 / radius2_factor(generation)).min(MAX_PHOTON_GROWTH)
}

/// The seed of the samples after `done_spp` of a round whose first ones used `seed` (a
/// generation boundary inside a round), or of generation `g`'s photon maps and cache.
fn generation_seed(seed: u64, n: u32) -> u64 {
    seed ^ (n as u64).wrapping_mul(0xd1b5_4a32_d192_ed03)
}

impl RenderSettings {
    /// The settings of generation `generation` (module header of `rounds`): its own seed for
    /// the photons and the cache, and with `radius2_factor`: more photons (then fewer nearest
    /// photons in each estimate) and smaller maximum radii, and a cache with tighter accuracy
    /// and closer records.
    pub fn for_generation(&self, generation: u32) -> RenderSettings {
        if generation == 0 {
            return self.clone();
        }
        let f = radius2_factor(generation);
        // The radii shrink by tracing more photons for the same k (k-nearest estimates with few
        // photons are biased low next to bright patches); past `MAX_PHOTON_GROWTH` times the
        // photons, k shrinks instead.
        let grow = photon_growth(generation);
        let k = |k: u32| ((k as f32 * f * grow).round() as u32).max(1);
        let n = |n: u32| (n as f32 * grow).round() as u32;
        let photon = PhotonSettings {
            global_photons: n(self.photon.global_photons),
            caustic_photons: n(self.photon.caustic_photons),
            k_global: k(self.photon.k_global),
            k_caustic: k(self.photon.k_caustic),
            global_radius: self.photon.global_radius * f.sqrt(),
            caustic_radius: self.photon.caustic_radius * f.sqrt(),
            volume_photons: n(self.photon.volume_photons),
            volume_radius: self.photon.volume_radius * f.sqrt(),
            ..self.photon.clone()
        };
        let ic = &self.irradiance_cache;
        // The cache's interpolation error grows with the accuracy (a record's reach) where
        // irradiance changes fast, as at a room's edges: shrinking it with the squared radii
        // rather than with the radii lowers it as fast as the maps' own blur.
        let irradiance_cache = IcSettings {
            accuracy: ic.accuracy * f,
            min_spacing: (ic.min_spacing * f.sqrt()).max(0.5),
            ..ic.clone()
        };
        RenderSettings {
            seed: generation_seed(self.seed, generation.wrapping_mul(GENERATION_SPP)),
            photon,
            irradiance_cache,
            ..self.clone()
        }
    }
}

/// The photon maps of a photon method and the view it renders.
type Maps = Option<(PhotonMaps, View)>;

/// What one generation renders with.
struct Prepared {
    generation: u32,
    maps: Maps,
    cache: Option<IrradianceCache>,
}

/// Build generation `generation`'s photon maps (photons from `emitters`) and irradiance cache
/// with `settings` (already `for_generation`), adding their statistics to `stats`.
fn prepare(
    ctx: &Context,
    emitters: Option<&Emitters>,
    settings: &RenderSettings,
    generation: u32,
    progress: &Progress,
    stats: &mut RenderStats,
) -> Result<Prepared> {
    let maps = match (settings.method.photon_view(), emitters) {
        (Some(view), Some(emitters)) => {
            let (maps, info) = build_maps(
                ctx,
                emitters,
                &settings.photon,
                settings.seed,
                settings.sampler,
                progress,
            )?;
            stats
                .photon
                .get_or_insert_with(PhotonInfo::default)
                .add(&info);
            Some((maps, view))
        }
        _ => None,
    };
    let cache = prepare_cache(ctx, settings, &maps, progress, stats)?;
    stats.generations += 1;
    Ok(Prepared {
        generation,
        maps,
        cache,
    })
}

/// Build the irradiance cache the method needs over the full frame: from the photon maps for
/// the photon method (when enabled and a global map exists) and the photon cache views, from
/// path-traced records for `path-cache`; `None` for the other methods.
fn prepare_cache(
    ctx: &Context,
    settings: &RenderSettings,
    maps: &Maps,
    progress: &Progress,
    stats: &mut RenderStats,
) -> Result<Option<IrradianceCache>> {
    let ic = &settings.irradiance_cache;
    let frame = (settings.width, settings.height);
    let view = settings.method.cache_view();
    let source = match maps {
        Some((m, _)) if m.global.is_none() => return Ok(None),
        Some((m, _)) if view.is_some() || (settings.method == Method::Photon && ic.enabled) => {
            Source::Photon(m)
        }
        None if view.is_some() => Source::Path,
        _ => return Ok(None),
    };
    let (cache, info) = cache::build_cache(ctx, source, ic, frame, settings.seed, progress)?;
    stats
        .irradiance_cache
        .get_or_insert_with(IcInfo::default)
        .add(&info);
    Ok(Some(cache))
}

/// A camera ray through pixel (x, y): its film position from the pixel filter, then a lens
/// sample only with an aperture and a moment only when something moves (still scenes seen by
/// pinhole cameras keep their streams), drawn from `rng` in that order. Its `t_max` is 0 outside
/// a fisheye's image.
fn camera_ray(round: &RoundSetup, (x, y): (u32, u32), rng: &mut Rng) -> crate::accel::Ray {
    let film = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) + round.filter.sample(rng.uniform2());
    let lens = if round.camera.has_lens() {
        rng.uniform2()
    } else {
        Vec2::ZERO
    };
    let time = round.moving.then(|| rng.uniform());
    round.camera.sample_ray(film, lens, time)
}

/// Tag of the Sobol sequence of the emission rays (`RenderSettings::emission_rays`).
const EMISSION_RAYS_TAG: u64 = 0x5ee5_e111;

/// Replace what sample `s` of pixel (x, y) sees directly by the mean of what
/// `settings.emission_rays` other camera rays of the pixel see (`walk::seen_emission`): both
/// estimate the same integral over the pixel filter, so the sample stays unbiased, and edges of
/// bright emitters take that many more positions. Each ray draws its film position, lens and
/// moment from one Sobol sequence per pixel (sample s·n + k), so a pixel's emission rays are
/// stratified together. Only pixels that may see an emitter take them (`EmitterPixels`):
/// elsewhere they would all see nothing, as the sample's own ray did. Returns the rays traced.
fn see_emission(
    round: &RoundSetup,
    sample: &mut CameraSample,
    pixel_index: u64,
    s: u32,
    (x, y): (u32, u32),
) -> u32 {
    let settings = round.settings;
    let n = settings.emission_rays;
    let (mut seen, mut rays) = (Vec3::ZERO, 0);
    for k in 0..n {
        let mut rng = Rng::sobol(settings.seed ^ EMISSION_RAYS_TAG, pixel_index, s * n + k);
        let ray = camera_ray(round, (x, y), &mut rng);
        if ray.t_max > 0.0 {
            let (le, traced) = walk::seen_emission(round.ctx, ray, &mut rng);
            seen += le;
            rays += traced;
        }
    }
    let seen = seen / n as f32;
    sample.radiance += seen - sample.seen_emission;
    sample
        .passes
        .add(LightPass::Emission, seen - sample.seen_emission);
    sample.seen_emission = seen;
    rays
}

/// Take `step` more samples in each active pixel of `tile`, each pixel's samples numbered on
/// from those it already has.
fn render_tile(
    round: &RoundSetup,
    tile: &mut Tile,
    step: u32,
    progress: &Progress,
    rays: &AtomicU64,
    nonfinite: &AtomicU64,
) -> Result<()> {
    let (ctx, integrator, camera, settings) =
        (round.ctx, round.integrator, round.camera, round.settings);
    let mut tile_rays = 0u64;
    let mut tile_nonfinite = 0u64;
    let width = tile.x1 - tile.x0;
    for (i, px) in tile.pixels.iter_mut().enumerate() {
        if !px.active {
            continue;
        }
        let (x, y) = (tile.x0 + i as u32 % width, tile.y0 + i as u32 / width);
        progress.check()?;
        let pixel_index = y as u64 * settings.width as u64 + x as u64;
        let first = round.first_sample;
        for s in first + px.n..first + px.n + step {
            // The camera's dimensions (film, lens, moment) come from the pixel's Sobol sequence
            // for every method; the path tracer's and the photon method's paths go on drawing
            // from it, the cache methods' from a pseudo-random stream.
            let random = || Rng::for_item(settings.seed, pixel_index, s as u64);
            let mut camera_rng = match settings.sampler {
                Sampler::Sobol => Rng::sobol(settings.seed, pixel_index, s),
                Sampler::Random => random(),
            };
            let ray = camera_ray(round, (x, y), &mut camera_rng);
            let mut rng = match (integrator, settings.sampler) {
                (Integrator::Path | Integrator::Photon(..), _) | (_, Sampler::Random) => camera_rng,
                _ => random(),
            };
            if ray.t_max <= 0.0 {
                continue; // outside a fisheye's image: black, as in Cycles
            }
            // The shadow catcher's second path draws the same numbers (`shadow_catcher`).
            let catcher_rng = round.catcher.map(|_| rng.clone());
            let mut sample = integrator.trace(ctx, ray, &mut rng);
            if round.emitter_pixels.is_some_and(|e| e.may_see(x, y)) {
                tile_rays += see_emission(round, &mut sample, pixel_index, s, (x, y)) as u64;
            }
            if let (true, Some(only), Some(mut r)) = (sample.catcher, round.catcher, catcher_rng) {
                let without = path::trace(only, ray, &mut r);
                tile_rays += without.rays as u64;
                if sample.radiance.is_finite() && without.radiance.is_finite() {
                    px.catcher.add(sample.radiance, without.radiance);
                }
            }
            tile_rays += sample.rays as u64;
            if sample.radiance.is_finite() {
                px.sum += sample.radiance;
                px.passes += sample.passes;
                if is_class_a(s) {
                    px.sum_a += sample.radiance;
                }
            } else {
                tile_nonfinite += 1;
            }
            px.holdouts += sample.holdout as u32 as f32;
            if sample.hit {
                px.coverage += 1.0;
                px.depth_sum += sample.depth * ray.direction.normalize().dot(camera.forward());
            }
            px.albedo += sample.albedo;
            px.normal += sample.normal;
        }
        px.n += step;
    }
    rays.fetch_add(tile_rays, Ordering::Relaxed);
    nonfinite.fetch_add(tile_nonfinite, Ordering::Relaxed);
    Ok(())
}
