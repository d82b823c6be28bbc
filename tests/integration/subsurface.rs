//! Subsurface scattering (dipole diffusion, Jensen et al. 2001; hierarchical evaluation, Jensen
//! & Buhler 2002): the dipole's total diffuse reflectance against its closed form, the albedo
//! inversion, energy conservation of the sample kernel, the hierarchical sum against brute
//! force, the exitance cache, the render's lattice interpolation against brute force, and
//! rendered slabs under a sun against R_d·E/π.

use crate::support::scenes;

use scenes::with_progress;

use photon::integrator::photon::settings::PhotonSettings;
use photon::math::Vec3;
use photon::metrics::compare;
use photon::plan::{plan_for_image, Quality};
use photon::render::{render, Method, RenderSettings};
use photon::rng::Rng;
use photon::scene::{Light, Material, Scene, Subsurface, SubsurfaceMethod};
use photon::subsurface::{
    boundary_term, invert_albedo, total_reflectance, Dipole, ExitanceCache, Sample, SampleTree,
};
use std::f32::consts::PI;

/// ∫₀^∞ R_d(r) 2πr dr by the midpoint rule in u = ln r (R_d spans many decades).
fn integrate_rd(d: &Dipole, lo: f32, hi: f32, steps: usize) -> Vec3 {
    let (a, b) = (lo.ln() as f64, hi.ln() as f64);
    let du = (b - a) / steps as f64;
    let mut sum = [0.0f64; 3];
    for i in 0..steps {
        let r = (a + (i as f64 + 0.5) * du).exp();
        let v = d.rd((r * r) as f32);
        for c in 0..3 {
            sum[c] += v[c] as f64 * 2.0 * std::f64::consts::PI * r * r * du;
        }
    }
    Vec3::new(sum[0] as f32, sum[1] as f32, sum[2] as f32)
}

#[test]
fn dipole_total_reflectance_matches_closed_form() {
    for eta in [1.0, 1.3, 1.5] {
        let a = boundary_term(eta);
        for alpha in [0.1f32, 0.5, 0.9, 0.99, 1.0] {
            // `Dipole::new` takes a reflectance; give it the one this α′ has.
            let rd = total_reflectance(alpha, a);
            let d = Dipole::new(Vec3::splat(rd), Vec3::new(1.0, 0.1, 0.01), eta, 1e-9);
            assert!(
                (d.reduced_albedo() - Vec3::splat(alpha))
                    .abs()
                    .max_element()
                    < 1e-4
            );
            let lengths = [1.0f32, 0.1, 0.01];
            for (c, &l) in lengths.iter().enumerate() {
                let numeric = integrate_rd(&d, l * 1e-5, l * 1e5, 20_000)[c];
                assert!(
                    (numeric - rd).abs() < 2e-3 * rd.max(0.01),
                    "η {eta} α′ {alpha} ℓ {l}: ∫R_d = {numeric}, closed form {rd}"
                );
                let disc = d.cumulative(l * 1e5)[c];
                assert!((disc - rd).abs() < 1e-4, "P(∞) = {disc} vs {rd}");
            }
        }
    }
}

#[test]
fn albedo_inversion_reproduces_the_base_colour() {
    for eta in [1.0, 1.4, 2.0] {
        let a = boundary_term(eta);
        let mut last = -1.0;
        for i in 0..=100 {
            let c = i as f32 / 100.0;
            let alpha = invert_albedo(c, a);
            assert!((0.0..=1.0).contains(&alpha));
            assert!(alpha >= last, "the inversion is monotone");
            last = alpha;
            let back = total_reflectance(alpha, a);
            // α′ is an f32: near 1 (η = 2, c = 0.99) its last bit moves R_d by ~1e-4.
            assert!(
                (back - c).abs() < 2e-4,
                "η {eta}: R_d({alpha}) = {back} ≠ {c}"
            );
        }
    }
    // Out-of-range colours are clamped, not NaN.
    assert_eq!(invert_albedo(f32::NAN, 1.0), invert_albedo(0.0, 1.0));
    assert!((total_reflectance(invert_albedo(3.0, 2.0), 2.0) - 1.0).abs() < 1e-5);
}

