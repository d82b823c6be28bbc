//! The unbiased path tracer: the reference every other method is measured against.
//!
//! At each vertex: emission found by the BSDF-sampled ray is weighted against light sampling with
//! the power heuristic; next-event estimation samples one light chosen by power; the BSDF is
//! sampled to continue; Russian roulette on the throughput after three bounces (pbrt-v4 §13.4).
//! Inside a transmissive object the throughput is attenuated by Beer–Lambert absorption.

use super::{CameraSample, Context};
use crate::accel::{Ray, Visibility};
use crate::bsdf::{bsdf_pdf, eval_bsdf, sample_bsdf, Bsdf};
use crate::interaction::SurfaceHit;
use crate::light::emitted_radiance;
use crate::material::eval_material;
use crate::math::{max_component, Vec3};
use crate::rng::Rng;
use crate::sampling::power_heuristic;

/// Trace one path from the camera ray and return its radiance and first-hit data.
pub fn trace(ctx: &Context, camera_ray: Ray, rng: &mut Rng) -> CameraSample {
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

    for depth in 0..=ctx.max_depth {
        let visibility = if depth == 0 {
            Visibility::Camera
        } else {
            Visibility::Secondary
        };
        out.rays += 1;
        let Some(hit) = ctx.accel.intersect(scene, &ray, visibility) else {
            if depth == 0 && ctx.transparent_background {
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
        if le != Vec3::ZERO {
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
                        let w = if ls.delta {
                            1.0
                        } else {
                            power_heuristic(ls.pdf, bsdf_pdf(&bsdf, wo_local, wi_local))
                        };
                        radiance += beta * f * ls.li * (w / ls.pdf);
                    }
                }
            }
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
