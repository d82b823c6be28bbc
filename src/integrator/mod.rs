//! Integrators: the algorithms that turn a camera ray into radiance, chosen once per render.
//!
//! The core, which every integrator imports and which imports none of them:
//! - `shading`: the shading point (hit → material → BSDF, frame, the side of the surface, the
//!   medium a ray leaves into);
//! - `classify`: which surfaces are specular, Lambertian, or store photons (shared with the
//!   scene planner and photon tracing);
//! - `direct`: the one direct-light sampler with MIS (Veach 1997, power heuristic);
//! - `walk`: the one camera path walk (an explicit path state with escaped / emitted / advance /
//!   roulette steps) and the one specular-chain follower;
//! - `random_walk`: the volumetric walk through translucent objects (Chiang et al. 2016, as
//!   Cycles' Random Walk), which `walk` takes for both integrators.
//!
//! The integrators on top: `path` (the unbiased reference: Kajiya 1986 with next-event
//! estimation and MIS), `photon` (Jensen 1996/2001 photon mapping with final gathering, its
//! debug views and the subsurface diffusion mode), and `cache` (Ward 1988's irradiance cache
//! wired to both, and its debug views).

pub mod cache;
pub mod classify;
pub mod direct;
pub mod media;
pub mod path;
pub mod photon;
pub mod random_walk;
pub mod shading;
pub mod walk;

use crate::accel::Accel;
use crate::light::Lights;
use crate::light_pass::Passes;
use crate::math::Vec3;
use crate::scene::Scene;

/// Everything an integrator reads while rendering; shared by all threads.
pub struct Context<'a> {
    pub scene: &'a Scene,
    pub accel: &'a Accel,
    pub lights: &'a Lights,
    /// Maximum number of bounces (0 = emitters and direct visibility of lights only).
    pub max_depth: u32,
    /// Blender's "Film → Transparent": camera rays that leave the scene see nothing (alpha 0)
    /// instead of the world, which still lights the scene.
    pub transparent_background: bool,
}

/// What one camera sample produced.
#[derive(Clone, Copy, Debug, Default)]
pub struct CameraSample {
    pub radiance: Vec3,
    /// The camera ray hit geometry (alpha coverage).
    pub hit: bool,
    /// The camera ray met a Holdout: a hole in the alpha even with an opaque film, as Cycles
    /// makes it.
    pub holdout: bool,
    /// The camera ray met a shadow catcher first (`crate::shadow_catcher`).
    pub catcher: bool,
    pub albedo: Vec3,
    /// World-space shading normal at the first hit.
    pub normal: Vec3,
    pub depth: f32,
    /// Rays traced for this sample (closest-hit and shadow), for statistics.
    pub rays: u32,
    /// `radiance` split by light path (`crate::light_pass::LightPass`); every integrator sets
    /// both so that the passes sum to `radiance`.
    pub passes: Passes,
    /// The part of `radiance` the camera ray sees directly: the emission it meets going
    /// straight on through transparent surfaces, media and delta lobes (smooth mirrors and
    /// glass) before any other scattering, or the background it escapes to (the Emission
    /// pass; `walk::seen_emission` estimates the same for another ray).
    pub seen_emission: Vec3,
}
