//! `photon bench`: run time against error. For each scene, a reference (path-traced, or by the
//! photon method for caustics of small lights) is rendered once as two independent halves
//! (seeds 1 and 2) and cached in `OUT/refs/` (keyed by a hash of the scene file, the renderer
//! version, the resolution and the samples) with the estimate of its own noise the halves give;
//! then each method (path, photon map, photon map + irradiance cache, auto) renders at a series
//! of budgets (samples per pixel and photon counts scaled together; auto with the photons the
//! planner sizes, as `photon render` runs it). Every render runs as a
//! child process of this binary, so its wall time and peak memory (the child's VmHWM) are its
//! own. From the (time, relMSE) points it derives the time each method needs to reach a target
//! error and judges auto against the best fixed method at auto's time, both by log-log
//! interpolation. Each method's longest budget is rendered once more with another seed, which
//! splits its error there into noise and bias (the part no number of samples at that budget
//! removes). Writes `OUT/results.csv`, `OUT/report.md`, `OUT/summary.json` and one log-log SVG
//! plot of relMSE against time per scene.

use photon::error::{Error, Result};
use photon::film::{FilterSettings, Image};
use photon::image_io::{write_image, ExrLayout};
use photon::metrics::{compare, ImageError};
use photon::plan::{plan, Quality};
use photon::render::GENERATION_SPP;
use photon::scene::load::{image_size, load_scene};
use serde_json::json;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

/// Global photons per unit of budget (budget 40 gives the default 200 000), per generation of
/// maps: a budget past `GENERATION_SPP` gets more generations, not larger maps.
const GLOBAL_PHOTONS_PER_BUDGET: u64 = 5_000;
/// Caustic photons per unit of budget (budget 40 gives the default 100 000).
const CAUSTIC_PHOTONS_PER_BUDGET: u64 = 2_500;

#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Scenes to benchmark [default: every .glb in scenes/].
    scenes: Vec<PathBuf>,
    /// Budgets: samples per pixel; photon counts scale with them.
    #[arg(long, value_delimiter = ',', default_values_t = [1, 4, 16])]
    budgets: Vec<u32>,
    /// Methods to compare: path, photon (no irradiance cache), photon-ic, auto, path-random
    /// (the path tracer with independent random numbers), path-adaptive and auto-adaptive
    /// (with adaptive sampling at Blender's default threshold, 0.01) [default: the first four].
    #[arg(long, value_delimiter = ',')]
    methods: Vec<String>,
    /// Worker threads of each timed render (0: one per core); references use every core.
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Output directory.
    #[arg(long, default_value = "bench")]
    out: PathBuf,
    /// Image width of every render.
    #[arg(long, default_value_t = 64)]
    width: u32,
    /// Image height (default: from the scene camera's aspect ratio).
    #[arg(long)]
    height: Option<u32>,
    /// Samples per pixel of the reference (two halves with seeds 1 and 2).
    #[arg(long, default_value_t = 1024)]
    reference_spp: u32,
    /// How the references are rendered: `path`; `photon`, for scenes whose caustics of small
    /// lights the path tracer does not resolve (the photon method without the cache, with
    /// `REFERENCE_PHOTONS` global and caustic photons per generation: consistent, so it
    /// converges with the samples; it agrees with the path tracer where both converge); `auto`,
    /// `photon` for the scenes whose planner pilot finds such caustics, `path` for the others.
    #[arg(long, value_enum, default_value_t = ReferenceMethod::Auto)]
    reference_method: ReferenceMethod,
    /// Runs of each timed render, in rounds over all of a scene's renders; the fastest counts
    /// (renders are deterministic, so the image is the same; on a shared machine the minimum is
    /// the least disturbed time).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=100))]
    repeats: u32,
    /// Pixel filter of every render and of the reference, TYPE[:WIDTH] as `photon render
    /// --filter` [default: the scene's, else blackman-harris:1.5].
    #[arg(long, value_name = "TYPE[:WIDTH]")]
    filter: Option<String>,
    /// The relMSE whose time to reach the report tabulates per method.
    #[arg(long, default_value_t = 0.01)]
    target_error: f64,
}

/// How `photon bench` renders its references.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ReferenceMethod {
    Auto,
    Path,
    Photon,
}

/// How a reference rendered with `method` (`Path` or `Photon`) is described in the report.
fn reference_words(method: ReferenceMethod) -> String {
    match method {
        ReferenceMethod::Photon => format!(
            "the photon method without the cache ({REFERENCE_PHOTONS} global and caustic photons \
             per generation of 64 spp)"
        ),
        _ => "the path tracer".to_string(),
    }
}

/// The seed of the second render that splits a method's error into noise and bias (the timed
/// renders use the default seed, 0).
const SECOND_SEED: u64 = 2;

/// Global and caustic photons per generation of a photon-method reference.
const REFERENCE_PHOTONS: u32 = 1_000_000;

/// The bench methods and the render options each adds. `photon` is pure final gathering,
/// `photon-ic` takes the indirect light from Ward's irradiance cache; `auto` renders the planner's
/// choice with the same budget, so the bench judges the choice. `path-random` is the path tracer
/// with independent random numbers instead of its Sobol points, `path-adaptive` and
/// `auto-adaptive` the path tracer and the planner's choice with adaptive sampling at Blender's
/// default Noise Threshold, 0.01, the budget being the most samples a pixel takes (not run
/// unless asked for).
const METHODS: [(&str, &[&str]); 7] = [
    ("path", &["--method", "path"]),
    (
        "photon",
        &["--method", "photon", "--irradiance-cache", "off"],
    ),
    (
        "photon-ic",
        &["--method", "photon", "--irradiance-cache", "on"],
    ),
    ("auto", &["--method", "auto"]),
    ("path-random", &["--method", "path", "--sampler", "random"]),
    (
        "path-adaptive",
        &["--method", "path", "--adaptive-threshold", "0.01"],
    ),
    (
        "auto-adaptive",
        &["--method", "auto", "--adaptive-threshold", "0.01"],
    ),
];

/// The methods run without `--methods`.
const DEFAULT_METHODS: [&str; 4] = ["path", "photon", "photon-ic", "auto"];

/// The render options of the bench method `name`; unknown names are a settings error.
fn method_options(name: &str) -> Result<&'static [&'static str]> {
    METHODS
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, options)| *options)
        .ok_or_else(|| {
            let valid: Vec<&str> = METHODS.iter().map(|(n, _)| *n).collect();
            Error::Settings(format!(
                "unknown bench method '{name}' (valid: {})",
                valid.join(", ")
            ))
        })
}

