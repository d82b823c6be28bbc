//! Photon mapping (Jensen 1996, "Global illumination using photon maps"; Jensen 2001,
//! "Realistic Image Synthesis Using Photon Mapping"), split by job:
//! - `settings`: the settings and the statistics of photon tracing;
//! - `tracing`: photon emission and the photon random walk;
//! - `volume_emitters`: photons from emitting media;
//! - `guide`: guided emission, towards what the render reads (Peter & Pietrek 1998);
//! - `estimate`: density estimation from the maps and Christensen's precomputed irradiance;
//! - `subsurface`: the diffusion photon mode for Christensen–Burley translucent materials
//!   (Jensen & Buhler 2002);
//! - `build`: tracing the photons into the maps everything else reads;
//! - `shade`: rendering from the maps (direct, specular, caustics, final gathering, the
//!   irradiance cache) and the debug views.
//!
//! The irradiance cache sits beside the maps (`crate::integrator::cache`), not inside them.

pub mod build;
pub mod estimate;
pub mod guide;
pub mod settings;
pub mod shade;
pub mod subsurface;
pub mod tracing;
pub mod volume_emitters;
