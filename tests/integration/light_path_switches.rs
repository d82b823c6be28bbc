//! Blender's Light Paths › Caustics settings: `PHOTON_render` carries Reflective and Refractive
//! Caustics and Filter Glossy (absent: on, on, off; a bad value is refused), and the BSDF a
//! path meets loses or widens the lobes Cycles does: straight after a diffuse bounce, with a
//! switch off, the glossy reflection lobes (metal, specular layer, coat, the glass's
//! reflection) or the glass's refraction, a Transparent BSDF's pass kept; Filter Glossy widens
//! GGX lobes and hair fibres by the path's smallest density.

use crate::support::gltf::triangle_doc;
use photon::bsdf::{Bsdf, BsdfSample, PathFilter, Scattering};
use photon::integrator::shading::{LightPathFilter, PathHistory};
use photon::material::SurfaceMaterial;
use photon::math::{Vec2, Vec3};
use photon::scene::gltf::{load_slice, LoadOptions};
use photon::scene::Scene;
use photon::shader::Hair;
use serde_json::{json, Value};

fn with_render(render: Value) -> photon::error::Result<Scene> {
    let mut doc = triangle_doc();
    doc.json["scenes"][0]["extensions"] = json!({ "PHOTON_render": render });
    load_slice(&doc.glb(), "fixture.glb", &LoadOptions::default())
}

#[test]
fn light_path_switches_are_read_with_their_defaults_and_bad_values_refused() {
    let settings = with_render(json!({})).unwrap().render_settings;
    assert!(!settings.reflective_caustics_off && !settings.refractive_caustics_off);
    assert_eq!(settings.filter_glossy, 0.0);
    let settings = with_render(json!({
        "caustics_reflective": false,
        "caustics_refractive": false,
        "filter_glossy": 1.0
    }))
    .unwrap()
    .render_settings;
    assert!(settings.reflective_caustics_off && settings.refractive_caustics_off);
    assert_eq!(settings.filter_glossy, 1.0);
    for (field, bad) in [
        ("caustics_reflective", json!("off")),
        ("filter_glossy", json!(-1.0)),
    ] {
        let text = with_render(json!({ field: bad })).unwrap_err().to_string();
        assert!(text.contains(field), "{text}");
    }
}

const UP: Vec3 = Vec3::new(0.3, 0.0, 0.954);

const DROP_BOTH: PathFilter = PathFilter {
    drop_reflection: true,
    drop_refraction: true,
    min_alpha: 0.0,
};

fn albedo(m: &SurfaceMaterial, filter: PathFilter) -> Vec3 {
    Bsdf::new(m).filtered(filter).viewed_from(UP).albedo()
}

#[test]
fn light_path_switches_drop_glossy_reflection_and_keep_the_diffuse_whole() {
    let metal = SurfaceMaterial {
        metallic: 1.0,
        roughness: 0.2,
        ..SurfaceMaterial::default()
    };
    assert!(albedo(&metal, PathFilter::default()).x > 0.5);
    assert_eq!(albedo(&metal, DROP_BOTH), Vec3::ZERO);
    // A dielectric: the specular layer gone, its diffuse gives nothing up to it (Cycles
    // allocates no layer, so the diffuse keeps its whole weight).
    let plastic = SurfaceMaterial {
        roughness: 0.3,
        ..SurfaceMaterial::default()
    };
    let (full, filtered) = (
        Bsdf::new(&plastic).viewed_from(UP),
        Bsdf::new(&plastic).filtered(DROP_BOTH).viewed_from(UP),
    );
    assert!(full.diffuse_reflectance().x < 0.8 * 0.99);
    assert!((filtered.diffuse_reflectance().x - 0.8).abs() < 1e-4);
    assert!(
        (filtered.albedo() - filtered.diffuse_reflectance())
            .abs()
            .max_element()
            < 1e-6
    );
}