/// One render of the benchmark.
#[derive(Clone, Debug)]
struct Row {
    scene: String,
    method: String,
    budget: u32,
    seconds: f64,
    peak_mib: f64,
    error: ImageError,
}

/// FNV-1a, 64 bits: a stable content hash for the reference cache key.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

fn io_error(path: &Path, e: std::io::Error) -> Error {
    Error::Settings(format!("{}: {e}", path.display()))
}

fn default_scenes() -> Result<Vec<PathBuf>> {
    let dir = Path::new("scenes");
    let mut scenes: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| io_error(dir, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "glb"))
        .collect();
    scenes.sort();
    Ok(scenes)
}

/// What one child render reported.
struct ChildRun {
    seconds: f64,
    peak_mib: f64,
}

/// Render `scene` in a child process on `threads` threads with `extra` arguments; wall time
/// measured here, peak memory from the child's final JSON statistics.
fn render_child(
    scene: &Path,
    output: &Path,
    threads: usize,
    size: (u32, u32),
    filter: Option<&str>,
    extra: &[String],
) -> Result<ChildRun> {
    let exe = std::env::current_exe()
        .map_err(|e| Error::Internal(format!("cannot find the photon binary: {e}")))?;
    let start = Instant::now();
    let result = Command::new(exe)
        .arg("render")
        .arg(scene)
        .arg("-o")
        .arg(output)
        .args(["--progress", "json", "--threads", &threads.to_string()])
        .args([
            "--width",
            &size.0.to_string(),
            "--height",
            &size.1.to_string(),
        ])
        .args(extra)
        .args(filter.iter().flat_map(|f| ["--filter", f]))
        .output()
        .map_err(|e| Error::Internal(format!("cannot run a child render: {e}")))?;
    let seconds = start.elapsed().as_secs_f64();
    let stderr = String::from_utf8_lossy(&result.stderr);
    if !result.status.success() {
        return Err(Error::Internal(format!(
            "child render of {} failed: {}",
            scene.display(),
            stderr.lines().last().unwrap_or("")
        )));
    }
    let peak_mib = stderr
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .filter(|v| v["stage"] == "done")
        .find_map(|v| v["stats"]["peak_memory_mib"].as_f64())
        .unwrap_or(f64::NAN);
    Ok(ChildRun { seconds, peak_mib })
}

/// Bench image size: `--width`, and `--height` or the scene's own aspect ratio.
fn bench_size(scene: &photon::scene::Scene, args: &BenchArgs) -> (u32, u32) {
    let (w, h) = image_size(scene, None, None);
    let height = args
        .height
        .unwrap_or_else(|| ((args.width as u64 * h as u64) / w.max(1) as u64).max(1) as u32);
    (args.width, height)
}

/// A scene's reference and an estimate of its own error.
struct Reference {
    /// How it was rendered: `Path` or `Photon`.
    method: ReferenceMethod,
    pixels: Vec<[f32; 4]>,
    /// Estimated relMSE of the reference against the true image.
    noise: f64,
}

/// The mean of two independent renders `a` and `b`, and the mean's relMSE against the truth
/// estimated from their difference: E[(A − B)²] = 2σ² and the mean has variance σ²/2, so it is
/// relMSE(A, B)/4. The mean stands in for the truth in relMSE's denominator (A − B + M is
/// compared with M), as the reference does for every bench error.
fn two_half_noise(a: &[[f32; 4]], b: &[[f32; 4]]) -> (Vec<[f32; 4]>, f64) {
    let mean: Vec<[f32; 4]> = a
        .iter()
        .zip(b)
        .map(|(p, q)| std::array::from_fn(|c| 0.5 * (p[c] + q[c])))
        .collect();
    let shifted: Vec<[f32; 4]> = a
        .iter()
        .zip(b)
        .zip(&mean)
        .map(|((p, q), m)| std::array::from_fn(|c| p[c] - q[c] + m[c]))
        .collect();
    let noise = compare(&shifted, &mean).rel_mse / 4.0;
    (mean, noise)
}

/// The cached reference of `scene`, rendered when missing with `reference_method` (`Path` or
/// `Photon`): two halves of `--reference-spp / 2` samples with seeds 1 and 2, averaged into
/// `refs/KEY.exr`, their noise estimate in `refs/KEY.noise.json`.
fn reference(
    scene: &Path,
    reference_method: ReferenceMethod,
    args: &BenchArgs,
    size: (u32, u32),
) -> Result<Reference> {
    let bytes = std::fs::read(scene).map_err(|e| io_error(scene, e))?;
    let refs = args.out.join("refs");
    std::fs::create_dir_all(&refs).map_err(|e| io_error(&refs, e))?;
    let method = match reference_method {
        ReferenceMethod::Photon => "photon",
        _ => "path",
    };
    // The scene's own filter is part of its bytes; one given on the command line is named.
    let filter = args
        .filter
        .as_deref()
        .map(FilterSettings::parse)
        .transpose()?
        .map_or_else(String::new, |f| {
            format!("-{}", f.to_string().replace(':', ""))
        });
    let key = format!(
        "{}-{:016x}-v{}-{}x{}-{}spp-{method}{filter}",
        stem(scene),
        fnv1a(&bytes),
        env!("CARGO_PKG_VERSION"),
        size.0,
        size.1,
        args.reference_spp
    );
    let exr = refs.join(format!("{key}.exr"));
    let noise_file = refs.join(format!("{key}.noise.json"));
    if let (true, Ok(text)) = (exr.exists(), std::fs::read_to_string(&noise_file)) {
        let cached: serde_json::Value = serde_json::from_str(&text).unwrap_or_default();
        if let Some(noise) = cached["reference_noise_rel_mse"].as_f64() {
            return Ok(Reference {
                method: reference_method,
                pixels: read_rgba(&exr)?,
                noise,
            });
        }
    }
    eprintln!("photon bench: reference for {} ...", scene.display());
    let half_spp = (args.reference_spp / 2).max(1);
    let mut halves = Vec::new();
    for seed in ["1", "2"] {
        let half = refs.join(format!("{key}.half{seed}.exr"));
        let mut extra: Vec<String> = ["--method", method, "--spp", &half_spp.to_string()]
            .into_iter()
            .chain(["--seed", seed])
            .map(String::from)
            .collect();
        if reference_method == ReferenceMethod::Photon {
            let photons = REFERENCE_PHOTONS.to_string();
            let options = ["--irradiance-cache", "off", "--photons", &photons];
            extra.extend(
                options
                    .into_iter()
                    .chain(["--caustic-photons", &photons])
                    .map(String::from),
            );
        }
        // References are not timed: every core renders them, whatever `--threads` says.
        render_child(scene, &half, 0, size, args.filter.as_deref(), &extra)?;
        halves.push(read_rgba(&half)?);
        std::fs::remove_file(&half).map_err(|e| io_error(&half, e))?;
    }
    let (pixels, noise) = two_half_noise(&halves[0], &halves[1]);
    let mut image = Image::new(size.0, size.1);
    image.rgba.clone_from(&pixels);
    write_image(&exr, &image, &ExrLayout::Rgba, &AtomicBool::new(false))?;
    let cached = serde_json::json!({
        "reference_noise_rel_mse": noise,
        "half_spp": half_spp,
        "seeds": [1, 2],
    });
    write_file(&noise_file, &format!("{cached:#}\n"))?;
    Ok(Reference {
        method: reference_method,
        pixels,
        noise,
    })
}

