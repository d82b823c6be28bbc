//! Photon mapping end to end: energy bookkeeping of pass 1 (stored first-hit power equals the
//! emitted power, second-hit power the reflected power), the closed furnace sphere renders ≈ 1,
//! agreement with the path tracer on the Cornell box, and determinism across thread counts.

use crate::support::scenes;

use scenes::with_progress;

use photon::accel::Accel;
use photon::film::Image;
use photon::integrator::photon::build::{build_maps, PhotonMaps};
use photon::integrator::photon::settings::{PhotonInfo, PhotonSettings};
use photon::integrator::photon::tracing::Emitters;
use photon::integrator::Context;
use photon::light::Lights;
use photon::math::Vec3;
use photon::render::{render, Method, RenderSettings, Sampler};
use photon::scene::gltf::LoadOptions;
use photon::scene::{builtin, Light, Material, Projection, Scene};
use std::f32::consts::PI;

fn render_with(scene: &Scene, settings: &RenderSettings) -> Image {
    let (image, stats) = with_progress(|p| render(scene, settings, p)).expect("render");
    assert_eq!(stats.nonfinite_samples, 0);
    image
}

fn photon_settings(size: u32, spp: u32, photons: u32) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        spp,
        max_depth: 64,
        seed: 1,
        method: Method::Photon,
        photon: PhotonSettings {
            global_photons: photons,
            caustic_photons: photons,
            gather_rays: 16,
            ..PhotonSettings::default()
        },
        ..RenderSettings::default()
    }
}

/// A rendering context over `scene` with `max_depth` bounces and an opaque film.
fn context<'a>(
    scene: &'a Scene,
    accel: &'a Accel,
    lights: &'a Lights,
    max_depth: u32,
) -> Context<'a> {
    Context {
        scene,
        accel,
        lights,
        max_depth,
        transparent_background: false,
    }
}

/// The photon maps of `scene` from `global_photons` photons, with the default settings
/// otherwise (seed 3, 64 bounces, Sobol photons).
fn photon_maps(scene: &Scene, global_photons: u32) -> (PhotonMaps, PhotonInfo) {
    photon_maps_with(scene, global_photons, 3, Sampler::Sobol)
}

/// `photon_maps` with the seed and the photons' numbers chosen.
fn photon_maps_with(
    scene: &Scene,
    global_photons: u32,
    seed: u64,
    sampler: Sampler,
) -> (PhotonMaps, PhotonInfo) {
    let accel = Accel::new(scene);
    let lights = Lights::new(scene);
    let ctx = context(scene, &accel, &lights, 64);
    let settings = PhotonSettings {
        global_photons,
        ..PhotonSettings::default()
    };
    with_progress(|p| {
        build_maps(
            &ctx,
            &Emitters::guided(&ctx, 1.0, 3),
            &settings,
            seed,
            sampler,
            p,
        )
    })
    .expect("photons")
}

#[test]
fn quasi_random_photons_leave_the_lamp_evenly() {
    // Photon i of a Sobol run is sample i of one scrambled Sobol sequence (Keller 1996): the
    // share of the Cornell box lamp's photons leaving within 37° of straight down (read from
    // the first-hit photons' incoming directions in the closed box) varies between seeds far
    // less than with independent streams, by more than 4× at 4000 photons; both agree on it.
    let scene = builtin::cornell_box(&LoadOptions::default()).expect("cornell box");
    let spread = |sampler: Sampler| {
        let shares: Vec<f64> = (0..8)
            .map(|seed| {
                let (maps, _) = photon_maps_with(&scene, 4000, seed, sampler);
                let photons = maps.global.as_ref().expect("global map").photons();
                let direct = photons.iter().filter(|ph| ph.is_direct());
                let steep = direct.clone().filter(|ph| ph.incoming().y > 0.8).count();
                steep as f64 / direct.count() as f64
            })
            .collect();
        let mean = shares.iter().sum::<f64>() / shares.len() as f64;
        let var = shares.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / 7.0;
        (mean, var.sqrt())
    };
    let (sobol_mean, sobol) = spread(Sampler::Sobol);
    let (random_mean, random) = spread(Sampler::Random);
    assert!(
        (sobol_mean - random_mean).abs() < 3.0 * random,
        "share leaving steeply: Sobol {sobol_mean:.4}, random {random_mean:.4} ± {random:.4}"
    );
    assert!(
        sobol < 0.25 * random,
        "its spread between seeds: Sobol {sobol:.5}, random {random:.5}"
    );
}

