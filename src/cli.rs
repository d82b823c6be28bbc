//! The command line: parses arguments (clap), runs the command, prints progress and errors, and
//! chooses the exit code. The only place in Photon that prints to the terminal.

use clap::{Parser, Subcommand, ValueEnum};
use photon::accel::Accel;
use photon::adaptive::AdaptiveSettings;
use photon::error::{Error, Result};
use photon::exr_merge::SampleRanges;
use photon::film::FilterSettings;
use photon::image_io::{write_image, ExrLayout};
use photon::integrator::photon::settings::PhotonSettings;
use photon::irradiance_cache::IcSettings;
use photon::plan::{
    cache_density, cache_gather_rays, cache_ray_budget, plan_for_image, plan_with_pilot, Pilot,
    Quality,
};
use photon::progress::{Progress, ProgressEvent};
use photon::render::{Method, RenderSettings, RenderStats, Sampler};
use photon::rounds::{render_in_rounds, RoundsResult};
use photon::scene::load::{image_size, load_scene_with, LoadOptions};
use photon::scene::{Projection, Scene, SubsurfaceMethod};
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Samples per pixel of one round when rendering under `--time-limit`.
const TIME_LIMITED_ROUND_SPP: u32 = 4;
/// Upper bound on samples per pixel under `--time-limit` without `--spp`.
const TIME_LIMITED_MAX_SPP: u32 = 65_536;

#[derive(Parser, Debug)]
#[command(
    name = "photon",
    version,
    about = "Photon: photon maps, irradiance caching and path tracing for glTF and Blender scenes"
)]
pub struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a glTF scene (or the embedded Cornell box) to EXR or PNG.
    Render(Box<RenderArgs>),
    /// Compare an image with a reference: relMSE, RMSE, difference of means.
    Compare {
        /// The image to judge (EXR).
        image: PathBuf,
        /// The reference (EXR).
        reference: PathBuf,
        /// Also write a false-colour map of the per-pixel relative error (.exr or .png).
        #[arg(long)]
        error_image: Option<PathBuf>,
    },
    /// Merge renders of one frame made from disjoint sample ranges (`render --sample-offset`,
    /// Blender's Sample Offset) into the render of all their samples: each pass averaged by
    /// the files' sample counts (Depth: the nearest; normals made unit length again).
    Merge {
        /// The merged EXR (may be one of the inputs).
        output: PathBuf,
        /// The renders (EXR files written by photon render or saved by Blender from the
        /// add-on's renders), with the same size, passes and seed.
        #[arg(required = true, num_args = 2..)]
        inputs: Vec<PathBuf>,
    },
    /// Describe a scene: what it holds and how it would be rendered.
    Info {
        /// The .glb or .gltf file.
        scene: PathBuf,
        /// Camera to use (glTF node or camera name).
        #[arg(long)]
        camera: Option<String>,
        /// Material variant to describe (as `render --variant`).
        #[arg(long, value_name = "NAME")]
        variant: Option<String>,
        /// Animation time to describe (as `render --time`).
        #[arg(long, value_name = "SECONDS")]
        time: Option<f32>,
        /// Quality preset the plan is made for.
        #[arg(long, value_enum, default_value_t = QualityArg::Default)]
        quality: QualityArg,
    },
    /// Benchmark run time against error for each method on each scene.
    Bench(crate::bench::BenchArgs),
    /// Interactive rendering (Blender's Rendered viewport): load the scene once, then render
    /// each view requested on stdin (one JSON object a line) progressively into the -o file,
    /// a new request cancelling the one running; ends when stdin closes. Takes the render
    /// flags (--method, --spp, ...); --width and --height size the planner's pilot only.
    View(Box<RenderArgs>),
}

/// Quality preset (`--quality`): samples and photon counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum QualityArg {
    /// Few samples and photons, for a quick look.
    Preview,
    /// The default.
    Default,
    /// Many samples and photons, for final frames.
    Final,
}

impl From<QualityArg> for Quality {
    fn from(q: QualityArg) -> Quality {
        match q {
            QualityArg::Preview => Quality::Preview,
            QualityArg::Default => Quality::Default,
            QualityArg::Final => Quality::Final,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum ProgressMode {
    /// A progress bar when stderr is a terminal, nothing otherwise.
    Auto,
    /// A progress bar.
    Bar,
    /// One JSON object per line on stderr (for the Blender add-on and scripts).
    Json,
    /// Only the final summary.
    None,
}

/// The rendering algorithm (`--method`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum MethodArg {
    /// The scene planner's choice (see `photon info`).
    Auto,
    /// Unbiased path tracing (the reference).
    Path,
    /// Photon mapping with final gathering.
    Photon,
    /// Debug: the global photon map's radiance estimate, seen directly.
    PhotonGlobal,
    /// Debug: the caustic photon map's radiance estimate.
    PhotonCaustic,
    /// Debug: photon positions (white: global, orange: caustic).
    Photons,
    /// Path tracing with an irradiance cache (path-traced records) at the first diffuse bounce.
    PathCache,
    /// Debug: the photon method's cached indirect irradiance.
    IcIrradiance,
    /// Debug: irradiance-record positions (white dots over the dimmed cached irradiance).
    IcRecords,
}

/// The camera samples' sampler (`--sampler`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum SamplerArg {
    /// Owen-scrambled Sobol points, each pixel randomised on its own.
    Sobol,
    /// Independent pseudo-random numbers (PCG32).
    Random,
}

/// How translucent materials scatter under their surface (`--subsurface`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum SubsurfaceArg {
    /// As each material's Subsurface Method says (Random Walk unless it says Christensen–Burley).
    Material,
    /// Every translucent material walked as Cycles' Random Walk, by either method.
    Walk,
    /// Every translucent material as the dipole diffusion of subsurface photons in the photon
    /// method (Christensen–Burley; the path tracer still walks it).
    Dipole,
}

