//! Integrators: the algorithms that turn a camera ray into radiance. Chosen once per render.
//! `path` is the unbiased reference (Kajiya 1986 with next-event estimation and MIS, Veach 1997);
//! `photon` is Jensen's two-pass photon mapping with final gathering, and its debug views; `ic`
//! connects Ward's irradiance cache to both.

pub mod ic;
pub mod path;
pub mod photon;

use crate::accel::Accel;
use crate::light::Lights;
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
    pub albedo: Vec3,
    /// World-space shading normal at the first hit.
    pub normal: Vec3,
    pub depth: f32,
    /// Rays traced for this sample (closest-hit and shadow), for statistics.
    pub rays: u32,
}