fn stem(path: &Path) -> String {
    path.file_stem()
        .map_or_else(|| "scene".into(), |s| s.to_string_lossy().into_owned())
}

fn read_rgba(path: &Path) -> Result<Vec<[f32; 4]>> {
    Ok(photon::image_io::read_exr_rgba(path)?.2)
}

/// What the bench learnt of one scene besides its rows.
struct SceneResult {
    name: String,
    /// How its reference was rendered.
    reference_method: ReferenceMethod,
    /// Estimated relMSE of the reference itself.
    reference_noise: f64,
    analysis: Analysis,
    biases: Vec<Bias>,
}

/// A method's error at its longest budget split into noise and bias, from a second render of
/// that budget with another seed (`split_bias`).
struct Bias {
    method: String,
    budget: u32,
    /// relMSE of one render against the reference.
    rel_mse: f64,
    /// The relMSE one render owes to its own noise: half the two renders' difference.
    noise: f64,
    /// What is left of the two renders' mean's relMSE without its noise and the reference's:
    /// the squared bias, which no number of samples at this budget's settings removes.
    bias: f64,
    /// The two renders' mean's relative difference of means against the reference.
    mean_error: f64,
}

/// Split a method's error at one budget into noise and bias from two renders `a` and `b` with
/// different seeds: their mean's relMSE is bias² + noise/2 + the reference's noise, and half
/// their difference estimates the noise of one.
fn split_bias(a: &[[f32; 4]], b: &[[f32; 4]], reference: &Reference) -> (f64, f64, f64, f64) {
    let mean: Vec<[f32; 4]> = a
        .iter()
        .zip(b)
        .map(|(p, q)| std::array::from_fn(|c| 0.5 * (p[c] + q[c])))
        .collect();
    // The difference of two independent renders has twice the variance of one; relMSE
    // normalises by the reference, like every error the bench reports.
    let difference: Vec<[f32; 4]> = a
        .iter()
        .zip(b)
        .zip(&reference.pixels)
        .map(|((p, q), r)| std::array::from_fn(|c| r[c] + p[c] - q[c]))
        .collect();
    let noise = compare(&difference, &reference.pixels).rel_mse / 2.0;
    let total = compare(&mean, &reference.pixels);
    let bias = (total.rel_mse - noise / 2.0 - reference.noise).max(0.0);
    (
        compare(a, &reference.pixels).rel_mse,
        noise,
        bias,
        total.mean_relative_difference,
    )
}

fn bench_scene(scene_path: &Path, args: &BenchArgs, rows: &mut Vec<Row>) -> Result<SceneResult> {
    let scene = load_scene(Some(scene_path), None)?;
    let size = bench_size(&scene, args);
    let scene_plan = plan(&scene, Quality::Default);
    let reference_method = match args.reference_method {
        ReferenceMethod::Auto if scene_plan.hard_caustics() => ReferenceMethod::Photon,
        ReferenceMethod::Auto => ReferenceMethod::Path,
        given => given,
    };
    let reference = reference(scene_path, reference_method, args, size)?;
    let reference_pixels = &reference.pixels;
    let images = args.out.join("images");
    std::fs::create_dir_all(&images).map_err(|e| io_error(&images, e))?;
    let name = stem(scene_path);
    // Every (method, budget) render of the scene, with its options.
    let mut jobs: Vec<(&String, u32, Vec<String>)> = Vec::new();
    for method in &args.methods {
        // Photon mapping has nothing to do in a scene without light.
        if method.starts_with("photon") && !scene_plan.anything_to_trace {
            continue;
        }
        for &budget in &args.budgets {
            let per_generation = budget.min(GENERATION_SPP);
            let mut extra: Vec<String> = method_options(method)?
                .iter()
                .map(|s| s.to_string())
                .collect();
            extra.extend(["--spp".into(), budget.to_string()]);
            // The planner's methods are timed as `photon render` runs them: with the photons it
            // sizes to the image and the samples.
            if !method.starts_with("auto") {
                extra.extend([
                    "--photons".into(),
                    (per_generation as u64 * GLOBAL_PHOTONS_PER_BUDGET).to_string(),
                    "--caustic-photons".into(),
                    (per_generation as u64 * CAUSTIC_PHOTONS_PER_BUDGET).to_string(),
                ]);
            }
            jobs.push((method, budget, extra));
        }
    }
    let output = |method: &str, budget: u32| images.join(format!("{name}-{method}-{budget}.exr"));
    // Repeats go round all the renders in turn, so that a slow spell of the shared machine
    // falls on every method alike rather than on all the repeats of one; the fastest run counts.
    let mut fastest: Vec<Option<ChildRun>> = jobs.iter().map(|_| None).collect();
    let rounds = args.repeats.max(1);
    for round in 1..=rounds {
        if rounds > 1 {
            eprintln!("photon bench: {name} round {round} of {rounds}");
        }
        for ((method, budget, extra), best) in jobs.iter().zip(&mut fastest) {
            let out = output(method, *budget);
            let filter = args.filter.as_deref();
            let run = render_child(scene_path, &out, args.threads, size, filter, extra)?;
            if best.as_ref().is_none_or(|b| run.seconds < b.seconds) {
                *best = Some(run);
            }
        }
    }
    for ((method, budget, _), run) in jobs.iter().zip(fastest) {
        let Some(run) = run else { continue };
        let out = output(method, *budget);
        let pixels = read_rgba(&out)?;
        if pixels.len() != reference_pixels.len() {
            return Err(Error::Internal(format!(
                "{} and its reference differ in size",
                out.display()
            )));
        }
        let error = compare(&pixels, reference_pixels);
        eprintln!(
            "photon bench: {name} {method} budget {budget}: {:.2} s, relMSE {:.5}",
            run.seconds, error.rel_mse
        );
        rows.push(Row {
            scene: name.clone(),
            method: (*method).clone(),
            budget: *budget,
            seconds: run.seconds,
            peak_mib: run.peak_mib,
            error,
        });
    }
    // Bias apart from noise: each method's longest budget once more with another seed.
    let mut biases = Vec::new();
    for method in &args.methods {
        let longest = jobs
            .iter()
            .filter(|(m, _, _)| *m == method)
            .max_by_key(|(_, budget, _)| *budget);
        let Some((_, budget, extra)) = longest else {
            continue;
        };
        let second = images.join(format!("{name}-{method}-{budget}-seed2.exr"));
        let mut extra = extra.clone();
        extra.extend(["--seed".into(), SECOND_SEED.to_string()]);
        let filter = args.filter.as_deref();
        render_child(scene_path, &second, args.threads, size, filter, &extra)?;
        let (a, b) = (read_rgba(&output(method, *budget))?, read_rgba(&second)?);
        let (rel_mse, noise, bias, mean_error) = split_bias(&a, &b, &reference);
        eprintln!(
            "photon bench: {name} {method} budget {budget}: noise {noise:.2e}, bias {bias:.2e}"
        );
        biases.push(Bias {
            method: method.clone(),
            budget: *budget,
            rel_mse,
            noise,
            bias,
            mean_error,
        });
    }
    Ok(SceneResult {
        analysis: analyse(rows, &name, args),
        name,
        reference_method: reference.method,
        reference_noise: reference.noise,
        biases,
    })
}

