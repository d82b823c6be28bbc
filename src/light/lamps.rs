//! Lamps: a point or spot light with a radius as Cycles 4 defines it (`kernel/light/point.h`,
//! `spot.h`): uniform radiance I / (πr²) over a disc of radius r facing the point it lights
//! (Blender's Soft Falloff, the default) or over a sphere. Light sampling draws a direction
//! uniformly in the cone the lamp fills; rays that surfaces scatter meet it too
//! (`Lights::lamps_met`, which the camera walk calls on every segment), so both are weighted by
//! MIS with the same density, select probability / the cone's solid angle. Lamps are not
//! geometry: rays pass through them, shadow rays ignore them; past eight lamps a small BVH over
//! their spheres (`LampSet`) keeps a ray from testing them all. Point and spot lights without a
//! radius are sampled here too, as the delta lights they are.

use super::emission::smoothstep;
use super::source::{LightSample, LightSource};
use crate::accel::Ray;
use crate::interaction::LightPoint;
use crate::math::{Frame, Vec2, Vec3};
use crate::scene::Lamp;
use std::f32::consts::PI;

/// Position, radius and ray visibility of a point or spot light; `None` for other lights.
pub fn lamp_of(source: &LightSource) -> Option<(Vec3, f32, Lamp)> {
    match *source {
        LightSource::Point {
            position,
            radius,
            lamp,
            ..
        }
        | LightSource::Spot {
            position,
            radius,
            lamp,
            ..
        } => Some((position, radius, lamp)),
        _ => None,
    }
}

/// A spot's own cone as light sampling may draw from it (`LampCone::sampled`): the axis
/// pointing back along the spot's direction and 1 − cos of its outer half-angle; `None` for
/// other lights.
pub(super) fn spot_spread(source: &LightSource) -> Option<(Vec3, f32)> {
    match *source {
        LightSource::Spot {
            direction,
            cos_outer,
            ..
        } => Some((-direction, 1.0 - cos_outer)),
        _ => None,
    }
}

/// A lamp's cone seen from a point (`lamp_cone`).
#[derive(Clone, Copy, Debug)]
pub(super) struct LampCone {
    /// Unit direction from the point to the lamp's centre.
    to_centre: Vec3,
    /// Distance to the centre.
    distance: f32,
    /// 1 − cos of the cone's half-angle (kept apart: it is tiny for small lamps); 2 inside
    /// a sphere, whose every direction meets the lamp.
    one_minus_cos: f32,
    /// The point is inside the sphere: rays meet its far side, and a spot's cone does not dim
    /// it (as in Cycles).
    inside: bool,
}

/// The cone of directions in which a lamp of radius `radius` at `position` is seen from `p`:
/// a sphere's (sin θ = r/d; inside it, the whole sphere of directions, drawn uniformly where
/// Cycles draws the hemisphere by cosine) or, with Soft Falloff, a disc's facing `p`
/// (tan θ = r/d), all of uniform radiance. `None` where the lamp is a point from `p`: radius
/// 0, `p` at its centre, or so far that the cone is numerically a point.
pub(super) fn lamp_cone(
    position: Vec3,
    radius: f32,
    soft_falloff: bool,
    p: Vec3,
) -> Option<LampCone> {
    let d = position - p;
    let d2 = d.length_squared();
    let r2 = radius * radius;
    if !(radius > 0.0 && d2 > 0.0 && d2.is_finite()) {
        return None;
    }
    let distance = d2.sqrt();
    let inside = !soft_falloff && d2 <= r2;
    let one_minus_cos = if soft_falloff {
        // 1 − d/h with h² = d² + r², written without cancellation.
        let h = (d2 + r2).sqrt();
        r2 / (h * (h + distance))
    } else if inside {
        2.0
    } else {
        let sin2 = r2 / d2;
        sin2 / (1.0 + (1.0 - sin2).sqrt())
    };
    (one_minus_cos > MIN_LAMP_CONE).then(|| LampCone {
        to_centre: d / distance,
        distance,
        one_minus_cos,
        inside,
    })
}

/// Smallest 1 − cos θ of a lamp's cone that is sampled as a cone; narrower ones are points.
pub(super) const MIN_LAMP_CONE: f32 = 1e-6;

