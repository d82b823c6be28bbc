//! The environment-map light: its importance sampler against its density (chi-square, and the
//! density integrates to 1), radiance lookups in Blender's orientation, the world light built
//! from a loaded scene, and the loader's errors for missing or broken environment images.

mod common;

use common::chi2::chi2_sphere;
use photon::error::Error;
use photon::light::{EnvironmentLight, Lights};
use photon::math::{Mat3, Vec2, Vec3};
use photon::rng::Rng;
use photon::scene::gltf::{load, LoadOptions};
use photon::scene::Environment;
use serde_json::json;
use std::f32::consts::PI;
use std::path::PathBuf;

const NUM_TESTS: usize = 2;

/// An 8×4 map: a dim sky gradient, a black band and one bright patch, rotated away from the
/// axes so that the mapping and its inverse are both exercised.
fn test_map(closest: bool) -> Environment {
    let (w, h) = (8u32, 4u32);
    let mut pixels = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let sky = Vec3::new(0.2, 0.3, 0.5) * (1.0 - y as f32 / h as f32);
            let c = if (2..4).contains(&x) && y == 1 {
                Vec3::new(40.0, 30.0, 20.0)
            } else if y == 3 {
                Vec3::ZERO
            } else {
                sky
            };
            pixels.push(c);
        }
    }
    Environment {
        width: w,
        height: h,
        pixels: pixels.into(),
        to_map: Mat3::from_rotation_z(0.7) * Mat3::from_rotation_x(0.3),
        closest,
    }
}

fn check_sampler(closest: bool, seed: u64) {
    let light = EnvironmentLight::new(&test_map(closest));
    let mut rng = Rng::new(seed);
    let mut bad = None;
    let p = chi2_sphere(
        "environment map",
        300_000,
        |_| {
            let (dir, li, pdf) = light.sample(rng.uniform2())?;
            // The returned radiance and density are the ones the lookups give.
            let again = (light.eval(dir), light.pdf(dir));
            if (li - again.0).abs().max_element() > 1e-4 || (pdf - again.1).abs() > 1e-3 * pdf {
                bad = Some((dir, li, pdf, again));
            }
            Some(dir)
        },
        |w| light.pdf(w) as f64,
        NUM_TESTS,
    );
    assert!(bad.is_none(), "sample disagrees with eval/pdf: {bad:?}");
    assert!(p.is_ok(), "{}", p.unwrap_err());
    let mass = sphere_integral(|w| light.pdf(w) as f64);
    assert!((mass - 1.0).abs() < 2e-3, "pdf integrates to {mass}");
}

/// ∫ f dω over the sphere by the midpoint rule on a fine grid in (cos θ, φ), where dω = d cos θ dφ.
fn sphere_integral(f: impl Fn(Vec3) -> f64) -> f64 {
    let (n_cos, n_phi) = (1000, 2000);
    let mut sum = 0.0;
    for i in 0..n_cos {
        let cos = -1.0 + 2.0 * (i as f64 + 0.5) / n_cos as f64;
        let sin = (1.0 - cos * cos).sqrt();
        for j in 0..n_phi {
            let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / n_phi as f64;
            sum += f(Vec3::new(
                (sin * phi.cos()) as f32,
                (sin * phi.sin()) as f32,
                cos as f32,
            ));
        }
    }
    sum * 4.0 * std::f64::consts::PI / (n_cos * n_phi) as f64
}

#[test]
fn bilinear_environment_sampler_matches_its_pdf() {
    check_sampler(false, 11);
}

#[test]
fn closest_environment_sampler_matches_its_pdf() {
    check_sampler(true, 12);
}

#[test]
fn average_radiance_is_the_integral_over_the_sphere() {
    let light = EnvironmentLight::new(&test_map(true));
    let integral = sphere_integral(|w| light.eval(w).x as f64);
    let expected = 4.0 * PI as f64 * light.average.x as f64;
    assert!(
        (integral - expected).abs() < 1e-3 * expected,
        "∫L dω = {integral}, 4π·average = {expected}"
    );
}