#[test]
fn stored_power_equals_emitted_and_reflected_power() {
    // A point light of flux Φ at the centre of a closed diffuse sphere of albedo ρ: every photon
    // hits the wall first, so first-hit photons carry Φ exactly (up to RGBE rounding), and the
    // second hits carry ρΦ within the Russian-roulette noise.
    let rho = 0.6;
    let intensity = 2.0;
    let scene = scenes::scene(
        vec![scenes::sphere(Vec3::ZERO, 1.0, 24, 48, true, 0)],
        vec![Material::diffuse("wall", Vec3::splat(rho))],
        vec![Light::Point {
            position: Vec3::new(0.1, 0.2, -0.1),
            intensity: Vec3::splat(intensity),
            radius: 0.0,
            lamp: Default::default(),
        }],
        scenes::camera_looking_at(Vec3::ZERO, -Vec3::Z, Projection::Perspective { yfov: 1.0 }),
        Vec3::ZERO,
    );
    let n = 50_000;
    let (maps, info) = photon_maps(&scene, n);
    assert!(
        info.caustic_skipped.is_some(),
        "a diffuse scene needs no caustic map"
    );
    assert!(maps.caustic.is_none());
    let global = maps.global.expect("global map");
    let phi = 4.0 * PI * intensity;
    let sum = |bounces: u32| -> (f64, f64, usize) {
        let mut s = 0.0f64;
        let mut s2 = 0.0f64;
        let mut count = 0;
        for ph in global.photons().iter().filter(|p| p.bounces() == bounces) {
            let v = ph.power().x as f64;
            s += v;
            s2 += v * v;
            count += 1;
        }
        (s, s2, count)
    };
    let (first, _, count) = sum(0);
    assert_eq!(count, n as usize);
    assert!(global
        .photons()
        .iter()
        .filter(|p| p.bounces() == 0)
        .all(|p| p.is_direct()));
    assert!(
        (first / phi as f64 - 1.0).abs() < 0.002,
        "first {first} vs Φ {phi}"
    );
    // Second bounce: Σ over n emitted photons of a per-photon value; its standard error is
    // √(n·E[v²] − (Σv)²/…)/… ≈ √(Σv²); accept 4σ.
    let (second, second2, _) = sum(1);
    let expected = rho as f64 * phi as f64;
    let sigma = second2.sqrt();
    assert!(
        (second - expected).abs() < 4.0 * sigma + 0.002 * expected,
        "second {second} vs ρΦ {expected} (σ {sigma})"
    );
}

#[test]
fn closed_furnace_sphere_renders_one() {
    let image = render_with(&scenes::furnace(), &photon_settings(12, 2, 40_000));
    let mean = image.mean_rgb();
    // Analytic 1. The global estimate on the curved wall and the k-NN blur bias it by well
    // under 1 %; the remaining tolerance is the gather noise of 288 samples.
    for c in 0..3 {
        assert!((mean[c] - 1.0).abs() < 0.03, "mean {mean:?}");
    }
}

#[test]
fn photons_bounce_as_far_as_the_render_allows() {
    // A white furnace (albedo 0.9): 0.9¹⁶ = 19 % of its radiance comes from light that bounced
    // more than 16 times. Photons used to stop at 16 bounces whatever the render's limit (64
    // here), and the image came out about 15 % dark; it must be 1.
    let image = render_with(
        &scenes::furnace_with_albedo(0.9),
        &photon_settings(12, 2, 40_000),
    );
    let mean = image.mean_rgb();
    for c in 0..3 {
        assert!((mean[c] - 1.0).abs() < 0.03, "mean {mean:?}");
    }
}

