//! Every scene shipped in `scenes/` (the Blender-made ones and the gallery too) loads and renders
//! with the path tracer and with the method `--method auto` picks: no NaN or Inf, no dropped
//! samples, something visible. The furnace scene also gives its analytic radiance.

use crate::support::scenes;

use photon::plan::{plan, Quality};
use photon::render::{Method, RenderSettings};
use photon::scene::gltf::{load, LoadOptions};
use std::path::Path;

/// Render `path` at a tiny size with `method`, or with the method and photon settings the
/// planner picks for `--method auto` (at preview quality, photon counts divided by 20).
fn render_file(path: &Path, size: u32, spp: u32, method: Option<Method>) -> photon::film::Image {
    let scene = load(path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let plan = plan(&scene, Quality::Preview);
    let mut photon = plan.photon.clone();
    photon.global_photons /= 20;
    photon.caustic_photons /= 20;
    let settings = RenderSettings {
        width: size,
        height: size,
        spp,
        max_depth: 16,
        seed: 3,
        method: method.unwrap_or(plan.method),
        photon,
        ..RenderSettings::default()
    };
    let (image, stats) =
        scenes::render_quietly(&scene, &settings).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(stats.nonfinite_samples, 0, "{}", path.display());
    image
}

#[test]
fn every_shipped_scene_renders_finite_and_visible() {
    let mut count = 0;
    for dir in ["scenes", "scenes/blender", "scenes/gallery"] {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().and_then(|e| e.to_str()) != Some("glb") {
                continue;
            }
            // The path tracer and the method `--method auto` picks.
            for method in [Some(Method::Path), None] {
                let image = render_file(&path, 24, 4, method);
                assert!(image.rgba.iter().all(|p| p.iter().all(|v| v.is_finite())));
                let mean = image.mean_rgb();
                assert!(
                    mean.max_element() > 1e-3,
                    "{} rendered black ({method:?})",
                    path.display()
                );
            }
            count += 1;
        }
    }
    assert!(count >= 19, "only {count} scenes found");
}

#[test]
fn furnace_scene_file_renders_its_analytic_radiance() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/furnace.glb");
    let mean = render_file(&path, 16, 64, Some(Method::Path)).mean_rgb();
    for c in 0..3 {
        assert!((mean[c] - 1.0).abs() < 0.03, "{mean:?}");
    }
}