/// The line through (x0, y0) and (x1, y1) in log-log space, at `x`; linear where a value is not
/// positive (a log would be infinite), and y0 when x0 = x1.
fn log_log(x0: f64, y0: f64, x1: f64, y1: f64, x: f64) -> f64 {
    if x0 == x1 {
        y0
    } else if x0 > 0.0 && x1 > 0.0 && x > 0.0 && y0 > 0.0 && y1 > 0.0 {
        y0 * (y1 / y0).powf((x / x0).ln() / (x1 / x0).ln())
    } else {
        y0 + (y1 - y0) * (x - x0) / (x1 - x0)
    }
}

/// The (time, relMSE) points of `method` on `scene`, sorted by time.
fn curve(rows: &[Row], scene: &str, method: &str) -> Vec<(f64, f64)> {
    let mut points: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.scene == scene && r.method == method)
        .map(|r| (r.seconds, r.error.rel_mse))
        .collect();
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    points
}

/// When a method's error reaches the target.
#[derive(Clone, Copy, Debug, PartialEq)]
enum TimeToTarget {
    /// Interpolated between the two measured points that bracket the target.
    Reached(f64),
    /// Already at or below the target at the shortest measured time: at most that time.
    AtMost(f64),
    /// No measured point reached it: the best error, its time, the longest measured time, and
    /// the time extrapolated from the last point with relMSE ∝ 1/t (Monte Carlo convergence of
    /// an unbiased method; an estimate, not a bound).
    NotReached {
        best_error: f64,
        seconds: f64,
        longest: f64,
        extrapolated: f64,
    },
}

impl TimeToTarget {
    /// The interval the time lies in.
    fn bounds(self) -> (f64, f64) {
        match self {
            TimeToTarget::Reached(t) => (t, t),
            TimeToTarget::AtMost(t) => (0.0, t),
            TimeToTarget::NotReached { longest, .. } => (longest, f64::INFINITY),
        }
    }

    fn text(self) -> String {
        match self {
            TimeToTarget::Reached(t) => format!("{t:.2} s"),
            TimeToTarget::AtMost(t) => format!("≤ {t:.2} s (below target at the smallest budget)"),
            TimeToTarget::NotReached {
                best_error,
                seconds,
                extrapolated,
                ..
            } => format!(
                "not reached (best relMSE {best_error:.2e} at {seconds:.2} s; ≈ {extrapolated:.3} s extrapolated as 1/t)"
            ),
        }
    }

    /// The time itself where measured, else its bound or extrapolation.
    fn estimate(self) -> f64 {
        match self {
            TimeToTarget::Reached(t) | TimeToTarget::AtMost(t) => t,
            TimeToTarget::NotReached { extrapolated, .. } => extrapolated,
        }
    }
}

/// The time `curve` (sorted by time) reaches `target`: log-log interpolation between the first
/// pair of consecutive points whose errors bracket it.
fn time_to_target(curve: &[(f64, f64)], target: f64) -> Option<TimeToTarget> {
    let &(t0, e0) = curve.first()?;
    if e0 <= target {
        return Some(TimeToTarget::AtMost(t0));
    }
    if let Some(w) = curve
        .windows(2)
        .find(|w| w[0].1 > target && w[1].1 <= target)
    {
        let ((ta, ea), (tb, eb)) = (w[0], w[1]);
        return Some(TimeToTarget::Reached(log_log(ea, ta, eb, tb, target)));
    }
    let &(seconds, best_error) = curve.iter().min_by(|a, b| a.1.total_cmp(&b.1))?;
    let &(longest, last_error) = curve.last()?;
    Some(TimeToTarget::NotReached {
        best_error,
        seconds,
        longest,
        extrapolated: longest * last_error / target,
    })
}

/// The ratio of a method's time to target to path's, as far as the bounds tell it: a number when
/// both were interpolated, "≤ x" or "≥ x" when one is a bound, "—" when nothing is known; when
/// either did not reach the target, followed by the ratio of the 1/t extrapolations.
fn ratio_text(method: TimeToTarget, path: TimeToTarget) -> String {
    if method == path {
        return "1.00".into();
    }
    let ((m_lo, m_hi), (p_lo, p_hi)) = (method.bounds(), path.bounds());
    let (lo, hi) = (m_lo / p_hi, m_hi / p_lo);
    let bounded = if lo == hi {
        format!("{lo:.2}")
    } else if hi.is_finite() {
        format!("≤ {hi:.2}")
    } else if lo > 0.0 {
        format!("≥ {lo:.2}")
    } else {
        "—".into()
    };
    let extrapolated = |t: TimeToTarget| matches!(t, TimeToTarget::NotReached { .. });
    if extrapolated(method) || extrapolated(path) {
        let ratio = method.estimate() / path.estimate();
        format!("{bounded} (≈ {ratio:.3} extrapolated)")
    } else {
        bounded
    }
}

