//! Lights as the integrators see them: every emitter of the scene (emissive triangles, point,
//! spot and sun lights, the world background) in one list, a light chosen by power or, among a
//! few lights, partly by its irradiance at the shading point, with `Lights::sample` (a
//! direction towards a light, for next-event estimation) and the matching densities for
//! multiple importance sampling (Veach 1997, ch. 9). By concern:
//! - `source`: one emitter, one light sample, the point a sample is drawn from;
//! - `lights`: the light list, `Lights::sample` and the densities MIS reads;
//! - `selection`: which light a sample goes to (`LocalSelection`, after Conty Estevez & Kulla
//!   2018);
//! - `lamps`: point and spot lights with a radius as Cycles makes them, and the BVH over them
//!   that rays meet (`Lights::lamps_met`);
//! - `environment`: the environment map as a light, importance-sampled (pbrt-v4 §12.5.2);
//! - `emission`: the radiance surfaces emit, Cycles' area-light spread, and the points drawn on
//!   emitters;
//! - `linking`: Blender's light and shadow linking of the object a ray hit.
//!
//! Units follow Cycles (docs/ARCHITECTURE.md): triangle and world radiance as given, point and spot
//! intensity in W/sr, sun irradiance in W/m².

mod emission;
mod environment;
mod lamps;
mod lights;
mod linking;
mod selection;
mod source;

pub use emission::{
    emitted_radiance, sample_emitter_point, smoothstep, spread_factor, EmitterPoint, EmitterSample,
};
pub use environment::EnvironmentLight;
pub use lamps::lamp_of;
pub use lights::Lights;
pub use linking::hit_links;
pub use source::{LightSample, LightSource, Receiver};
