//! Participating media against closed forms: a scattering sphere in a white world is a white
//! furnace (radiance 1 everywhere once every volume bounce is followed), an absorbing and
//! emitting sphere seen through its centre gives Beer–Lambert and its emission integral, and a
//! world volume stops the light of the sun entirely (as Cycles renders it). The photon method's
//! volume photon map agrees with the path tracer where light scatters many times in fog, and
//! converges as its generations shrink their radii.

use crate::support::scenes;

use photon::film::Image;
use photon::integrator::photon::settings::PhotonSettings;
use photon::math::Vec3;
use photon::medium::Coefficients;
use photon::metrics::compare;
use photon::phase::Phase;
use photon::render::{render, Method, RenderSettings};
use photon::scene::{Lamp, Light, Material, Projection, Scene, Volume};
use scenes::{camera_looking_at, floor, scene, sphere, volume_material, with_progress};

fn render_with(scene: &Scene, method: Method, size: u32, spp: u32) -> Image {
    let settings = RenderSettings {
        width: size,
        height: size,
        spp,
        max_depth: 256,
        seed: 3,
        method,
        ..RenderSettings::default()
    };
    let (image, stats) = with_progress(|p| render(scene, &settings, p)).expect("render");
    assert_eq!(stats.nonfinite_samples, 0);
    image
}

/// A unit sphere of medium `c` at the origin under a uniform world of radiance `world`, seen
/// by an orthographic camera covering the central ±`half` of it.
fn sphere_scene(c: Coefficients, world: f32, half: f32) -> Scene {
    scene(
        vec![sphere(Vec3::ZERO, 1.0, 48, 96, false, 0)],
        vec![volume_material(c)],
        Vec::new(),
        camera_looking_at(
            Vec3::new(0.0, 0.0, 4.0),
            Vec3::ZERO,
            Projection::Orthographic {
                xmag: half,
                ymag: half,
            },
        ),
        Vec3::splat(world),
    )
}

#[test]
fn a_scattering_sphere_in_a_white_world_is_a_furnace() {
    let c = Coefficients {
        scattering: Vec3::new(3.0, 1.5, 0.5),
        absorption: Vec3::ZERO,
        emission: Vec3::ZERO,
        phase: Phase::henyey_greenstein(0.6),
    };
    let mut s = sphere_scene(c, 1.0, 1.2);
    s.render_settings.volume_bounces = 1000;
    let all = render_with(&s, Method::Path, 16, 64).mean_rgb();
    assert!((all - Vec3::ONE).abs().max_element() < 0.015, "mean {all}");
    // Single scattering alone loses the light scattered more than once.
    s.render_settings.volume_bounces = 0;
    let single = render_with(&s, Method::Path, 16, 64).mean_rgb();
    assert!(
        single.x < 0.95 && single.x < single.z,
        "single scattering {single}"
    );
}

#[test]
fn an_absorbing_emitting_sphere_follows_beer_lambert() {
    let sigma = Vec3::new(0.5, 1.0, 2.0);
    let c = Coefficients {
        scattering: Vec3::ZERO,
        absorption: sigma,
        emission: Vec3::new(0.2, 0.3, 0.4),
        phase: Phase::henyey_greenstein(0.0),
    };
    // Through the centre: a chord of 2 (the view covers ±0.02, chords within 0.0004 of it).
    let chord = 2.0;
    let through = (-sigma * chord).exp();
    let emitted = c.emission * (Vec3::ONE - through) / sigma;
    for method in [Method::Path, Method::Photon] {
        let got = render_with(&sphere_scene(c, 1.0, 0.02), method, 4, 4).mean_rgb();
        let want = through + emitted;
        assert!(
            (got - want).abs().max_element() < 2e-3,
            "{method:?}: {got} vs {want}"
        );
    }
}

