//! Photon: a Blender-compatible render engine with photon maps, irradiance caching and an
//! unbiased path tracer as reference. See DESIGN.md for the data flow: load → plan → build
//! acceleration → build caches → render tiles → write the image.

// `!(x > 0.0)` is the idiom for "not positive, or NaN": rejecting NaN is the point there.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod bsdf;
pub mod camera;
pub mod error;
pub mod film;
pub mod image_io;
pub mod integrator;
pub mod interaction;
pub mod irradiance_cache;
pub mod light;
pub mod material;
pub mod math;
pub mod metrics;
pub mod passes;
pub mod photon_map;
pub mod plan;
pub mod render;
pub mod rng;
pub mod sampling;
pub mod scene;
pub mod subsurface;