/// A switch (`on` / `off`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
enum OnOff {
    On,
    Off,
}

#[derive(clap::Args, Debug)]
struct RenderArgs {
    /// The .glb or .gltf scene; without it the embedded Cornell box is rendered.
    scene: Option<PathBuf>,
    /// Output image: .exr (linear float RGBA) or .png (sRGB preview).
    #[arg(short, long, default_value = "photon.png")]
    output: PathBuf,
    /// Image width in pixels (default: the scene's, else 640).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=65536))]
    width: Option<u32>,
    /// Image height in pixels (default: the scene's, else from the camera's aspect ratio).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=65536))]
    height: Option<u32>,
    /// Samples per pixel [default: from --quality; with --time-limit, as many as fit].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    spp: Option<u32>,
    /// Quality preset: samples per pixel and, for photon mapping, photon counts.
    #[arg(long, value_enum, default_value_t = QualityArg::Default)]
    quality: QualityArg,
    /// Stop adding samples after this many seconds (rendering in rounds; the first always completes).
    #[arg(long, value_name = "SECONDS")]
    time_limit: Option<f64>,
    /// Maximum number of bounces.
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(0..=1024))]
    max_depth: u32,
    /// Blender's Clamp Direct: the largest light-sample or emitter contribution a path adds at
    /// its first bounce, per colour channel on average; 0: no limit [default: the scene's].
    #[arg(long, value_name = "LIMIT", value_parser = non_negative_limit)]
    clamp_direct: Option<f32>,
    /// Blender's Clamp Indirect: the same for light after more bounces [default: the scene's].
    #[arg(long, value_name = "LIMIT", value_parser = non_negative_limit)]
    clamp_indirect: Option<f32>,
    /// Blender's Reflective Caustics off: glossy reflection is left out of surfaces a path meets
    /// straight after a diffuse bounce [default: the scene's, else on].
    #[arg(long)]
    no_reflective_caustics: bool,
    /// Blender's Refractive Caustics off: the same for glossy transmission.
    #[arg(long)]
    no_refractive_caustics: bool,
    /// Blender's Filter Glossy: glossy lobes are roughened by the smallest density of the
    /// path's bounces so far, divided by this; 0: off [default: the scene's, else 0].
    #[arg(long, value_name = "FILTER", value_parser = non_negative_limit)]
    filter_glossy: Option<f32>,
    /// Worker threads (0: one per core).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Random seed; the same seed gives the same image.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Render samples N .. N+spp-1 of the pixels' sample sequence (Blender's Sample Offset):
    /// renders of disjoint ranges of one frame, on several machines, merge with `photon
    /// merge` into the render of their union. Not with --time-limit or adaptive sampling.
    #[arg(long, value_name = "N", default_value_t = 0)]
    sample_offset: u32,
    /// Camera to render through (glTF node or camera name; default: the first camera).
    #[arg(long)]
    camera: Option<String>,
    /// Material variant to show (glTF KHR_materials_variants, by name; default: each
    /// primitive's own material).
    #[arg(long, value_name = "NAME")]
    variant: Option<String>,
    /// Render the file's animations at this time in seconds: node transforms, skins and morph
    /// weights (default: the nodes' own values).
    #[arg(long, value_name = "SECONDS")]
    time: Option<f32>,
    /// How progress is shown on stderr.
    #[arg(long, value_enum, default_value_t = ProgressMode::Auto)]
    progress: ProgressMode,
    /// Name EXR channels for Blender's multilayer loader: <VIEW_LAYER>.Combined.R and so on.
    #[arg(long, value_name = "VIEW_LAYER")]
    exr_layer: Option<String>,
    /// With --exr-layer, also write the light-path passes (Emit, DiffDir, DiffInd, Caustic,
    /// Subsurface; see `light_pass::LightPass`), which add up to Combined.
    #[arg(long, requires = "exr_layer")]
    passes: bool,
    /// Render only this window of the frame (Blender's render region), in pixels from the
    /// top-left corner, X1 and Y1 exclusive; the image has the window's size.
    #[arg(long, num_args = 4, value_names = ["X0", "Y0", "X1", "Y1"])]
    region: Option<Vec<u32>>,
    /// Pixel filter TYPE[:WIDTH]: blackman-harris, gaussian or box, with Blender's width in
    /// pixels (Cycles' definitions) [default: the scene's, else blackman-harris:1.5].
    #[arg(long, value_name = "TYPE[:WIDTH]")]
    filter: Option<String>,
    /// Numbers of the camera samples and photons: Owen-scrambled Sobol points or independent
    /// random numbers (every method's pixel position, lens and moment; the rest of the path
    /// tracer's and the photon method's paths, final gathering included; photon tracing, one
    /// sequence per map; the cache methods' gathers and cache records always use random numbers).
    #[arg(long, value_enum, default_value_t = SamplerArg::Sobol)]
    sampler: SamplerArg,
    /// Adaptive sampling (Blender's Noise Threshold): a pixel stops taking samples once its
    /// estimated error is below T; 0: automatic (1 / samples, at least 0.001). Off unless given.
    #[arg(long, value_name = "T")]
    adaptive_threshold: Option<f32>,
    /// Samples every pixel takes before adaptive sampling first checks it (Blender's Min
    /// Samples); 0: automatic, from the threshold.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 0,
        requires = "adaptive_threshold"
    )]
    adaptive_min_samples: u32,
    /// Extra camera rays per sample that see only emission: edges of lamps, windows and other
    /// emitters the camera sees directly are averaged over that many more positions in each
    /// pixel [auto: the planner's choice from its pilot image; other methods: 0].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(0..=64))]
    emission_rays: Option<u32>,
    /// Rendering algorithm (auto: the scene planner's choice, see `photon info`).
    #[arg(long, value_enum, default_value_t = MethodArg::Auto)]
    method: MethodArg,
    /// How translucent materials scatter under their surface: as each material says, all by
    /// the random walk, or all by the photon method's dipole.
    #[arg(long, value_enum, default_value_t = SubsurfaceArg::Material)]
    subsurface: SubsurfaceArg,
    /// Photons emitted for the global map [default: 200000].
    #[arg(long)]
    photons: Option<u32>,
    /// Photons emitted for the caustic map (0 skips it) [default: 100000].
    #[arg(long)]
    caustic_photons: Option<u32>,
    /// Final-gather rays per shading point (0 reads the global map directly) [default: 4].
    #[arg(long)]
    gather_rays: Option<u32>,
    /// Nearest photons in a global radiance estimate [default: 64].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    k: Option<u32>,
    /// Nearest photons in a caustic radiance estimate [default: 64].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=10_000))]
    caustic_k: Option<u32>,
    /// Maximum global search radius, as a fraction of the scene's bounding radius [default: 0.1].
    #[arg(long)]
    radius: Option<f32>,
    /// Maximum caustic search radius, as a fraction of the scene's bounding radius [default: 0.02].
    #[arg(long)]
    caustic_radius: Option<f32>,
    /// Precompute irradiance at every n-th global photon for final gathering (Christensen 1999;
    /// 0: a full radiance estimate at every gather hit) [default: 4].
    #[arg(long)]
    irradiance_stride: Option<u32>,
    /// Photons emitted for the subsurface samples of translucent materials [default: 1000000].
    #[arg(long)]
    subsurface_photons: Option<u32>,
    /// Jensen & Buhler's octree error bound (solid angle) [default: 0.2].
    #[arg(long)]
    subsurface_accuracy: Option<f32>,
    /// Memory budget of the photon maps and subsurface samples, in MiB; tracing stops with an
    /// error when they would exceed it [default: half the machine's memory].
    #[arg(long, value_name = "MIB")]
    memory_limit: Option<u64>,
    /// Sum every subsurface sample instead of using the octree (for measurements).
    #[arg(long)]
    subsurface_brute_force: bool,
    /// Ward's irradiance cache for the photon method's indirect light on Lambertian surfaces
    /// (off: final gather rays at every shading point) [default: on].
    #[arg(long, value_enum)]
    irradiance_cache: Option<OnOff>,
    /// Irradiance-cache accuracy a (records are used where Ward's weight exceeds 1/a) [default: 0.2;
    /// auto: up to 0.3 below 16 samples per pixel].
    #[arg(long)]
    ic_accuracy: Option<f32>,
    /// Gather rays per irradiance record (split into T x P strata) [default: 256; auto: 8 per
    /// sample per pixel, from 64 up to 256, when the samples are known].
    #[arg(long)]
    ic_gather_rays: Option<u32>,
    /// Smallest radius an irradiance record covers, in pixels [default: 3; auto: up to 5 below 16
    /// samples per pixel].
    #[arg(long)]
    ic_min_spacing: Option<f32>,
    /// Largest radius an irradiance record covers, in pixels [default: 48].
    #[arg(long)]
    ic_max_spacing: Option<f32>,
    /// Gather rays per pixel the irradiance cache may cost; the build stops before passing
    /// them and points no record covers are shaded as without the cache [auto: the final
    /// gather's rays at the render's samples per pixel, unless --irradiance-cache is given or
    /// a time limit leaves the samples open; otherwise no limit].
    #[arg(long, value_name = "RAYS", allow_negative_numbers = true)]
    ic_ray_budget: Option<f32>,
}