#[test]
fn records_agree_with_full_estimates_on_glossy_coated_surfaces() {
    // Blender's default surface is a diffuse base under a rough dielectric layer (the Blender
    // Cornell box: roughness 0.5 everywhere). Final-gather hits read the diffuse lobe from the
    // precomputed records and trace the glossy layer; the full estimate weighs each photon by
    // the whole BSDF. Both must give the same ceiling, which sees only light bounced off the
    // floor and walls. Shading the glossy layer from the records as if its light came evenly
    // from every direction made the ceiling 4.8 % brighter than the full estimate here, and
    // records that counted the disc behind a wall (the room's corners) while full estimates
    // did not, 3 %; both now agree within 1 %.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/blender/cornell.glb");
    let scene = photon::scene::load::load_scene(Some(&path), None).expect("Blender Cornell box");
    let mut settings = photon_settings(32, 16, 100_000);
    settings.irradiance_cache.enabled = false;
    let ceiling = |image: &Image| {
        let (mut sum, mut n) = (0.0, 0);
        for y in 1..7 {
            for x in 6..26 {
                let px = image.rgba[(y * 32 + x) as usize];
                let v = (px[0] + px[1] + px[2]) / 3.0;
                // Leave out the lamp and its edge pixels.
                if v < 1.0 {
                    sum += v as f64;
                    n += 1;
                }
            }
        }
        assert!(n > 60, "only {n} ceiling pixels");
        sum / n as f64
    };
    let with = ceiling(&render_with(&scene, &settings));
    settings.photon.irradiance_stride = 0;
    let without = ceiling(&render_with(&scene, &settings));
    let rel = with / without - 1.0;
    assert!(
        rel.abs() < 0.02,
        "ceiling with records {with}, full estimates {without}"
    );
}

#[test]
fn precomputed_irradiance_records_are_unbiased_at_small_k() {
    // Records chosen by a reach that came from the same photons as their value favoured low
    // values (a bias ∝ 1/k: −1.4 % at k = 16 in the furnace). With the same seed, the gather
    // rays of a render with records and one with full estimates are identical.
    let scene = scenes::furnace();
    let mut settings = photon_settings(16, 2, 40_000);
    settings.irradiance_cache.enabled = false;
    settings.photon.k_global = 16;
    let with = render_with(&scene, &settings).mean_rgb();
    settings.photon.irradiance_stride = 0;
    let without = render_with(&scene, &settings).mean_rgb();
    for c in 0..3 {
        let rel = (with[c] - without[c]) / without[c];
        assert!(rel.abs() < 0.005, "with {with:?} without {without:?}");
    }
}

#[test]
fn cornell_box_matches_the_path_tracer() {
    let scene = builtin::cornell_box(&LoadOptions::default()).expect("cornell box");
    let size = 24;
    let reference = render_with(
        &scene,
        &RenderSettings {
            method: Method::Path,
            spp: 512,
            ..photon_settings(size, 1, 0)
        },
    );
    // The noise floor: a second path-traced image with another seed against the first.
    let second = render_with(
        &scene,
        &RenderSettings {
            method: Method::Path,
            spp: 512,
            seed: 2,
            ..photon_settings(size, 1, 0)
        },
    );
    // Pixels where either image exceeds 1 are left out: at 8 spp the bright lamp's edge pixels
    // carry the noise of its sub-pixel coverage (a 5× error on a handful of pixels), which has
    // nothing to do with the photon maps and would dominate the relMSE.
    let masked = |im: &Image, other: &Image| -> Vec<[f32; 4]> {
        im.rgba
            .iter()
            .zip(&other.rgba)
            .filter(|(a, b)| a[..3].iter().chain(&b[..3]).all(|&v| v <= 1.0))
            .map(|(a, _)| *a)
            .collect()
    };
    let floor =
        photon::metrics::compare(&masked(&second, &reference), &masked(&reference, &second));
    let image = render_with(&scene, &photon_settings(size, 8, 100_000));
    let e = photon::metrics::compare(&masked(&image, &reference), &masked(&reference, &image));
    // Measured: photon relMSE ≈ 0.012 (its own final-gather noise at 8 spp × 16 rays, plus
    // the reference's ≈ 0.0025 shown by `floor`), mean within 1 %. A missing or double-counted
    // term (direct, caustic, indirect) shifts the mean by ≥ 10 %, far beyond these bounds.
    assert!(
        e.rel_mse < 0.02 && floor.rel_mse < 0.01,
        "photon {e:?}, path noise floor {floor:?}"
    );
    assert!(e.mean_relative_difference.abs() < 0.03, "{e:?}");
}

