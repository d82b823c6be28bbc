//! Photon-map density estimation (Jensen 2001, ch. 7 and 8): the radiance estimate from the k
//! nearest photons, Christensen's precomputed irradiance (Christensen 1999, "Faster photon map
//! global illumination"), and which photons count as lying on the shaded surface.
//!
//! Radiance estimates use the k nearest photons within a maximum radius (relative to the scene's
//! bounding radius), L ≈ Σ f_r ΔΦ / (π r²), where r is the k-th distance (or the maximum radius
//! when fewer are found), discarding photons off the tangent plane (more than `PLANE_TOLERANCE`
//! of r away along the normal) and photons recorded on another side or surface (`on_surface`).
//!
//! Precomputed irradiance: after photon tracing, irradiance is estimated at about one global
//! photon in `irradiance_stride` from nearby photons on the same surface side and stored as
//! records in a kd-tree of their own; a final-gather hit reads the nearest record whose normal
//! agrees instead of a full k-nearest estimate.

use crate::accel::Visibility;
use crate::error::Result;
use crate::integrator::shading::Shading;
use crate::integrator::Context;
use crate::math::{Frame, Vec3};
use crate::photon_map::{in_first_half, Neighbors, Photon, PhotonMap};
use crate::progress::Progress;
use rayon::prelude::*;
use std::f32::consts::PI;

/// Photons further than this fraction of the search radius from the tangent plane are ignored.
pub const PLANE_TOLERANCE: f32 = 0.25;

/// How far from its photon a precomputed irradiance record serves, as a fraction of the radius
/// of the estimate it holds (`nearest_irradiance`).
const RECORD_REACH: f32 = 0.5;

