//! Blender's Light Paths settings and light linking on a floor lit by a point light: Clamp
//! Direct holds every pixel to the limit (each sample's one light sample is held there), for
//! the path tracer and the photon method, and leaves the image alone when off; a light whose
//! receiver set leaves the floor out lights nothing, a light whose blocker set leaves a
//! blocking quad out shines through it.

use crate::support::scenes;

use photon::integrator::photon::settings::PhotonSettings;
use photon::math::Vec3;
use photon::render::{Method, RenderSettings};
use photon::scene::{Lamp, Light, LightLinks, Scene};

const SIZE: u32 = 8;

fn lit_floor() -> Scene {
    scenes::lit_floor(
        0.8,
        Light::Point {
            position: Vec3::new(0.0, 1.0, 0.0),
            intensity: Vec3::new(40.0, 20.0, 10.0),
            radius: 0.0,
            lamp: Lamp::default(),
        },
    )
}

fn settings(method: Method) -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        spp: 8,
        seed: 5,
        method,
        photon: PhotonSettings {
            global_photons: 5_000,
            caustic_photons: 5_000,
            gather_rays: 4,
            ..PhotonSettings::default()
        },
        ..RenderSettings::default()
    }
}

/// The pixels' colour sums (r + g + b).
fn sums(scene: &Scene, method: Method) -> Vec<f32> {
    let (image, _) = scenes::render_quietly(scene, &settings(method)).unwrap();
    image.rgba.iter().map(|p| p[0] + p[1] + p[2]).collect()
}

#[test]
fn light_paths_clamp_direct_holds_each_pixel_to_the_limit() {
    for method in [Method::Path, Method::Photon] {
        let mut scene = lit_floor();
        let unclamped = sums(&scene, method);
        let brightest = unclamped.iter().cloned().fold(0.0, f32::max);
        assert!(
            brightest > 3.0,
            "{method:?}: the floor is bright ({brightest})"
        );
        scene.render_settings.clamp_direct = 0.5;
        let clamped = sums(&scene, method);
        for (c, u) in clamped.iter().zip(&unclamped) {
            // The sum of three channels is held to three times the limit.
            assert!(*c <= 1.5 * 1.0001, "{method:?}: {c} above the limit");
            assert!(
                *c <= *u * 1.0001,
                "{method:?}: clamping brightened {u} to {c}"
            );
        }
        // The indirect limit does not touch a floor lit only directly.
        scene.render_settings.clamp_direct = 0.0;
        scene.render_settings.clamp_indirect = 0.01;
        assert_eq!(sums(&scene, method), unclamped, "{method:?}");
    }
}

#[test]
fn light_paths_a_light_lights_only_its_receivers() {
    let mut scene = lit_floor();
    scene.light_links = vec![LightLinks {
        receiver_set: 3,
        ..LightLinks::NONE
    }];
    let lit = sums(&scene, Method::Path);
    assert!(lit.iter().all(|&s| s > 0.0), "the floor is in every set");
    scene.meshes[0].links.lit_by &= !(1 << 3);
    let unlit = sums(&scene, Method::Path);
    assert!(
        unlit.iter().all(|&s| s == 0.0),
        "the floor is not lit: {unlit:?}"
    );
}

#[test]
fn light_paths_shadow_rays_pass_what_is_not_in_the_blocker_set() {
    let mut scene = lit_floor();
    // A quad between the light and the floor, facing down.
    scene.meshes.push(scenes::floor(20.0, 0.5, 0));
    // Camera rays must not see it: the camera looks down from above it, so hide it.
    scene.meshes[1].camera_visible = false;
    let shadowed = sums(&scene, Method::Path);
    scene.light_links = vec![LightLinks {
        blocker_set: 2,
        ..LightLinks::NONE
    }];
    let floor_only = LightLinks {
        blocks: !(1 << 2),
        ..LightLinks::NONE
    };
    scene.meshes[1].links = floor_only;
    let through = sums(&scene, Method::Path);
    let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len() as f32;
    assert!(
        mean(&through) > 10.0 * mean(&shadowed).max(1e-6),
        "shadow linking: {} vs {}",
        mean(&through),
        mean(&shadowed)
    );
}