#[test]
fn photon_method_honours_the_bounce_limit() {
    // With at most 1, 2 or 3 bounces the photon method (with and without the irradiance cache)
    // must give the path tracer's image at that limit: every estimate counts only photons whose
    // bounces, with the camera path's, stay within it. Ignoring the limit, it was +30 %, +13 %
    // and +6 % too bright on a Cornell box. Means over the pixels below 1 in both images (the
    // lamp's edge pixels carry the noise of its sub-pixel coverage). Against a converged path
    // image (8192 spp) these 32-spp photon renders are 3.5 %, 3.3 % and 3.2 % dark at limits 1,
    // 2 and 3, so the bound is 5 %. That is the filter's doing, not the
    // photon method's: it drops the pixels a noisy image pushes above 1, so it lowers the mean
    // of any noisy image (a 32-spp path image: 2.0 and 1.5 % dark at limit 1 with seeds 1 and 2),
    // and over all pixels the photon image at limit 1 is +0.6 % and at limit 2 +0.3 %.
    let scene = builtin::cornell_box(&LoadOptions::default()).expect("cornell box");
    let mean = |im: &Image, other: &Image| {
        let lit = im.rgba.iter().zip(&other.rgba);
        let dim = lit.filter(|(a, b)| a[..3].iter().chain(&b[..3]).all(|&v| v <= 1.0));
        dim.map(|(a, _)| a[0] + a[1] + a[2]).sum::<f32>()
    };
    for max_depth in [1, 2, 3] {
        let path = RenderSettings {
            method: Method::Path,
            spp: 256,
            max_depth,
            ..photon_settings(16, 1, 0)
        };
        let reference = render_with(&scene, &path);
        for cache in [false, true] {
            let mut settings = photon_settings(16, 32, 200_000);
            settings.max_depth = max_depth;
            settings.irradiance_cache.enabled = cache;
            let image = render_with(&scene, &settings);
            let ratio = mean(&image, &reference) / mean(&reference, &image);
            assert!(
                (ratio - 1.0).abs() < 0.05,
                "max depth {max_depth}, cache {cache}: photon / path = {ratio:.4}"
            );
        }
    }
}

#[test]
fn photon_render_is_identical_with_one_and_two_threads() {
    let scene = builtin::cornell_box(&LoadOptions::default()).expect("cornell box");
    let s = photon_settings(12, 1, 20_000);
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
            .install(|| render_with(&scene, &s))
    };
    let bits = |im: &Image| {
        im.rgba
            .iter()
            .flat_map(|p| p.map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&run(1)), bits(&run(2)));
}

#[test]
fn precomputed_irradiance_matches_the_full_estimate() {
    // Christensen's records replace the k-nearest estimate at final-gather hits; with the same
    // seed the gather rays are identical, so the images differ only by that estimate: the mean
    // must agree within 1 % (measured −0.1 % at 96 × 96).
    let scene = builtin::cornell_box(&LoadOptions::default()).expect("cornell box");
    let mut settings = photon_settings(24, 2, 40_000);
    let with = render_with(&scene, &settings).mean_rgb();
    settings.photon.irradiance_stride = 0;
    let without = render_with(&scene, &settings).mean_rgb();
    for c in 0..3 {
        let rel = (with[c] - without[c]) / without[c];
        assert!(rel.abs() < 0.01, "with {with:?} without {without:?}");
    }
}