/// The relMSE of `curve` (sorted by time) at time `t`: log-log interpolation between the measured
/// points around `t`; outside them, extrapolation from the nearest end with relMSE ∝ 1/t (Monte
/// Carlo convergence; a biased method converges no faster, so this favours the fixed method).
fn error_at_time(curve: &[(f64, f64)], t: f64) -> Option<f64> {
    let (&(t0, e0), &(tn, en)) = (curve.first()?, curve.last()?);
    if t <= t0 {
        return Some(e0 * t0 / t);
    }
    if t >= tn {
        return Some(en * tn / t);
    }
    let w = curve.windows(2).find(|w| w[0].0 <= t && t <= w[1].0)?;
    Some(log_log(w[0].0, w[0].1, w[1].0, w[1].1, t))
}

/// Auto's verdict is "ok" while its relMSE is at most this many times the best fixed method's:
/// timings and errors of single small renders are noisy, so equality cannot be asked for.
const AUTO_TOLERANCE: f64 = 1.25;

/// Auto at one budget against the fixed methods at auto's time.
#[derive(Clone, Debug, PartialEq)]
struct AutoCheck {
    budget: u32,
    seconds: f64,
    rel_mse: f64,
    /// The fixed method with the least error at auto's time, and that error.
    best_method: String,
    best_rel_mse: f64,
}

impl AutoCheck {
    fn ratio(&self) -> f64 {
        self.rel_mse / self.best_rel_mse
    }

    fn ok(&self) -> bool {
        self.ratio() <= AUTO_TOLERANCE
    }
}

/// Auto's (budget, time, relMSE) points against the best of the `fixed` (method, curve) pairs at
/// auto's time.
fn auto_checks(auto: &[(u32, f64, f64)], fixed: &[(String, Vec<(f64, f64)>)]) -> Vec<AutoCheck> {
    auto.iter()
        .filter_map(|&(budget, seconds, rel_mse)| {
            let (best_method, best_rel_mse) = fixed
                .iter()
                .filter_map(|(m, c)| Some((m.clone(), error_at_time(c, seconds)?)))
                .min_by(|a, b| a.1.total_cmp(&b.1))?;
            Some(AutoCheck {
                budget,
                seconds,
                rel_mse,
                best_method,
                best_rel_mse,
            })
        })
        .collect()
}

/// What the report and summary.json say about one scene.
struct Analysis {
    time_to_target: Vec<(String, TimeToTarget)>,
    auto_checks: Vec<AutoCheck>,
}

fn analyse(rows: &[Row], scene: &str, args: &BenchArgs) -> Analysis {
    let time_to_target = args
        .methods
        .iter()
        .filter_map(|m| {
            let time = time_to_target(&curve(rows, scene, m), args.target_error)?;
            Some((m.clone(), time))
        })
        .collect();
    let auto: Vec<(u32, f64, f64)> = rows
        .iter()
        .filter(|r| r.scene == scene && r.method == "auto")
        .map(|r| (r.budget, r.seconds, r.error.rel_mse))
        .collect();
    let fixed: Vec<(String, Vec<(f64, f64)>)> = args
        .methods
        .iter()
        .filter(|m| *m != "auto")
        .map(|m| (m.clone(), curve(rows, scene, m)))
        .filter(|(_, c)| !c.is_empty())
        .collect();
    Analysis {
        time_to_target,
        auto_checks: auto_checks(&auto, &fixed),
    }
}

fn write_file(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).map_err(|e| io_error(path, e))
}

fn csv(rows: &[Row]) -> String {
    let mut out = String::from(
        "scene,method,budget,seconds,peak_mib,rel_mse,rmse,mean_relative_difference\n",
    );
    for r in rows {
        let _ = writeln!(
            out,
            "{},{},{},{:.4},{:.1},{:.6},{:.6},{:.6}",
            r.scene,
            r.method,
            r.budget,
            r.seconds,
            r.peak_mib,
            r.error.rel_mse,
            r.error.rmse,
            r.error.mean_relative_difference
        );
    }
    out
}