/// A direction drawn uniformly with `u` in the cone around unit `axis` whose half-angle has
/// 1 − cos = `one_minus_cos` (the sine from 1 − cos, which keeps its digits in narrow cones).
pub(super) fn cone_direction(axis: Vec3, one_minus_cos: f32, u: Vec2) -> Vec3 {
    let one_minus_z = u.x * one_minus_cos;
    let z = 1.0 - one_minus_z;
    let r = (one_minus_z * (2.0 - one_minus_z)).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Frame::from_normal(axis).to_world(Vec3::new(r * phi.cos(), r * phi.sin(), z))
}

impl LampCone {
    /// The cone light sampling draws from (1 − cos and axis): the lamp's, or, as Cycles does,
    /// a spot's own cone around the reversed spot direction (`spread`: that axis and its
    /// 1 − cos) where it is the narrower, since no direction outside it carries light. Inside a
    /// sphere the lamp's.
    pub(super) fn sampled(&self, spread: Option<(Vec3, f32)>) -> (Vec3, f32) {
        match spread {
            Some((axis, omc)) if !self.inside && omc < self.one_minus_cos => (axis, omc),
            _ => (self.to_centre, self.one_minus_cos),
        }
    }

    /// Density per solid angle with which light sampling draws a direction that meets the lamp
    /// (uniform in the cone `sampled` gives).
    pub(super) fn pdf(&self, spread: Option<(Vec3, f32)>) -> f32 {
        1.0 / (2.0 * PI * self.sampled(spread).1)
    }

    /// Distance along unit direction `w` from the cone's apex to the lamp (the near side of
    /// the sphere, its far side from inside, or the disc through the centre facing the apex);
    /// `None` when `w` misses it.
    pub(super) fn hit(&self, w: Vec3, radius: f32, soft_falloff: bool) -> Option<f32> {
        let c = self.to_centre * self.distance;
        let along = w.dot(c);
        // Squared distance of the centre from the line, from the cross product: no
        // cancellation for nearly head-on rays.
        let off2 = w.cross(c).length_squared();
        let r2 = radius * radius;
        if self.inside {
            return Some(along + (r2 - off2).max(0.0).sqrt());
        }
        if along <= 0.0 {
            return None;
        }
        if soft_falloff {
            // Within the disc: tan α ≤ r/d.
            (off2 * self.distance * self.distance <= r2 * along * along)
                .then(|| self.distance * self.distance / along)
        } else {
            (off2 <= r2).then(|| along - (r2 - off2).max(0.0).sqrt())
        }
    }
}

/// A light sample towards a point or spot light, and the factor that turns its intensity into
/// the radiance arriving along the sample's direction (before a spot's cone).
pub(super) struct PunctualSample {
    sample: LightSample,
    scale: f32,
    /// `p` is inside a sphere lamp (`LampCone::inside`).
    inside: bool,
}

/// Direction towards a point or spot light seen from `p`. With a lamp's cone (`lamp_cone`) the
/// direction is drawn uniformly in it and the radiance is I / (πr²) (the lamp's projected area
/// is πr²; far away this gives the point's I / d²), a sample BSDF rays can also find when
/// `lamp.bounces` (a spot's `spread`, `spot_spread`, may narrow the cone drawn from:
/// `LampCone::sampled`). Without one, a true point: I / d², density 1, delta.
pub(super) fn sample_punctual(
    position: Vec3,
    radius: f32,
    lamp: Lamp,
    spread: Option<(Vec3, f32)>,
    p: Vec3,
    u: Vec2,
) -> Option<PunctualSample> {
    let Some(cone) = lamp_cone(position, radius, lamp.soft_falloff, p) else {
        let d = position - p;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0) {
            return None;
        }
        let sample = LightSample {
            li: Vec3::ZERO,
            wi: d / dist2.sqrt(),
            pdf: 1.0,
            delta: true,
            target: LightPoint {
                p: position,
                p_error: Vec3::ZERO,
                n: Vec3::ZERO,
                distant: false,
            },
            blockers: 0,
        };
        return Some(PunctualSample {
            sample,
            scale: 1.0 / dist2,
            inside: false,
        });
    };
    let (axis, one_minus_cos) = cone.sampled(spread);
    let wi = cone_direction(axis, one_minus_cos, u);
    // Drawn in the lamp's cone the direction meets it (to rounding); in a spot's narrower cone
    // it may not.
    let t = match cone.hit(wi, radius, lamp.soft_falloff) {
        Some(t) => t,
        None if one_minus_cos == cone.one_minus_cos => cone.distance,
        None => return None,
    };
    let q = p + wi * t;
    let target = LightPoint {
        p: q,
        p_error: crate::math::gamma(8) * (q.abs() + position.abs()),
        n: (q - position).normalize_or(-wi),
        distant: false,
    };
    let sample = LightSample {
        li: Vec3::ZERO,
        wi,
        pdf: cone.pdf(spread),
        delta: !lamp.bounces,
        target,
        blockers: 0,
    };
    Some(PunctualSample {
        sample,
        scale: 1.0 / (PI * radius * radius),
        inside: cone.inside,
    })
}