/// Christensen's precomputation: irradiance at about one photon of `map` in `stride`, counting
/// only photons on the same side of the same surface (normal within ~60°, within a quarter
/// radius of the tangent plane, arriving from the normal's side). Each record is a photon whose
/// `power` is the irradiance and whose `incoming` direction is the surface normal.
///
/// The map is split in two halves (`in_first_half`). The first half decides where records sit
/// and how far each reaches (the radius of its k/2 nearest first-half photons); the second half
/// alone gives the irradiance, from its photons inside that radius. Which record serves a point
/// is then independent of the value it holds. With one set of photons for both, records whose
/// estimate came out low (a large radius, a sparse neighbourhood) reached further and served
/// more points, and the records read low by a bias proportional to 1/k that more photons never
/// removed.
pub fn precompute_irradiance(
    map: &PhotonMap,
    stride: u32,
    k: u32,
    max_radius2: f32,
    progress: &Progress,
) -> Result<Vec<Photon>> {
    let photons = map.photons();
    // Records sit at first-half photons, so where they are (and which one serves a point)
    // depends on the first half alone, like their reach; their irradiance on the second alone.
    let step = (stride as usize / 2).max(1);
    let ids: Vec<usize> = (0..photons.len())
        .filter(|&i| in_first_half(i))
        .step_by(step)
        .collect();
    let half_k = (k as usize).div_ceil(2);
    let records = ids
        .par_chunks(256)
        .map_init(
            || (Neighbors::default(), Vec::new()),
            |(first, second), chunk| {
                let mut out = Vec::with_capacity(chunk.len());
                // A cancelled build skips the remaining chunks (each is a few milliseconds).
                if progress.check().is_err() {
                    return out;
                }
                for &i in chunk {
                    let ph = &photons[i];
                    let (p, n) = (ph.position(), ph.normal());
                    // Leave the record's own photon out: counting it would add one photon's
                    // power to every record (1/k of it, more as generations shrink k).
                    let others = |q: &Photon| same_side(q, n) && !std::ptr::eq(q, ph);
                    map.nearest_split(p, half_k, max_radius2, first, second, others);
                    let r2 = first.radius2;
                    let r = r2.sqrt();
                    let mut sum = Vec3::ZERO;
                    for nb in second.iter() {
                        let q = &photons[nb.index as usize];
                        if on_surface(q, p, n, r) && q.incoming().dot(n) > 0.0 {
                            sum += q.power();
                        }
                    }
                    // The second half holds half of the photons.
                    let e = if r2 > 0.0 {
                        sum * (2.0 / (PI * r2))
                    } else {
                        Vec3::ZERO
                    };
                    let reach = (r2 / max_radius2).sqrt();
                    out.push(Photon::new(p, e, n, 0, false).with_reach(reach));
                }
                out
            },
        )
        .collect::<Vec<_>>()
        .concat();
    progress.check()?;
    Ok(records)
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
/// (cos > 0.9), that lies near its tangent plane, and that reaches `s`: no further than
/// `RECORD_REACH` times the radius of the estimate it holds. Records sit at photons, so they are
/// as dense as the light; without the reach test a point in shadow next to a bright patch takes
/// the patch's nearby records, and dim surfaces near bright ones come out too bright (+6 % on a
/// window-lit room). The reach and the record's value come from disjoint photons
/// (`precompute_irradiance`), so choosing by reach does not favour low values. `None` when no
/// record qualifies within `max_radius2`. With the irradiance, the radius of the estimate the
/// record holds.
pub fn nearest_irradiance(map: &PhotonMap, max_radius2: f32, s: &Shading) -> Option<(Vec3, f32)> {
    let accept = |rec: &Photon, dist2: f32| {
        let d = rec.position() - s.sh.p;
        let reach2 = max_radius2 * (RECORD_REACH * rec.reach()).powi(2);
        dist2 <= reach2
            && rec.incoming().dot(s.ng) >= 0.9
            && d.dot(s.ng).abs() <= PLANE_TOLERANCE * dist2.sqrt()
    };
    map.nearest_accepted(s.sh.p, max_radius2, accept)
        .map(|(i, _)| {
            let record = &map.photons()[i as usize];
            (record.power(), record.reach() * max_radius2.sqrt())
        })
}

/// Angular sectors of the disc around a shading point in which `Walls` looks for occluders.
const SECTORS: usize = 8;

/// How far the surface around a shading point is open in each of `SECTORS` directions of its
/// tangent plane, up to the search radius: a photon beyond a wall (the other side of a thin
/// occluder standing on the surface) lit a place the point does not see and must not count.
pub struct Walls {
    /// Open distance per sector, at most the search radius.
    open: [f32; SECTORS],
    frame: Frame,
}

impl Walls {
    /// One short ray per sector from `s`, rising 2 % above its tangent plane so that it leaves
    /// the surface itself; `rays` counts them.
    pub fn around(ctx: &Context, s: &Shading, radius: f32, rays: &mut u32) -> Walls {
        let frame = Frame::from_normal(s.ng);
        let open = std::array::from_fn(|i| {
            let angle = 2.0 * PI * (i as f32 + 0.5) / SECTORS as f32;
            let along = frame.s * angle.cos() + frame.t * angle.sin();
            let dir = (along + 0.02 * s.ng).normalize();
            let mut ray = s.sh.spawn(dir);
            ray.t_max = radius;
            *rays += 1;
            ctx.accel
                .intersect(ctx.scene, &ray, Visibility::Secondary)
                .map_or(radius, |hit| hit.t)
        });
        Walls { open, frame }
    }

    fn sector(&self, offset: Vec3) -> usize {
        let angle = offset.dot(self.frame.t).atan2(offset.dot(self.frame.s));
        let turn = angle.rem_euclid(2.0 * PI) / (2.0 * PI);
        ((turn * SECTORS as f32) as usize).min(SECTORS - 1)
    }

    /// Whether a photon at `offset` from the shading point lies on its side of every wall.
    fn sees(&self, offset: Vec3) -> bool {
        offset.length() <= self.open[self.sector(offset)]
    }

    /// The area of the open part of the disc of radius `r`, weighted by the cone filter when
    /// `cone` is set (∫ (1 − ρ/r) dA): πr² and πr²/3 without walls.
    fn area(&self, r: f32, cone: bool) -> f32 {
        let wedge = 2.0 * PI / SECTORS as f32;
        self.open
            .iter()
            .map(|&o| {
                let o = o.min(r);
                match cone {
                    true => wedge * (o * o / 2.0 - o * o * o / (3.0 * r)),
                    false => wedge * o * o / 2.0,
                }
            })
            .sum()
    }
}

/// Radiance leaving `s` towards its viewer estimated from `map`: Σ f_r ΔΦ / (π r²), with a cone
/// filter (k = 1, normalised by 1 − 2/3) when `cone` is set. With `walls` (`Walls::around` `s`
/// at the search radius, which the closure receives) photons behind a wall are left out and
/// the area is the open part of the disc. With `max_bounces` only photons stored after at most
/// that many bounces count (the render's bounce limit).
#[allow(clippy::too_many_arguments)]
pub fn radiance_estimate(
    map: &PhotonMap,
    k: u32,
    max_radius2: f32,
    cone: bool,
    s: &Shading,
    buf: &mut Neighbors,
    walls: Option<&mut dyn FnMut(f32) -> Walls>,
    max_bounces: Option<u32>,
) -> Vec3 {
    let counts = |q: &Photon| same_side(q, s.ng) && max_bounces.is_none_or(|m| q.bounces() <= m);
    map.nearest_where(s.sh.p, k as usize, max_radius2, buf, counts);
    if buf.is_empty() {
        return Vec3::ZERO;
    }
    let r2 = buf.radius2;
    let r = r2.sqrt();
    // The k-th photon lies on the circle it defines: the k − 1 inside it estimate the density
    // without bias, all k would overestimate it by k/(k − 1) (the cone filter gives it weight 0).
    let boundary = buf.boundary().filter(|_| !cone);
    // Pure Lambertian opaque surfaces: f_r = ρ/π on the viewer's side, no per-photon BSDF call.
    let rho = s.bsdf.diffuse_reflectance();
    let lambert = s.is_opaque_lambertian();
    let mut sum = Vec3::ZERO;
    let walls = walls.map(|around| around(r));
    for nb in buf.iter().filter(|nb| Some(nb.index) != boundary) {
        let ph = &map.photons()[nb.index as usize];
        if !on_surface(ph, s.sh.p, s.ng, r) {
            continue;
        }
        if walls
            .as_ref()
            .is_some_and(|w| !w.sees(ph.position() - s.sh.p))
        {
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
    let area = match &walls {
        Some(w) => w.area(r, cone),
        None if cone => PI * r2 / 3.0,
        None => PI * r2,
    };
    if area > 0.0 {
        sum / area
    } else {
        Vec3::ZERO
    }
}
