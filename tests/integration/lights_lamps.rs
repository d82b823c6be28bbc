//! Lamps (point and spot lights with a radius) as rays meet them, as Cycles makes them: the
//! intersection of a ray with the sphere or with the disc Soft Falloff gives, the density of a
//! light sample equal to the one a ray that meets the lamp in the same direction computes (so
//! MIS weights sum to one), ray visibility, the hierarchy over many lamps, and MIS lowering the
//! path tracer's error on a glossy floor at equal samples.

use crate::support::scenes;

use photon::accel::{Ray, FRAME_TIME};
use photon::light::{Lights, Receiver};
use photon::math::{Vec2, Vec3};
use photon::metrics::compare;
use photon::render::RenderSettings;
use photon::rng::Rng;
use photon::scene::{Lamp, Light, Material, Scene};
use photon::shader::RayPath;
use std::f32::consts::PI;

fn lamp(soft_falloff: bool) -> Lamp {
    Lamp {
        soft_falloff,
        camera: false,
        bounces: true,
    }
}

fn point(position: Vec3, radius: f32, lamp: Lamp) -> Light {
    Light::Point {
        position,
        intensity: Vec3::splat(10.0),
        radius,
        lamp,
    }
}

fn lights_of(lights: Vec<Light>) -> (Scene, Lights) {
    let mut scene = scenes::lit_floor(0.5, point(Vec3::ZERO, 0.0, Lamp::default()));
    scene.lights = lights;
    let l = Lights::new(&scene);
    (scene, l)
}

fn ray(origin: Vec3, direction: Vec3) -> Ray {
    Ray {
        origin,
        direction,
        t_max: f32::INFINITY,
        time: FRAME_TIME,
    }
}

/// Every lamp `ray` meets: (radiance, pdf, distance).
fn met(lights: &Lights, ray: &Ray, reach: f32, camera: bool) -> Vec<(Vec3, f32, f32)> {
    let mut out = Vec::new();
    lights.lamps_met(ray, Receiver::at(ray.origin), reach, camera, |l, pdf, t| {
        out.push((l, pdf, t))
    });
    out
}

#[test]
fn rays_meet_the_sphere_and_the_soft_falloff_disc_where_they_are() {
    let centre = Vec3::new(0.0, 3.0, 0.0);
    let r = 0.5;
    for soft in [false, true] {
        let (_, lights) = lights_of(vec![point(centre, r, lamp(soft))]);
        // Head-on: the sphere's near side at d − r, the disc through the centre at d.
        let hits = met(
            &lights,
            &ray(Vec3::ZERO, Vec3::new(0.0, 2.0, 0.0)),
            1e9,
            false,
        );
        assert_eq!(hits.len(), 1, "soft {soft}");
        let expected = if soft { 3.0 } else { 2.5 };
        assert!((hits[0].2 - expected).abs() < 1e-5, "{hits:?}");
        // Radiance I / (πr²) either way.
        assert!((hits[0].0.x - 10.0 / (PI * r * r)).abs() < 1e-4);
        // Blocked by a surface before the lamp.
        assert!(met(&lights, &ray(Vec3::ZERO, Vec3::Y), expected - 0.01, false).is_empty());
        // Just inside and just outside the lamp's cone (sphere: sin θ = r/d; disc: tan θ = r/d).
        let edge = if soft {
            (r / 3.0f32).atan()
        } else {
            (r / 3.0f32).asin()
        };
        for (angle, hit) in [(edge * 0.999, true), (edge * 1.001, false)] {
            let w = Vec3::new(angle.sin(), angle.cos(), 0.0);
            assert_eq!(
                !met(&lights, &ray(Vec3::ZERO, w), 1e9, false).is_empty(),
                hit
            );
        }
        // Pointing away nothing is met; from inside the sphere, its far side, every direction
        // with the whole sphere's density.
        assert!(met(&lights, &ray(Vec3::ZERO, -Vec3::Y), 1e9, false).is_empty());
        if !soft {
            let inside = met(&lights, &ray(centre + Vec3::X * 0.1, Vec3::X), 1e9, false);
            assert_eq!(inside.len(), 1);
            assert!((inside[0].2 - 0.4).abs() < 1e-5, "{inside:?}");
            assert!((inside[0].1 - 1.0 / (4.0 * PI)).abs() < 1e-6);
        }
    }
}