/// A light sample from `p` towards a point or spot light (`None` for other sources): a
/// direction in the cone a lamp fills, or the direction to a point; a spot's cone evaluated
/// along it.
pub(super) fn sample_punctual_light(source: &LightSource, p: Vec3, u: Vec2) -> Option<LightSample> {
    match *source {
        LightSource::Point {
            position,
            intensity,
            radius,
            lamp,
        } => {
            let s = sample_punctual(position, radius, lamp, None, p, u)?;
            Some(LightSample {
                li: intensity * s.scale,
                ..s.sample
            })
        }
        LightSource::Spot {
            position,
            direction,
            intensity,
            cos_inner,
            cos_outer,
            radius,
            lamp,
        } => {
            let spread = spot_spread(source);
            let s = sample_punctual(position, radius, lamp, spread, p, u)?;
            // As Cycles: the cone is evaluated along the sampled ray, from the sampled point
            // of the lamp, which widens it by about the radius (a point: from the centre).
            let falloff = match s.inside {
                true => 1.0,
                false => smoothstep(cos_outer, cos_inner, -s.sample.wi.dot(direction)),
            };
            if falloff <= 0.0 {
                return None;
            }
            Some(LightSample {
                li: intensity * (falloff * s.scale),
                ..s.sample
            })
        }
        _ => None,
    }
}

/// The lamps (point and spot lights with a radius that some rays see) and, when there are many,
/// a bounding-volume hierarchy over their spheres, so a ray tests only the lamps near it.
#[derive(Default)]
pub(super) struct LampSet {
    /// Indices into `Lights::sources`, in the hierarchy's order.
    lamps: Vec<u32>,
    /// The hierarchy's nodes, root first; empty when the lamps are few enough to test all.
    nodes: Vec<LampNode>,
    /// Some lamp is seen by scattered rays.
    seen_by_bounces: bool,
}

/// Lamps tested one by one below this count; a hierarchy above it.
pub(super) const LAMPS_WITHOUT_TREE: usize = 8;

/// A node of `LampSet`'s hierarchy: the bounds of its lamps' spheres and either two children
/// (`count` 0, the second at `index`; the first follows the node) or `count` lamps from
/// `index`.
#[derive(Clone, Copy, Debug)]
pub(super) struct LampNode {
    min: Vec3,
    max: Vec3,
    index: u32,
    count: u32,
}

impl LampSet {
    /// Whether no ray can meet a lamp.
    pub(super) fn is_empty(&self) -> bool {
        self.lamps.is_empty()
    }

    pub(super) fn new(sources: &[LightSource]) -> LampSet {
        let mut lamps: Vec<u32> = Vec::new();
        let mut seen_by_bounces = false;
        for (i, source) in sources.iter().enumerate() {
            if let Some((_, radius, lamp)) = lamp_of(source) {
                if radius > 0.0 && (lamp.camera || lamp.bounces) {
                    lamps.push(i as u32);
                    seen_by_bounces |= lamp.bounces;
                }
            }
        }
        let mut set = LampSet {
            lamps,
            nodes: Vec::new(),
            seen_by_bounces,
        };
        if set.lamps.len() > LAMPS_WITHOUT_TREE {
            let bounds = |i: u32| {
                let (c, r, _) = lamp_of(&sources[i as usize]).unwrap_or_default();
                (c - Vec3::splat(r), c + Vec3::splat(r))
            };
            let n = set.lamps.len();
            set.build(0, n, &bounds);
        }
        set
    }

