//! The unbiased path tracer: the reference every other method is measured against.
//!
//! At each vertex: emission found by the BSDF-sampled ray is weighted against light sampling with
//! the power heuristic; next-event estimation samples one light chosen by power; the BSDF is
//! sampled to continue; Russian roulette on the throughput after three bounces (pbrt-v4 §13.4).
//! Inside a transmissive object the throughput is attenuated by Beer–Lambert absorption.
//!
//! Translucent materials (subsurface weight w > 0) use the same dipole BSSRDF as the photon
//! renderer (`crate::subsurface`), sampled by probe rays (as pbrt-v3 and Cycles' disk method
//! do): with probability ½ the path takes the subsurface branch, else the BSDF without w of its
//! Lambertian part. The branch picks a channel, a radius from that channel's R_d profile and a
//! projection axis (normal ½, tangents ¼ each), casts a probe through the disc and picks one of
//! its hits on the same material uniformly; the area density of that point sums all channels
//! and axes (one-sample MIS). The throughput is multiplied by w·T(ω_o)·R_d(d)/pdf, and the path
//! continues from the exit point with an entry lobe f = T(ω_i)/π (light sampling with MIS, then
//! a cosine-sampled direction). T is the specular layer's transmission, as in the photon
//! renderer, so both evaluate S = w T(ω_o) R_d(d) T(ω_i)/π.
//!
//! With an irradiance cache (`--method path-cache`, see `ic`), the first surface that stores
//! photons on the camera path (after specular ones only) takes its indirect light from the cache
//! when it is Lambertian and a record covers it: emission + light sample + ρ/π · E, then one
//! BSDF-sampled bounce that adds only the emission it meets (MIS-weighted with the light
//! sample; skipped when no light can be hit), and the path ends; elsewhere the path goes on as
//! usual. The records' gather rays are paths too (`incident_radiance`), leaving out the
//! emission of their first hit.
//!
//! Light passes (`super::LightPass`): each contribution goes to the pass given by the number of
//! non-delta vertices before it (a light sample counts its own vertex), or to Subsurface once
//! the path took the subsurface branch; the cached term is Indirect. Caustic stays 0.

use super::ic::lambertian_reflectance;
use super::photon::tracing::stores_photons;
use super::{CameraSample, Context, LightPass, Passes};
use crate::accel::{Ray, Visibility};
use crate::bsdf::Bsdf;
use crate::interaction::SurfaceHit;
use crate::irradiance_cache::{Incoming, IrradianceCache};
use crate::light::emitted_radiance;
use crate::material::{eval_material, SurfaceMaterial};
use crate::math::{max_component, Frame, Vec3};
use crate::rng::Rng;
use crate::sampling::{cosine_hemisphere_pdf, power_heuristic, square_to_cosine_hemisphere};
use crate::subsurface::Dipole;
use std::f32::consts::{FRAC_1_PI, PI};

/// Probability of the subsurface branch at a translucent vertex.
const SUBSURFACE_BRANCH: f32 = 0.5;
/// Most probe-ray hits considered.
const MAX_PROBE_HITS: usize = 8;