impl RenderArgs {
    /// Irradiance-cache settings: the command line's, else the defaults.
    fn ic_settings(&self) -> Result<IcSettings> {
        let d = IcSettings::default();
        let ic = IcSettings {
            enabled: self.irradiance_cache.map_or(d.enabled, |s| s == OnOff::On),
            accuracy: self.ic_accuracy.unwrap_or(d.accuracy),
            gather_rays: self.ic_gather_rays.unwrap_or(d.gather_rays),
            min_spacing: self.ic_min_spacing.unwrap_or(d.min_spacing),
            max_spacing: self.ic_max_spacing.unwrap_or(d.max_spacing),
            max_rays_per_pixel: self.ic_ray_budget,
        };
        ic.validate()?;
        Ok(ic)
    }

    /// Photon settings: the command line's, else `defaults` (the plan's for `auto`).
    fn photon_settings(&self, defaults: &PhotonSettings) -> Result<PhotonSettings> {
        let d = defaults.clone();
        for (name, r) in [
            ("radius", self.radius),
            ("caustic-radius", self.caustic_radius),
            ("subsurface-accuracy", self.subsurface_accuracy),
        ] {
            if let Some(r) = r {
                if !(r.is_finite() && r > 0.0) {
                    return Err(Error::Settings(format!(
                        "--{name} must be positive, not {r}"
                    )));
                }
            }
        }
        Ok(PhotonSettings {
            global_photons: self.photons.unwrap_or(d.global_photons),
            caustic_photons: self.caustic_photons.unwrap_or(d.caustic_photons),
            k_global: self.k.unwrap_or(d.k_global),
            k_caustic: self.caustic_k.unwrap_or(d.k_caustic),
            global_radius: self.radius.unwrap_or(d.global_radius),
            caustic_radius: self.caustic_radius.unwrap_or(d.caustic_radius),
            gather_rays: self.gather_rays.unwrap_or(d.gather_rays),
            irradiance_stride: self.irradiance_stride.unwrap_or(d.irradiance_stride),
            subsurface_photons: self.subsurface_photons.unwrap_or(d.subsurface_photons),
            subsurface_accuracy: self.subsurface_accuracy.unwrap_or(d.subsurface_accuracy),
            subsurface_brute_force: self.subsurface_brute_force,
            memory_limit_mib: self.memory_limit.unwrap_or_else(default_memory_limit_mib),
            ..d
        })
    }
}

