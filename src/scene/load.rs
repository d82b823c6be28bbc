//! Opening a scene for rendering: a glTF file or the embedded Cornell box, and the image size a
//! render of it takes when the caller gives none or only one side.

use super::gltf::load;
pub use super::gltf::LoadOptions;
use super::{builtin, Scene};
use crate::error::Result;
use std::path::Path;

/// The scene in the glTF file at `path`, or the embedded Cornell box without one, seen through
/// `camera` (a glTF node or camera name; default: the first camera).
pub fn load_scene(path: Option<&Path>, camera: Option<String>) -> Result<Scene> {
    let options = LoadOptions {
        camera,
        ..LoadOptions::default()
    };
    load_scene_with(path, &options)
}

/// The scene in the glTF file at `path` (or the embedded Cornell box) as `options` choose it:
/// camera, material variant, animation time.
pub fn load_scene_with(path: Option<&Path>, options: &LoadOptions) -> Result<Scene> {
    match path {
        Some(p) => load(p, options),
        None => builtin::cornell_box(options),
    }
}

/// Image size: the command line's, else the scene's stored resolution, else 640 wide; a missing
/// side follows the aspect ratio of the stored resolution (or of the camera).
pub fn image_size(scene: &Scene, width: Option<u32>, height: Option<u32>) -> (u32, u32) {
    let stored = (scene.render_settings.width, scene.render_settings.height);
    // The frame's aspect ratio: the scene's stored resolution, else its camera's.
    let aspect = match stored {
        (Some(w), Some(h)) if w > 0 && h > 0 => Some(w as f32 / h as f32),
        _ => scene.camera.aspect_ratio,
    }
    .filter(|a| a.is_finite() && *a > 0.0)
    .unwrap_or(4.0 / 3.0);
    let complete = |size: (Option<u32>, Option<u32>)| match size {
        (Some(w), Some(h)) => Some((w, h)),
        (Some(w), None) => Some((w, ((w as f32 / aspect).round() as u32).max(1))),
        (None, Some(h)) => Some((((h as f32 * aspect).round() as u32).max(1), h)),
        (None, None) => None,
    };
    // A size given on the command line wins as a whole: `--width` alone keeps the aspect ratio
    // instead of pairing with the stored height.
    complete((width, height))
        .or_else(|| complete(stored))
        .unwrap_or_else(|| (640, ((640.0 / aspect).round() as u32).max(1)))
}
