//! The unbiased path tracer: the reference every other method is measured against.
//!
//! At each vertex: emission found by the BSDF-sampled ray is weighted against light sampling with
//! the power heuristic; next-event estimation samples one light chosen by power; the BSDF is
//! sampled to continue; Russian roulette on the throughput after three bounces (pbrt-v4 §13.4).
//! Inside a transmissive object the throughput is attenuated by Beer–Lambert absorption.
//!
//! With an irradiance cache (`--method path-cache`, see `ic`), the first surface that stores
//! photons on the camera path (after specular ones only) takes its indirect light from the cache
//! when it is Lambertian and a record covers it: emission + light sample (no MIS, no BSDF ray) +
//! ρ/π · E, and the path ends; elsewhere the path goes on as usual. The records' gather rays
//! are paths too (`incident_radiance`), leaving out the emission of their first hit.

use super::ic::lambertian_reflectance;
use super::photon::tracing::stores_photons;
use super::{CameraSample, Context};
use crate::accel::{Ray, Visibility};
use crate::bsdf::{bsdf_pdf, eval_bsdf, sample_bsdf, Bsdf};
use crate::interaction::SurfaceHit;
use crate::irradiance_cache::IrradianceCache;
use crate::light::emitted_radiance;
use crate::material::eval_material;
use crate::math::{max_component, Vec3};
use crate::rng::Rng;
use crate::sampling::power_heuristic;
use std::f32::consts::FRAC_1_PI;

/// Trace one path from the camera ray and return its radiance and first-hit data.
pub fn trace(ctx: &Context, camera_ray: Ray, rng: &mut Rng) -> CameraSample {
    trace_path(ctx, None, camera_ray, rng, false)
}

/// `trace`, reading indirect light at the first diffuse surface from `cache` (module header).
pub fn trace_cached(
    ctx: &Context,
    cache: Option<&IrradianceCache>,
    camera_ray: Ray,
    rng: &mut Rng,
) -> CameraSample {
    trace_path(ctx, cache, camera_ray, rng, false)
}

/// Radiance arriving along `ray` (a gather ray of an irradiance record) without the emission of
/// the first surface it meets or the world it escapes to, and the distance of that surface.
pub fn incident_radiance(ctx: &Context, ray: Ray, rng: &mut Rng) -> (Vec3, f32) {
    let out = trace_path(ctx, None, ray, rng, true);
    let distance = if out.hit { out.depth } else { f32::INFINITY };
    (out.radiance, distance)
}

