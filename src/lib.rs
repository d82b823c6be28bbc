//! Photon: a Blender-compatible render engine with photon maps, irradiance caching and an
//! unbiased path tracer as reference. See DESIGN.md for the data flow: load → plan → build
//! acceleration → build caches → render tiles → write the image.

pub mod bsdf;
pub mod error;
pub mod material;
pub mod math;
pub mod rng;
pub mod sampling;
pub mod scene;