#[test]
fn kernel_conserves_energy_for_any_mean_free_path() {
    // ∫ K over the plane is R_d(α′) whatever ℓ and h: the disc mean inside h plus R_d outside.
    for l in [1e-5f32, 1e-3, 0.1, 10.0] {
        for h in [1e-4f32, 0.05] {
            let d = Dipole::new(Vec3::new(1.0, 0.6, 0.2), Vec3::splat(l), 1.0, h);
            let outside = d.total() - d.cumulative(h);
            let inside = d.kernel(0.0) * (PI * h * h);
            let total = inside + outside;
            assert!(total.is_finite(), "ℓ {l} h {h}");
            assert!(
                (total - Vec3::new(1.0, 0.6, 0.2)).abs().max_element() < 1e-3,
                "ℓ {l} h {h}: {total}"
            );
            for r in [0.0, 1e-6, h, 1.0, 1e3] {
                assert!(d.kernel(r * r).is_finite() && d.kernel(r * r).min_element() >= 0.0);
            }
        }
    }
}

/// Samples spread over a 1 × 1 square (z = 0) with a varying flux.
fn square_samples(n: usize, seed: u64) -> Vec<Sample> {
    let mut rng = Rng::new(seed);
    (0..n)
        .map(|_| {
            let u = rng.uniform2();
            Sample {
                position: Vec3::new(u.x, u.y, 0.0),
                flux: Vec3::new(1.0, 0.5 + u.x, 2.0 * u.y) / n as f32,
            }
        })
        .collect()
}

#[test]
fn hierarchical_exitance_matches_brute_force() {
    let samples = square_samples(40_000, 7);
    let tree = SampleTree::build(samples, 1.0, 16.0);
    assert_eq!(tree.len(), 40_000);
    let d = Dipole::new(
        Vec3::new(0.8, 0.5, 0.3),
        Vec3::new(0.05, 0.01, 0.002),
        1.4,
        tree.smoothing(),
    );
    let mut rng = Rng::new(3);
    let (mut image, mut reference) = (Vec::new(), Vec::new());
    let mut evaluations = 0u64;
    for _ in 0..300 {
        let u = rng.uniform2();
        let x = Vec3::new(u.x * 1.2 - 0.1, u.y * 1.2 - 0.1, 0.0);
        let (m, e) = tree.exitance(x, &d, PhotonSettings::default().subsurface_accuracy);
        evaluations += e as u64;
        image.push([m.x, m.y, m.z, 1.0]);
        let b = tree.exitance_brute_force(x, &d);
        reference.push([b.x, b.y, b.z, 1.0]);
    }
    let err = compare(&image, &reference);
    assert!(err.rel_mse <= 1e-3, "relMSE {}", err.rel_mse);
    println!(
        "relMSE {:.2e}, {} kernel evaluations per point for 40 000 samples",
        err.rel_mse,
        evaluations / 300
    );
    // The hierarchy must actually prune: far fewer kernel evaluations than samples.
    assert!(
        evaluations < 300 * 40_000 / 10,
        "{} evaluations per point",
        evaluations / 300
    );
}