/// Half the machine's memory (from /proc/meminfo), else the library default.
fn default_memory_limit_mib() -> u64 {
    let total_kib = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| {
            let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
            line.split_whitespace().nth(1)?.parse::<u64>().ok()
        });
    total_kib.map_or(PhotonSettings::default().memory_limit_mib, |kib| kib / 2048)
}

/// Run the command line and return the process exit code.
pub fn main() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            // clap uses 2 for usage errors and 0 for --help / --version.
            return e.exit_code();
        }
    };
    // No command at all renders the embedded scene with the defaults.
    let command = cli
        .command
        .or_else(|| Cli::try_parse_from(["photon", "render"]).ok()?.command);
    let result = match command {
        None => Err(Error::Internal("cannot build the default command".into())),
        Some(command) => match command {
            Command::Render(args) => run_render(*args),
            Command::Info {
                scene,
                camera,
                variant,
                time,
                quality,
            } => {
                let options = LoadOptions {
                    camera,
                    variant,
                    time,
                };
                run_info(&scene, &options, quality.into())
            }
            Command::Bench(args) => crate::bench::run_bench(args),
            Command::View(args) => run_view(*args),
            Command::Compare {
                image,
                reference,
                error_image,
            } => run_compare(&image, &reference, error_image.as_deref()),
            Command::Merge { output, inputs } => run_merge(&output, &inputs),
        },
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("photon: error: {e}");
            e.exit_code()
        }
    }
}

/// Ctrl+C and SIGTERM set the flag; a second signal ends the process at once with 130.
fn install_signal_handlers() -> Result<Arc<AtomicBool>> {
    let cancel = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register_conditional_shutdown(signal, 130, cancel.clone())
            .and_then(|_| signal_hook::flag::register(signal, cancel.clone()))
            .map_err(|e| Error::Internal(format!("cannot install signal handler: {e}")))?;
    }
    Ok(cancel)
}

fn peak_memory_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

fn json_line(value: serde_json::Value) {
    let mut err = std::io::stderr().lock();
    let _ = writeln!(err, "{value}");
}

/// A clamp limit: a finite number ≥ 0.
fn non_negative_limit(text: &str) -> std::result::Result<f32, String> {
    match text.parse::<f32>() {
        Ok(x) if x.is_finite() && x >= 0.0 => Ok(x),
        _ => Err(format!("expected a number >= 0, found {text:?}")),
    }
}

/// A scene loaded and a render configured from the command line: what `render` and `view`
/// share.
pub(crate) struct Prepared {
    pub scene: Scene,
    /// The BVH, when the planner's pilot needed it (`--method auto`).
    pub accel: Option<Accel>,
    pub settings: RenderSettings,
    pub pool: rayon::ThreadPool,
    pub threads: usize,
    pub time_limit: Option<Duration>,
    pub load_seconds: f64,
    pub pilot_build_seconds: f64,
}

