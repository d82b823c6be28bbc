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
//! the path took the subsurface branch; the cached term is Indirect. Caustic stays 0.

use super::classify::{lambertian_reflectance, stores_photons};
use super::direct::{sample_direct_on, Previous};
use super::shading::Shading;
use super::walk::{walk, Next, PathState, Scatter};
use super::{CameraSample, Context};
use crate::accel::{Ray, Visibility};
use crate::bsdf::Scattering;
use crate::interaction::SurfaceHit;
use crate::irradiance_cache::{Incoming, IrradianceCache};
use crate::material::SurfaceMaterial;
use crate::math::{Frame, Vec3};
use crate::rng::Rng;
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
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
        time: sh.time,
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

/// The path tracer's part in the walk: the subsurface branch, the cache on the camera's
/// specular chain, and a light sample at every non-delta vertex.
struct PathTracer<'a> {
    ctx: &'a Context<'a>,
    cache: Option<&'a IrradianceCache>,
    /// Still on the camera's specular chain, where cache records are placed.
    on_chain: bool,
}

impl Scatter for PathTracer<'_> {
    fn scatter(&mut self, path: &mut PathState, s: &mut Shading, rng: &mut Rng) -> Next {
        let weight = s.surface.subsurface.weight;
        if weight > 0.0 && s.opaque {
            // Translucent surfaces are path traced: the cache holds no subsurface light.
            self.on_chain = false;
            if rng.uniform() < SUBSURFACE_BRANCH {
                return subsurface_branch(self.ctx, path, s, rng);
            }
            s.bsdf = s.bsdf.without_subsurface(weight);
            path.beta /= 1.0 - SUBSURFACE_BRANCH;
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

/// The subsurface branch at translucent `s`: leave the material at a point x_i found by a probe
/// ray, sample a light there through the entry lobe, and continue from x_i along a
/// cosine-sampled direction.
fn subsurface_branch(ctx: &Context, state: &mut PathState, s: &Shading, rng: &mut Rng) -> Next {
    let enter = s.surface.subsurface.weight * s.bsdf.base_transmittance() / SUBSURFACE_BRANCH;
    let Some((exit, rd_over_pdf)) = sample_exit(ctx, &s.sh, &s.frame, &s.surface, rng) else {
        return Next::End;
    };
    state.beta *= rd_over_pdf * enter;
    state.subsurface = true;
    let exit_frame = Frame::from_normal(exit.ng);
    let transmit = |wi: Vec3| {
        s.bsdf
            .viewed_from(exit_frame.to_local(wi))
            .base_transmittance()
    };
    let (beta, on) = (state.beta, state.light_path);
    let l = sample_direct_on(ctx, &exit, on, beta, true, rng, &mut state.rays, |wi| {
        let cos = wi.dot(exit.ng);
        if cos > 0.0 {
            (
                Vec3::splat(transmit(wi) * cos / PI),
                cosine_hemisphere_pdf(cos),
            )
        } else {
            (Vec3::ZERO, 0.0)
        }
    });
    state.add(0, l);
    let local = square_to_cosine_hemisphere(rng.uniform2());
    let wi = exit_frame.to_world(local).normalize();
    state.beta *= transmit(wi);
    if state.beta == Vec3::ZERO || !state.beta.is_finite() {
        return Next::End;
    }
    state.previous = Previous {
        p: exit.p,
        horizon: None,
        pdf: cosine_hemisphere_pdf(local.z),
        delta: false,
    };
    state.ray = exit.spawn(wi);
    state.light_path = on.after(Scattering::Diffuse, false);
    Next::Moved
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