fn report(rows: &[Row], scenes: &[SceneResult], args: &BenchArgs) -> String {
    let mut out = format!(
        "# Photon benchmark\n\n{} px wide, reference: {} at {} spp; budget b = b spp, \
         {}·min(b, 64) global and {}·min(b, 64) caustic photons per generation of maps (auto: \
         the planner's, as `photon render` sizes them), {} thread(s). Time is the wall time of the whole \
         render process, the fastest of {} run(s). \
         Time to target: log-log interpolation between the two measured points that bracket it. \
         Targets: photon-ic reaches relMSE 0.01 in at most 1/5 of path's time on caustic \
         and indirect-lit scenes, 1/2 on the Cornell box. Auto against the fixed methods: each \
         fixed method's relMSE at auto's time, log-log interpolated between its measured points \
         and extrapolated beyond them with relMSE ∝ 1/t (which favours the fixed method); \
         verdict ok when auto's relMSE is at most {AUTO_TOLERANCE} times the best.\n",
        args.width,
        match args.reference_method {
            ReferenceMethod::Path => "the path tracer".to_string(),
            ReferenceMethod::Photon => reference_words(ReferenceMethod::Photon),
            ReferenceMethod::Auto => format!(
                "the path tracer, or where the planner's pilot finds caustics of lamps and \
                 emitting meshes, {}",
                reference_words(ReferenceMethod::Photon)
            ),
        },
        args.reference_spp,
        GLOBAL_PHOTONS_PER_BUDGET,
        CAUSTIC_PHOTONS_PER_BUDGET,
        if args.threads == 0 {
            "all".to_string()
        } else {
            args.threads.to_string()
        },
        args.repeats
    );
    for SceneResult {
        name: scene,
        reference_method,
        reference_noise,
        analysis,
        biases,
    } in scenes
    {
        let _ = write!(
            out,
            "\n## {scene}\n\n![relMSE against time]({scene}.svg)\n\n\
             Reference: {}; noise ≈ relMSE {reference_noise:.2e} (two halves of {} spp, seeds 1 \
             and 2); errors below ~{:.2e} are not resolved.\n\n\
             | method | budget | time (s) | peak MiB | relMSE | mean error |\n|---|---:|---:|---:|---:|---:|\n",
            reference_words(*reference_method),
            (args.reference_spp / 2).max(1),
            3.0 * reference_noise
        );
        for r in rows.iter().filter(|r| &r.scene == scene) {
            let _ = writeln!(
                out,
                "| {} | {} | {:.2} | {:.0} | {:.5} | {:+.2} % |",
                r.method,
                r.budget,
                r.seconds,
                r.peak_mib,
                r.error.rel_mse,
                100.0 * r.error.mean_relative_difference
            );
        }
        if !biases.is_empty() {
            out.push_str(
                "\n### Bias at the longest budget\n\nEach method's longest budget rendered \
                 again with another seed: the noise is half the two renders' relMSE \
                 difference, the bias what remains of their mean's relMSE without its noise \
                 and the reference's (0 when within them).\n\n\
                 | method | budget | relMSE | noise | bias (relMSE) | mean error |\n\
                 |---|---:|---:|---:|---:|---:|\n",
            );
            for b in biases {
                let _ = writeln!(
                    out,
                    "| {} | {} | {:.2e} | {:.2e} | {:.2e} | {:+.2} % |",
                    b.method,
                    b.budget,
                    b.rel_mse,
                    b.noise,
                    b.bias,
                    100.0 * b.mean_error
                );
            }
        }
        let _ = write!(
            out,
            "\n### Time to relMSE {}\n\n| method | time to target | ratio to path |\n|---|---:|---:|\n",
            args.target_error
        );
        let path = analysis
            .time_to_target
            .iter()
            .find(|(m, _)| m == "path")
            .map(|(_, t)| *t);
        for (method, time) in &analysis.time_to_target {
            let ratio = path.map_or_else(|| "—".into(), |p| ratio_text(*time, p));
            let _ = writeln!(out, "| {method} | {} | {ratio} |", time.text());
        }
        if analysis.auto_checks.is_empty() {
            continue;
        }
        out.push_str(
            "\n### Auto against the best fixed method\n\n\
             | budget | auto time (s) | auto relMSE | best fixed method | its relMSE at auto's time | auto / best | verdict |\n\
             |---:|---:|---:|---|---:|---:|---|\n",
        );
        for c in &analysis.auto_checks {
            let _ = writeln!(
                out,
                "| {} | {:.2} | {:.2e} | {} | {:.2e} | {:.2} | {} |",
                c.budget,
                c.seconds,
                c.rel_mse,
                c.best_method,
                c.best_rel_mse,
                c.ratio(),
                if c.ok() { "ok" } else { "worse" }
            );
        }
        let _ = writeln!(
            out,
            "\nAuto within tolerance at {} of {} budgets.",
            analysis.auto_checks.iter().filter(|c| c.ok()).count(),
            analysis.auto_checks.len()
        );
    }
    out
}

/// `summary.json`: per scene, the reference noise, the time to target per method and the auto
/// check rows.
fn summary(scenes: &[SceneResult], args: &BenchArgs) -> serde_json::Value {
    let scene_json = |r: &SceneResult| {
        let path = r.analysis.time_to_target.iter().find(|(m, _)| m == "path");
        let times: serde_json::Map<String, serde_json::Value> = r
            .analysis
            .time_to_target
            .iter()
            .map(|(method, time)| {
                let mut v = match *time {
                    TimeToTarget::Reached(t) => json!({"status": "reached", "seconds": t}),
                    TimeToTarget::AtMost(t) => json!({"status": "at_most", "seconds": t}),
                    TimeToTarget::NotReached {
                        best_error,
                        seconds,
                        extrapolated,
                        ..
                    } => json!({"status": "not_reached", "best_rel_mse": best_error, "seconds": seconds, "extrapolated_seconds": extrapolated}),
                };
                if let Some((_, p)) = path {
                    v["ratio_to_path"] = ratio_text(*time, *p).into();
                }
                (method.clone(), v)
            })
            .collect();
        let checks: Vec<serde_json::Value> = r
            .analysis
            .auto_checks
            .iter()
            .map(|c| {
                json!({
                    "budget": c.budget,
                    "auto_seconds": c.seconds,
                    "auto_rel_mse": c.rel_mse,
                    "best_fixed_method": c.best_method,
                    "best_fixed_rel_mse": c.best_rel_mse,
                    "ratio": c.ratio(),
                    "ok": c.ok(),
                })
            })
            .collect();
        json!({
            "scene": r.name,
            "reference_method": format!("{:?}", r.reference_method).to_lowercase(),
            "reference_noise_rel_mse": r.reference_noise,
            "time_to_target": times,
            "auto_check": checks,
            "auto_ok_budgets": r.analysis.auto_checks.iter().filter(|c| c.ok()).count(),
            "bias_at_longest_budget": r.biases.iter().map(|b| json!({
                "method": b.method,
                "budget": b.budget,
                "rel_mse": b.rel_mse,
                "noise_rel_mse": b.noise,
                "bias_rel_mse": b.bias,
                "mean_error": b.mean_error,
            })).collect::<Vec<_>>(),
        })
    };
    json!({
        "target_rel_mse": args.target_error,
        "auto_tolerance": AUTO_TOLERANCE,
        "width": args.width,
        "reference_spp": args.reference_spp,
        "reference_method": format!("{:?}", args.reference_method).to_lowercase(),
        "threads": args.threads,
        "repeats": args.repeats,
        "budgets": args.budgets,
        "methods": args.methods,
        "scenes": scenes.iter().map(scene_json).collect::<Vec<_>>(),
    })
}

