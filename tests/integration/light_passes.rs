//! The light-path passes (`light_pass::LightPass`) on a small scene with a glass sphere, a
//! translucent one, a diffuse floor and wall and a spherical emitter in view: for the path and photon methods the passes
//! add up to Combined per pixel and are non-negative, Emission is the emitter's radiance where the
//! camera sees it, a one-bounce render has no Indirect light, and `--passes` names the EXR
//! channels as Blender's view layer expects. On a floor half in fog, lit by a point light, the
//! volume passes hold the light the fog scatters (Volume Direct straight from the light, Volume
//! Indirect after more scatterings), the two methods agree on Volume Direct, and the passes
//! still add up to Combined.

use crate::support::scenes;

use photon::film::Image;
use photon::image_io::{write_image, ExrLayout, LIGHT_PASS_NAMES};
use photon::integrator::photon::settings::PhotonSettings;
use photon::light_pass::{LightPass, Passes};
use photon::math::Vec3;
use photon::medium::Coefficients;
use photon::phase::Phase;
use photon::render::{render, Method, RenderSettings};
use photon::rounds::render_in_rounds;
use photon::scene::{Lamp, Light, Material, Projection, Scene, Subsurface};
use std::sync::atomic::AtomicBool;

const SIZE: u32 = 32;
/// Radiance of the emitter.
const LE: f32 = 4.0;

fn glass_scene() -> Scene {
    let glass = Material {
        transmission: 1.0,
        roughness: 0.0,
        ..Material::diffuse("glass", Vec3::ONE)
    };
    let mut translucent = Material::diffuse("translucent", Vec3::new(0.8, 0.6, 0.5));
    translucent.subsurface = Subsurface {
        weight: 1.0,
        radius: Vec3::splat(0.1),
        scale: 1.0,
        ..Subsurface::default()
    };
    let mut emitter = Material::diffuse("emitter", Vec3::ZERO);
    emitter.emission = Vec3::splat(LE);
    emitter.double_sided = false;
    // A back wall at z = −1.5 facing the camera, so that there is indirect light to find.
    let mut wall = scenes::floor(6.0, 0.0, 0);
    for p in &mut wall.positions {
        *p = Vec3::new(p.x, 3.0 - p.z, -1.5);
    }
    wall.normals = vec![Vec3::Z; 4];
    scenes::scene(
        vec![
            scenes::floor(6.0, 0.0, 0),
            wall,
            scenes::sphere(Vec3::new(0.0, 0.5, 0.0), 0.5, 16, 32, false, 1),
            scenes::sphere(Vec3::new(0.0, 1.6, -0.5), 0.3, 12, 24, false, 2),
            scenes::sphere(Vec3::new(1.1, 0.4, 0.0), 0.4, 12, 24, false, 3),
        ],
        vec![
            Material::diffuse("floor", Vec3::splat(0.7)),
            glass,
            emitter,
            translucent,
        ],
        Vec::new(),
        scenes::camera_looking_at(
            Vec3::new(0.0, 1.5, 3.0),
            Vec3::new(0.0, 0.5, 0.0),
            Projection::Perspective { yfov: 1.0 },
        ),
        Vec3::ZERO,
    )
}

fn settings(method: Method, max_depth: u32) -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        spp: 16,
        max_depth,
        seed: 3,
        method,
        photon: PhotonSettings {
            global_photons: 20_000,
            caustic_photons: 20_000,
            gather_rays: 4,
            subsurface_photons: 20_000,
            ..PhotonSettings::default()
        },
        light_passes: true,
        ..RenderSettings::default()
    }
}

fn render_image(scene: &Scene, settings: &RenderSettings) -> Image {
    let (image, stats) =
        scenes::with_progress(|p| render(scene, settings, p)).expect("render succeeds");
    assert_eq!(stats.nonfinite_samples, 0);
    image
}

fn pass_sum(image: &Image, pass: LightPass) -> f32 {
    let p = pass as usize;
    image.passes.iter().map(|v| v.0[p].element_sum()).sum()
}

/// Passes sum to Combined (relative 1e-4) and none is negative.
fn check_sums(image: &Image) {
    for (i, (px, passes)) in image.rgba.iter().zip(&image.passes).enumerate() {
        let combined = Vec3::new(px[0], px[1], px[2]);
        let total = passes.total();
        let scale = combined.max_element().max(1e-3);
        assert!(
            (total - combined).abs().max_element() <= 1e-4 * scale,
            "pixel {i}: passes sum to {total:?}, Combined is {combined:?}"
        );
        for (p, v) in passes.0.iter().enumerate() {
            assert!(v.min_element() >= 0.0, "pixel {i} pass {p}: {v:?}");
        }
    }
}