/// A unit sphere whose medium reads a voxel grid by a Principled Volume's Density Attribute
/// (black: absorption only, σ_a = density), the grid 1 + 2x over Blender's x in [−1.75, 1.25]
/// (linear, which trilinear interpolation keeps exactly) in a white world. Seen along the
/// chord at x = 0.5 it follows Beer–Lambert with the grid's value there; at x = −0.5, where
/// the grid is zero, nothing is absorbed. Tracked against the grid's majorant blocks.
#[test]
fn a_density_grid_attenuates_by_its_value_along_the_ray() {
    use photon::math::{Affine3A, Mat4};
    use photon::scene::grids::{Grid, VolumeGrids};
    use photon::scene::{ObjectSpace, BLENDER_AXES};
    use photon::shader::{compile, CompileWarnings};
    use std::sync::Arc;
    let tree = serde_json::json!({
        "nodes": [{"name": "P", "type": "ShaderNodeVolumePrincipled",
                   "attributes": {"density": "density", "color": "", "temperature": ""},
                   "inputs": {"Color": [0, 0, 0, 1], "Density": 1.0}}],
        "output": {"node": 0, "output": "Volume"}
    });
    let mut warnings = CompileWarnings::new();
    let program = compile(&tree, 0, &mut warnings).expect("volume tree");
    assert_eq!(program.attributes, ["density"]);
    let n = 7;
    // Voxel i's centre at −1.75 + 0.5 i (the grid spans the sphere), value 1 + 2x there.
    let to_object = Mat4::from_translation(Vec3::splat(-1.75)) * Mat4::from_scale(Vec3::splat(0.5));
    let values = (0..n * n * n)
        .map(|i| {
            let x = -1.75 + 0.5 * (i % n) as f32;
            1.0 + 2.0 * x
        })
        .collect();
    let grid = Grid::new("density".into(), 1, [n, n, n], values, to_object).unwrap();
    let mut s = sphere_scene(Coefficients::VACUUM, 1.0, 0.01);
    s.materials[0].volume = Volume::of(program);
    s.meshes[0].volume_grids = Some(Arc::new(VolumeGrids {
        grids: vec![grid],
        majorant: None,
        world_space: false,
        extent: None,
        stochastic: false,
    }));
    // Object coordinates: the world's in Blender's axes (as a Volume object at the origin).
    s.meshes[0].object_space = Some(ObjectSpace {
        to_object: Affine3A::from_mat3(BLENDER_AXES),
        texspace_location: Vec3::ZERO,
        texspace_size: Vec3::ONE,
    });
    s.bound_volumes();
    let blocks = s.meshes[0].volume_grids.as_ref().unwrap().majorant.as_ref();
    assert!(
        blocks.is_some(),
        "the grid's majorant is bounded block by block"
    );
    s.camera = camera_looking_at(
        Vec3::new(0.5, 0.0, 4.0),
        Vec3::new(0.5, 0.0, 0.0),
        Projection::Orthographic {
            xmag: 0.01,
            ymag: 0.01,
        },
    );
    let chord = 2.0 * 0.75f32.sqrt();
    let want = (-(1.0 + 2.0 * 0.5) * chord).exp();
    let got = render_with(&s, Method::Path, 4, 256).mean_rgb();
    assert!(
        (got - Vec3::splat(want)).abs().max_element() < 0.01 * want + 2e-3,
        "{got} vs {want}"
    );
    s.camera = camera_looking_at(
        Vec3::new(-0.5, 0.0, 4.0),
        Vec3::new(-0.5, 0.0, 0.0),
        Projection::Orthographic {
            xmag: 0.01,
            ymag: 0.01,
        },
    );
    let clear = render_with(&s, Method::Path, 4, 16).mean_rgb();
    assert!((clear - Vec3::ONE).abs().max_element() < 0.02, "{clear}");
}

#[test]
fn a_world_volume_stops_the_sun() {
    let mut s = scene(
        vec![floor(20.0, 0.0, 0)],
        vec![Material::diffuse("floor", Vec3::splat(0.8))],
        vec![Light::Sun {
            direction: Vec3::new(0.2, -1.0, 0.1).normalize(),
            irradiance: Vec3::splat(3.0),
            angle: 0.0,
            camera: true,
        }],
        camera_looking_at(
            Vec3::new(0.0, 3.0, 3.0),
            Vec3::ZERO,
            Projection::Perspective { yfov: 0.8 },
        ),
        Vec3::ZERO,
    );
    let clear = render_with(&s, Method::Path, 8, 4).mean_rgb();
    assert!(
        clear.x > 0.1,
        "the sun lights the floor without a medium: {clear}"
    );
    s.world.volume = Some(Volume::homogeneous(Coefficients {
        scattering: Vec3::splat(0.04),
        absorption: Vec3::ZERO,
        emission: Vec3::ZERO,
        phase: Phase::henyey_greenstein(0.0),
    }));
    let fog = render_with(&s, Method::Path, 8, 4).mean_rgb();
    assert_eq!(fog, Vec3::ZERO);
}