#[test]
fn exitance_of_white_material_conserves_flux() {
    // α′ = 1 (white): the exitance integrated over a plane much larger than ℓ equals the flux
    // that entered. Integrated on a grid over [-1, 2]², samples in the unit square.
    // The white dipole's tail falls only as 1/r³ (∫ beyond R ≈ (z_r + z_v)/2R), so ℓ is kept
    // small against the grid: the tail beyond it is below 0.5 %.
    let samples = square_samples(5_000, 11);
    let tree = SampleTree::build(samples, 1.0, 16.0);
    let d = Dipole::new(Vec3::ONE, Vec3::splat(0.002), 1.3, tree.smoothing());
    let n = 300;
    let cell = 3.0 / n as f32;
    let mut total = Vec3::ZERO;
    for i in 0..n {
        for j in 0..n {
            let x = Vec3::new(
                -1.0 + (i as f32 + 0.5) * cell,
                -1.0 + (j as f32 + 0.5) * cell,
                0.0,
            );
            total += tree.exitance(x, &d, 0.05).0 * (cell * cell);
        }
    }
    let flux = tree.total_flux();
    assert!(
        ((total - flux) / flux).abs().max_element() < 0.02,
        "exitance {total} vs flux {flux}"
    );
}

/// A 2 × 2 translucent slab (no specular layer) under a sun of irradiance E straight down,
/// seen from above over its central 0.2 × 0.2, with the Christensen–Burley method (the photon
/// method's dipole). An open surface: the random walk sees it as the top of a half-space.
fn slab(colour: Vec3, mfp: f32, ior: f32, e: f32) -> Scene {
    slab_with(SubsurfaceMethod::ChristensenBurley, colour, mfp, ior, e)
}

/// `slab` with the subsurface method `method`.
fn slab_with(method: SubsurfaceMethod, colour: Vec3, mfp: f32, ior: f32, e: f32) -> Scene {
    let mut s = scenes::lit_floor(
        0.5,
        Light::Sun {
            direction: -Vec3::Y,
            irradiance: Vec3::splat(e),
            angle: 0.0,
            camera: true,
        },
    );
    s.meshes = vec![scenes::floor(2.0, 0.0, 0)];
    let mut m = Material::diffuse("slab", colour);
    m.subsurface = Subsurface {
        method,
        weight: 1.0,
        radius: Vec3::splat(mfp),
        scale: 1.0,
        ior,
        anisotropy: 0.0,
    };
    s.materials = vec![m];
    s
}

/// Mean radiance and pixels of a 16 × 16 photon render.
fn mean_radiance(scene: &Scene, brute_force: bool) -> (Vec3, Vec<[f32; 4]>) {
    mean_radiance_at(scene, brute_force, 16)
}

/// `mean_radiance` on a `size` × `size` image.
fn mean_radiance_at(scene: &Scene, brute_force: bool, size: u32) -> (Vec3, Vec<[f32; 4]>) {
    let settings = RenderSettings {
        width: size,
        height: size,
        spp: 2,
        max_depth: 8,
        seed: 1,
        method: Method::Photon,
        photon: PhotonSettings {
            global_photons: 2_000,
            gather_rays: 1,
            subsurface_photons: 400_000,
            subsurface_brute_force: brute_force,
            ..PhotonSettings::default()
        },
        ..RenderSettings::default()
    };
    let (image, stats) = with_progress(|p| render(scene, &settings, p)).expect("render");
    assert_eq!(stats.nonfinite_samples, 0);
    let sum: Vec3 = image.rgba.iter().map(|p| Vec3::new(p[0], p[1], p[2])).sum();
    (sum / image.rgba.len() as f32, image.rgba)
}

#[test]
fn slab_under_uniform_light_shows_rd_e_over_pi() {
    let colour = Vec3::new(0.8, 0.5, 0.2);
    let e = 3.0;
    let (l, _) = mean_radiance(&slab(colour, 0.02, 1.4, e), false);
    let expected = colour * (e / PI);
    let rel = ((l - expected) / expected).abs().max_element();
    assert!(rel < 0.03, "L = {l}, R_d·E/π = {expected} ({rel:.4})");
}

