//! The embedded default scene: the Cornell box from `scenes/cornell_box.glb`, compiled into the
//! binary so `photon` with no arguments renders something.

use super::gltf::{load_slice, LoadOptions};
use super::Scene;
use crate::error::Result;

/// The Cornell box built by `scenes/build_scenes.py`.
pub fn cornell_box(options: &LoadOptions) -> Result<Scene> {
    load_slice(DEFAULT_SCENE, "<embedded Cornell box>", options)
}

const DEFAULT_SCENE: &[u8] = &[];