/// Load the scene and turn the command line into render settings (the planner's for `auto`),
/// reporting the stages and warnings as `mode` says.
fn prepare(args: &RenderArgs, mode: ProgressMode, process: Instant) -> Result<Prepared> {
    let filter = args
        .filter
        .as_deref()
        .map(FilterSettings::parse)
        .transpose()?;
    let adaptive = match args.adaptive_threshold {
        Some(t) if !(t.is_finite() && t >= 0.0) => {
            return Err(Error::Settings(format!(
                "--adaptive-threshold must be a number >= 0 (0: automatic), not {t}"
            )))
        }
        Some(threshold) => Some(AdaptiveSettings {
            threshold,
            min_samples: args.adaptive_min_samples,
        }),
        None => None,
    };
    if mode == ProgressMode::Json {
        json_line(
            serde_json::json!({"stage": "load", "fraction": 0.0, "message": "loading scene"}),
        );
    }
    let options = LoadOptions {
        camera: args.camera.clone(),
        variant: args.variant.clone(),
        time: args.time,
    };
    let mut scene = load_scene_with(args.scene.as_deref(), &options)?;
    let load_seconds = process.elapsed().as_secs_f64();
    let method = match args.subsurface {
        SubsurfaceArg::Material => None,
        SubsurfaceArg::Walk => Some(SubsurfaceMethod::RandomWalk),
        SubsurfaceArg::Dipole => Some(SubsurfaceMethod::ChristensenBurley),
    };
    if let Some(method) = method {
        for material in &mut scene.materials {
            material.subsurface.method = method;
        }
    }
    let settings = &mut scene.render_settings;
    settings.clamp_direct = args.clamp_direct.unwrap_or(settings.clamp_direct);
    settings.clamp_indirect = args.clamp_indirect.unwrap_or(settings.clamp_indirect);
    settings.reflective_caustics_off |= args.no_reflective_caustics;
    settings.refractive_caustics_off |= args.no_refractive_caustics;
    settings.filter_glossy = args.filter_glossy.unwrap_or(settings.filter_glossy);
    for w in &scene.warnings {
        if mode == ProgressMode::Json {
            json_line(serde_json::json!({"stage": "load", "fraction": 1.0, "warning": w}));
        } else {
            eprintln!("photon: warning: {w}");
        }
    }
    let (width, height) = image_size(&scene, args.width, args.height);
    let quality = Quality::from(args.quality);
    if args.sample_offset > 0 && args.time_limit.is_some() {
        return Err(Error::Settings(
            "--sample-offset cannot be combined with --time-limit: the parts of a split frame \
             need known sample ranges"
                .into(),
        ));
    }
    let time_limit = match args.time_limit {
        Some(t) if t.is_finite() && t > 0.0 => Some(Duration::from_secs_f64(t)),
        Some(t) => {
            return Err(Error::Settings(format!(
                "--time-limit must be positive, not {t}"
            )))
        }
        None => None,
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads)
        .build()
        .map_err(|e| Error::Internal(format!("cannot start threads: {e}")))?;
    let threads = pool.current_num_threads();
    // The auto method's photon pilot needs the BVH: build it once, for the pilot and the render.
    let start = Instant::now();
    let accel = (args.method == MethodArg::Auto).then(|| pool.install(|| Accel::new(&scene)));
    let pilot_build_seconds = start.elapsed().as_secs_f64();
    let plan = plan_with_pilot(
        &scene,
        quality,
        width,
        height,
        accel.as_ref().map(|a| Pilot {
            photons: [args.photons, args.caustic_photons],
            ..Pilot::new(a, args.spp)
        }),
    );
    if args.method == MethodArg::Auto {
        let message = format!("auto: {} ({})", plan.method_name(), plan.method_reason);
        match mode {
            ProgressMode::Json => {
                json_line(serde_json::json!({"stage": "plan", "fraction": 1.0, "message": message}))
            }
            _ => eprintln!("photon: {message}"),
        }
    }
    let ic_settings = args.ic_settings()?;
    let spp = match (args.spp, time_limit) {
        (Some(spp), _) => spp,
        (None, Some(_)) => TIME_LIMITED_MAX_SPP,
        (None, None) => plan.spp,
    };
    let photon = if args.method == MethodArg::Auto {
        // Explicit counts override the plan's, but maps the plan skips stay skipped.
        let mut photon = args.photon_settings(&plan.photon)?;
        if !plan.global_map.needed {
            photon.global_photons = 0;
        }
        if !plan.caustic_map.needed {
            photon.caustic_photons = 0;
        }
        photon
    } else {
        args.photon_settings(&PhotonSettings::default())?
    };
    let ray_state = scene.ray_state_materials();
    if !ray_state.is_empty() && !matches!(args.method, MethodArg::Auto | MethodArg::Path) {
        let w = format!(
            "material(s) {} read Light Path's ray kind or depths: photon paths, gathers and \
             cache records do not carry a camera path's state (they read 0), so this method \
             renders them differently from Cycles; --method path (auto's choice) renders them \
             as Cycles does",
            ray_state.join(", ")
        );
        if mode == ProgressMode::Json {
            json_line(serde_json::json!({"stage": "load", "fraction": 1.0, "warning": w}));
        } else {
            eprintln!("photon: warning: {w}");
        }
    }
    // Auto sizes the irradiance cache to the samples when they are known.
    let sized_by_samples =
        args.method == MethodArg::Auto && (args.spp.is_some() || time_limit.is_none());
    let coarse = cache_density(spp, ic_settings.accuracy, ic_settings.min_spacing);
    let settings = RenderSettings {
        width,
        height,
        spp,
        max_depth: args.max_depth,
        seed: args.seed,
        method: match args.method {
            MethodArg::Auto => plan.method,
            MethodArg::Path => Method::Path,
            MethodArg::Photon => Method::Photon,
            MethodArg::PhotonGlobal => Method::PhotonGlobal,
            MethodArg::PhotonCaustic => Method::PhotonCaustic,
            MethodArg::Photons => Method::Photons,
            MethodArg::PathCache => Method::PathCache,
            MethodArg::IcIrradiance => Method::IcIrradiance,
            MethodArg::IcRecords => Method::IcRecords,
        },
        irradiance_cache: IcSettings {
            // Auto holds the cache to the rays final gathering would spend at this many samples
            // (`plan.rs`) unless the cache or its budget was asked for; a render whose samples
            // are not known in advance (a time limit without --spp) and the explicit methods
            // build it whole.
            max_rays_per_pixel: match ic_settings.max_rays_per_pixel {
                Some(budget) => Some(budget),
                None if args.method == MethodArg::Auto
                    && args.irradiance_cache.is_none()
                    && (args.spp.is_some() || time_limit.is_none()) =>
                {
                    Some(cache_ray_budget(spp, photon.gather_rays))
                }
                None => None,
            },
            // Auto gathers fewer rays per record, and places records less densely, at a few
            // samples (`plan.rs`), unless the settings were given.
            gather_rays: match args.ic_gather_rays {
                None if sized_by_samples => cache_gather_rays(spp, ic_settings.gather_rays),
                _ => ic_settings.gather_rays,
            },
            accuracy: match args.ic_accuracy {
                None if sized_by_samples => coarse.0,
                _ => ic_settings.accuracy,
            },
            min_spacing: match args.ic_min_spacing {
                None if sized_by_samples => coarse.1.min(ic_settings.max_spacing),
                _ => ic_settings.min_spacing,
            },
            ..ic_settings
        },
        region: args.region.as_deref().map(|r| photon::render::Region {
            x0: r[0],
            y0: r[1],
            x1: r[2],
            y1: r[3],
        }),
        photon,
        light_passes: args.passes,
        filter,
        sampler: match args.sampler {
            SamplerArg::Sobol => Sampler::Sobol,
            SamplerArg::Random => Sampler::Random,
        },
        adaptive,
        emission_rays: match (args.emission_rays, args.method) {
            (Some(n), _) => n,
            (None, MethodArg::Auto) => plan.emission_rays,
            (None, _) => 0,
        },
        sample_offset: args.sample_offset,
    };

    Ok(Prepared {
        scene,
        accel,
        settings,
        pool,
        threads,
        time_limit,
        load_seconds,
        pilot_build_seconds,
    })
}

