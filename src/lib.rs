//! Photon: a Blender-compatible render engine with photon maps, irradiance caching and an
//! unbiased path tracer as reference. `docs/ARCHITECTURE.md` describes the layers and the data
//! flow: load → plan → build acceleration → build caches → render tiles → write the image.

// `!(x > 0.0)` is the idiom for "not positive, or NaN": rejecting NaN is the point there.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod adaptive;
pub mod bsdf;
pub mod camera;
pub mod color_space;
pub mod emitter_pixels;
pub mod error;
pub mod exr_merge;
pub mod film;
pub mod image_io;
pub mod integrator;
pub mod interaction;
pub mod irradiance_cache;
pub mod light;
pub mod light_pass;
pub mod material;
pub mod math;
pub mod medium;
pub mod metrics;
pub mod phase;
pub mod photon_map;
pub mod plan;
pub mod progress;
pub mod render;
pub mod rng;
pub mod rounds;
pub mod sampling;
pub mod scene;
pub mod shader;
pub mod shadow_catcher;
pub mod sobol;
pub mod subsurface;
pub mod volume_photon_map;