#[test]
fn light_sample_density_equals_the_density_a_ray_meeting_the_lamp_computes() {
    let spot = Light::Spot {
        position: Vec3::new(0.4, 2.5, -0.3),
        direction: Vec3::new(0.1, -1.0, 0.2).normalize(),
        intensity: Vec3::new(30.0, 20.0, 10.0),
        cos_inner: 0.95,
        cos_outer: 0.8,
        radius: 0.3,
        lamp: lamp(false),
    };
    let soft = point(Vec3::new(-1.0, 1.5, 0.5), 0.2, lamp(true));
    // A sphere lamp around part of the floor: points inside it sample the whole sphere.
    let around = point(Vec3::new(0.6, 0.1, 0.6), 0.4, lamp(false));
    let hard = point(Vec3::new(2.0, 2.0, 2.0), 0.0, lamp(true));
    // A narrow spot lamp close to the floor: its own cone is narrower than the lamp's, and
    // light sampling draws from it (as Cycles does).
    let narrow = Light::Spot {
        position: Vec3::new(-0.6, 0.45, -0.6),
        direction: -Vec3::Y,
        intensity: Vec3::splat(20.0),
        cos_inner: 12f32.to_radians().cos(),
        cos_outer: 14f32.to_radians().cos(),
        radius: 0.3,
        lamp: lamp(false),
    };
    let (scene, lights) = lights_of(vec![spot, soft, around, hard, narrow]);
    let mut rng = Rng::new(7);
    let (mut checked, mut inside, mut in_spread) = (0, 0, 0);
    for i in 0..4000 {
        let p = Vec3::new(rng.uniform() - 0.5, 0.0, rng.uniform() - 0.5) * 2.0;
        let u = Vec2::new(rng.uniform(), rng.uniform());
        let Some(ls) = lights.sample(
            &scene,
            Receiver::at(p),
            RayPath::default(),
            FRAME_TIME,
            true,
            rng.uniform(),
            u,
        ) else {
            continue;
        };
        // The lamp met where the sample's shadow ray ends is the sampled one (a ray from inside
        // the sphere lamp also meets that one); a point light is never met.
        let hits = met(&lights, &ray(p, ls.wi), 1e9, false);
        let at_target = hits
            .iter()
            .find(|h| (p + ls.wi * h.2).distance(ls.target.p) < 1e-4);
        if ls.delta {
            assert!(
                at_target.is_none(),
                "sample {i}: a point light is never met"
            );
            continue;
        }
        let Some(&(l, pdf, t)) = at_target else {
            panic!("sample {i}: {ls:?} not met: {hits:?}");
        };
        inside += (p.distance(Vec3::new(0.6, 0.1, 0.6)) < 0.4) as u32;
        // Seen from the floor the narrow spot's lamp fills a cone far wider than its 14°.
        let on_narrow = (ls.target.p.distance(Vec3::new(-0.6, 0.45, -0.6)) - 0.3).abs() < 1e-3;
        in_spread += on_narrow as u32;
        assert!((pdf / ls.pdf - 1.0).abs() < 1e-4, "pdf {pdf} vs {}", ls.pdf);
        // The spot's cone is evaluated along the ray as along the sample (to rounding).
        let brightest = 30.0 / (PI * 0.3 * 0.3);
        assert!(
            (l - ls.li).abs().max_element() < 1e-4 * brightest,
            "{l} vs {}",
            ls.li
        );
        assert!((p + ls.wi * t).distance(ls.target.p) < 1e-4);
        checked += 1;
    }
    assert!(
        checked > 1000 && inside > 20 && in_spread > 20,
        "{checked} lamp samples, {inside} inside, {in_spread} from the narrow spot"
    );
}

#[test]
fn camera_rays_see_only_lamps_visible_to_the_camera() {
    let seen = Lamp {
        camera: true,
        bounces: false,
        ..lamp(true)
    };
    let (_, lights) = lights_of(vec![point(Vec3::Y * 3.0, 0.5, seen)]);
    let up = ray(Vec3::ZERO, Vec3::Y);
    assert_eq!(met(&lights, &up, 1e9, true).len(), 1);
    assert!(met(&lights, &up, 1e9, false).is_empty());
    let (scene, hidden) = lights_of(vec![point(Vec3::Y * 3.0, 0.5, lamp(true))]);
    assert!(met(&hidden, &up, 1e9, true).is_empty());
    // A lamp hidden from scattered rays is a light sample without MIS.
    let (_, lights) = lights_of(vec![point(Vec3::Y * 3.0, 0.5, seen)]);
    let ls = lights
        .sample(
            &scene,
            Receiver::at(Vec3::ZERO),
            RayPath::default(),
            FRAME_TIME,
            true,
            0.5,
            Vec2::splat(0.5),
        )
        .unwrap();
    assert!(ls.delta);
    assert!(!lights.hittable());
    assert!(hidden.hittable());
}

