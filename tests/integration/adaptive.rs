//! Adaptive sampling (`adaptive`, Cycles' noise threshold): pixels whose error estimate falls
//! below the threshold stop taking samples and keep the value they had, noisy ones take every
//! sample, across rounds and with the photon method too, and the image does not depend on the
//! thread count.

use crate::support::scenes;

use photon::adaptive::AdaptiveSettings;
use photon::film::Image;
use photon::integrator::photon::settings::PhotonSettings;
use photon::math::{Mat3, Vec3};
use photon::render::{Method, RenderSettings};
use photon::rounds::render_in_rounds;
use photon::scene::{Environment, Light, Scene};

const SIZE: u32 = 24;
const SPP: u32 = 128;
/// With 16 minimum samples, the first check is after 32 (`adaptive::Convergence::step`).
const FIRST_CHECK: u32 = 32;

/// A floor under a uniform grey world filling the left half of the frame, seen from above: the
/// floor's pixels are noisy (sky light sampled with MIS, half of the light samples below the
/// horizon), the right half sees the constant world and has no noise at all. The world is an
/// environment map of one grey, which light sampling draws from (a constant colour is left to
/// BSDF sampling, which sees it without noise on a Lambertian floor).
fn half_floor() -> Scene {
    let mut scene = scenes::lit_floor(
        0.8,
        Light::Point {
            position: Vec3::new(0.0, 3.0, 0.0),
            intensity: Vec3::ZERO,
            radius: 0.0,
            lamp: Default::default(),
        },
    );
    scene.lights.clear();
    // The camera looks down with +x to the image's left: the floor keeps x > 0.
    for p in &mut scene.meshes[0].positions {
        p.x += 10.0;
    }
    scene.world.background.environment = Some(Environment {
        width: 4,
        height: 2,
        pixels: vec![Vec3::splat(0.5); 8].into(),
        to_map: Mat3::IDENTITY,
        closest: true,
    });
    scene
}

fn settings(adaptive: bool) -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        spp: SPP,
        seed: 3,
        adaptive: adaptive.then_some(AdaptiveSettings {
            threshold: 0.001,
            min_samples: 16,
        }),
        ..RenderSettings::default()
    }
}

/// Pixel (x, y) of `image`.
fn at(image: &Image, x: u32, y: u32) -> usize {
    (y * image.width + x) as usize
}

/// The background columns far enough from the floor's edge that no pixel next to them is
/// noisy.
fn background_columns() -> std::ops::Range<u32> {
    SIZE / 2 + 3..SIZE
}

#[test]
fn converged_pixels_stop_and_noisy_ones_take_every_sample() {
    let scene = half_floor();
    let (full, _) = scenes::render_quietly(&scene, &settings(false)).expect("render");
    let (image, stats) = scenes::render_quietly(&scene, &settings(true)).expect("render");
    assert!(full.samples.iter().all(|&n| n == SPP));
    for y in 0..SIZE {
        for x in 0..SIZE / 2 - 2 {
            assert_eq!(
                image.samples[at(&image, x, y)],
                SPP,
                "floor pixel ({x}, {y})"
            );
        }
        for x in background_columns() {
            let k = at(&image, x, y);
            assert_eq!(image.samples[k], FIRST_CHECK, "background pixel ({x}, {y})");
            // The world is seen directly: every sample gives its colour.
            assert_eq!(image.rgba[k], full.rgba[k]);
        }
    }
    let taken: u64 = image.samples.iter().map(|&n| n as u64).sum();
    assert_eq!(stats.camera_samples, taken);
    assert!(
        taken < (SIZE * SIZE * SPP) as u64 * 3 / 4,
        "{taken} samples"
    );
    // The floor keeps its value: the noisy pixels took the same samples as without adaptive
    // sampling (the same numbers, the same sums).
    let k = at(&image, 2, SIZE / 2);
    assert_eq!(image.rgba[k], full.rgba[k]);
}

#[test]
fn the_same_seed_gives_the_same_bits_on_any_thread_count() {
    let scene = half_floor();
    let render = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        pool.install(|| scenes::render_quietly(&scene, &settings(true)).expect("render"))
            .0
    };
    let (one, three) = (render(1), render(3));
    assert_eq!(one.samples, three.samples);
    assert_eq!(one.rgba, three.rgba);
}

#[test]
fn converged_pixels_stay_stopped_in_later_rounds() {
    let scene = half_floor();
    let rounds = scenes::with_progress(|progress| {
        render_in_rounds(&scene, None, &settings(true), 16, None, progress)
    })
    .expect("render");
    assert_eq!(rounds.rounds, SPP / 16);
    let image = rounds.image;
    for y in 0..SIZE {
        assert_eq!(image.samples[at(&image, 0, y)], SPP);
        for x in background_columns() {
            let k = at(&image, x, y);
            assert_eq!(image.samples[k], FIRST_CHECK);
            assert!((image.rgba[k][0] - 0.5).abs() < 1e-6, "{:?}", image.rgba[k]);
        }
    }
}

#[test]
fn the_photon_method_stops_converged_pixels_too() {
    let scene = half_floor();
    let settings = RenderSettings {
        method: Method::Photon,
        photon: PhotonSettings {
            global_photons: 2_000,
            caustic_photons: 0,
            gather_rays: 4,
            ..PhotonSettings::default()
        },
        ..settings(true)
    };
    let (image, _) = scenes::render_quietly(&scene, &settings).expect("render");
    for y in 0..SIZE {
        for x in background_columns() {
            assert_eq!(image.samples[at(&image, x, y)], FIRST_CHECK);
        }
    }
    let floor: Vec<u32> = (0..SIZE).map(|y| image.samples[at(&image, 0, y)]).collect();
    assert!(floor.iter().all(|&n| n > FIRST_CHECK), "{floor:?}");
}

#[test]
fn a_render_ends_once_every_pixel_has_stopped() {
    // Only the world in view: every pixel converges at the first check, in the second round of
    // 16 samples, and no more rounds follow.
    let mut scene = half_floor();
    for p in &mut scene.meshes[0].positions {
        p.x += 100.0;
    }
    let settings = RenderSettings {
        spp: 4096,
        ..settings(true)
    };
    let rounds = scenes::with_progress(|progress| {
        render_in_rounds(&scene, None, &settings, 16, None, progress)
    })
    .expect("render");
    assert_eq!(rounds.rounds, FIRST_CHECK / 16);
    assert_eq!(rounds.spp, FIRST_CHECK);
    assert!(rounds.image.samples.iter().all(|&n| n == FIRST_CHECK));
    assert!(rounds.image.rgba.iter().all(|p| p[0] == 0.5));
}
