//! `EmitterPixels`: the pixels where emission rays are traced must hold every pixel whose
//! filter window can see an emitter (else the image would lose light), and should be few.

use photon::accel::{Accel, Visibility};
use photon::camera::CameraRays;
use photon::emitter_pixels::EmitterPixels;
use photon::integrator::Context;
use photon::light::Lights;
use photon::math::Vec2;
use photon::scene::{builtin, gltf::LoadOptions, Scene};

/// Whether a dense grid of camera rays over pixel (x, y)'s window of half-width `radius` meets
/// an emitting surface first.
fn pixel_sees_an_emitter(
    scene: &Scene,
    accel: &Accel,
    camera: &CameraRays,
    x: u32,
    y: u32,
) -> bool {
    let radius = 1.5;
    let n = 12;
    (0..n * n).any(|k| {
        let offset = Vec2::new((k % n) as f32 + 0.5, (k / n) as f32 + 0.5) / n as f32;
        let film = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) + (offset * 2.0 - 1.0) * radius;
        let ray = camera.ray(film);
        accel
            .intersect(scene, &ray, Visibility::Camera)
            .is_some_and(|hit| {
                scene.materials[scene.meshes[hit.mesh as usize].material as usize].is_emissive()
            })
    })
}

fn context<'a>(scene: &'a Scene, accel: &'a Accel, lights: &'a Lights) -> Context<'a> {
    Context {
        scene,
        accel,
        lights,
        max_depth: 4,
        transparent_background: false,
    }
}

#[test]
fn emission_rays_go_to_every_pixel_that_sees_the_lamp_and_few_others() {
    let scene = builtin::cornell_box(&LoadOptions::default()).expect("cornell box");
    let (accel, lights) = (Accel::new(&scene), Lights::new(&scene));
    let ctx = context(&scene, &accel, &lights);
    let (width, height) = (48, 48);
    let camera = CameraRays::new(&scene.camera, width, height);
    let pixels = EmitterPixels::new(&ctx, &camera, 1.5, (width, height), true);
    let mut seeing = 0;
    for y in 0..height {
        for x in 0..width {
            if pixel_sees_an_emitter(&scene, &accel, &camera, x, y) {
                seeing += 1;
                assert!(
                    pixels.may_see(x, y),
                    "pixel ({x}, {y}) sees the lamp but is left out"
                );
            }
        }
    }
    assert!(seeing > 0, "the camera must see the lamp");
    let share = pixels.share();
    let seen = seeing as f64 / (width * height) as f64;
    assert!(
        share < 0.15 && share < 3.0 * seen,
        "{share} of the image marked, {seen} sees the lamp"
    );
}

#[test]
fn a_lens_or_a_lit_world_makes_every_pixel_count() {
    let mut scene = builtin::cornell_box(&LoadOptions::default()).expect("cornell box");
    scene.world.background.color = photon::math::Vec3::splat(0.1);
    let (accel, lights) = (Accel::new(&scene), Lights::new(&scene));
    let ctx = context(&scene, &accel, &lights);
    let camera = CameraRays::new(&scene.camera, 16, 16);
    assert_eq!(
        EmitterPixels::new(&ctx, &camera, 1.5, (16, 16), true).share(),
        1.0
    );
    // Film → Transparent: the world is not seen, so only the lamp counts again.
    let hidden = Context {
        transparent_background: true,
        ..ctx
    };
    assert!(EmitterPixels::new(&hidden, &camera, 1.5, (16, 16), true).share() < 0.5);
    // A lens blurs the lamp over any pixel.
    let mut lensed = scene.camera.clone();
    lensed.lens = Some(photon::scene::ThinLens {
        radius: 0.05,
        focus_distance: 3.0,
        blades: 0,
        rotation: 0.0,
        ratio: 1.0,
    });
    let camera = CameraRays::new(&lensed, 16, 16);
    assert_eq!(
        EmitterPixels::new(&hidden, &camera, 1.5, (16, 16), true).share(),
        1.0
    );
}