#[test]
fn a_camera_inside_a_medium_starts_in_it() {
    let sigma = Vec3::new(0.3, 0.7, 1.5);
    let c = Coefficients {
        scattering: Vec3::ZERO,
        absorption: sigma,
        emission: Vec3::ZERO,
        phase: Phase::henyey_greenstein(0.0),
    };
    let mut s = sphere_scene(c, 1.0, 0.5);
    // From the centre every ray crosses one radius of the medium.
    s.camera = camera_looking_at(
        Vec3::ZERO,
        Vec3::new(0.0, 0.0, -1.0),
        Projection::Perspective { yfov: 1.0 },
    );
    let got = render_with(&s, Method::Path, 4, 1).mean_rgb();
    let want = (-sigma).exp();
    assert!((got - want).abs().max_element() < 2e-3, "{got} vs {want}");
}

/// A floor lit by a point light through a sphere of fog that the floor cuts: the photon method
/// (photons scattered and attenuated by the fog on their way to the floor) against the path
/// tracer. (A point light inside fog gives light samples from points near it unbounded
/// variance until equiangular sampling; this light stays outside.)
#[test]
fn photons_cross_fog_as_camera_paths_do() {
    let fog = Coefficients {
        scattering: Vec3::new(0.8, 1.0, 1.2),
        absorption: Vec3::splat(0.2),
        emission: Vec3::ZERO,
        phase: Phase::henyey_greenstein(0.3),
    };
    let mut s = scene(
        vec![
            floor(6.0, 0.0, 0),
            sphere(Vec3::ZERO, 1.2, 32, 64, false, 1),
        ],
        vec![
            Material::diffuse("floor", Vec3::splat(0.7)),
            volume_material(fog),
        ],
        vec![Light::Point {
            position: Vec3::new(0.3, 2.5, 0.2),
            intensity: Vec3::splat(20.0),
            radius: 0.0,
            lamp: Lamp::default(),
        }],
        camera_looking_at(
            Vec3::new(0.0, 2.0, 2.5),
            Vec3::ZERO,
            Projection::Perspective { yfov: 0.9 },
        ),
        Vec3::ZERO,
    );
    s.render_settings.volume_bounces = 2;
    let path = render_with(&s, Method::Path, 16, 256).mean_rgb();
    let photon = render_with(&s, Method::Photon, 16, 256).mean_rgb();
    let ratio = photon / path;
    assert!(path.x > 0.01, "lit: {path}");
    assert!(
        (ratio - Vec3::ONE).abs().max_element() < 0.04,
        "photon {photon} / path {path}"
    );
}

/// A floor under a sphere of fog it cuts, lit by a point light above the fog, with
/// `volume_bounces` scatterings in the fog followed: the glow the fog scatters several times.
/// (A spot's light samples from the fog are mostly outside its cone: noisier means.)
fn lamp_over_fog(volume_bounces: u32) -> Scene {
    let fog = Coefficients {
        scattering: Vec3::new(0.6, 0.7, 0.8),
        absorption: Vec3::splat(0.05),
        emission: Vec3::ZERO,
        phase: Phase::henyey_greenstein(0.3),
    };
    let mut s = scene(
        vec![
            floor(6.0, 0.0, 0),
            sphere(Vec3::new(0.0, 0.6, 0.0), 1.8, 32, 64, false, 1),
        ],
        vec![
            Material::diffuse("floor", Vec3::splat(0.7)),
            volume_material(fog),
        ],
        vec![Light::Point {
            position: Vec3::new(0.3, 2.9, 0.2),
            intensity: Vec3::splat(30.0),
            radius: 0.0,
            lamp: Lamp::default(),
        }],
        camera_looking_at(
            Vec3::new(0.0, 2.2, 4.5),
            Vec3::new(0.0, 0.6, 0.0),
            Projection::Perspective { yfov: 0.9 },
        ),
        Vec3::ZERO,
    );
    s.render_settings.volume_bounces = volume_bounces;
    s
}