#[test]
fn aimed_caustic_photons_carry_the_same_flux_as_unaimed_ones() {
    // Projection towards the specular objects' bounding spheres must not change the caustic
    // flux: for each kind of light, the total power of stored caustic photons with and without
    // aiming agrees within the Monte Carlo error (two glass spheres, one overlapping the other's
    // cone, so the mixture density matters).
    use photon::integrator::photon::tracing::{trace_photon, Emitters, MapKind};
    use photon::rng::Rng;
    let glass = Material {
        name: "glass".into(),
        base_color: Vec3::ONE.extend(1.0),
        metallic: 0.0,
        roughness: 0.0,
        transmission: 1.0,
        ior: 1.5,
        ..Material::default()
    };
    let lights = [
        Light::Point {
            position: Vec3::new(0.3, 3.0, 0.2),
            intensity: Vec3::splat(10.0),
            radius: 0.0,
            lamp: Default::default(),
        },
        Light::Spot {
            position: Vec3::new(0.3, 3.0, 0.2),
            direction: -Vec3::Y,
            intensity: Vec3::splat(10.0),
            cos_inner: 0.95,
            cos_outer: 0.85,
            radius: 0.0,
            lamp: Default::default(),
        },
        Light::Sun {
            direction: Vec3::new(0.3, -1.0, 0.1).normalize(),
            irradiance: Vec3::splat(2.0),
            angle: 0.05,
            camera: true,
        },
    ];
    let mut setups: Vec<(String, Scene)> = Vec::new();
    for light in lights {
        let scene = scenes::scene(
            vec![
                scenes::floor(6.0, 0.0, 0),
                scenes::sphere(Vec3::new(0.0, 0.8, 0.0), 0.8, 16, 32, false, 1),
                scenes::sphere(Vec3::new(0.9, 0.5, 0.3), 0.5, 16, 32, false, 1),
            ],
            vec![Material::diffuse("floor", Vec3::splat(0.8)), glass.clone()],
            vec![light.clone()],
            scenes::camera_looking_at(
                Vec3::new(0.0, 3.0, 5.0),
                Vec3::ZERO,
                Projection::Perspective { yfov: 0.8 },
            ),
            Vec3::ZERO,
        );
        setups.push((format!("{light:?}"), scene));
    }
    // An emissive quad (Blender's area lights) and a uniform world, with the spot's geometry.
    let mut quad = setups[0].1.clone();
    quad.lights.clear();
    let mut lamp = scenes::floor(0.5, 3.0, 2);
    for t in &mut lamp.indices {
        t.swap(1, 2);
    }
    for n in &mut lamp.normals {
        *n = -Vec3::Y;
    }
    quad.meshes.push(lamp);
    let mut emitter = Material::diffuse("lamp", Vec3::ZERO);
    emitter.emission = Vec3::splat(20.0);
    emitter.double_sided = false;
    quad.materials.push(emitter);
    setups.push(("emissive quad".into(), quad));
    let mut world = setups[0].1.clone();
    world.lights.clear();
    world.world.background.color = Vec3::ONE;
    setups.push(("uniform world".into(), world));
    for (light, scene) in setups {
        let accel = Accel::new(&scene);
        let lights = Lights::new(&scene);
        let ctx = context(&scene, &accel, &lights, 16);
        let emitters = Emitters::new(&ctx);
        assert!(emitters.has_caustic_targets());
        let n = 120_000;
        let flux = |aimed: bool| -> (f64, f64, usize) {
            let mut rng = Rng::for_item(5, 0, 0);
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            let mut stored = 0;
            for _ in 0..n {
                let mut out = Vec::new();
                if let Some(e) = emitters.emit(&ctx, aimed, &mut rng) {
                    trace_photon(&ctx, &e, MapKind::Caustic, 16, &mut rng, &mut out);
                }
                let v: f64 = out.iter().map(|p| p.power().x as f64).sum();
                sum += v;
                sum2 += v * v;
                stored += out.len();
            }
            let mean = sum / n as f64;
            let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
            (mean, sigma, stored)
        };
        let (plain, plain_sigma, plain_stored) = flux(false);
        let (aimed, aimed_sigma, aimed_stored) = flux(true);
        let sigma = (plain_sigma * plain_sigma + aimed_sigma * aimed_sigma).sqrt();
        assert!(
            (plain - aimed).abs() < 4.0 * sigma + 0.005 * plain,
            "{light}: caustic flux {plain} (σ {plain_sigma}) plain vs {aimed} (σ {aimed_sigma}) aimed"
        );
        // The spot's own cone already points at the spheres: a smaller gain there.
        assert!(
            2 * aimed_stored > 3 * plain_stored,
            "{light}: aiming stored {aimed_stored} vs {plain_stored}"
        );
    }
}