/// `photon view`: prepare as `render` does (progress as JSON lines), then serve view requests
/// (`view::serve`). No signal handlers: SIGTERM ends the process at once.
fn run_view(args: RenderArgs) -> Result<()> {
    if args.region.is_some() || args.passes || args.time_limit.is_some() || args.sample_offset > 0 {
        return Err(Error::Settings(
            "view takes no --region, --passes, --time-limit or --sample-offset (each request is \
             a whole view, rendered up to --spp)"
                .into(),
        ));
    }
    let prepared = prepare(&args, ProgressMode::Json, Instant::now())?;
    crate::view::serve(
        prepared.scene,
        prepared.accel,
        &prepared.settings,
        &prepared.pool,
        &args.output,
    )
}

fn run_render(args: RenderArgs) -> Result<()> {
    let process = Instant::now();
    let cancel = install_signal_handlers()?;
    let mode = match args.progress {
        ProgressMode::Auto if std::io::stderr().is_terminal() => ProgressMode::Bar,
        ProgressMode::Auto => ProgressMode::None,
        m => m,
    };
    let prepared = prepare(&args, mode, process)?;
    let (scene, accel, settings, pool) = (
        prepared.scene,
        prepared.accel,
        prepared.settings,
        prepared.pool,
    );
    let (threads, time_limit) = (prepared.threads, prepared.time_limit);
    let (load_seconds, pilot_build_seconds) = (prepared.load_seconds, prepared.pilot_build_seconds);
    let bar = (mode == ProgressMode::Bar).then(|| {
        let bar = indicatif::ProgressBar::new(1000);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} {prefix:>6} [{bar:40}] {percent:>3}% {elapsed_precise} ETA {eta} {msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
            .progress_chars("=> "),
        );
        bar
    });
    let last_stage = Mutex::new(String::new());
    let report = |event: &ProgressEvent| match mode {
        ProgressMode::Json => json_line(serde_json::json!({
            "stage": event.stage, "fraction": event.fraction, "message": event.message,
        })),
        ProgressMode::Bar => {
            if let Some(bar) = &bar {
                if let Ok(mut last) = last_stage.lock() {
                    if *last != event.stage {
                        *last = event.stage.to_string();
                        bar.set_prefix(event.stage.to_string());
                    }
                }
                bar.set_position((event.fraction * 1000.0) as u64);
            }
        }
        _ => {}
    };
    let progress = Progress {
        cancel: &cancel,
        report: &report,
    };
    let round_spp = if time_limit.is_some() {
        TIME_LIMITED_ROUND_SPP
    } else {
        settings.spp
    };
    let result = pool.install(|| {
        render_in_rounds(
            &scene,
            accel.as_ref(),
            &settings,
            round_spp,
            time_limit,
            &progress,
        )
    });
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    let RoundsResult {
        image,
        mut stats,
        spp,
        ..
    } = result?;
    stats.build_seconds += pilot_build_seconds;
    let settings = RenderSettings { spp, ..settings };
    let layout = match &args.exr_layer {
        Some(layer) => ExrLayout::Blender {
            view_layer: layer.clone(),
            light_passes: args.passes,
        },
        None => ExrLayout::Rgba,
    };
    let mut image = image;
    image.metadata =
        SampleRanges::single(settings.seed, settings.sample_offset, settings.spp).metadata();
    let writing = Instant::now();
    write_image(&args.output, &image, &layout, &cancel)?;
    let timing = ProcessTiming {
        total: process.elapsed().as_secs_f64(),
        load: load_seconds,
        write: writing.elapsed().as_secs_f64(),
    };
    let pixels = image.width as u64 * image.height as u64;
    summarise(
        &args.output,
        &settings,
        &stats,
        &timing,
        pixels,
        threads,
        mode,
    );
    Ok(())
}