/// `check_sums`, and the emitter's central pixels show exactly its radiance in Emission.
fn check_passes(image: &Image) {
    check_sums(image);
    // The emitter's centre projects 20° above the image centre: row 5, columns 15 and 16 (its
    // disc is about 9 px wide, wider than the 3 px filter footprint).
    for x in [15, 16] {
        let emission = image.passes[(5 * SIZE + x) as usize].0[LightPass::Emission as usize];
        assert!(
            (emission - Vec3::splat(LE)).abs().max_element() < 1e-4 * LE,
            "emitter pixel ({x}, 5): Emission {emission:?}"
        );
    }
    for pass in [
        LightPass::Direct,
        LightPass::Indirect,
        LightPass::Subsurface,
    ] {
        assert!(pass_sum(image, pass) > 0.0, "{pass:?}");
    }
    // No medium, no volume light.
    for pass in [LightPass::VolumeDirect, LightPass::VolumeIndirect] {
        assert_eq!(pass_sum(image, pass), 0.0, "{pass:?}");
    }
}

/// A floor under a sphere of fog (its surface a white Transparent BSDF, as a Blender material
/// with only a Volume) that covers half the view, lit by a point light inside the fog, the
/// world black; `volume_bounces` scatterings in the fog followed.
fn fog_scene(volume_bounces: u32) -> Scene {
    let fog = scenes::volume_material(Coefficients {
        scattering: Vec3::new(0.6, 0.8, 1.0),
        absorption: Vec3::splat(0.1),
        emission: Vec3::ZERO,
        phase: Phase::henyey_greenstein(0.3),
    });
    let mut s = scenes::scene(
        vec![
            scenes::floor(6.0, 0.0, 0),
            scenes::sphere(Vec3::new(-0.8, 0.5, 0.0), 1.2, 24, 48, false, 1),
        ],
        vec![Material::diffuse("floor", Vec3::splat(0.7)), fog],
        vec![Light::Point {
            position: Vec3::new(-0.5, 1.2, 0.3),
            intensity: Vec3::splat(10.0),
            radius: 0.0,
            lamp: Lamp::default(),
        }],
        scenes::camera_looking_at(
            Vec3::new(0.0, 2.0, 4.0),
            Vec3::new(0.0, 0.4, 0.0),
            Projection::Perspective { yfov: 0.9 },
        ),
        Vec3::ZERO,
    );
    s.render_settings.volume_bounces = volume_bounces;
    s
}

fn fog_settings(method: Method) -> RenderSettings {
    RenderSettings {
        spp: 64,
        ..settings(method, 64)
    }
}

/// Pass sums, as a fraction of the image's total.
fn shares(image: &Image) -> Vec<f32> {
    let total: f32 = LightPass::ALL.iter().map(|&p| pass_sum(image, p)).sum();
    LightPass::ALL
        .iter()
        .map(|&p| pass_sum(image, p) / total)
        .collect()
}

#[test]
fn fog_scatters_into_the_volume_passes() {
    let scene = fog_scene(4);
    let path = render_image(&scene, &fog_settings(Method::Path));
    let photon = render_image(&scene, &fog_settings(Method::Photon));
    for image in [&path, &photon] {
        check_sums(image);
        for pass in [
            LightPass::Direct,
            LightPass::Indirect,
            LightPass::VolumeDirect,
            LightPass::VolumeIndirect,
        ] {
            assert!(pass_sum(image, pass) > 0.0, "{pass:?}");
        }
        // Nothing emits in view.
        assert_eq!(pass_sum(image, LightPass::Emission), 0.0);
    }
    // Single scattering straight from the light: both methods estimate it without bias; the
    // volume photon map's estimate of the rest is biased by its radius.
    for (pass, tolerance) in [
        (LightPass::VolumeDirect, 0.03),
        (LightPass::VolumeIndirect, 0.15),
    ] {
        let (a, b) = (pass_sum(&path, pass), pass_sum(&photon, pass));
        assert!(
            (a / b - 1.0).abs() < tolerance,
            "{pass:?}: path {a}, photon {b}"
        );
    }
    eprintln!("path shares {:?}", shares(&path));
    eprintln!("photon shares {:?}", shares(&photon));
    // No volume bounce beyond the first: the path tracer's fog scatters only light straight
    // from the light (and the emission met after a scattering, of which there is none).
    let single = render_image(&fog_scene(0), &fog_settings(Method::Path));
    check_sums(&single);
    assert_eq!(pass_sum(&single, LightPass::VolumeIndirect), 0.0);
    assert!(pass_sum(&single, LightPass::VolumeDirect) > 0.0);
}