/// Blender's orientation (Cycles' equirectangular mapping): the image centre faces Blender +X,
/// u = 0.25 faces +Y, the top row is +Z; glTF (x, y, z) is Blender (x, −z, y).
#[test]
fn lookups_follow_blenders_orientation() {
    let (w, h) = (8u32, 4u32);
    let pixels: Vec<Vec3> = (0..w * h).map(|i| Vec3::splat(i as f32)).collect();
    let light = EnvironmentLight::new(&Environment {
        width: w,
        height: h,
        pixels: pixels.into(),
        to_map: Mat3::from_cols(Vec3::X, Vec3::Z, Vec3::NEG_Y),
        closest: true,
    });
    let pixel_of = |blender: Vec3| {
        let gltf = Vec3::new(blender.x, blender.z, -blender.y).normalize();
        light.eval(gltf).x as u32
    };
    // Just below the horizon towards Blender +X (a little towards −Y): u just above 0.5.
    assert_eq!(pixel_of(Vec3::new(1.0, -0.05, -0.1)), 2 * w + w / 2);
    // Towards Blender +Y (a little towards +X), above the horizon: u just above 0.25, row 1.
    assert_eq!(pixel_of(Vec3::new(0.05, 1.0, 0.1)), w + w / 4);
    // Towards Blender −Y: u = 0.75.
    assert_eq!(pixel_of(Vec3::new(-0.05, -1.0, 0.1)), w + 3 * w / 4);
    // Straight up: the top row; straight down: the bottom row.
    assert!(pixel_of(Vec3::new(0.01, 0.0, 1.0)) < w);
    assert!(pixel_of(Vec3::new(0.01, 0.0, -1.0)) >= (h - 1) * w);
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("photon-env-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A .gltf with no geometry whose world is the environment `environment`.
fn world_gltf(dir: &std::path::Path, environment: serde_json::Value) -> PathBuf {
    let doc = json!({
        "asset": {"version": "2.0"}, "scene": 0, "extensionsUsed": ["PHOTON_world"],
        "scenes": [{"nodes": [], "extensions": {"PHOTON_world": {
            "color": [0.0, 0.0, 0.0], "strength": 2.0, "environment": environment}}}]
    });
    let path = dir.join("world.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

fn load_error(path: &std::path::Path) -> String {
    match load(path, &LoadOptions::default()) {
        Err(e @ Error::Scene { .. }) => e.to_string(),
        Err(other) => panic!("expected a scene error, got {other:?}"),
        Ok(_) => panic!("expected a scene error, the file loaded"),
    }
}

#[test]
fn environment_image_loads_and_lights_the_scene() {
    let dir = temp_dir("ok");
    exr::prelude::write_rgb_file(dir.join("sky.exr"), 4, 2, |x, y| {
        (x as f32 + 1.0, y as f32, 0.5f32)
    })
    .unwrap();
    let path = world_gltf(&dir, json!({"uri": "sky.exr", "rotation": [0.0, 0.0, 0.5]}));
    let scene = load(&path, &LoadOptions::default()).unwrap();
    let env = scene
        .world
        .environment
        .as_ref()
        .expect("environment loaded");
    assert_eq!((env.width, env.height), (4, 2));
    // × strength 2; row 0 is the file's top row.
    assert_eq!(env.pixels[1], Vec3::new(4.0, 0.0, 1.0));
    assert_eq!(env.pixels[4], Vec3::new(2.0, 2.0, 1.0));
    assert!(!env.closest && scene.world.emits());
    let lights = Lights::new(&scene);
    let (wi, li, pdf) = lights.sample_world(Vec2::new(0.3, 0.6)).unwrap();
    assert!(li.max_element() > 0.0 && pdf > 0.0 && (wi.length() - 1.0).abs() < 1e-4);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn missing_or_broken_environment_images_are_scene_errors() {
    let dir = temp_dir("bad");
    let missing = load_error(&world_gltf(&dir, json!({"uri": "nowhere.exr"})));
    assert!(
        missing.contains("nowhere.exr") && missing.contains("not found"),
        "{missing}"
    );

    std::fs::write(dir.join("junk.exr"), b"this is not an EXR file").unwrap();
    let junk = load_error(&world_gltf(&dir, json!({"uri": "junk.exr"})));
    assert!(
        junk.contains("cannot read environment image 'junk.exr'"),
        "{junk}"
    );

    let no_uri = load_error(&world_gltf(&dir, json!({"strength": 1.0})));
    assert!(no_uri.contains("'uri'"), "{no_uri}");

    exr::prelude::write_rgb_file(dir.join("nan.exr"), 2, 1, |x, _| {
        (if x == 0 { f32::NAN } else { 1.0 }, 0.0f32, 0.0f32)
    })
    .unwrap();
    let nan = load_error(&world_gltf(&dir, json!({"uri": "nan.exr"})));
    assert!(nan.contains("NaN"), "{nan}");

    exr::prelude::write_rgb_file(dir.join("ok.exr"), 2, 1, |_, _| (1.0f32, 1.0f32, 1.0f32))
        .unwrap();
    let interp = load_error(&world_gltf(
        &dir,
        json!({"uri": "ok.exr", "interpolation": "cubic"}),
    ));
    assert!(interp.contains("interpolation"), "{interp}");
    let _ = std::fs::remove_dir_all(&dir);
}
