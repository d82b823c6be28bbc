//! The irradiance cache (Ward 1988, Ward & Heckbert 1992) on its own and in the renderers:
//! interpolated against brute-force irradiance on the Cornell box (with gradients better than
//! without), finite-difference checks of both gradients on an analytic configuration, record
//! count against accuracy, agreement of `path-cache` with the path tracer, determinism across
//! thread counts and region renders, the debug views and bad settings.

use photon::accel::{Accel, Ray, Visibility};
use photon::camera::CameraRays;
use photon::film::Image;
use photon::integrator::photon::settings::PhotonSettings;
use photon::interaction::SurfaceHit;
use photon::irradiance_cache::{build, gather_record, IcSettings, Incoming, IrradianceCache, Site};
use photon::light::Lights;
use photon::material::eval_material;
use photon::math::{Vec2, Vec3};
use photon::progress::{Progress, ProgressEvent};
use photon::render::{render, Method, RenderSettings};
use photon::rng::Rng;
use photon::scene::gltf::LoadOptions;
use photon::scene::{builtin, Scene};
use std::sync::atomic::AtomicBool;

const SIZE: u32 = 64;

/// The Cornell box where every surface glows with its base colour: a smooth radiance field with
/// occlusion, cheap enough for brute-force irradiance at many points.
struct GlowBox {
    scene: Scene,
    accel: Accel,
    camera: CameraRays,
}

impl GlowBox {
    fn new() -> GlowBox {
        let scene = builtin::cornell_box(&LoadOptions::default()).expect("cornell box");
        let accel = Accel::new(&scene);
        let camera = CameraRays::new(&scene.camera, SIZE, SIZE);
        GlowBox {
            scene,
            accel,
            camera,
        }
    }

    /// The surface seen through film position `film`, with its normal towards the camera.
    fn site(&self, film: Vec2) -> Option<(Site, SurfaceHit)> {
        let ray = self.camera.ray(film);
        let hit = self
            .accel
            .intersect(&self.scene, &ray, Visibility::Camera)?;
        let sh = SurfaceHit::new(&self.scene, &ray, &hit);
        let n = if sh.ng.dot(ray.direction) > 0.0 {
            -sh.ng
        } else {
            sh.ng
        };
        let next = self.camera.ray(film + Vec2::X);
        let footprint = (next.direction - ray.direction).length() * hit.t;
        Some((
            Site {
                p: sh.p,
                n,
                footprint,
            },
            sh,
        ))
    }

    fn gather(&self, sh: &SurfaceHit, dir: Vec3) -> Incoming {
        let ray: Ray = sh.spawn(dir);
        match self
            .accel
            .intersect(&self.scene, &ray, Visibility::Secondary)
        {
            Some(hit) => {
                let h = SurfaceHit::new(&self.scene, &ray, &hit);
                let m = &self.scene.materials[h.material as usize];
                Incoming {
                    radiance: eval_material(&self.scene, m, h.uv).base_color,
                    distance: hit.t,
                    normal: h.frame.n,
                }
            }
            None => Incoming::NONE,
        }
    }