#[test]
fn white_slab_loses_nothing() {
    // Zero absorption: α′ = 1, R_d = 1, so all the light that enters comes out (ℓ small against
    // the slab: the white dipole's 1/r³ tail beyond its edge is below 0.5 %).
    let e = 2.0;
    let (l, _) = mean_radiance(&slab(Vec3::ONE, 0.002, 1.3, e), false);
    let rel = (l / (e / PI) - Vec3::ONE).abs().max_element();
    assert!(rel < 0.03, "L = {l}, E/π = {}", e / PI);
}

#[test]
fn extreme_radii_and_unit_ior_stay_finite() {
    let colour = Vec3::new(0.7, 0.4, 0.9);
    for (mfp, ior) in [(1e-5, 1.0), (1e-5, 1.4), (10.0, 1.0), (10.0, 1.4)] {
        let scene = slab(colour, mfp, ior, 1.0);
        let (l, pixels) = mean_radiance(&scene, false);
        assert!(pixels.iter().all(|p| p.iter().all(|v| v.is_finite())));
        let (path, pixels) = path_mean(&scene);
        assert!(pixels.iter().all(|p| p.iter().all(|v| v.is_finite())));
        assert!(path.cmple(colour / PI * 1.05).all(), "path ℓ {mfp}: {path}");
        let expected = colour / PI;
        if mfp < 1e-3 {
            // The diffuse limit: light leaves where it entered.
            let rel = ((l - expected) / expected).abs().max_element();
            assert!(rel < 0.05, "ℓ {mfp} η {ior}: {l} vs {expected}");
            let rel = ((path - expected) / expected).abs().max_element();
            assert!(rel < 0.05, "path ℓ {mfp} η {ior}: {path} vs {expected}");
        } else {
            // ℓ = 10 on a 2-unit slab: most light leaves the slab's area, never more than R_d.
            assert!(
                l.cmple(expected * 1.03).all() && l.min_element() > 0.0,
                "{l}"
            );
        }
    }
}

#[test]
fn hierarchical_render_matches_brute_force_render() {
    // The render reads M from the lattice over each triangle (octree sums at its points); brute
    // force sums every sample at every shading point. A mean free path above and one well below
    // the smoothing radius (there M has the kernel's steps of the disc mean). At 8 × 8 pixels:
    // brute force's cost is its shading points times its 400 000 samples.
    for mfp in [0.05, 0.002] {
        let scene = slab(Vec3::new(0.9, 0.6, 0.3), mfp, 1.3, 1.0);
        let (fast_mean, fast) = mean_radiance_at(&scene, false, 8);
        let (brute_mean, brute) = mean_radiance_at(&scene, true, 8);
        let err = compare(&fast, &brute);
        let bias = (fast_mean / brute_mean - Vec3::ONE).abs().max_element();
        println!(
            "ℓ {mfp}: relMSE {} (bound 1e-3), bias {bias} (bound 0.005)",
            err.rel_mse
        );
        assert!(err.rel_mse <= 1e-3, "ℓ {mfp}: relMSE {}", err.rel_mse);
        assert!(bias <= 0.005, "ℓ {mfp}: mean {fast_mean} vs {brute_mean}");
    }
    // Deterministic whatever the thread count (photon batches, octree order and lattice values
    // are fixed).
    let scene = slab(Vec3::new(0.9, 0.6, 0.3), 0.05, 1.3, 1.0);
    let (_, fast) = mean_radiance(&scene, false);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build();
    let (_, single) = pool.expect("pool").install(|| mean_radiance(&scene, false));
    let bits = |im: &[[f32; 4]]| {
        im.iter()
            .flat_map(|p| p.map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&fast), bits(&single));
}