/// Where a render's process spent its time, beside what `RenderStats` times.
struct ProcessTiming {
    /// From the start of `run_render` to the image written.
    total: f64,
    /// Reading the scene.
    load: f64,
    /// Writing the image.
    write: f64,
}

impl ProcessTiming {
    /// The process's parts, in seconds, named as the summary line names them: each stage
    /// timed, and what is left of the whole (planning, pilots, threads) as "other".
    fn parts(&self, stats: &RenderStats) -> Vec<(&'static str, f64)> {
        let mut parts = vec![("loading", self.load), ("BVH", stats.build_seconds)];
        if let Some(p) = &stats.photon {
            let maps = p.trace_seconds
                + p.guide_seconds
                + p.kdtree_seconds
                + p.volume_seconds
                + p.subsurface_seconds;
            parts.push(("photon maps", maps));
            if p.irradiance_records > 0 {
                parts.push(("irradiance records", p.irradiance_seconds));
            }
        }
        if let Some(c) = &stats.irradiance_cache {
            parts.push(("irradiance cache", c.seconds));
        }
        parts.push(("rendering", stats.render_seconds));
        parts.push(("writing", self.write));
        let timed: f64 = parts.iter().map(|(_, t)| t).sum();
        parts.push(("other", (self.total - timed).max(0.0)));
        parts
    }
}

fn summarise(
    output: &Path,
    settings: &RenderSettings,
    stats: &RenderStats,
    timing: &ProcessTiming,
    pixels: u64,
    threads: usize,
    mode: ProgressMode,
) {
    let parts = timing.parts(stats);
    // Samples per pixel on average: fewer than `spp` where adaptive sampling stopped pixels.
    let mean_spp = stats.camera_samples as f64 / pixels.max(1) as f64;
    let mrays = stats.rays as f64 / stats.render_seconds.max(1e-9) / 1e6;
    if let Some(p) = &stats.photon {
        let rate = (p.global_emitted + p.caustic_emitted) as f64 / p.trace_seconds.max(1e-9);
        if mode == ProgressMode::Json {
            json_line(serde_json::json!({
                "stage": "photons", "fraction": 1.0, "message": "photon maps built",
                "stats": {
                    "global_emitted": p.global_emitted, "global_stored": p.global_stored,
                    "caustic_emitted": p.caustic_emitted, "caustic_stored": p.caustic_stored,
                    "caustic_skipped": p.caustic_skipped, "trace_seconds": p.trace_seconds,
                    "guided": p.guided, "guide_seconds": p.guide_seconds,
                    "kdtree_seconds": p.kdtree_seconds, "photons_per_second": rate,
                    "irradiance_records": p.irradiance_records,
                    "irradiance_seconds": p.irradiance_seconds,
                    "subsurface_emitted": p.subsurface_emitted,
                    "subsurface_stored": p.subsurface_stored,
                    "subsurface_skipped": p.subsurface_skipped,
                    "subsurface_seconds": p.subsurface_seconds,
                }
            }));
        } else {
            if let Some(why) = &p.caustic_skipped {
                eprintln!("photon: caustic map skipped: {why}");
            }
            eprintln!(
                "photon: photons: global {} emitted / {} stored, caustic {} emitted / {} stored; traced in {:.3} s ({:.2} M photons/s), kd-trees {:.3} s, {} irradiance records in {:.3} s",
                p.global_emitted,
                p.global_stored,
                p.caustic_emitted,
                p.caustic_stored,
                p.trace_seconds,
                rate / 1e6,
                p.kdtree_seconds,
                p.irradiance_records,
                p.irradiance_seconds
            );
            if p.guided {
                eprintln!(
                    "photon: photons guided towards what the camera's paths meet (pilots {:.3} s)",
                    p.guide_seconds
                );
            }
            if p.subsurface_stored > 0 {
                eprintln!(
                    "photon: subsurface: {} photons emitted / {} samples on translucent surfaces, built with their octrees in {:.3} s",
                    p.subsurface_emitted, p.subsurface_stored, p.subsurface_seconds
                );
            }
        }
    }
    if let Some(c) = &stats.irradiance_cache {
        if mode == ProgressMode::Json {
            json_line(serde_json::json!({
                "stage": "cache", "fraction": 1.0, "message": "irradiance cache built",
                "stats": {"records": c.records, "seconds": c.seconds,
                          "strata": [c.strata.0, c.strata.1],
                          "budget_reached": c.budget_reached}
            }));
        } else {
            eprintln!(
                "photon: irradiance cache: {} records ({} x {} gather rays) in {:.3} s{}",
                c.records,
                c.strata.0,
                c.strata.1,
                c.seconds,
                if c.budget_reached {
                    ", stopped at its ray budget (points no record covers are shaded without it)"
                } else {
                    ""
                }
            );
        }
    }
    let memory = peak_memory_mib().unwrap_or(0.0);
    if mode == ProgressMode::Json {
        json_line(serde_json::json!({
            "stage": "done", "fraction": 1.0, "message": format!("wrote {}", output.display()),
            "stats": {
                "method": format!("{:?}", settings.method),
                "width": settings.width, "height": settings.height, "spp": settings.spp,
                "threads": threads, "triangles": stats.triangles, "lights": stats.lights,
                "build_seconds": stats.build_seconds, "render_seconds": stats.render_seconds,
                "total_seconds": timing.total,
                "parts_seconds": parts.iter().map(|(name, t)| (name.to_string(), serde_json::json!(t)))
                    .collect::<serde_json::Map<_, _>>(),
                "rays": stats.rays, "mrays_per_second": mrays,
                "nonfinite_samples": stats.nonfinite_samples, "peak_memory_mib": memory,
                "camera_samples": stats.camera_samples, "mean_spp": mean_spp,
            }
        }));
    } else {
        eprintln!(
            "photon: wrote {} ({}x{}, {} spp{}) in {:.2} s on {} threads ({}): {:.1} M rays/s rendering, peak memory {:.0} MiB{}",
            output.display(),
            settings.width,
            settings.height,
            settings.spp,
            match settings.adaptive {
                Some(_) => format!(", adaptive: {mean_spp:.1} on average"),
                None => String::new(),
            },
            timing.total,
            threads,
            parts
                .iter()
                .map(|(name, t)| format!("{name} {t:.2} s"))
                .collect::<Vec<_>>()
                .join(", "),
            mrays,
            memory,
            if stats.nonfinite_samples > 0 {
                format!(", {} non-finite samples dropped", stats.nonfinite_samples)
            } else {
                String::new()
            }
        );
    }
}

