//! The embedded default scene: the Cornell box from `scenes/cornell_box.glb`, compiled into the
//! binary so `photon` with no arguments renders something. It goes through the same glTF loader
//! as any file, so it is a live test of the loader too.

use super::gltf::{load_slice, LoadOptions};
use super::Scene;
use crate::error::Result;

/// The Cornell box built by `scenes/build_scenes.py`.
pub fn cornell_box(options: &LoadOptions) -> Result<Scene> {
    load_slice(DEFAULT_SCENE, "<embedded Cornell box>", options)
}

const DEFAULT_SCENE: &[u8] = include_bytes!("../../scenes/cornell_box.glb");

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_cornell_box_loads() {
        let scene = cornell_box(&LoadOptions::default()).unwrap();
        assert_eq!(scene.placed_triangle_count(), 36);
        assert!(scene.materials.iter().any(|m| m.is_emissive()));
        assert_eq!(scene.render_settings.width, Some(256));
    }
}