/// A point where light leaves the translucent material, found by a probe ray from `sh`, with
/// the throughput factor R_d(d)/pdf(x_i) per channel. `None` when the probe finds nothing.
fn sample_exit(
    ctx: &Context,
    sh: &SurfaceHit,
    frame: &Frame,
    surface: &SurfaceMaterial,
    rng: &mut Rng,
) -> Option<(SurfaceHit, Vec3)> {
    let sub = &surface.subsurface;
    let dipole = Dipole::new(
        surface.base_color.clamp(Vec3::ZERO, Vec3::ONE),
        sub.mean_free_path(),
        sub.ior,
        0.0,
    );
    let r_max: [f32; 3] = std::array::from_fn(|c| dipole.max_radius(c));
    let channel = (rng.uniform() * 3.0).min(2.0) as usize;
    let axes = [
        (frame.n, frame.s, frame.t, 0.5f32),
        (frame.s, frame.t, frame.n, 0.25),
        (frame.t, frame.n, frame.s, 0.25),
    ];
    let u = rng.uniform();
    let (axis, a, b, _) = axes[if u < 0.5 {
        0
    } else if u < 0.75 {
        1
    } else {
        2
    }];
    let r = dipole.sample_radius(channel, rng.uniform(), r_max[channel]);
    let phi = 2.0 * PI * rng.uniform();
    let half = (r_max[channel] * r_max[channel] - r * r).max(0.0).sqrt();
    let centre = sh.p + (a * phi.cos() + b * phi.sin()) * r;
    // Collect the probe's hits on the same material, from one end of the chord to the other.
    let mut hits = Vec::with_capacity(MAX_PROBE_HITS);
    let mut ray = Ray {
        origin: centre + axis * half,
        direction: -axis,
        t_max: 2.0 * half,
    };
    let end = centre - axis * half;
    while hits.len() < MAX_PROBE_HITS {
        let Some(hit) = ctx.accel.intersect(ctx.scene, &ray, Visibility::Secondary) else {
            break;
        };
        let h = SurfaceHit::new(ctx.scene, &ray, &hit);
        if h.material == sh.material {
            hits.push(h);
        }
        ray = h.spawn(-axis);
        ray.t_max = (end - ray.origin).dot(-axis);
        if !(ray.t_max > 0.0) {
            break;
        }
    }
    if hits.is_empty() {
        return None;
    }
    let exit = hits[((rng.uniform() * hits.len() as f32) as usize).min(hits.len() - 1)];
    let d = exit.p - sh.p;
    let mut pdf = 0.0;
    for (axis, _, _, p_axis) in axes {
        let along = d.dot(axis);
        let r_axis = (d.length_squared() - along * along).max(0.0).sqrt();
        let cos = exit.ng.dot(axis).abs();
        for (c, &rm) in r_max.iter().enumerate() {
            pdf += p_axis / 3.0 * dipole.disc_pdf(c, r_axis, rm) * cos;
        }
    }
    pdf /= hits.len() as f32;
    let weight = dipole.rd(d.length_squared()) / pdf;
    (pdf > 0.0 && weight.is_finite()).then_some((exit, weight))
}

/// The pass of light reaching the camera after `diffuse` non-specular vertices, `subsurface`
/// when the path went through a translucent material (`LightPass`).
fn light_pass(diffuse: u32, subsurface: bool) -> LightPass {
    if subsurface {
        LightPass::Subsurface
    } else {
        LightPass::after(diffuse)
    }
}