#[test]
fn exitance_cache_computes_each_point_once_and_stays_bounded() {
    use std::sync::atomic::{AtomicU32, Ordering};
    let cache = ExitanceCache::new(64 * 4);
    let calls = AtomicU32::new(0);
    let value = |k: u32| Vec3::new(k as f32, 1.0, 2.0);
    let get = |k: u32| {
        cache.get_or_compute([0, 1, 2, k], || {
            calls.fetch_add(1, Ordering::Relaxed);
            value(k)
        })
    };
    for k in 0..100 {
        assert_eq!(get(k), value(k));
    }
    let first = calls.load(Ordering::Relaxed);
    assert_eq!(first, 100);
    // Stored points are not computed again; past the bound, points are computed and not kept.
    let stored = cache.len();
    assert!(stored <= 64 * 4 && stored > 0);
    for k in 0..100 {
        assert_eq!(get(k), value(k));
    }
    assert_eq!(calls.load(Ordering::Relaxed) - first, 100 - stored as u32);
    for k in 0..10_000 {
        assert_eq!(get(k), value(k));
    }
    assert!(cache.len() <= 64 * 4);
}

#[test]
fn plan_needs_subsurface_only_for_translucent_lit_scenes() {
    let translucent = slab(Vec3::splat(0.5), 0.01, 1.3, 1.0);
    let plan = plan_for_image(&translucent, Quality::Default, 16, 16);
    assert!(plan.subsurface.needed, "{}", plan.subsurface.reason);
    assert_eq!(plan.method, Method::Photon, "{}", plan.method_reason);
    let mut opaque = translucent.clone();
    opaque.materials[0].subsurface.weight = 0.0;
    let plan = plan_for_image(&opaque, Quality::Default, 16, 16);
    assert!(!plan.subsurface.needed);
    assert!(plan.subsurface.reason.contains("no translucent"));
    let mut dark = translucent;
    dark.lights.clear();
    assert!(
        !plan_for_image(&dark, Quality::Default, 16, 16)
            .subsurface
            .needed
    );
}

/// Mean radiance and pixels of an 8 × 8 path-traced render at 64 spp.
fn path_mean(scene: &Scene) -> (Vec3, Vec<[f32; 4]>) {
    let settings = RenderSettings {
        width: 8,
        height: 8,
        spp: 64,
        max_depth: 8,
        seed: 1,
        method: Method::Path,
        ..RenderSettings::default()
    };
    let (image, stats) = with_progress(|p| render(scene, &settings, p)).expect("render");
    assert_eq!(stats.nonfinite_samples, 0);
    let sum: Vec3 = image.rgba.iter().map(|p| Vec3::new(p[0], p[1], p[2])).sum();
    (sum / image.rgba.len() as f32, image.rgba)
}

#[test]
fn random_walk_slab_agrees_between_path_tracer_and_photon_method() {
    // Both integrators walk the same medium (the shared path walk); the photon method shades
    // the exit by its light sample and final gather, the path tracer by its light sample and
    // bounce: the same light. Below the base colour: the walk enters by refraction (IOR 1.4),
    // deeper than a diffuse entry, and loses more the darker the channel.
    let colour = Vec3::new(0.8, 0.5, 0.2);
    let scene = slab_with(SubsurfaceMethod::RandomWalk, colour, 0.02, 1.4, 1.0);
    let mean = |method| {
        let settings = RenderSettings {
            width: 16,
            height: 16,
            spp: 256,
            max_depth: 8,
            seed: 1,
            method,
            photon: PhotonSettings {
                global_photons: 2_000,
                gather_rays: 1,
                ..PhotonSettings::default()
            },
            ..RenderSettings::default()
        };
        let (image, _) = with_progress(|p| render(&scene, &settings, p)).expect("render");
        let sum: Vec3 = image.rgba.iter().map(|p| Vec3::new(p[0], p[1], p[2])).sum();
        sum / image.rgba.len() as f32
    };
    let (path, photon) = (mean(Method::Path), mean(Method::Photon));
    let rel = ((photon - path) / path).abs().max_element();
    assert!(rel < 0.03, "photon {photon} vs path {path} ({rel:.4})");
    let upper = colour / PI;
    assert!(
        path.cmple(upper).all() && path.cmpgt(upper * 0.7).all(),
        "path {path} vs R_d·E/π {upper}"
    );
}