    fn cache(&self, settings: &IcSettings) -> IrradianceCache {
        let bounds = Lights::new(&self.scene).scene_sphere();
        let find =
            |x: u32, y: u32, _: &mut Rng| self.site(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
        let gather = |sh: &SurfaceHit, dir: Vec3, _: &mut Rng| self.gather(sh, dir);
        let (cache, info) =
            build(SIZE, SIZE, settings, 7, bounds, find, gather, |_| Ok(())).expect("build");
        assert_eq!(info.records, cache.len());
        assert_eq!(info.levels, 6);
        cache
    }
}

fn ic(accuracy: f32, gather_rays: u32) -> IcSettings {
    IcSettings {
        accuracy,
        gather_rays,
        ..IcSettings::default()
    }
}

#[test]
fn interpolation_is_within_the_accuracy_and_gradients_lower_the_error() {
    let scene = GlowBox::new();
    let accuracy = 0.15;
    let mut cache = scene.cache(&ic(accuracy, 256));
    let mut rng = Rng::new(11);
    let (mut with, mut without, mut n, mut uncovered) = (0.0f64, 0.0f64, 0, 0);
    for i in 0..300 {
        let film = rng.uniform2() * SIZE as f32;
        let Some((site, sh)) = scene.site(film) else {
            continue;
        };
        let mut r = Rng::new(i);
        let truth = gather_record(&site, &ic(accuracy, 4096), &mut r, |d, _| {
            scene.gather(&sh, d)
        })
        .e;
        cache.gradients = true;
        let Some(e_with) = cache.lookup(site.p, site.n) else {
            uncovered += 1;
            continue;
        };
        cache.gradients = false;
        let e_without = cache.lookup(site.p, site.n).expect("same records");
        let rel = |e: Vec3| {
            (((e - truth).abs() / truth.max(Vec3::splat(1e-3))).element_sum() / 3.0) as f64
        };
        with += rel(e_with);
        without += rel(e_without);
        n += 1;
    }
    let (with, without) = (with / n as f64, without / n as f64);
    println!(
        "{} records, {n} points, {uncovered} uncovered: mean relative error {with:.4} with gradients, {without:.4} without",
        cache.len()
    );
    assert!(n >= 250, "only {n} covered points");
    assert!(
        with < 0.5 * accuracy as f64,
        "mean relative error {with} with gradients"
    );
    assert!(
        with < 0.9 * without,
        "gradients: {with} vs {without} without"
    );
}

/// Radiance on the ceiling z = 1 of the analytic configuration: a smooth ramp across x and y.
fn ceiling_radiance(q: Vec3) -> f32 {
    1.0 + 0.8 * (2.0 * q.x + 0.7 * q.y + 0.3).tanh()
}

/// Irradiance at `p` with normal `n` under the ceiling (nothing below the horizon z = p.z), from
/// a fine stratified gather with a fixed seed (so nearby evaluations share their jitter).
fn ceiling_record(p: Vec3, n: Vec3) -> photon::irradiance_cache::Record {
    let site = Site {
        p,
        n,
        footprint: 1e-6,
    };
    let mut rng = Rng::new(5);
    gather_record(&site, &ic(0.1, 40_000), &mut rng, |d, _| {
        if d.z <= 0.0 {
            return Incoming::NONE;
        }
        let t = (1.0 - p.z) / d.z;
        Incoming {
            radiance: Vec3::splat(ceiling_radiance(p + t * d)),
            distance: t,
            normal: Vec3::NEG_Z,
        }
    })
}

#[test]
fn gradients_match_finite_differences() {
    let p = Vec3::new(0.1, -0.2, 0.0);
    let rec = ceiling_record(p, Vec3::Z);
    let h = 0.01;
    for axis in [Vec3::X, Vec3::Y] {
        // Translation along the tangent plane.
        let plus = ceiling_record(p + h * axis, Vec3::Z).e.x;
        let minus = ceiling_record(p - h * axis, Vec3::Z).e.x;
        let fd = (plus - minus) / (2.0 * h);
        let g = rec.grad_t[0].dot(axis);
        println!("translation {axis}: gradient {g:.4}, finite difference {fd:.4}");
        assert!(fd.abs() > 0.1, "the configuration must vary along {axis}");
        assert!(
            (g - fd).abs() < 0.05 * fd.abs(),
            "translation along {axis}: {g} vs {fd}"
        );
        // Rotation of the normal about the axis.
        let tilt = |a: f32| (Vec3::Z * a.cos() + axis.cross(Vec3::Z) * a.sin()).normalize();
        let plus = ceiling_record(p, tilt(h)).e.x;
        let minus = ceiling_record(p, tilt(-h)).e.x;
        let fd = (plus - minus) / (2.0 * h);
        let g = rec.grad_r[0].dot(axis);
        println!("rotation about {axis}: gradient {g:.4}, finite difference {fd:.4}");
        assert!(
            fd.abs() > 0.1,
            "the configuration must vary under rotation about {axis}"
        );
        assert!(
            (g - fd).abs() < 0.05 * fd.abs(),
            "rotation about {axis}: {g} vs {fd}"
        );
    }
    // Interpolation uses them: a point and normal nearby are predicted better than by Eᵢ alone.
    let (q, n) = (
        p + Vec3::new(0.05, 0.03, 0.0),
        Vec3::new(0.05, -0.04, 1.0).normalize(),
    );
    let truth = ceiling_record(q, n).e.x;
    let predicted = rec.e.x + rec.n.cross(n).dot(rec.grad_r[0]) + (q - p).dot(rec.grad_t[0]);
    assert!((predicted - truth).abs() < 0.2 * (rec.e.x - truth).abs());
}

#[test]
fn a_ray_budget_keeps_the_first_levels_whole() {
    let scene = GlowBox::new();
    let full = scene.cache(&ic(0.2, 64));
    let bounds = Lights::new(&scene.scene).scene_sphere();
    let find = |x: u32, y: u32, _: &mut Rng| scene.site(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
    let gather = |sh: &SurfaceHit, dir: Vec3, _: &mut Rng| scene.gather(sh, dir);
    let pixels = (SIZE * SIZE) as f32;
    let (t, p) = ic(0.2, 64).strata();
    let rays_per_record = (t * p) as f32;
    let full_budget = full.len() as f32 * rays_per_record / pixels;
    // Budgets from none to the whole cache's: each build is a prefix of the whole cache, within
    // its budget, and made of whole levels (one record count per number of levels built).
    let mut count_at_levels = std::collections::HashMap::new();
    let mut previous = 0;
    for step in 0..=20 {
        let budget = full_budget * step as f32 / 20.0;
        let settings = IcSettings {
            max_rays_per_pixel: Some(budget),
            ..ic(0.2, 64)
        };
        let (cache, info) =
            build(SIZE, SIZE, &settings, 7, bounds, find, gather, |_| Ok(())).expect("build");
        assert_eq!(info.budget_reached, step < 20, "{info:?} at {budget}");
        assert!(cache.len() as f32 * rays_per_record <= budget * pixels);
        assert!(cache.len() >= previous);
        previous = cache.len();
        for (a, b) in cache.records().iter().zip(full.records()) {
            assert_eq!(a, b);
        }
        let count = *count_at_levels.entry(info.levels).or_insert(cache.len());
        assert_eq!(count, cache.len(), "{} levels", info.levels);
    }
    assert_eq!(previous, full.len());
    // Several levels were cut off at some budget, none at zero budget.
    assert!(count_at_levels.len() >= 4, "{count_at_levels:?}");
    assert_eq!(count_at_levels.get(&0), Some(&0));
}

#[test]
fn record_count_grows_as_accuracy_tightens() {
    let scene = GlowBox::new();
    let coarse = scene.cache(&ic(0.2, 64)).len();
    let fine = scene.cache(&ic(0.1, 64)).len();
    println!("records: {coarse} at a = 0.2, {fine} at a = 0.1");
    assert!(coarse > 20);
    // Fewer than the 4× of 1/a² spacing: on this 64-pixel frame many records are held to the
    // frame-share bound on their radius (4.8 px) at either accuracy.
    assert!(fine as f32 > 1.3 * coarse as f32, "{fine} vs {coarse}");
}

fn render_in_pool(scene: &Scene, settings: &RenderSettings, threads: usize) -> Image {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool");
    let cancel = AtomicBool::new(false);
    let report = |_: &ProgressEvent| {};
    let progress = Progress {
        cancel: &cancel,
        report: &report,
    };
    let (image, stats) = pool
        .install(|| render(scene, settings, &progress))
        .expect("render");
    assert_eq!(stats.nonfinite_samples, 0);
    assert!(stats.irradiance_cache.is_some_and(|c| c.records > 0));
    image
}

fn cornell_settings(method: Method, size: u32, spp: u32) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        spp,
        max_depth: 16,
        seed: 3,
        method,
        photon: PhotonSettings {
            global_photons: 20_000,
            caustic_photons: 0,
            ..PhotonSettings::default()
        },
        irradiance_cache: ic(0.2, 64),
        ..RenderSettings::default()
    }
}