/// A log-log plot of relMSE against time, one polyline per method.
fn svg_plot(scene: &str, rows: &[Row]) -> String {
    let (w, h, margin) = (480.0, 320.0, 50.0);
    let points: Vec<&Row> = rows
        .iter()
        .filter(|r| r.scene == scene && r.seconds > 0.0 && r.error.rel_mse > 0.0)
        .collect();
    let decade = |f: fn(f64, f64) -> f64, init: f64, v: &dyn Fn(&Row) -> f64| {
        points.iter().map(|r| v(r).log10()).fold(init, f)
    };
    let (x0, x1) = (
        decade(f64::min, f64::INFINITY, &|r| r.seconds).floor(),
        decade(f64::max, f64::NEG_INFINITY, &|r| r.seconds).ceil(),
    );
    let (y0, y1) = (
        decade(f64::min, f64::INFINITY, &|r| r.error.rel_mse).floor(),
        decade(f64::max, f64::NEG_INFINITY, &|r| r.error.rel_mse).ceil(),
    );
    let (x1, y1) = (x1.max(x0 + 1.0), y1.max(y0 + 1.0));
    let px = |s: f64| margin + (s.log10() - x0) / (x1 - x0) * (w - 2.0 * margin);
    let py = |e: f64| h - margin - (e.log10() - y0) / (y1 - y0) * (h - 2.0 * margin);
    let mut out = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"11\">\n\
         <rect width=\"{w}\" height=\"{h}\" fill=\"white\"/>\n<text x=\"{}\" y=\"16\" text-anchor=\"middle\">{scene}: relMSE against time (s)</text>\n",
        w / 2.0
    );
    if !(x0.is_finite() && y0.is_finite()) {
        out.push_str("</svg>\n");
        return out;
    }
    for d in (x0 as i32)..=(x1 as i32) {
        let x = px(10f64.powi(d));
        let _ = writeln!(out, "<line x1=\"{x}\" y1=\"{}\" x2=\"{x}\" y2=\"{}\" stroke=\"#ddd\"/><text x=\"{x}\" y=\"{}\" text-anchor=\"middle\">1e{d}</text>", margin, h - margin, h - margin + 14.0);
    }
    for d in (y0 as i32)..=(y1 as i32) {
        let y = py(10f64.powi(d));
        let _ = writeln!(out, "<line x1=\"{margin}\" y1=\"{y}\" x2=\"{}\" y2=\"{y}\" stroke=\"#ddd\"/><text x=\"{}\" y=\"{}\" text-anchor=\"end\">1e{d}</text>", w - margin, margin - 4.0, y + 4.0);
    }
    let colours = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e"];
    let mut methods: Vec<&str> = points.iter().map(|r| r.method.as_str()).collect();
    methods.dedup();
    for (i, method) in methods.iter().enumerate() {
        let colour = colours[i % colours.len()];
        let line: Vec<(f64, f64)> = points
            .iter()
            .filter(|r| r.method == *method)
            .map(|r| (px(r.seconds), py(r.error.rel_mse)))
            .collect();
        for (x, y) in &line {
            let _ = writeln!(
                out,
                "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"3\" fill=\"{colour}\"/>"
            );
        }
        let coordinates: Vec<String> = line.iter().map(|(x, y)| format!("{x:.1},{y:.1}")).collect();
        let _ = writeln!(
            out,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"2\"/>\n<text x=\"{}\" y=\"{}\" fill=\"{colour}\">{method}</text>",
            coordinates.join(" "),
            w - margin + 4.0,
            margin + 14.0 * i as f64
        );
    }
    out.push_str("</svg>\n");
    out
}

