//! Loading a glTF file into a `Scene`: the entry points, the walk of the default scene that
//! assembles everything, and the choice of the camera.

use super::camera::{framing_camera, FoundCamera};
use super::container::Loader;
use super::hierarchy::Placement;
use crate::error::{Error, Result};
use crate::scene::{Camera, Scene};
use std::path::Path;

/// Options that change what is loaded.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Use the camera whose glTF node or camera name matches; `None` picks the first camera.
    pub camera: Option<String>,
    /// Show the `KHR_materials_variants` variant of this name; `None`: each primitive's own
    /// material (the file's default).
    pub variant: Option<String>,
    /// Pose the file's animations at this time in seconds (node transforms, skins and morph
    /// weights); `None`: the nodes' own values.
    pub time: Option<f32>,
}

/// Load a `.glb` or `.gltf` file.
pub fn load(path: &Path, options: &LoadOptions) -> Result<Scene> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let base = path.parent().unwrap_or_else(|| Path::new("."));
    Loader::parse(&bytes, path, Some(base))?.build(options)
}

/// Load a `.glb` (or self-contained `.gltf`) held in memory; `name` stands for the path in
/// messages. External files cannot be resolved, so every buffer and image must be embedded.
pub fn load_slice(bytes: &[u8], name: &str, options: &LoadOptions) -> Result<Scene> {
    Loader::parse(bytes, Path::new(name), None)?.build(options)
}

impl Loader {
    /// Walk the default scene and assemble everything.
    pub(super) fn build(mut self, options: &LoadOptions) -> Result<Scene> {
        if let Some(name) = &options.variant {
            self.choose_variant(name)?;
        }
        if let Some(time) = options.time {
            self.pose = self.pose_at(time)?;
        }
        let document = self.document.clone();
        let gltf_scene = document
            .default_scene()
            .or_else(|| document.scenes().next());
        if let Some(gltf_scene) = &gltf_scene {
            // Images and the sky are taken into the working space as they load.
            self.read_working_space(gltf_scene)?;
        }
        self.load_materials()?;
        let mut cameras = Vec::new();
        if let Some(gltf_scene) = &gltf_scene {
            self.check_sizes(gltf_scene)?;
            for node in gltf_scene.nodes() {
                let mut ancestors = Vec::new();
                self.visit_node(&node, Placement::ROOT, &mut ancestors, &mut cameras)?;
            }
            self.read_scene_extensions(gltf_scene)?;
        } else {
            self.scene.warnings.push("the file has no scene".into());
        }
        self.scene.camera = self.choose_camera(cameras, options)?;
        self.scene.bound_volumes();
        self.scene
            .validate()
            .map_err(|m| Error::scene(&self.path, "scene", m))?;
        Ok(self.scene)
    }

    pub(super) fn choose_camera(
        &mut self,
        cameras: Vec<FoundCamera>,
        options: &LoadOptions,
    ) -> Result<Camera> {
        if let Some(wanted) = &options.camera {
            let available: Vec<String> = cameras
                .iter()
                .map(|c| format!("'{}' (camera '{}')", c.node_name, c.camera_name))
                .collect();
            return cameras
                .into_iter()
                .find(|c| &c.node_name == wanted || &c.camera_name == wanted)
                .map(|c| c.camera)
                .ok_or_else(|| {
                    let list = if available.is_empty() {
                        "the file has no cameras".to_string()
                    } else {
                        format!("available: {}", available.join(", "))
                    };
                    self.err(
                        format!("camera '{wanted}'"),
                        format!("no such camera; {list}"),
                    )
                });
        }
        if let Some(first) = cameras.into_iter().next() {
            return Ok(first.camera);
        }
        self.scene
            .warnings
            .push("the file has no camera; using one that frames the scene".into());
        Ok(framing_camera(self.scene.bounds()))
    }
}