#[test]
fn same_seed_same_image_for_one_and_two_threads() {
    let scene = builtin::cornell_box(&LoadOptions::default()).expect("cornell box");
    for method in [Method::PathCache, Method::Photon] {
        let settings = cornell_settings(method, 24, 2);
        let one = render_in_pool(&scene, &settings, 1);
        let two = render_in_pool(&scene, &settings, 2);
        assert!(
            one.rgba == two.rgba,
            "{method:?} differs between 1 and 2 threads"
        );
    }
}

#[test]
fn a_region_render_with_the_cache_is_the_crop_of_the_full_render() {
    let scene = builtin::cornell_box(&LoadOptions::default()).expect("cornell box");
    let settings = cornell_settings(Method::Photon, 24, 1);
    let full = render_in_pool(&scene, &settings, 2);
    let (x0, y0, x1, y1) = (5, 9, 20, 17);
    let mut cropped = settings.clone();
    cropped.region = Some(photon::render::Region { x0, y0, x1, y1 });
    let crop = render_in_pool(&scene, &cropped, 2);
    assert_eq!(crop.rgba.len(), 15 * 8);
    for (i, a) in crop.rgba.iter().enumerate() {
        let (x, y) = (x0 as usize + i % 15, y0 as usize + i / 15);
        let b = full.rgba[y * 24 + x];
        assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "pixel {x},{y}");
    }
}

