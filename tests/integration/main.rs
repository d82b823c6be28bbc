//! Photon's Rust integration tests, built as one crate so the library is linked into one test
//! binary rather than into one per file. Each module is a topic (the BVH, the BSDFs, the glTF
//! loader, the command line, …) and its test names start with the module's name:
//! `cargo test --release --test integration bsdf::` runs one topic. Shared helpers live in
//! `support` (scenes built in code, the chi-square harness, running the `photon` binary).
//! Two checks stay crates of their own, `tests/image_hashes.rs` and `tests/layers.rs` (see each
//! file's first paragraph).

mod support;

mod accel;
mod adaptive;
mod bench;
mod bsdf;
mod cli;
mod displacement;
mod emitter_pixels;
mod environment;
mod frame_split;
mod fuzz_gltf;
mod gltf_compression;
mod gltf_core;
mod gltf_draco;
mod gltf_loader;
mod instancing;
mod irradiance_cache;
mod light_passes;
mod light_path_switches;
mod light_paths;
mod lights_lamps;
mod media;
mod nodes;
mod object_attributes;
mod photon_map;
mod photon_render;
mod plan;
mod render;
mod rough_dielectric;
mod sampler;
mod scenes;
mod stress;
mod subsurface;
mod view;
mod volume_objects;
mod warps;