fn run_info(path: &Path, options: &LoadOptions, quality: Quality) -> Result<()> {
    let scene = load_scene_with(Some(path), options)?;
    let (width, height) = image_size(&scene, None, None);
    println!("scene: {}", path.display());
    println!("textures: {}", scene.textures.len());
    let projection = match scene.camera.projection {
        Projection::Perspective { yfov } => {
            format!("perspective, vertical fov {:.1} deg", yfov.to_degrees())
        }
        Projection::Orthographic { xmag, ymag } => format!("orthographic {xmag} x {ymag}"),
        Projection::Equirectangular { .. } => "panoramic, equirectangular".to_string(),
        Projection::FisheyeEquidistant { fov } => {
            format!("panoramic, equidistant fisheye {:.1} deg", fov.to_degrees())
        }
        Projection::FisheyeEquisolid { lens, fov, .. } => format!(
            "panoramic, equisolid fisheye {lens} mm, {:.1} deg",
            fov.to_degrees()
        ),
        Projection::FisheyePolynomial { fov, .. } => {
            format!("panoramic, polynomial fisheye {:.1} deg", fov.to_degrees())
        }
        Projection::MirrorBall => "panoramic, mirror ball".to_string(),
        Projection::CentralCylindrical { .. } => "panoramic, central cylindrical".to_string(),
        Projection::CubeMapFace => "panoramic, equiangular cube-map face".to_string(),
    };
    println!("camera: '{}', {projection}", scene.camera.name);
    println!("{}", plan_for_image(&scene, quality, width, height));
    for w in scene.warnings.iter().chain(&scene.export_notes) {
        println!("warning: {w}");
    }
    Ok(())
}

fn run_merge(output: &Path, inputs: &[PathBuf]) -> Result<()> {
    let cancel = install_signal_handlers()?;
    let summary = photon::exr_merge::merge(inputs, output, &cancel)?;
    let ranges: Vec<String> = summary
        .samples
        .ranges
        .iter()
        .map(|(a, b)| format!("{a}-{b}"))
        .collect();
    eprintln!(
        "photon: merged {} images into {} ({}x{}, {} channels, {} samples: {})",
        inputs.len(),
        output.display(),
        summary.width,
        summary.height,
        summary.channels,
        summary.samples.count(),
        ranges.join(", ")
    );
    Ok(())
}

fn run_compare(image: &Path, reference: &Path, error_image: Option<&Path>) -> Result<()> {
    let (w, h, pixels) = photon::image_io::read_exr_rgba(image)?;
    let (rw, rh, ref_pixels) = photon::image_io::read_exr_rgba(reference)?;
    if (w, h) != (rw, rh) {
        return Err(Error::Settings(format!(
            "{} is {w}x{h} but {} is {rw}x{rh}",
            image.display(),
            reference.display()
        )));
    }
    let e = photon::metrics::compare(&pixels, &ref_pixels);
    println!("relMSE {:.6}", e.rel_mse);
    println!(
        "relMSE without the worst {} % of pixels {:.6}",
        100.0 * photon::metrics::OUTLIER_SHARE,
        e.rel_mse_without_outliers
    );
    println!("RMSE {:.6}", e.rmse);
    println!(
        "mean {:.6} vs reference {:.6} ({:+.2} %)",
        e.mean_image,
        e.mean_reference,
        100.0 * e.mean_relative_difference
    );
    if let Some(path) = error_image {
        let mut out = photon::film::Image::new(w, h);
        out.rgba = photon::metrics::false_colour_error(&pixels, &ref_pixels);
        write_image(path, &out, &ExrLayout::Rgba, &AtomicBool::new(false))?;
    }
    Ok(())
}
