//! Every scene shipped in `scenes/` (and the Blender-made ones) loads and renders: no NaN or Inf,
//! no dropped samples, something visible. The furnace scene also gives its analytic radiance.

#[path = "support/scenes.rs"]
mod scenes;

use photon::render::RenderSettings;
use photon::scene::gltf::{load, LoadOptions};
use std::path::Path;

fn render_file(path: &Path, size: u32, spp: u32) -> photon::film::Image {
    let scene = load(path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let settings = RenderSettings {
        width: size,
        height: size,
        spp,
        max_depth: 16,
        seed: 3,
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
    for dir in ["scenes", "scenes/blender"] {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().and_then(|e| e.to_str()) != Some("glb") {
                continue;
            }
            let image = render_file(&path, 24, 4);
            assert!(image.rgba.iter().all(|p| p.iter().all(|v| v.is_finite())));
            let mean = image.mean_rgb();
            assert!(
                mean.max_element() > 1e-3,
                "{} rendered black",
                path.display()
            );
            count += 1;
        }
    }
    assert!(count >= 10, "only {count} scenes found");
}

#[test]
fn furnace_scene_file_renders_its_analytic_radiance() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/furnace.glb");
    let mean = render_file(&path, 16, 64).mean_rgb();
    for c in 0..3 {
        assert!((mean[c] - 1.0).abs() < 0.03, "{mean:?}");
    }
}