/// The photon method (single scattering by light samples, the rest from the volume photon
/// map) against the path tracer where light scatters many times in fog: means within 2 %.
#[test]
fn the_volume_photon_map_matches_the_path_tracer_with_multiple_scattering() {
    let s = lamp_over_fog(6);
    let path = render_with(&s, Method::Path, 16, 1024).mean_rgb();
    let photon = render_with(&s, Method::Photon, 16, 256).mean_rgb();
    let ratio = photon / path;
    assert!(path.x > 0.01, "lit: {path}");
    assert!(
        (ratio - Vec3::ONE).abs().max_element() < 0.02,
        "photon {photon} / path {path}"
    );
}

/// At Blender's default of 0 Volume bounces, with no emitting medium, no volume photon is
/// traced (light samples carry all the light fog scatters towards the camera) and the photon
/// method still agrees with the path tracer; from 1 bounce up they are traced.
#[test]
fn volume_photons_are_traced_only_where_camera_paths_gather_them() {
    let stats = |s: &Scene| {
        let settings = RenderSettings {
            width: 12,
            height: 12,
            spp: 16,
            method: Method::Photon,
            ..RenderSettings::default()
        };
        let (image, stats) = with_progress(|p| render(s, &settings, p)).expect("render");
        (image, stats.photon.expect("photon statistics"))
    };
    let single = lamp_over_fog(0);
    let (photon, info) = stats(&single);
    assert_eq!((info.volume_emitted, info.volume_stored), (0, 0));
    let path = render_with(&single, Method::Path, 12, 1024).mean_rgb();
    let ratio = photon.mean_rgb() / path;
    assert!(
        (ratio - Vec3::ONE).abs().max_element() < 0.03,
        "photon {} / path {path}",
        photon.mean_rgb()
    );
    let (_, info) = stats(&lamp_over_fog(1));
    assert!(
        info.volume_emitted > 0 && info.volume_stored > 0,
        "{info:?}"
    );
}

/// Auto plans scenes with media as it plans others, from its pilots: the volume photons scale
/// with the budget as the surface photons do, and none are planned where none would be stored.
#[test]
fn auto_plans_volume_photons_only_where_they_are_stored() {
    use photon::plan::{plan_for_image, Quality};
    let full = PhotonSettings::default().volume_photons;
    let p = plan_for_image(&lamp_over_fog(0), Quality::Default, 16, 16);
    assert_eq!(p.photon.volume_photons, 0);
    assert!(!p.method_reason.contains("media"), "{}", p.method_reason);
    let p = plan_for_image(&lamp_over_fog(2), Quality::Default, 16, 16);
    let volume = p.photon.volume_photons;
    assert!(
        volume > 0 && volume < full,
        "{volume} volume photons at 16 px"
    );
}

/// Where light scatters several times in fog, the photon method reaches relMSE 0.01 in about
/// half the path tracer's time (docs/bench/volumes.md, `time_to_error_in_fog`): auto's pilot
/// counts the fog's direct light with the noise the photon method's light samples along each
/// segment leave, and picks it.
#[test]
fn auto_takes_the_photon_method_for_light_scattered_in_fog() {
    use photon::plan::{plan_for_image, Quality};
    for s in [lamp_over_fog(4), spot_in_fog(4)] {
        let p = plan_for_image(&s, Quality::Default, 48, 48);
        assert_eq!(p.method, Method::Photon, "{}", p.method_reason);
    }
}

/// The photon method converges in fog: its error against a path-traced reference falls as its
/// generations of photon maps shrink their radii.
#[test]
fn the_photon_method_converges_in_fog() {
    let s = lamp_over_fog(4);
    let reference = render_with(&s, Method::Path, 12, 8192);
    let error = |spp: u32| {
        let image = render_with(&s, Method::Photon, 12, spp);
        compare(&image.rgba, &reference.rgba).rel_mse
    };
    let (early, late) = (error(64), error(512));
    assert!(
        late < 0.6 * early,
        "relMSE {early} at 64 spp, {late} at 512"
    );
}

/// A spot light shining down through a sphere of fog onto a floor: the light cone, the glow
/// around it and the fog's shadow, with `volume_bounces` scatterings followed.
fn spot_in_fog(volume_bounces: u32) -> Scene {
    let mut s = lamp_over_fog(volume_bounces);
    let cone = |degrees: f32| (0.5 * degrees.to_radians()).cos();
    s.lights = vec![Light::Spot {
        position: Vec3::new(0.3, 2.9, 0.2),
        direction: Vec3::new(-0.1, -1.0, 0.0).normalize(),
        intensity: Vec3::splat(60.0),
        cos_inner: cone(30.0),
        cos_outer: cone(40.0),
        radius: 0.0,
        lamp: Lamp::default(),
    }];
    s
}

