//! The light-path passes (`light_pass::LightPass`) on a small scene with a glass sphere, a
//! translucent one, a diffuse floor and wall and a spherical emitter in view: for the path and photon methods the passes
//! add up to Combined per pixel and are non-negative, Emission is the emitter's radiance where the
//! camera sees it, a one-bounce render has no Indirect light, and `--passes` names the EXR
//! channels as Blender's view layer expects.

use crate::support::scenes;

use photon::film::Image;
use photon::image_io::{write_image, ExrLayout, LIGHT_PASS_NAMES};
use photon::integrator::photon::settings::PhotonSettings;
use photon::light_pass::{LightPass, Passes};
use photon::math::Vec3;
use photon::render::{render, Method, RenderSettings};
use photon::rounds::render_in_rounds;
use photon::scene::{Material, Projection, Scene, Subsurface};
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

/// Passes sum to Combined (relative 1e-4), none is negative, and the emitter's central pixels
/// show exactly its radiance in Emission.
fn check_passes(image: &Image) {
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
    let channels = |light_passes: bool| {
        let layout = ExrLayout::Blender {
            view_layer: "ViewLayer".into(),
            light_passes,
        };
        write_image(&path, &image, &layout, &AtomicBool::new(false)).expect("write");
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
    let plain = channels(false);
    assert!(!plain.iter().any(|(n, _)| n.contains("DiffDir")));
    let with = channels(true);
    assert_eq!(with.len(), plain.len() + 15);
    for (p, name) in LIGHT_PASS_NAMES.iter().enumerate() {
        for (chan, want) in [("R", p as f32), ("G", 0.5), ("B", 0.25)] {
            let full = format!("ViewLayer.{name}.{chan}");
            let found = with.iter().find(|(n, _)| *n == full);
            assert_eq!(found.map(|f| f.1), Some(want), "{full}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
