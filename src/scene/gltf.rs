//! The only code that reads glTF: `.glb` and `.gltf` (with external buffers and images) into a
//! plain-data `Scene`.
//!
//! CONTRACT: stub; the glTF loader work replaces it.

use super::Scene;
use crate::error::{Error, Result};
use std::path::Path;

/// Options that change what is loaded.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Use the camera whose glTF node or camera name matches; `None` picks the first camera.
    pub camera: Option<String>,
}

/// Load a `.glb` or `.gltf` file.
pub fn load(path: &Path, options: &LoadOptions) -> Result<Scene> {
    let _ = options;
    Err(Error::scene(
        path,
        "file",
        "glTF loading is not implemented yet",
    ))
}

/// Load a `.glb` held in memory; `name` stands for the path in messages.
pub fn load_slice(bytes: &[u8], name: &str, options: &LoadOptions) -> Result<Scene> {
    let _ = (bytes, options);
    Err(Error::scene(
        name,
        "file",
        "glTF loading is not implemented yet",
    ))
}