#[test]
fn photon_cache_on_glossy_coated_diffuse_agrees_with_the_path_tracer() {
    // Principled's default: a GGX specular layer over the diffuse base. The cache serves the
    // diffuse lobe and the gather rays the rest; the sum must stay unbiased. At roughness 0.8
    // the gather hits also read the precomputed irradiance for the glossy layer (albedo/π · E).
    for roughness in [0.4, 0.8] {
        let mut scene = builtin::cornell_box(&LoadOptions::default()).expect("cornell box");
        for m in &mut scene.materials {
            m.specular = 1.0;
            m.roughness = roughness;
        }
        let mut settings = cornell_settings(Method::Photon, 32, 32);
        settings.photon.global_photons = 50_000;
        assert_mean_matches_the_path_tracer(&scene, settings);
    }
}

/// The image mean of `settings` (a cache method) within 4 % of the path tracer's per channel.
fn assert_mean_matches_the_path_tracer(scene: &Scene, mut settings: RenderSettings) {
    let cached = render_in_pool(scene, &settings, 2).mean_rgb();
    settings.method = Method::Path;
    let cancel = AtomicBool::new(false);
    let report = |_: &ProgressEvent| {};
    let progress = Progress {
        cancel: &cancel,
        report: &report,
    };
    let path = render(scene, &settings, &progress)
        .expect("render")
        .0
        .mean_rgb();
    let diff = ((cached - path) / path).abs().max_element();
    println!("mean {cached} with the cache, {path} path traced");
    assert!(diff < 0.04, "means differ by {:.1} %", 100.0 * diff);
}

#[test]
fn path_cache_agrees_with_the_path_tracer() {
    let scene = builtin::cornell_box(&LoadOptions::default()).expect("cornell box");
    let mut settings = cornell_settings(Method::PathCache, 32, 32);
    settings.irradiance_cache.gather_rays = 256;
    assert_mean_matches_the_path_tracer(&scene, settings);
}

#[test]
fn debug_views_show_irradiance_and_record_dots() {
    let scene = builtin::cornell_box(&LoadOptions::default()).expect("cornell box");
    let irradiance = render_in_pool(&scene, &cornell_settings(Method::IcIrradiance, 24, 1), 2);
    let lit = irradiance.rgba.iter().filter(|p| p[0] > 0.0).count();
    assert!(
        lit > 24 * 24 / 2,
        "only {lit} pixels show cached irradiance"
    );
    let records = render_in_pool(&scene, &cornell_settings(Method::IcRecords, 24, 1), 2);
    let dots = records.rgba.iter().filter(|p| p[..3] == [1.0; 3]).count();
    assert!(dots > 10 && dots < 24 * 24 / 2, "{dots} record dots");
}