/// Russian roulette on the throughput: false when the path ends, else `beta` is reweighted.
fn russian_roulette(beta: &mut Vec3, rng: &mut Rng) -> bool {
    let q = max_component(*beta).min(1.0);
    if q < 1.0 {
        if rng.uniform() >= q {
            return false;
        }
        *beta /= q;
    }
    true
}

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
/// the first surface it meets or the world it escapes to, with that surface's distance and
/// normal.
pub fn incident_radiance(ctx: &Context, ray: Ray, rng: &mut Rng) -> Incoming {
    let out = trace_path(ctx, None, ray, rng, true);
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
    let mut passes = Passes::default();
    // Non-specular vertices so far, and whether the path went through the subsurface branch.
    let mut diffuse = 0u32;
    let mut subsurface = false;
    let mut beta = Vec3::ONE;
    let mut ray = camera_ray;
    // The previous bounce's sampling density and whether it was a delta lobe, for MIS.
    let mut prev_pdf = 0.0f32;
    let mut prev_delta = true;
    let mut prev_p = ray.origin;
    let mut absorption = Vec3::ZERO;
    // Still on the camera's specular chain, where cache records are placed.
    let mut on_chain = cache.is_some();
    // The cache served the last surface: this bounce only adds the emission it meets.
    let mut emission_only = false;

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
            let pass = light_pass(diffuse, subsurface);
            ctx.lights.escaped(ray.direction, |le, light_pdf| {
                let w = if prev_delta {
                    1.0
                } else {
                    power_heuristic(prev_pdf, light_pdf)
                };
                passes.add(pass, beta * le * w);
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
            passes.add(light_pass(diffuse, subsurface), beta * le * w);
        }
        if depth == ctx.max_depth || emission_only {
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
        let mut bsdf = Bsdf::new(&surface).viewed_from(frame.to_local(wo));

        let weight = surface.subsurface.weight;
        if weight > 0.0 && opaque {
            // Translucent surfaces are path traced: the cache holds no subsurface light.
            on_chain = false;
            if rng.uniform() < SUBSURFACE_BRANCH {
                // The subsurface branch: leave the material at x_i, then the entry lobe there.
                let enter = weight * bsdf.base_transmittance() / SUBSURFACE_BRANCH;
                let Some((exit, rd_over_pdf)) = sample_exit(ctx, &sh, &frame, &surface, rng) else {
                    break;
                };
                beta *= rd_over_pdf * enter;
                subsurface = true;
                let exit_frame = Frame::from_normal(exit.ng);
                let transmit = |wi: Vec3| {
                    bsdf.viewed_from(exit_frame.to_local(wi))
                        .base_transmittance()
                };
                if let Some(ls) = ctx
                    .lights
                    .sample(scene, exit.p, rng.uniform(), rng.uniform2())
                {
                    let cos = ls.wi.dot(exit.ng);
                    if cos > 0.0 && ls.li != Vec3::ZERO {
                        out.rays += 1;
                        if ctx.accel.unoccluded(scene, &exit.spawn_to(&ls.target)) {
                            let w = if ls.delta {
                                1.0
                            } else {
                                power_heuristic(ls.pdf, cosine_hemisphere_pdf(cos))
                            };
                            let f = transmit(ls.wi) * cos / PI;
                            passes.add(LightPass::Subsurface, beta * ls.li * (f * w / ls.pdf));
                        }
                    }
                }
                let local = square_to_cosine_hemisphere(rng.uniform2());
                let wi = exit_frame.to_world(local).normalize();
                beta *= transmit(wi);
                if beta == Vec3::ZERO || !beta.is_finite() {
                    break;
                }
                prev_pdf = cosine_hemisphere_pdf(local.z);
                prev_delta = false;
                prev_p = exit.p;
                ray = exit.spawn(wi);
                if depth >= 3 && !russian_roulette(&mut beta, rng) {
                    break;
                }
                continue;
            }
            bsdf = bsdf.without_subsurface(weight);
            beta /= 1.0 - SUBSURFACE_BRANCH;
        }

        let mut cached = None;
        if on_chain && stores_photons(&bsdf) {
            on_chain = false;
            if let (Some(cache), Some(rho)) = (cache, lambertian_reflectance(&bsdf, opaque)) {
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
                let (f, bsdf_pdf) = if geometric_ok {
                    bsdf.eval_and_pdf(wi_local)
                } else {
                    (Vec3::ZERO, 0.0)
                };
                if f != Vec3::ZERO && ls.li != Vec3::ZERO {
                    out.rays += 1;
                    if ctx.accel.unoccluded(scene, &sh.spawn_to(&ls.target)) {
                        let w = if ls.delta {
                            1.0
                        } else {
                            power_heuristic(ls.pdf, bsdf_pdf)
                        };
                        let pass = light_pass(diffuse + 1, subsurface);
                        passes.add(pass, beta * f * ls.li * (w / ls.pdf));
                    }
                }
            }
        }

        if let Some(indirect) = cached {
            passes.add(light_pass(diffuse + 2, subsurface), beta * indirect);
            // The light sample alone speckles where few of its samples reach a light (the world
            // through a window): one BSDF-sampled bounce adds the emission it meets, MIS-weighted
            // with it, wherever a ray can meet a light; then the path ends.
            if !ctx.lights.hittable() {
                break;
            }
            emission_only = true;
        }

        let Some(s) = bsdf.sample(rng.uniform(), rng.uniform2()) else {
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
        if !s.delta {
            diffuse += 1;
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

        if depth >= 3 && !russian_roulette(&mut beta, rng) {
            break;
        }
    }
    out.radiance = passes.total();
    out.passes = passes;
    out
}