/// With many lamps the hierarchy finds exactly what testing each lamp alone finds.
#[test]
fn many_lamps_are_found_through_the_hierarchy() {
    let mut rng = Rng::new(3);
    let mut all = Vec::new();
    for _ in 0..300 {
        let c = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 20.0 - 10.0;
        all.push(point(
            c,
            0.05 + 0.5 * rng.uniform(),
            lamp(rng.uniform() < 0.5),
        ));
    }
    let (_, lights) = lights_of(all.clone());
    let alone: Vec<Lights> = all.iter().map(|l| lights_of(vec![l.clone()]).1).collect();
    let mut found = 0;
    for _ in 0..3000 {
        let o = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 24.0 - 12.0;
        let w = photon::sampling::square_to_uniform_sphere(Vec2::new(rng.uniform(), rng.uniform()));
        let reach = 30.0 * rng.uniform();
        let r = ray(o, w * 2.0);
        let mut through_tree: Vec<f32> =
            met(&lights, &r, reach, false).iter().map(|h| h.2).collect();
        let mut one_by_one: Vec<f32> = alone
            .iter()
            .flat_map(|l| met(l, &r, reach, false))
            .map(|h| h.2)
            .collect();
        through_tree.sort_by(f32::total_cmp);
        one_by_one.sort_by(f32::total_cmp);
        assert_eq!(through_tree, one_by_one);
        found += one_by_one.len();
    }
    assert!(found > 50, "{found} lamps met");
}

/// A glossy metal floor (roughness 0.1) reflecting a lamp of radius 0.1: with MIS (the lamp
/// met by BSDF rays) the path tracer's relMSE at 16 spp is far below light sampling alone (the
/// lamp hidden from scattered rays), and both converge to the same image.
#[test]
fn mis_with_the_lamp_lowers_the_glossy_highlights_error() {
    let scene_with = |bounces: bool| {
        let mut floor = Material::diffuse("metal", Vec3::splat(0.9));
        floor.metallic = 1.0;
        floor.roughness = 0.1;
        let light = Light::Point {
            position: Vec3::new(0.05, 2.0, 0.02),
            intensity: Vec3::splat(10.0),
            radius: 0.1,
            lamp: Lamp {
                bounces,
                ..lamp(true)
            },
        };
        let mut scene = scenes::lit_floor(0.5, light);
        scene.materials = vec![floor];
        scene
    };
    let settings = |spp: u32, seed: u64| RenderSettings {
        width: 16,
        height: 16,
        spp,
        seed,
        ..RenderSettings::default()
    };
    let render = |bounces: bool, spp: u32, seed: u64| {
        scenes::render_quietly(&scene_with(bounces), &settings(spp, seed))
            .expect("render")
            .0
            .rgba
    };
    let reference = render(true, 2048, 1);
    let light_only_reference = render(false, 2048, 2);
    let mean = |img: &[[f32; 4]]| img.iter().map(|p| p[0] as f64).sum::<f64>() / img.len() as f64;
    let (m_mis, m_light) = (mean(&reference), mean(&light_only_reference));
    assert!(m_mis > 0.5, "the highlight fills the view: {m_mis}");
    assert!((m_light / m_mis - 1.0).abs() < 0.02, "{m_light} vs {m_mis}");
    let mis = compare(&render(true, 16, 3), &reference).rel_mse;
    let light_only = compare(&render(false, 16, 3), &reference).rel_mse;
    println!("relMSE at 16 spp: MIS {mis:.5}, light sampling alone {light_only:.5}");
    assert!(
        mis < 0.5 * light_only,
        "MIS {mis} vs light sampling {light_only}"
    );
}

/// A floor inside a sphere lamp (Soft Falloff off) sees the lamp's radiance L = I / (πr²) over
/// its whole hemisphere, so it shows ρL, with light sampling alone and with MIS.
#[test]
fn a_floor_inside_a_sphere_lamp_shows_albedo_times_its_radiance() {
    for bounces in [false, true] {
        let light = Light::Point {
            position: Vec3::new(0.0, 0.1, 0.0),
            intensity: Vec3::splat(2.0),
            radius: 0.5,
            lamp: Lamp {
                soft_falloff: false,
                camera: false,
                bounces,
            },
        };
        let settings = RenderSettings {
            width: 8,
            height: 8,
            spp: 64,
            ..RenderSettings::default()
        };
        let image = scenes::render_quietly(&scenes::lit_floor(0.5, light), &settings)
            .expect("render")
            .0;
        let expected = 0.5 * 2.0 / (PI * 0.25);
        let mean = image.mean_rgb().x;
        assert!(
            (mean / expected - 1.0).abs() < 0.01,
            "bounces {bounces}: {mean} vs {expected}"
        );
    }
}
