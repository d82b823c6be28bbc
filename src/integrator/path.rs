//! The unbiased path tracer: the reference every other method is measured against.
//!
//! At each vertex: emission found by the BSDF-sampled ray is weighted against light sampling with
//! the power heuristic; next-event estimation samples one light chosen by power; the BSDF is
//! sampled to continue; Russian roulette on the throughput after three bounces (pbrt-v4 §13.4).
//! Inside a transmissive object the throughput is attenuated by Beer–Lambert absorption.
//!
//! Translucent materials (subsurface weight w > 0) are walked through by the shared path walk
//! (`super::walk`, `super::random_walk`: Cycles' random walk, whatever the material's
//! subsurface method); the path tracer shades the exit point as the Lambertian surface it is.
//!
//! With an irradiance cache (`--method path-cache`, see `super::cache`), the first surface that stores
//! photons on the camera path (after specular ones only) takes its indirect light from the cache
//! when it is Lambertian and a record covers it: emission + light sample + ρ/π · E, then one
//! BSDF-sampled bounce that adds only the emission it meets (MIS-weighted with the light
//! sample; skipped when no light can be hit), and the path ends; elsewhere the path goes on as
//! usual. The records' gather rays are paths too (`incident_radiance`), leaving out the
//! emission of their first hit.
//!
//! Light passes (`crate::light_pass::LightPass`): each contribution goes to the pass given by the number of
//! non-delta vertices before it (a light sample counts its own vertex), or to Subsurface once
//! the path walked through a translucent material; the cached term is Indirect. Caustic stays 0.

use super::classify::{lambertian_reflectance, stores_photons};
use super::shading::Shading;
use super::walk::{walk, Next, PathState, Scatter};
use super::{CameraSample, Context};
use crate::accel::Ray;
use crate::irradiance_cache::{Incoming, IrradianceCache};
use crate::rng::Rng;
use std::f32::consts::FRAC_1_PI;

/// The path tracer's part in the walk: the cache on the camera's specular chain, and a light
/// sample at every non-delta vertex.
struct PathTracer<'a> {
    ctx: &'a Context<'a>,
    cache: Option<&'a IrradianceCache>,
    /// Still on the camera's specular chain, where cache records are placed.
    on_chain: bool,
}

impl Scatter for PathTracer<'_> {
    fn scatter(&mut self, path: &mut PathState, s: &mut Shading, rng: &mut Rng) -> Next {
        if path.subsurface || s.surface.subsurface.weight > 0.0 {
            // Translucent surfaces are path traced: the cache holds no subsurface light.
            self.on_chain = false;
        }

        let mut cached = None;
        if self.on_chain && stores_photons(&s.bsdf) {
            self.on_chain = false;
            if let (Some(cache), Some(rho)) =
                (self.cache, lambertian_reflectance(&s.bsdf, s.opaque))
            {
                cached = cache.lookup(s.sh.p, s.frame.n).map(|e| rho * e * FRAC_1_PI);
            }
        }

        let light_sampled = s.bsdf.has_non_delta();
        if light_sampled {
            path.light_sample(self.ctx, s, rng);
        }

        if let Some(indirect) = cached {
            path.add(2, path.beta * indirect);
            // The light sample alone speckles where few of its samples reach a light (the world
            // through a window): one BSDF-sampled bounce adds the emission it meets, MIS-weighted
            // with it, wherever a ray can meet a light; then the path ends.
            if !self.ctx.lights.hittable() {
                return Next::End;
            }
            path.emission_only = true;
        }
        Next::Continue { light_sampled }
    }
}

/// Trace one path from the camera ray and return its radiance and first-hit data.
pub fn trace(ctx: &Context, camera_ray: Ray, rng: &mut Rng) -> CameraSample {
    trace_cached(ctx, None, camera_ray, rng)
}

/// `trace`, reading indirect light at the first diffuse surface from `cache` (module header).
pub fn trace_cached(
    ctx: &Context,
    cache: Option<&IrradianceCache>,
    camera_ray: Ray,
    rng: &mut Rng,
) -> CameraSample {
    let mut tracer = PathTracer {
        ctx,
        cache,
        on_chain: cache.is_some(),
    };
    walk(ctx, camera_ray, rng, false, &mut tracer)
}

/// The path tracer with the photon method's way through media: the path is only attenuated by
/// them, and the light they scatter towards it straight from the lights is one light sample
/// along each segment (`light_scattered_along`), where the path tracer samples free flights.
/// The planner's pilot measures the noise this leaves in the Volume Direct pass.
struct ThroughMedia<'a>(PathTracer<'a>);

impl Scatter for ThroughMedia<'_> {
    fn scatters_in_media(&self) -> bool {
        false
    }

    fn media_segment(&mut self, path: &mut PathState, reach: f32, rng: &mut Rng) {
        let mut rays = 0;
        let single = path.light_scattered_on_segment(self.0.ctx, reach, rng, &mut rays);
        path.rays += rays;
        path.add_in_medium(1, single);
    }

    fn scatter(&mut self, path: &mut PathState, s: &mut Shading, rng: &mut Rng) -> Next {
        self.0.scatter(path, s, rng)
    }
}

/// `trace` with media crossed as the photon method crosses them (`ThroughMedia`).
pub fn trace_through_media(ctx: &Context, camera_ray: Ray, rng: &mut Rng) -> CameraSample {
    let mut tracer = ThroughMedia(PathTracer {
        ctx,
        cache: None,
        on_chain: false,
    });
    walk(ctx, camera_ray, rng, false, &mut tracer)
}

/// Radiance arriving along `ray` (a gather ray of an irradiance record) without the emission of
/// the first surface it meets or the world it escapes to, with that surface's distance and
/// normal.
pub fn incident_radiance(ctx: &Context, ray: Ray, rng: &mut Rng) -> Incoming {
    let mut tracer = PathTracer {
        ctx,
        cache: None,
        on_chain: false,
    };
    let out = walk(ctx, ray, rng, true, &mut tracer);
    if !out.hit {
        return Incoming {
            radiance: out.radiance,
            ..Incoming::NONE
        };
    }
    Incoming {
        radiance: out.radiance,
        distance: out.depth,
        normal: out.normal,
    }
}
