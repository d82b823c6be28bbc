//! The only code that reads glTF: `.glb` and `.gltf` files (external buffers and images, or data
//! URIs) become a plain-data, validated `Scene` in world space. The `gltf` crate parses and
//! validates the JSON; buffers, accessors and images are read here with every byte range checked,
//! so a broken file gives an `Error::Scene` naming the glTF object, never a panic.
//!
//! Blender's exporter drops what glTF cannot say; the add-on writes it back in Photon's `PHOTON_*`
//! extensions, specified field by field in `docs/gltf_extensions.md` (with how Photon reads
//! the KHR extensions Blender's importer interprets, its limits and its units). The reading is
//! split by concern:
//! - `container`: the `.glb`/`.gltf` container, buffers and URIs (`encoding`: base64 and
//!   percent-escapes), and the `Loader` that carries the document and the scene being built;
//!   `meshopt`: buffer views compressed with `EXT_meshopt_compression` or
//!   `KHR_meshopt_compression`, decoded once;
//!   `draco`: primitives compressed with `KHR_draco_mesh_compression`, decoded once into
//!   their accessors' bytes;
//! - `extensions`: the `PHOTON_*` extensions as typed structures, each read once and checked;
//! - `build`: the entry points, the walk of the default scene and the choice of camera;
//! - `hierarchy`: the node hierarchy, the limits checked before allocating, instancing;
//!   `gpu_instancing`: `EXT_mesh_gpu_instancing`'s instances;
//! - `accessors`: accessors read with every byte range checked;
//! - `meshes`: primitives into meshes and prototypes; `skinning`: morph targets and skins;
//! - `animation`: the animations posed at a chosen time (`LoadOptions::time`);
//! - `motion`: poses over the shutter and deforming vertices;
//! - `materials`: materials and their KHR and `PHOTON_*` extensions; `imported_trees`: the
//!   unlit and specular-glossiness materials as the node trees Blender's importer builds;
//!   `variants`: `KHR_materials_variants`;
//! - `textures` and `images`: glTF textures and node trees' images, and their decoding (`ktx2`:
//!   KTX2 images of `KHR_texture_basisu`);
//! - `lights`: punctual and area lights;
//! - `world`: the world and the render settings;
//! - `camera`: cameras, and the camera that frames a scene without one.

mod accessors;
mod animation;
mod attributes;
mod build;
mod camera;
mod container;
mod draco;
mod encoding;
mod extensions;
mod gpu_instancing;
mod hierarchy;
mod images;
mod imported_trees;
mod ktx2;
mod lights;
mod materials;
mod meshes;
mod meshopt;
mod motion;
mod object_info;
mod skinning;
mod textures;
mod variants;
mod volumes;
mod world;

pub use build::{load, load_slice, LoadOptions};
pub use hierarchy::{MAX_NODE_INSTANCES, MAX_TRIANGLES, MAX_VERTICES};