pub fn run_bench(mut args: BenchArgs) -> Result<()> {
    if args.methods.is_empty() {
        args.methods = DEFAULT_METHODS.iter().map(|n| n.to_string()).collect();
    }
    for method in &args.methods {
        method_options(method)?;
    }
    let mut seen = std::collections::HashSet::new();
    args.methods.retain(|m| seen.insert(m.clone()));
    let scenes = if args.scenes.is_empty() {
        default_scenes()?
    } else {
        args.scenes.clone()
    };
    if scenes.is_empty() || args.budgets.is_empty() || args.budgets.contains(&0) {
        return Err(Error::Settings(
            "bench needs at least one scene and positive budgets".into(),
        ));
    }
    if !(args.target_error > 0.0 && args.target_error.is_finite()) {
        return Err(Error::Settings(format!(
            "--target-error {} must be a positive relMSE",
            args.target_error
        )));
    }
    if let Some(filter) = &args.filter {
        FilterSettings::parse(filter)?;
    }
    std::fs::create_dir_all(&args.out).map_err(|e| io_error(&args.out, e))?;
    let mut rows = Vec::new();
    let mut results = Vec::new();
    for scene in &scenes {
        results.push(bench_scene(scene, &args, &mut rows)?);
    }
    write_file(&args.out.join("results.csv"), &csv(&rows))?;
    write_file(&args.out.join("report.md"), &report(&rows, &results, &args))?;
    write_file(
        &args.out.join("summary.json"),
        &format!("{:#}\n", summary(&results, &args)),
    )?;
    for SceneResult { name, .. } in &results {
        write_file(
            &args.out.join(format!("{name}.svg")),
            &svg_plot(name, &rows),
        )?;
    }
    println!("wrote {}", args.out.join("report.md").display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use photon::rng::Rng;

    /// `n` pixels of value 1 plus uniform noise in [−h, h] (variance h²/3) in every channel.
    fn noisy(n: usize, h: f32, seed: u64) -> Vec<[f32; 4]> {
        let mut rng = Rng::new(seed);
        (0..n)
            .map(|_| std::array::from_fn(|_| 1.0 + h * (2.0 * rng.uniform() - 1.0)))
            .collect()
    }

    #[test]
    fn split_bias_separates_a_constant_offset_from_noise() {
        // Two renders of a biased method: truth 1 + bias 0.1 + uniform noise of half-width
        // 0.3. The noise of one is h²/3/1.01, the squared bias 0.1²/1.01.
        let (n, h) = (40_000, 0.3);
        let shift = |v: Vec<[f32; 4]>| -> Vec<[f32; 4]> {
            v.into_iter().map(|p| p.map(|x| x + 0.1)).collect()
        };
        let (a, b) = (shift(noisy(n, h, 3)), shift(noisy(n, h, 4)));
        let reference = Reference {
            method: ReferenceMethod::Path,
            pixels: vec![[1.0; 4]; n],
            noise: 0.0,
        };
        let (rel_mse, noise, bias, mean_error) = split_bias(&a, &b, &reference);
        let expected_noise = h as f64 * h as f64 / 3.0 / 1.01;
        let expected_bias = 0.01 / 1.01;
        assert!((noise / expected_noise - 1.0).abs() < 0.05, "{noise}");
        assert!((bias / expected_bias - 1.0).abs() < 0.1, "{bias}");
        assert!((rel_mse / (expected_noise + expected_bias) - 1.0).abs() < 0.05);
        assert!((mean_error - 0.1).abs() < 0.005, "{mean_error}");
        // Without the offset the bias vanishes into the noise.
        let (_, _, bias, _) = split_bias(&noisy(n, h, 5), &noisy(n, h, 6), &reference);
        assert!(bias < 0.1 * expected_bias, "{bias}");
    }

    #[test]
    fn two_half_noise_estimates_the_error_of_the_mean() {
        let (n, h) = (20_000, 0.3);
        let (a, b) = (noisy(n, h, 1), noisy(n, h, 2));
        let (mean, noise) = two_half_noise(&a, &b);
        // The mean has variance h²/3/2; relMSE divides by 1² + 0.01.
        let expected = h as f64 * h as f64 / 6.0 / 1.01;
        assert!(
            (noise / expected - 1.0).abs() < 0.05,
            "{noise} vs {expected}"
        );
        // And it agrees with the mean's actual error against the truth.
        let truth = vec![[1.0; 4]; n];
        let actual = compare(&mean, &truth).rel_mse;
        assert!((noise / actual - 1.0).abs() < 0.05, "{noise} vs {actual}");
        // Identical halves: no measurable noise.
        assert_eq!(two_half_noise(&a, &a).1, 0.0);
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-9 * b.abs().max(1.0)
    }

    #[test]
    fn log_log_interpolates_power_laws_exactly() {
        // relMSE ∝ 1/t through (1, 1) and (100, 0.01).
        assert!(close(log_log(1.0, 1.0, 100.0, 0.01, 10.0), 0.1));
        assert!(close(log_log(1.0, 1.0, 100.0, 0.01, 1000.0), 0.001));
        // A zero value falls back to linear interpolation instead of an infinite log.
        assert!(close(log_log(1.0, 0.0, 3.0, 1.0, 2.0), 0.5));
        assert_eq!(log_log(2.0, 5.0, 2.0, 7.0, 2.0), 5.0);
    }

    #[test]
    fn time_to_target_interpolates_bounds_or_gives_up() {
        let curve = [(1.0, 0.04), (4.0, 0.01), (16.0, 0.0025)];
        let Some(TimeToTarget::Reached(t)) = time_to_target(&curve, 0.02) else {
            panic!("reached");
        };
        assert!(close(t, 2.0), "{t}");
        assert_eq!(
            time_to_target(&curve, 0.05),
            Some(TimeToTarget::AtMost(1.0))
        );
        assert_eq!(
            time_to_target(&curve, 0.04),
            Some(TimeToTarget::AtMost(1.0))
        );
        assert_eq!(
            time_to_target(&curve, 0.001),
            Some(TimeToTarget::NotReached {
                best_error: 0.0025,
                seconds: 16.0,
                longest: 16.0,
                extrapolated: 40.0
            })
        );
        assert_eq!(time_to_target(&[], 0.01), None);
        // Noisy curve: the first bracketing pair counts ((1, 0.16)–(2, 0.04), e ∝ 1/t², so √2),
        // not the later (3, 0.09)–(4, 0.01).
        let noisy = [(1.0, 0.16), (2.0, 0.04), (3.0, 0.09), (4.0, 0.01)];
        let Some(TimeToTarget::Reached(t)) = time_to_target(&noisy, 0.08) else {
            panic!("reached");
        };
        assert!(close(t, 2f64.sqrt()), "{t}");
        // Not reached: the best point, which need not be the last.
        let plateau = [(1.0, 0.05), (2.0, 0.02), (4.0, 0.03)];
        assert_eq!(
            time_to_target(&plateau, 0.01),
            Some(TimeToTarget::NotReached {
                best_error: 0.02,
                seconds: 2.0,
                longest: 4.0,
                extrapolated: 12.0
            })
        );
    }

    #[test]
    fn ratios_to_path_respect_the_bounds() {
        use TimeToTarget::*;
        let not_reached = |longest| NotReached {
            best_error: 0.1,
            seconds: 1.0,
            longest,
            extrapolated: 10.0 * longest,
        };
        assert_eq!(ratio_text(Reached(1.0), Reached(4.0)), "0.25");
        assert_eq!(ratio_text(AtMost(1.0), Reached(4.0)), "≤ 0.25");
        assert_eq!(
            ratio_text(Reached(2.0), not_reached(4.0)),
            "≤ 0.50 (≈ 0.050 extrapolated)"
        );
        assert_eq!(
            ratio_text(not_reached(8.0), Reached(2.0)),
            "≥ 4.00 (≈ 40.000 extrapolated)"
        );
        assert_eq!(ratio_text(not_reached(8.0), not_reached(8.0)), "1.00");
        assert_eq!(
            ratio_text(not_reached(8.0), not_reached(4.0)),
            "— (≈ 2.000 extrapolated)"
        );
        assert_eq!(ratio_text(Reached(2.0), AtMost(1.0)), "≥ 2.00");
    }

    #[test]
    fn error_at_time_interpolates_inside_and_extrapolates_as_one_over_t() {
        let curve = [(1.0, 0.04), (4.0, 0.01)];
        assert!(close(error_at_time(&curve, 2.0).unwrap(), 0.02));
        assert!(close(error_at_time(&curve, 4.0).unwrap(), 0.01));
        assert!(close(error_at_time(&curve, 0.5).unwrap(), 0.08));
        assert!(close(error_at_time(&curve, 8.0).unwrap(), 0.005));
        // A single point extrapolates both ways.
        assert!(close(error_at_time(&[(2.0, 0.1)], 4.0).unwrap(), 0.05));
        assert_eq!(error_at_time(&[], 1.0), None);
    }

    #[test]
    fn auto_is_judged_against_the_best_fixed_method_at_its_time() {
        let fixed = [
            ("path".to_string(), vec![(1.0, 0.04), (4.0, 0.01)]),
            // A biased method that flattens out.
            ("photon".to_string(), vec![(1.0, 0.01), (4.0, 0.008)]),
        ];
        let auto = [(1, 2.0, 0.02), (2, 8.0, 0.0045)];
        let checks = auto_checks(&auto, &fixed);
        assert_eq!(checks.len(), 2);
        // At 2 s: path 0.02, photon 0.01·0.8^½ ≈ 0.00894: auto is 2.24 times worse.
        assert_eq!(checks[0].best_method, "photon");
        assert!(close(checks[0].best_rel_mse, 0.01 * 0.8f64.sqrt()));
        assert!(!checks[0].ok());
        // At 8 s, beyond both: path 0.005, photon 0.004 (∝ 1/t); 0.0045 is within 1.25.
        assert_eq!(checks[1].best_method, "photon");
        assert!(close(checks[1].best_rel_mse, 0.004));
        assert!(close(checks[1].ratio(), 1.125) && checks[1].ok());
        // Nothing to compare with: no rows.
        assert!(auto_checks(&auto, &[]).is_empty());
    }
}