#[test]
fn rounds_share_one_set_of_photon_maps() {
    // A time-limited render in rounds builds the photon maps once: global photon tracing
    // reports its last batch once, however many rounds run, and four rounds of 2 spp give the
    // image of the same rounds again (deterministic).
    use photon::progress::{Progress, ProgressEvent};
    use photon::rounds::render_in_rounds;
    use std::sync::atomic::AtomicBool;
    use std::sync::Mutex;
    let scene = builtin::cornell_box(&LoadOptions::default()).expect("cornell box");
    let settings = photon_settings(12, 8, 5_000);
    let finished = Mutex::new(0);
    let cancel = AtomicBool::new(false);
    let report = |e: &ProgressEvent| {
        if e.stage == "photons" && e.fraction == 1.0 && e.message.starts_with("Global") {
            *finished.lock().unwrap() += 1;
        }
    };
    let progress = Progress {
        cancel: &cancel,
        report: &report,
    };
    let a = render_in_rounds(&scene, None, &settings, 2, None, &progress).expect("render");
    assert_eq!(a.rounds, 4);
    assert_eq!(
        *finished.lock().unwrap(),
        1,
        "maps built once for four rounds"
    );
    let b = render_in_rounds(&scene, None, &settings, 2, None, &progress).expect("render");
    assert_eq!(a.image.rgba, b.image.rgba);
}

#[test]
fn cached_shading_under_a_world_seen_through_windows_is_free_of_speckles() {
    // The gallery's room lit by the sky and the sun through two windows: light sampling picks
    // the world rarely and the walls block most of those samples, so on cached surfaces the
    // few that pass through a window once made speckles (seed-to-seed relMSE 2.45× final
    // gathering's at 4 spp; with the MIS-weighted BSDF ray 1.1×). Allowed: 1.5×.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/gallery/interior.glb");
    let scene = photon::scene::gltf::load(&path, &LoadOptions::default()).expect("interior");
    let noise = |cache: bool| {
        let mut s = photon_settings(48, 4, 20_000);
        s.photon.gather_rays = PhotonSettings::default().gather_rays;
        s.irradiance_cache.enabled = cache;
        let a = render_with(&scene, &s);
        let b = render_with(&scene, &RenderSettings { seed: 2, ..s });
        photon::metrics::compare(&a.rgba, &b.rgba).rel_mse
    };
    let (cached, gathered) = (noise(true), noise(false));
    assert!(
        cached < 1.5 * gathered,
        "seed-to-seed relMSE {cached} with the cache, {gathered} with final gathering"
    );
}

