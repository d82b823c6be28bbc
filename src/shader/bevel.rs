//! Blender's Bevel node as Cycles 4.5 evaluates it (`svm_bevel`): a normal averaged over the
//! surface of the point's own object within Radius, which rounds hard edges. Each of `samples`
//! probes picks an axis of the geometric normal's frame (the normal with probability ½, each
//! tangent ¼), a point on the disc of that axis around the shading point by the cubic falloff
//! (10 (R − r)³ / (π R⁵), the profile Cycles borrows from its cubic BSSRDF), and a segment
//! through the disc along the axis, as long as the sphere of radius R is thick there; every
//! surface of the object the segment crosses adds its smooth normal, weighted by the falloff
//! at its true distance over the falloff the disc point was drawn with and by the power
//! heuristic over the three axes that could have found it (King, Kulla, Conty & Fajardo 2013,
//! "BSSRDF Importance Sampling"). A linked Normal input keeps its own direction and gains the
//! rounding (the input plus the averaged normal minus the shading normal). Without a scene to
//! trace, for rays after a diffuse bounce (Cycles bevels only rays of a high pdf) and where
//! nothing was found, the node gives the normal.

use super::inputs::{input, normal_input, v3, Operands, RayPath, SceneRays, ShadingInputs};
use super::inputs::{LocalHit, Socket, Tracing, Ty};
use crate::math::{Frame, Vec2, Vec3, Vec4};
use std::f32::consts::PI;

pub(super) const BEVEL_INPUTS: &[Socket] = &[
    Socket::float("Radius", 0.05),
    Socket::vector("Normal", Vec4::ZERO),
];
pub(super) const BEVEL_OUTPUTS: &[Socket] = &[Socket::output("Normal", Ty::Vector)];

/// The Bevel node's Normal at the shading point `at` with `samples` probes; `stream` names the
/// node's random numbers (`Tracing::point`).
pub(super) fn eval_bevel(
    samples: u32,
    at: &ShadingInputs,
    tracing: Option<&Tracing>,
    stream: u64,
    ins: &impl Operands,
) -> Vec4 {
    const RADIUS: usize = input(BEVEL_INPUTS, "Radius");
    const NORMAL: usize = input(BEVEL_INPUTS, "Normal");
    let n = at.normal;
    let blurry = at.path.diffuse > 0 || at.path.is(RayPath::DIFFUSE);
    let rounded = match tracing {
        Some(t) if !blurry => averaged_normal(
            t.scene,
            at.points[0].position,
            ins.float(RADIUS),
            samples,
            |k| t.point(stream, k),
        )
        .map_or(n, |sum| if at.backfacing { -sum } else { sum }),
        _ => n,
    };
    let given = ins.value(NORMAL);
    if given.truncate() == Vec3::ZERO {
        v3(rounded)
    } else {
        v3((normal_input(given, n) + (rounded - n)).normalize_or(n))
    }
}

/// The unit normal averaged over `scene`'s surface of the point's object around `p` within
/// `radius` by `samples` probes (the k-th from `point(k)`), of the surface's winding; `None`
/// when nothing was found.
pub(super) fn averaged_normal(
    scene: &dyn SceneRays,
    p: Vec3,
    radius: f32,
    samples: u32,
    point: impl Fn(u32) -> Vec2,
) -> Option<Vec3> {
    if !(radius > 0.0) || samples == 0 {
        return None;
    }
    let frame = Frame::from_normal(scene.geometric_normal());
    let mut sum = Vec3::ZERO;
    for k in 0..samples {
        let u = point(k);
        // The axis the probe runs along (`axes[0]`) and the two spanning its disc, each with
        // the probability of picking it.
        let (axes, pick, x) = if u.x < 0.5 {
            ([frame.n, frame.s, frame.t], [0.5, 0.25, 0.25], u.x * 2.0)
        } else if u.x < 0.75 {
            (
                [frame.s, frame.n, frame.t],
                [0.25, 0.5, 0.25],
                (u.x - 0.5) * 4.0,
            )
        } else {
            (
                [frame.t, frame.s, frame.n],
                [0.25, 0.25, 0.5],
                (u.x - 0.75) * 4.0,
            )
        };
        let r = radius * cubic_radius(u.y);
        let height = (radius * radius - r * r).max(0.0).sqrt();
        let phi = 2.0 * PI * x;
        let on_disc = r * (phi.cos() * axes[1] + phi.sin() * axes[2]);
        let origin = p + height * axes[0] + on_disc;
        let drawn = cubic_falloff(radius, r);
        scene.local_hits(origin, -axes[0], 2.0 * height, &mut |hit: LocalHit| {
            let pdf = [0, 1, 2].map(|a| pick[a] * axes[a].dot(hit.geometric_normal).abs());
            let mis = pdf[0] / (pdf[0] * pdf[0] + pdf[1] * pdf[1] + pdf[2] * pdf[2]);
            let falloff = cubic_falloff(radius, (hit.position - p).length());
            if mis.is_finite() && drawn > 0.0 {
                sum += mis * falloff / drawn * hit.normal;
            }
        });
    }
    let n = sum.normalize_or_zero();
    (n != Vec3::ZERO).then_some(n)
}