fn trace_path(
    ctx: &Context,
    cache: Option<&IrradianceCache>,
    camera_ray: Ray,
    rng: &mut Rng,
    gather: bool,
) -> CameraSample {
    let scene = ctx.scene;
    let mut out = CameraSample {
        depth: 1e10,
        ..CameraSample::default()
    };
    let mut radiance = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    let mut ray = camera_ray;
    // The previous bounce's sampling density and whether it was a delta lobe, for MIS.
    let mut prev_pdf = 0.0f32;
    let mut prev_delta = true;
    let mut prev_p = ray.origin;
    let mut absorption = Vec3::ZERO;
    // Still on the camera's specular chain, where cache records are placed.
    let mut on_chain = cache.is_some();

    for depth in 0..=ctx.max_depth {
        let visibility = if depth == 0 && !gather {
            Visibility::Camera
        } else {
            Visibility::Secondary
        };
        out.rays += 1;
        let Some(hit) = ctx.accel.intersect(scene, &ray, visibility) else {
            if depth == 0 && (ctx.transparent_background || gather) {
                break;
            }
            ctx.lights.escaped(ray.direction, |le, light_pdf| {
                let w = if prev_delta {
                    1.0
                } else {
                    power_heuristic(prev_pdf, light_pdf)
                };
                radiance += beta * le * w;
            });
            break;
        };
        if absorption != Vec3::ZERO {
            beta *= (-absorption * (hit.t * ray.direction.length())).exp();
        }
        let sh = SurfaceHit::new(scene, &ray, &hit);
        let wo = -ray.direction.normalize();
        let material = &scene.materials[sh.material as usize];
        let surface = eval_material(scene, material, sh.uv);
        if depth == 0 {
            out.hit = true;
            out.albedo = surface.base_color;
            out.normal = sh.frame.n;
            out.depth = hit.t * ray.direction.length();
        }

        let le = emitted_radiance(scene, &sh, wo);
        if le != Vec3::ZERO && !(gather && depth == 0) {
            let w = if prev_delta {
                1.0
            } else {
                power_heuristic(prev_pdf, ctx.lights.triangle_pdf(prev_p, &sh))
            };
            radiance += beta * le * w;
        }
        if depth == ctx.max_depth {
            break;
        }

        // Opaque surfaces scatter on the viewer's side: turn the frame to face `wo`. Transmissive
        // ones keep the frame on the outside (winding) so the BSDF knows inside from outside.
        let mut frame = sh.frame;
        let opaque = surface.transmission <= 0.0;
        let mut ng = sh.ng;
        if opaque && wo.dot(ng) < 0.0 {
            frame.n = -frame.n;
            frame.t = -frame.t;
            ng = -ng;
        }
        let bsdf = Bsdf::new(&surface);
        let wo_local = frame.to_local(wo);

        let mut cached = None;
        if on_chain && stores_photons(&bsdf, wo_local) {
            on_chain = false;
            if let (Some(cache), Some(rho)) =
                (cache, lambertian_reflectance(&bsdf, wo_local, opaque))
            {
                cached = cache.lookup(sh.p, frame.n).map(|e| rho * e * FRAC_1_PI);
            }
        }

        if bsdf.has_non_delta() {
            if let Some(ls) = ctx
                .lights
                .sample(scene, sh.p, rng.uniform(), rng.uniform2())
            {
                let wi_local = frame.to_local(ls.wi);
                // An opaque surface cannot be lit from behind its geometry, whatever the shading
                // normal says (avoids light leaking through interpolated normals).
                let geometric_ok = !opaque || ls.wi.dot(ng) > 0.0;
                let f = if geometric_ok {
                    eval_bsdf(&bsdf, wo_local, wi_local)
                } else {
                    Vec3::ZERO
                };
                if f != Vec3::ZERO && ls.li != Vec3::ZERO {
                    out.rays += 1;
                    if ctx.accel.unoccluded(scene, &sh.spawn_to(&ls.target)) {
                        let w = if ls.delta || cached.is_some() {
                            1.0
                        } else {
                            power_heuristic(ls.pdf, bsdf_pdf(&bsdf, wo_local, wi_local))
                        };
                        radiance += beta * f * ls.li * (w / ls.pdf);
                    }
                }
            }
        }

        if let Some(indirect) = cached {
            radiance += beta * indirect;
            break;
        }

        let Some(s) = sample_bsdf(&bsdf, wo_local, rng.uniform(), rng.uniform2()) else {
            break;
        };
        let wi = frame.to_world(s.wi).normalize();
        if opaque && wi.dot(ng) <= 0.0 {
            break;
        }
        beta *= s.weight;
        if beta == Vec3::ZERO || !beta.is_finite() {
            break;
        }
        prev_pdf = s.pdf;
        prev_delta = s.delta;
        prev_p = sh.p;
        if s.transmitted {
            // Entering the object when leaving against the outward normal.
            absorption = if wi.dot(sh.ng) < 0.0 {
                surface.absorption
            } else {
                Vec3::ZERO
            };
        }
        ray = sh.spawn(wi);

        if depth >= 3 {
            let q = max_component(beta).min(1.0);
            if q < 1.0 {
                if rng.uniform() >= q {
                    break;
                }
                beta /= q;
            }
        }
    }
    out.radiance = radiance;
    out
}