/// A spot's cone of light crossing the camera's rays through fog, lit only where a ray passes
/// the cone: the photon method's light samples along each camera segment, stratified in
/// distance (`walk::CAMERA_SEGMENT_POINTS`), see the cone evenly. At 4 samples per pixel its
/// relMSE against the path tracer's 8192-sample image is 0.010 and its mean −1.2 % (with one
/// point per segment: 0.22 and −6.5 %).
#[test]
fn camera_segments_sample_a_cone_of_light_evenly() {
    let s = spot_in_fog(0);
    let reference = render_with(&s, Method::Path, 16, 8192);
    let image = render_with(&s, Method::Photon, 16, 4);
    let error = compare(&image.rgba, &reference.rgba);
    let mean = error.mean_image / error.mean_reference - 1.0;
    println!("relMSE {}, mean {mean:+}", error.rel_mse);
    assert!(error.rel_mse < 0.05, "relMSE {}", error.rel_mse);
    assert!(mean.abs() < 0.04, "mean {mean:+}");
}

/// Measurement, not a check (docs/bench/volumes.md): the time the path tracer and the photon
/// method take to reach a relMSE against a path-traced reference on the spot in fog and the
/// lamp over fog, 48 × 48, budgets of samples per pixel with the photon counts scaled as
/// `photon bench` scales them (the scene files `photon bench` reads carry no media yet). Run
/// with `cargo test --release --test integration -- --ignored --nocapture media::time_to_error`.
#[test]
#[ignore]
fn time_to_error_in_fog() {
    let size = 48;
    let settings = |method, spp: u32, seed| {
        let b = spp.min(64);
        RenderSettings {
            width: size,
            height: size,
            spp,
            max_depth: 256,
            seed,
            method,
            photon: PhotonSettings {
                global_photons: 5_000 * b,
                caustic_photons: 2_500 * b,
                volume_photons: 5_000 * b,
                ..PhotonSettings::default()
            },
            ..RenderSettings::default()
        }
    };
    for (name, s) in [
        ("spot in fog", spot_in_fog(4)),
        ("lamp over fog", lamp_over_fog(4)),
    ] {
        let reference_spp = 8192;
        let (reference, _) =
            with_progress(|p| render(&s, &settings(Method::Path, reference_spp, 1), p))
                .expect("reference");
        println!("{name}: reference path {reference_spp} spp");
        for method in [Method::Path, Method::Photon] {
            let mut points = Vec::new();
            let budgets: &[u32] = match method {
                Method::Path => &[1, 4, 16, 64, 256, 1024, 2048],
                _ => &[1, 2, 4, 8, 16, 32, 64, 128],
            };
            for &spp in budgets {
                let start = std::time::Instant::now();
                let (image, _) =
                    with_progress(|p| render(&s, &settings(method, spp, 7), p)).expect("render");
                let seconds = start.elapsed().as_secs_f64();
                let error = compare(&image.rgba, &reference.rgba);
                println!(
                    "{name} {method:?} {spp} spp: {seconds:.3} s, relMSE {:.5}, mean {:+.2} %",
                    error.rel_mse,
                    100.0 * (error.mean_image / error.mean_reference - 1.0)
                );
                points.push((seconds, error.rel_mse));
            }
            for target in [0.01, 0.001] {
                println!(
                    "{name} {method:?}: time to relMSE {target}: {}",
                    time_to(&points, target).map_or("not reached".into(), |t| format!("{t:.3} s"))
                );
            }
        }
    }
}

/// The time at which the (time, error) points first reach `target`, interpolated log-log
/// between the two points that bracket it (the first point's time when it is already below).
fn time_to(points: &[(f64, f64)], target: f64) -> Option<f64> {
    let first = points.iter().position(|&(_, e)| e <= target)?;
    if first == 0 {
        return Some(points[0].0);
    }
    let ((t0, e0), (t1, e1)) = (points[first - 1], points[first]);
    let f = (target.ln() - e0.ln()) / (e1.ln() - e0.ln());
    Some((t0.ln() + f * (t1.ln() - t0.ln())).exp())
}
