//! Photon-map density estimation (Jensen 2001, ch. 7 and 8): the radiance estimate from the k
//! nearest photons, Christensen's precomputed irradiance (Christensen 1999, "Faster photon map
//! global illumination"), and which photons count as lying on the shaded surface.
//!
//! Radiance estimates use the k nearest photons within a maximum radius (relative to the scene's
//! bounding radius), L ≈ Σ f_r ΔΦ / (π r²), where r is the k-th distance (or the maximum radius
//! when fewer are found), discarding photons off the tangent plane (more than `PLANE_TOLERANCE`
//! of r away along the normal) and photons recorded on another side or surface (`on_surface`).
//!
//! Precomputed irradiance: after photon tracing, irradiance is estimated at every
//! `irradiance_stride`-th global photon from its k nearest photons on the same surface side and
//! stored as records in a kd-tree of their own; a final-gather hit reads the nearest record whose
//! normal agrees instead of a full k-nearest estimate.

use crate::integrator::shading::Shading;
use crate::math::Vec3;
use crate::photon_map::{Neighbors, Photon, PhotonMap};
use rayon::prelude::*;
use std::f32::consts::PI;

/// Photons further than this fraction of the search radius from the tangent plane are ignored.
pub const PLANE_TOLERANCE: f32 = 0.25;

/// Christensen's precomputation: irradiance at every `stride`-th photon of `map` (in heap
/// order, which is spatially well mixed) from its k nearest photons, counting only photons on
/// the same side of the same surface (normal within ~60°, within a quarter radius of the
/// tangent plane, arriving from the normal's side). Each record is a photon whose `power` is the
/// irradiance and whose `incoming` direction is the surface normal.
pub fn precompute_irradiance(
    map: &PhotonMap,
    stride: u32,
    k: u32,
    max_radius2: f32,
) -> Vec<Photon> {
    let photons = map.photons();
    let step = stride.max(1) as usize;
    let ids: Vec<usize> = (0..photons.len()).step_by(step).collect();
    ids.par_chunks(1024)
        .map_init(Neighbors::default, |buf, chunk| {
            let mut out = Vec::with_capacity(chunk.len());
            for &i in chunk {
                let ph = &photons[i];
                let (p, n) = (ph.position(), ph.normal());
                map.nearest_where(p, k as usize, max_radius2, buf, |q| same_side(q, n));
                let r2 = buf.radius2;
                let r = r2.sqrt();
                let mut sum = Vec3::ZERO;
                for nb in buf.iter() {
                    let q = &photons[nb.index as usize];
                    if on_surface(q, p, n, r) && q.incoming().dot(n) > 0.0 {
                        sum += q.power();
                    }
                }
                let e = if r2 > 0.0 {
                    sum / (PI * r2)
                } else {
                    Vec3::ZERO
                };
                out.push(Photon::new(p, e, n, 0, false));
            }
            out
        })
        .collect::<Vec<_>>()
        .concat()
}

/// Whether photon `ph`, found within radius `r` of point `p` with normal `n`, lies on the same
/// side of the same surface: near the tangent plane, its recorded normal within ~60° of `n`. The
/// normal test keeps photons on the far side of a thin or strongly curved object (the outside of
/// a small sphere, seen from within) out of the estimate: without it light leaks through walls.
pub fn on_surface(ph: &Photon, p: Vec3, n: Vec3, r: f32) -> bool {
    (ph.position() - p).dot(n).abs() <= PLANE_TOLERANCE * r && same_side(ph, n)
}

/// Whether photon `ph` was stored on the side of a surface with normal `n` (its recorded normal
/// within ~60°). The k nearest photons are searched among these only: photons on the other face
/// of a zero-thickness plane (a roof's sunlit top above a ceiling) or on a nearby perpendicular
/// surface would otherwise shrink the radius until only a few same-side photons — a record's
/// own photon always among them — fall inside it, and the estimate is too bright and blotchy.
pub fn same_side(ph: &Photon, n: Vec3) -> bool {
    ph.normal().dot(n) > 0.5
}

/// The nearest precomputed irradiance record to `s` whose normal agrees with the surface's
/// (cos > 0.9) and that lies near its tangent plane; `None` when there is none within
/// `max_radius2`.
pub fn nearest_irradiance(map: &PhotonMap, max_radius2: f32, s: &Shading) -> Option<Vec3> {
    let accept = |rec: &Photon, dist2: f32| {
        let d = rec.position() - s.sh.p;
        rec.incoming().dot(s.ng) >= 0.9 && d.dot(s.ng).abs() <= PLANE_TOLERANCE * dist2.sqrt()
    };
    map.nearest_accepted(s.sh.p, max_radius2, accept)
        .map(|(i, _)| map.photons()[i as usize].power())
}

/// Radiance leaving `s` towards its viewer estimated from `map`: Σ f_r ΔΦ / (π r²), with a cone
/// filter (k = 1, normalised by 1 − 2/3) when `cone` is set.
pub fn radiance_estimate(
    map: &PhotonMap,
    k: u32,
    max_radius2: f32,
    cone: bool,
    s: &Shading,
    buf: &mut Neighbors,
) -> Vec3 {
    map.nearest_where(s.sh.p, k as usize, max_radius2, buf, |q| same_side(q, s.ng));
    if buf.is_empty() {
        return Vec3::ZERO;
    }
    let r2 = buf.radius2;
    let r = r2.sqrt();
    // Pure Lambertian opaque surfaces: f_r = ρ/π on the viewer's side, no per-photon BSDF call.
    let rho = s.bsdf.diffuse_reflectance();
    let lambert = s.is_opaque_lambertian();
    let mut sum = Vec3::ZERO;
    for nb in buf.iter() {
        let ph = &map.photons()[nb.index as usize];
        if !on_surface(ph, s.sh.p, s.ng, r) {
            continue;
        }
        let wi = ph.incoming();
        let f = if lambert {
            if wi.dot(s.ng) > 0.0 {
                rho * (1.0 / PI)
            } else {
                continue;
            }
        } else {
            let wl = s.frame.to_local(wi);
            if wl.z.abs() < 1e-6 {
                continue;
            }
            s.bsdf.eval(wl) / wl.z.abs()
        };
        let w = if cone { 1.0 - nb.dist2.sqrt() / r } else { 1.0 };
        sum += f * ph.power() * w;
    }
    let area = if cone { PI * r2 / 3.0 } else { PI * r2 };
    sum / area
}