/// Emission rays replace only what the camera sees directly (the Emission pass): the light
/// the fog along the camera ray scatters stays.
#[test]
fn emission_rays_keep_the_light_scattered_along_the_camera_ray() {
    let scene = fog_scene(1);
    let plain = render_image(&scene, &fog_settings(Method::Path));
    let with_rays = render_image(
        &scene,
        &RenderSettings {
            emission_rays: 2,
            ..fog_settings(Method::Path)
        },
    );
    check_sums(&with_rays);
    for pass in LightPass::ALL {
        assert_eq!(
            pass_sum(&plain, pass),
            pass_sum(&with_rays, pass),
            "{pass:?}"
        );
    }
}

#[test]
fn path_tracer_passes_add_up() {
    // In two passes of 8 samples (as under a time limit), so that merging keeps the sums.
    let result = scenes::with_progress(|p| {
        render_in_rounds(
            &glass_scene(),
            None,
            &settings(Method::Path, 16),
            8,
            None,
            p,
        )
    })
    .expect("render succeeds");
    assert_eq!(result.rounds, 2);
    let image = result.image;
    check_passes(&image);
    // The path tracer's caustics are classified by their vertices: no Caustic pass.
    assert_eq!(pass_sum(&image, LightPass::Caustic), 0.0);
}

#[test]
fn photon_passes_add_up() {
    let image = render_image(&glass_scene(), &settings(Method::Photon, 16));
    check_passes(&image);
    // The glass sphere focuses the emitter onto the floor: the caustic map has something.
    assert!(pass_sum(&image, LightPass::Caustic) > 0.0);
}

#[test]
fn one_bounce_has_no_indirect_light() {
    let scene = glass_scene();
    // Passes are stored only on request.
    let mut off = settings(Method::Path, 1);
    off.light_passes = false;
    assert!(render_image(&scene, &off).passes.is_empty());
    let image = render_image(&scene, &settings(Method::Path, 1));
    assert_eq!(pass_sum(&image, LightPass::Indirect), 0.0);
    assert!(pass_sum(&image, LightPass::Direct) > 0.0);
    // The photon method without a global map: direct light, caustics and emission only.
    let mut photon = settings(Method::Photon, 16);
    photon.photon.global_photons = 0;
    let image = render_image(&scene, &photon);
    assert_eq!(pass_sum(&image, LightPass::Indirect), 0.0);
    assert!(pass_sum(&image, LightPass::Direct) > 0.0);
}

#[test]
fn multilayer_exr_holds_the_passes_under_blender_names() {
    let mut image = Image::new(2, 1);
    image.passes = vec![Passes::default(); 2];
    image.rgba = vec![[3.0, 3.0, 3.0, 1.0]; 2];
    for (p, pass) in LightPass::ALL.iter().enumerate() {
        for v in &mut image.passes {
            v.add(*pass, Vec3::new(p as f32, 0.5, 0.25));
        }
    }
    let dir = std::env::temp_dir().join(format!("photon-light-passes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("passes.exr");
    let channels = |image: &Image, light_passes: bool| {
        let layout = ExrLayout::Blender {
            view_layer: "ViewLayer".into(),
            light_passes,
        };
        write_image(&path, image, &layout, &AtomicBool::new(false)).expect("write");
        let read = exr::prelude::read_all_flat_layers_from_file(&path).expect("read");
        read.layer_data[0]
            .channel_data
            .list
            .iter()
            .map(|c| {
                let first = c.sample_data.values_as_f32().next().unwrap();
                (c.name.to_string(), first)
            })
            .collect::<Vec<_>>()
    };
    // Asking for passes that were not rendered is an error, not a panic.
    let unrendered = Image::new(2, 1);
    let layout = ExrLayout::Blender {
        view_layer: "ViewLayer".into(),
        light_passes: true,
    };
    let cancel = AtomicBool::new(false);
    assert!(write_image(&path, &unrendered, &layout, &cancel).is_err());
    assert!(!path.exists());
    let plain = channels(&image, false);
    assert!(!plain.iter().any(|(n, _)| n.contains("DiffDir")));
    let with = channels(&image, true);
    assert_eq!(with.len(), plain.len() + 21);
    for (p, name) in LIGHT_PASS_NAMES.iter().enumerate() {
        for (chan, want) in [("R", p as f32), ("G", 0.5), ("B", 0.25)] {
            let full = format!("ViewLayer.{name}.{chan}");
            let found = with.iter().find(|(n, _)| *n == full);
            assert_eq!(found.map(|f| f.1), Some(want), "{full}");
        }
    }
    // An image without volume light leaves the volume passes out.
    for v in &mut image.passes {
        v.0[LightPass::VolumeDirect as usize] = Vec3::ZERO;
        v.0[LightPass::VolumeIndirect as usize] = Vec3::ZERO;
    }
    let without = channels(&image, true);
    assert_eq!(without.len(), plain.len() + 15);
    assert!(!without.iter().any(|(n, _)| n.contains("Volume")));
    std::fs::remove_dir_all(&dir).unwrap();
}