    /// Append the subtree over `lamps[start..end]`, split at the median of the longest axis.
    pub(super) fn build(
        &mut self,
        start: usize,
        end: usize,
        bounds: &impl Fn(u32) -> (Vec3, Vec3),
    ) {
        let (mut min, mut max) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &i in &self.lamps[start..end] {
            let (lo, hi) = bounds(i);
            min = min.min(lo);
            max = max.max(hi);
        }
        let node = self.nodes.len();
        self.nodes.push(LampNode {
            min,
            max,
            index: start as u32,
            count: (end - start) as u32,
        });
        if end - start <= 2 {
            return;
        }
        let axis = (max - min).max_position();
        let centre = |i: &u32| {
            let (lo, hi) = bounds(*i);
            (lo + hi)[axis]
        };
        let mid = (start + end) / 2;
        self.lamps[start..end]
            .select_nth_unstable_by(mid - start, |a, b| centre(a).total_cmp(&centre(b)));
        self.build(start, mid, bounds);
        let second = self.nodes.len() as u32;
        self.build(mid, end, bounds);
        self.nodes[node].index = second;
        self.nodes[node].count = 0;
    }

    /// Call `visit` with every lamp whose bounds the segment from `o` along unit `w` up to
    /// `reach` passes.
    pub(super) fn candidates(&self, o: Vec3, w: Vec3, reach: f32, mut visit: impl FnMut(u32)) {
        if self.nodes.is_empty() {
            self.lamps.iter().for_each(|&i| visit(i));
            return;
        }
        let inv = w.recip();
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let at = stack[top];
            let node = self.nodes[at as usize];
            let t0 = (node.min - o) * inv;
            let t1 = (node.max - o) * inv;
            let near = t0.min(t1).max_element().max(0.0);
            let far = t0.max(t1).min_element().min(reach);
            // NaN (a zero direction component on a slab's plane) keeps the node.
            if near > far {
                continue;
            }
            if node.count > 0 {
                let range = node.index as usize..(node.index + node.count) as usize;
                self.lamps[range].iter().for_each(|&i| visit(i));
            } else if top + 2 <= stack.len() {
                stack[top] = node.index;
                stack[top + 1] = at + 1;
                top += 2;
            }
        }
    }

    /// Some lamp is seen by scattered rays.
    pub(super) fn seen_by_bounces(&self) -> bool {
        self.seen_by_bounces
    }

    /// The lamps `ray` meets before distance `reach` along it, as `Lights::lamps_met` says:
    /// for each, `visit(light, radiance, pdf, distance)` with `pdf` the density of light
    /// sampling's direction once the lamp is picked.
    pub(super) fn met(
        &self,
        sources: &[LightSource],
        ray: &Ray,
        reach: f32,
        camera: bool,
        mut visit: impl FnMut(u32, Vec3, f32, f32),
    ) {
        if self.lamps.is_empty() {
            return;
        }
        let length = ray.direction.length();
        if !(length > 0.0 && length.is_finite()) {
            return;
        }
        let (o, w) = (ray.origin, ray.direction / length);
        self.candidates(o, w, reach, |i| {
            let source = &sources[i as usize];
            let Some((position, radius, lamp)) = lamp_of(source) else {
                return;
            };
            if !(if camera { lamp.camera } else { lamp.bounces }) {
                return;
            }
            // Most rays pass wide of a lamp: both its sphere and its disc lie within r of the
            // centre, which the ray must pass ahead of its origin.
            let c = position - o;
            let r2 = radius * radius;
            let ahead = c.dot(w) > 0.0 && w.cross(c).length_squared() <= r2;
            if !ahead && (lamp.soft_falloff || c.length_squared() > r2) {
                return;
            }
            let Some(cone) = lamp_cone(position, radius, lamp.soft_falloff, o) else {
                return;
            };
            let Some(t) = cone.hit(w, radius, lamp.soft_falloff) else {
                return;
            };
            if t >= reach {
                return;
            }
            let radiance = match *source {
                LightSource::Point { intensity, .. } => intensity,
                LightSource::Spot {
                    intensity,
                    direction,
                    cos_inner,
                    cos_outer,
                    ..
                } if !cone.inside => {
                    intensity * smoothstep(cos_outer, cos_inner, -w.dot(direction))
                }
                LightSource::Spot { intensity, .. } => intensity,
                _ => Vec3::ZERO,
            } / (PI * radius * radius);
            if radiance != Vec3::ZERO {
                visit(i, radiance, cone.pdf(spot_spread(source)), t);
            }
        });
    }
}