#[test]
fn bad_cache_settings_exit_with_2() {
    for args in [
        ["--ic-accuracy", "0"],
        ["--ic-gather-rays", "0"],
        ["--ic-min-spacing", "0"],
        ["--irradiance-cache", "maybe"],
        ["--ic-ray-budget", "nan"],
        ["--ic-ray-budget", "-5"],
    ] {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_photon"))
            .args(["render", "--width", "8", "--height", "8", "--spp", "1"])
            .args(["-o", "/dev/null/never.png"])
            .args(args)
            .output()
            .expect("run photon");
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            stderr.contains(args[0].trim_start_matches('-')),
            "{args:?}: {stderr}"
        );
    }
}

#[test]
fn cancelling_during_the_cache_build_stops_the_render() {
    let scene = builtin::cornell_box(&LoadOptions::default()).expect("cornell box");
    let cancel = AtomicBool::new(false);
    let report = |e: &ProgressEvent| {
        if e.stage == "cache" {
            cancel.store(true, std::sync::atomic::Ordering::Relaxed);
        }
    };
    let progress = Progress {
        cancel: &cancel,
        report: &report,
    };
    let settings = cornell_settings(Method::PathCache, 64, 1);
    let result = render(&scene, &settings, &progress);
    assert!(matches!(result, Err(photon::error::Error::Cancelled)));
}

#[test]
fn no_fireflies_where_an_emitting_mesh_meets_a_cached_surface() {
    // Inside the furnace every surface emits, so the mesh's own facets meet at concave edges:
    // light sampling alone has unbounded variance there (old renders: pixels up to 1.44 for an
    // exact 1). With one MIS'd BSDF ray beside the light sample every pixel stays near 1.
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/furnace.glb");
    let scene =
        photon::scene::gltf::load(std::path::Path::new(path), &LoadOptions::default()).unwrap();
    for seed in 1..=4 {
        let settings = RenderSettings {
            seed,
            ..cornell_settings(Method::Photon, 48, 16)
        };
        let image = render_in_pool(&scene, &settings, 2);
        for (i, p) in image.rgba.iter().enumerate() {
            assert!(
                (p[0] - 1.0).abs() < 0.06,
                "seed {seed}, pixel {i}: {} (exactly 1 in the furnace)",
                p[0]
            );
        }
    }
}

#[test]
fn path_cache_under_a_world_seen_through_windows_is_free_of_speckles() {
    // The gallery's room lit by the sky and the sun through two windows (see the photon
    // method's test of the same name): with the light sample alone on cached surfaces,
    // path-cache's seed-to-seed relMSE at 4 spp was 0.55 of the path tracer's; with the
    // MIS-weighted emission bounce, 0.30. Allowed: 0.4.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/gallery/interior.glb");
    let scene = photon::scene::gltf::load(&path, &LoadOptions::default()).expect("interior");
    let cancel = AtomicBool::new(false);
    let report = |_: &ProgressEvent| {};
    let progress = Progress {
        cancel: &cancel,
        report: &report,
    };
    let noise = |method: Method| {
        let settings = |seed| RenderSettings {
            width: 48,
            height: 48,
            spp: 4,
            seed,
            method,
            ..RenderSettings::default()
        };
        let (a, _) = render(&scene, &settings(1), &progress).expect("render");
        let (b, _) = render(&scene, &settings(2), &progress).expect("render");
        let mean = (a.mean_rgb() + b.mean_rgb()).element_sum() / 6.0;
        (photon::metrics::compare(&a.rgba, &b.rgba).rel_mse, mean)
    };
    let ((cached, cached_mean), (path_traced, path_mean)) =
        (noise(Method::PathCache), noise(Method::Path));
    assert!(
        cached < 0.4 * path_traced,
        "seed-to-seed relMSE {cached} with the cache, {path_traced} path traced"
    );
    // MIS-weighting the light sample without the bounce would lose the bounce's share (−3.5 %
    // in the mean); measured −1.1 %.
    assert!(
        (cached_mean / path_mean - 1.0).abs() < 0.025,
        "mean {cached_mean} with the cache, {path_mean} path traced"
    );
}