#[test]
fn the_cache_keeps_the_indirect_light_of_an_open_floor() {
    // The gallery's glass cube: a floor under a black sky, lit by a lamp; its only indirect
    // light is the floor seen through the cube, which few of a record's gather rays find.
    // Records that found nothing near reached as far as the spacing bound allowed, and on a
    // small frame that was the whole frame: the cache gave half the indirect light of plain
    // final gathering (DiffInd 0.0084 against 0.0167 at 48 px). Records now cover at most a
    // share of the frame, and the two agree.
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/gallery/glass_cube.glb");
    let scene = photon::scene::load::load_scene(Some(&path), None).expect("glass cube");
    let indirect = |cache: bool| {
        let mut settings = photon_settings(48, 64, 200_000);
        settings.photon.gather_rays = 4;
        settings.irradiance_cache.enabled = cache;
        settings.light_passes = true;
        let image = render_with(&scene, &settings);
        let pass = photon::light_pass::LightPass::Indirect as usize;
        let sum: f64 = image
            .passes
            .iter()
            .map(|p| p.0[pass].element_sum() as f64)
            .sum();
        sum / image.passes.len() as f64
    };
    let (with, without) = (indirect(true), indirect(false));
    assert!(
        (with / without - 1.0).abs() < 0.1,
        "indirect light with the cache {with}, without {without}"
    );
}

#[test]
fn guided_photons_bring_the_same_light_into_a_window_lit_room() {
    // The room with thick walls lit by a sun through its window (scenes/blender/window_room.py):
    // uniform sun photons mostly land on the walls' outsides. Guided photons (emitted where
    // they reach what the camera's paths meet) must bring the same power into the room, within
    // noise, and far more of the photons must get in.
    use photon::integrator::photon::tracing::{trace_photon, Emitters, MapKind};
    use photon::rng::Rng;
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/blender/room_thick.glb");
    let scene = photon::scene::load::load_scene(Some(&path), None).expect("window-lit room");
    let accel = Accel::new(&scene);
    let lights = Lights::new(&scene);
    let ctx = context(&scene, &accel, &lights, 16);
    // The interior in glTF axes (Blender's z up is glTF's y): x, z in [-2, 2], y in [0, 2.5];
    // the walls' outer faces lie 0.2 m beyond it.
    let inside = |p: Vec3| p.x.abs() < 2.1 && p.z.abs() < 2.1 && p.y > -0.1 && p.y < 2.6;
    let n = 40_000;
    // (mean power into the room per photon, its standard error, photons that got in)
    let flux = |emitters: &Emitters| -> (f64, f64, u32) {
        let mut rng = Rng::for_item(11, 0, 0);
        let (mut sum, mut sum2, mut entered) = (0.0f64, 0.0f64, 0);
        let mut out = Vec::new();
        for _ in 0..n {
            out.clear();
            if let Some(e) = emitters.emit(&ctx, false, &mut rng) {
                trace_photon(&ctx, &e, MapKind::Global, 16, &mut rng, &mut out);
            }
            let v: f64 = out
                .iter()
                .filter(|p| inside(p.position()))
                .map(|p| p.power().y as f64)
                .sum();
            entered += u32::from(v > 0.0);
            sum += v;
            sum2 += v * v;
        }
        let mean = sum / n as f64;
        let sigma = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
        (mean, sigma, entered)
    };
    let uniform = Emitters::new(&ctx);
    let guided = Emitters::guided(&ctx, 1.0, 3);
    assert!(guided.is_guided(), "the sun's photons are not guided");
    let (plain, plain_sigma, plain_in) = flux(&uniform);
    let (aimed, aimed_sigma, aimed_in) = flux(&guided);
    let sigma = (plain_sigma * plain_sigma + aimed_sigma * aimed_sigma).sqrt();
    assert!(
        (plain - aimed).abs() < 4.0 * sigma,
        "power into the room: uniform {plain} (σ {plain_sigma}), guided {aimed} (σ {aimed_sigma})"
    );
    assert!(
        aimed_in > 4 * plain_in,
        "guiding did not bring the photons in: {aimed_in} of {n} guided, {plain_in} uniform"
    );
}