/// The cubic falloff at distance `r` within `radius`: 10 (R − r)³ / (π R⁵), a density over
/// the disc of radius R.
fn cubic_falloff(radius: f32, r: f32) -> f32 {
    if r >= radius {
        return 0.0;
    }
    let f = radius - r;
    10.0 * f * f * f / (PI * radius.powi(5))
}

/// The radius, as a fraction of R, at which the cubic falloff's distribution over the disc
/// reaches `xi`: the root x in [0, 1] of 10x² − 20x³ + 15x⁴ − 4x⁵ = ξ, by Newton's steps from
/// ¼ (the polynomial rises monotonically from 0 to 1 on [0, 1]).
fn cubic_radius(xi: f32) -> f32 {
    let mut x = 0.25f32;
    for _ in 0..10 {
        let x2 = x * x;
        let f = x2 * (10.0 - 20.0 * x + 15.0 * x2 - 4.0 * x2 * x) - xi;
        let slope = 20.0 * x * (1.0 - x).powi(3);
        if f.abs() < 1e-6 || slope == 0.0 {
            break;
        }
        x = (x - f / slope).clamp(0.0, 1.0);
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A right-angled edge along y through the origin: the top face z = 0 for x < 0 (normal
    /// +Z) and the side face x = 0 for z < 0 (normal +X), both of the point's object.
    struct Edge;

    impl SceneRays for Edge {
        fn occluded(&self, _: Vec3, _: f32, _: bool) -> bool {
            false
        }
        fn local_hits(&self, o: Vec3, d: Vec3, length: f32, visit: &mut dyn FnMut(LocalHit)) {
            let mut hits = Vec::new();
            for (axis, inside) in [(Vec3::Z, Vec3::X), (Vec3::X, Vec3::Z)] {
                let t = -o.dot(axis) / d.dot(axis);
                let q = o + t * d;
                if t >= 0.0 && t <= length && q.dot(inside) < 0.0 {
                    hits.push((t, axis, q));
                }
            }
            hits.sort_by(|a, b| a.0.total_cmp(&b.0));
            for (_, axis, q) in hits {
                visit(LocalHit {
                    position: q,
                    geometric_normal: axis,
                    normal: axis,
                });
            }
        }
        fn geometric_normal(&self) -> Vec3 {
            Vec3::Z
        }
    }

    fn bevel_at(x: f32) -> Vec3 {
        let tracing = Tracing {
            scene: &Edge,
            seed: 11,
        };
        let mut at = ShadingInputs {
            normal: Vec3::Z,
            ..ShadingInputs::default()
        };
        at.points[0].position = Vec3::new(x, 0.3, 0.0);
        let ins = [crate::shader::inputs::splat(0.1), Vec4::ZERO];
        eval_bevel(1024, &at, Some(&tracing), 5, &ins).truncate()
    }

    #[test]
    fn cubic_radius_inverts_the_falloffs_distribution() {
        // The distribution's integral of 2π r f(r) over [0, x R] is 10x² − 20x³ + 15x⁴ − 4x⁵.
        for xi in [0.01f32, 0.2, 0.5, 0.8, 0.99] {
            let x = cubic_radius(xi);
            let n = 4000;
            let dr = x / n as f32;
            let integral: f32 = (0..n)
                .map(|i| {
                    let r = (i as f32 + 0.5) * dr;
                    2.0 * PI * r * cubic_falloff(1.0, r) * dr
                })
                .sum();
            assert!((integral - xi).abs() < 1e-3, "{xi}: {x} gives {integral}");
        }
    }

    #[test]
    fn bevel_rounds_an_edge_and_leaves_a_face_flat() {
        // Farther from the edge than the radius: the face's own normal.
        let far = bevel_at(-0.25);
        assert!((far - Vec3::Z).length() < 1e-5, "{far}");
        // On the edge: halfway between the two faces' normals, by symmetry.
        let edge = bevel_at(0.0);
        let halfway = Vec3::new(1.0, 0.0, 1.0).normalize();
        assert!((edge - halfway).length() < 0.03, "{edge}");
        // Between: leaning towards the side face, less than halfway.
        let near = bevel_at(-0.03);
        assert!(near.x > 0.02 && near.x < near.z, "{near}");
        // A linked Normal keeps its direction and gains the rounding; no scene: the input.
        let ins = [
            crate::shader::inputs::splat(0.1),
            Vec4::new(0.0, 1.0, 1.0, 0.0),
        ];
        let at = ShadingInputs {
            normal: Vec3::Z,
            ..ShadingInputs::default()
        };
        let given = eval_bevel(4, &at, None, 0, &ins).truncate();
        assert!((given - Vec3::new(0.0, 1.0, 1.0).normalize()).length() < 1e-6);
    }
}