#[test]
fn light_path_switches_split_glass_into_its_reflection_and_refraction() {
    let glass = SurfaceMaterial {
        base_color: Vec3::ONE,
        transmission: 1.0,
        roughness: 0.0,
        ..SurfaceMaterial::default()
    };
    let only = |drop_reflection, drop_refraction| PathFilter {
        drop_reflection,
        drop_refraction,
        min_alpha: 0.0,
    };
    // Smooth glass: every sample a delta; with refraction dropped only reflection carries
    // light, with reflection dropped only refraction.
    for (filter, reflects, refracts) in [
        (only(false, true), true, false),
        (only(true, false), false, true),
    ] {
        let b = Bsdf::new(&glass).filtered(filter).viewed_from(UP);
        for i in 0..16 {
            let Some(s) = b.sample((i as f32 + 0.5) / 16.0, Vec2::splat(0.5)) else {
                continue;
            };
            let carries = s.weight.max_element() > 0.0;
            if s.transmitted {
                assert_eq!(carries, refracts, "{filter:?} {s:?}");
            } else {
                assert_eq!(carries, reflects, "{filter:?} {s:?}");
            }
        }
    }
    // A Transparent BSDF's pass is no refraction.
    let transparent = SurfaceMaterial {
        transparent: true,
        transmission: 1.0,
        ior: 1.0,
        base_color: Vec3::ONE,
        roughness: 0.0,
        ..SurfaceMaterial::default()
    };
    assert!(albedo(&transparent, DROP_BOTH).x > 0.99);
}

#[test]
fn light_path_switches_drop_only_after_a_diffuse_bounce_and_blur_by_the_smallest_density() {
    let mut scene =
        with_render(json!({"caustics_reflective": false, "filter_glossy": 1.0})).unwrap();
    let filter = LightPathFilter::of(&scene);
    let sample = |scattering, pdf| BsdfSample {
        wi: Vec3::Z,
        weight: Vec3::ONE,
        pdf,
        delta: false,
        transmitted: false,
        scattering,
    };
    let camera = PathHistory::default();
    assert!(filter.at(camera).is_none());
    let after_diffuse = camera.after(&sample(Scattering::Diffuse, 0.25));
    let f = filter.at(after_diffuse);
    assert!(f.drop_reflection && !f.drop_refraction);
    // α = ½ √(1 − p / F) with p = 0.25, F = 1.
    assert!((f.min_alpha - 0.5 * 0.75f32.sqrt()).abs() < 1e-6);
    // A glossy bounce after it: nothing dropped, the smallest density still the diffuse one's.
    let after_glossy = after_diffuse.after(&sample(Scattering::Glossy, 40.0));
    let f = filter.at(after_glossy);
    assert!(!f.drop_reflection && (f.min_alpha - 0.5 * 0.75f32.sqrt()).abs() < 1e-6);
    // A transparent pass keeps the path as it was; densities above F blur nothing.
    let passed = after_diffuse.after(&BsdfSample {
        delta: true,
        scattering: Scattering::Transparent,
        ..sample(Scattering::Transparent, 1.0)
    });
    assert_eq!(passed, after_diffuse);
    scene.render_settings.filter_glossy = 0.2;
    assert_eq!(LightPathFilter::of(&scene).at(after_diffuse).min_alpha, 0.0);
    // A smooth mirror widened is no longer a delta.
    let mirror = SurfaceMaterial {
        metallic: 1.0,
        roughness: 0.0,
        ..SurfaceMaterial::default()
    };
    let widened = PathFilter {
        min_alpha: 0.3,
        ..PathFilter::default()
    };
    assert!(Bsdf::new(&mirror).is_delta_only());
    assert!(!Bsdf::new(&mirror).filtered(widened).has_delta());
    // A Principled Hair fibre's R lobe widened: its variance at least the blur's value.
    let fibre = SurfaceMaterial {
        hair: Some(Hair::Chiang {
            sigma: Vec3::splat(0.5),
            roughness: 0.1,
            radial_roughness: 0.1,
            coat: 0.0,
            ior: 1.55,
            tilt: 0.0,
        }),
        ..SurfaceMaterial::default()
    };
    // `roughness` reads the R lobe's variance v as v^(1/4): 0.28 for roughness 0.1.
    let before = Bsdf::new(&fibre).roughness();
    let widened = Bsdf::new(&fibre).filtered(widened).roughness();
    assert!(before < 0.3, "{before}");
    assert!((widened - 0.3f32.sqrt().sqrt()).abs() < 1e-5, "{widened}");
}
