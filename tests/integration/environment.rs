//! The environment-map light: its importance sampler against its density (chi-square, and the
//! density integrates to 1), radiance lookups in Blender's orientation, the world light built
//! from a loaded scene, and the loader's errors for missing or broken environment images; the
//! worlds PHOTON_world builds from several backgrounds: a Nishita sky (a baked map and a sun),
//! a weighted mix, and what camera rays see instead.

use crate::support::binary::temp_dir;
use crate::support::chi2::chi2_sphere;
use photon::error::Error;
use photon::light::{EnvironmentLight, Lights};
use photon::math::{Mat3, Vec2, Vec3};
use photon::rng::Rng;
use photon::scene::gltf::{load, LoadOptions};
use photon::scene::{Environment, Light, Scene};
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
        .background
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

/// A .gltf with no geometry whose PHOTON_world is `world`.
fn world_doc(dir: &std::path::Path, world: serde_json::Value) -> PathBuf {
    let doc = json!({
        "asset": {"version": "2.0"}, "scene": 0, "extensionsUsed": ["PHOTON_world"],
        "scenes": [{"nodes": [], "extensions": {"PHOTON_world": world}}]
    });
    let path = dir.join("world.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

fn load_world(dir: &std::path::Path, world: serde_json::Value) -> Scene {
    load(&world_doc(dir, world), &LoadOptions::default()).unwrap()
}

/// Blender (x, y, z) as a glTF direction.
fn from_blender(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, z, -y)
}

#[test]
fn nishita_sky_becomes_a_map_and_a_sun() {
    let dir = temp_dir("sky");
    let sky = json!({"type": "NISHITA", "sun_elevation": 0.5, "sun_rotation": 1.2,
                     "sun_size": 0.02, "sun_intensity": 1.0, "sun_disc": true});
    let scene = load_world(&dir, json!({"strength": 0.1, "sky": sky}));
    let env = scene
        .world
        .background
        .environment
        .as_ref()
        .expect("a baked sky");
    assert_eq!((env.width, env.height), (1024, 512));
    // The sun: where Blender puts it (rotation turns it from +Y towards +X), 0.02 rad wide.
    let [Light::Sun {
        direction,
        irradiance,
        angle,
        ..
    }] = scene.lights[..]
    else {
        panic!("one sun expected: {:?}", scene.lights);
    };
    let (e, r) = (0.5f32, 1.2f32);
    let to_sun = from_blender(e.cos() * r.sin(), e.cos() * r.cos(), e.sin());
    assert!(
        (-direction).dot(to_sun) > 0.99999,
        "{direction} vs {to_sun}"
    );
    assert!((angle - 0.02).abs() < 1e-6 && irradiance.min_element() > 0.0);
    // Whiter and brighter than the sky: the sun outshines the whole sky on a level surface.
    let sky_on_ground: Vec3 = (0..64 * 32)
        .map(|i| {
            let (u, v) = ((i % 64) as f32 + 0.5, (i / 64) as f32 + 0.5);
            let (theta, phi) = (0.5 * PI * v / 32.0, 2.0 * PI * u / 64.0);
            let d = from_blender(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            env.radiance(d) * theta.cos() * theta.sin() * (0.5 * PI / 32.0) * (2.0 * PI / 64.0)
        })
        .sum();
    assert!(
        irradiance.y * e.sin() > sky_on_ground.y,
        "{irradiance} {sky_on_ground}"
    );
    // The zenith is blue; far below the horizon it is black.
    let zenith = env.radiance(Vec3::Y);
    assert!(zenith.z > zenith.x && zenith.x > 0.0, "{zenith}");
    assert_eq!(env.radiance(-Vec3::Y), Vec3::ZERO);

    let no_disc = load_world(
        &dir,
        json!({"sky": {"sun_elevation": 0.5, "sun_disc": false}}),
    );
    assert!(no_disc.lights.is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn mixed_backgrounds_add_up_with_their_weights() {
    let dir = temp_dir("mix");
    let constants = load_world(
        &dir,
        json!({"mix": [{"weight": 0.25, "color": [1.0, 0.0, 0.0], "strength": 2.0},
                       {"weight": 0.75, "color": [0.0, 1.0, 1.0]}]}),
    );
    assert_eq!(constants.world.background.color, Vec3::new(0.5, 0.75, 0.75));
    assert!(constants.world.background.environment.is_none());
    assert!(constants.world.camera_background.is_none());

    // A constant under a sky: added to every direction of the map, below the horizon too.
    let sky = json!({"sun_elevation": 0.3, "sun_disc": false});
    let scene = load_world(
        &dir,
        json!({"mix": [{"weight": 0.5, "sky": sky, "strength": 0.2},
                       {"weight": 0.5, "color": [0.2, 0.4, 0.6]}]}),
    );
    let env = scene.world.background.environment.as_ref().unwrap();
    let below = env.radiance(-Vec3::Y);
    assert!(
        (below - Vec3::new(0.1, 0.2, 0.3)).abs().max_element() < 1e-6,
        "{below}"
    );
    let alone = load_world(&dir, json!({"sky": sky, "strength": 0.1}));
    let up = from_blender(0.3, 0.2, 0.9).normalize();
    let expected = alone.world.background.radiance(up) + Vec3::new(0.1, 0.2, 0.3);
    let got = scene.world.background.radiance(up);
    assert!(
        (got - expected).abs().max_element() < 1e-4 * expected.max_element(),
        "{got}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn camera_rays_may_see_another_background() {
    let dir = temp_dir("camera");
    let scene = load_world(
        &dir,
        json!({"color": [0.1, 0.2, 0.3], "camera": {"color": [1.0, 1.0, 1.0], "strength": 0.5}}),
    );
    assert_eq!(scene.world.background.color, Vec3::new(0.1, 0.2, 0.3));
    let seen = scene.world.camera_background.as_ref().unwrap();
    assert_eq!(seen.radiance(Vec3::X), Vec3::splat(0.5));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_sky_settings_are_scene_errors() {
    let dir = temp_dir("badsky");
    for (sky, needle) in [
        (json!({"type": "MULTIPLE"}), "unknown sky type"),
        (json!({"type": "MULTIPLE_SCATTERING", "air": -1.0}), "'air'"),
        (json!({"dust": -1.0}), "'dust'"),
        (json!({"sun_size": 4.0}), "'sun_size'"),
        (json!({"rotation": [0.0, 1.0]}), "'rotation'"),
    ] {
        let message = load_error(&world_doc(&dir, json!({"sky": sky})));
        assert!(message.contains(needle), "{message}");
    }
    let mix = load_error(&world_doc(&dir, json!({"mix": {"color": [1, 1, 1]}})));
    assert!(mix.contains("'mix' must be a list"), "{mix}");
    let weight = load_error(&world_doc(&dir, json!({"mix": [{"weight": "half"}]})));
    assert!(weight.contains("'weight'"), "{weight}");
    let _ = std::fs::remove_dir_all(&dir);
}
