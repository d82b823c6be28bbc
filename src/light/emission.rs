//! Emission evaluated where light leaves a surface: the radiance an emitting surface sends
//! towards a direction (with Cycles' area-light spread, a soft box that narrows the emission
//! and keeps the power), and the points drawn on emissive triangles and instances that light
//! sampling and photon emission share, their radiance evaluated as Cycles evaluates a sampled
//! emitter.

use crate::bsdf::Bsdf;
use crate::interaction::{LightPoint, SurfaceHit};
use crate::material::{from_closure, SurfaceMaterial};
use crate::math::{Affine3A, Frame, Mat3, Vec2, Vec3};
use crate::sampling::square_to_triangle;
use crate::scene::{Mesh, Scene};
use crate::shader::RayPath;

pub fn smoothstep(edge0: f32, edge1: f32, x: f32) -> f32 {
    if edge1 <= edge0 {
        return if x >= edge0 { 1.0 } else { 0.0 };
    }
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Smallest spread an area light is given: narrower ones are lasers that nothing samples.
pub(super) const MIN_SPREAD: f32 = 1e-3;

/// Cycles' area-light spread as a factor on the radiance towards a direction at cos a to the
/// normal: a soft-box grid lets through (tan h − tan a) / (tan h − h) for a < h = spread/2, and
/// nothing beyond. The cosine-weighted integral of the factor over the hemisphere is π, so the
/// light's power is unchanged. 1 without a spread.
pub fn spread_factor(spread: Option<f32>, cos: f32) -> f32 {
    let Some(spread) = spread else {
        return 1.0;
    };
    if cos <= 0.0 {
        return 0.0;
    }
    let half = 0.5 * spread.max(MIN_SPREAD);
    let tan_half = half.tan();
    let tan_a = (1.0 - cos * cos).max(0.0).sqrt() / cos;
    // tan h − h loses its digits for small h; its series h³/3 does not.
    let normalize = if half > 0.05 {
        1.0 / (tan_half - half)
    } else {
        3.0 / (half * half * half)
    };
    ((tan_half - tan_a) * normalize).max(0.0)
}

/// The part of an area light's triangle that can light a point through the light's spread
/// (Cycles samples only the part of a spread area light that the soft box lets through, as
/// this does): the spread's cone from the point meets the light's plane in a disc about the
/// point's projection, of radius (distance to the plane) × tan(spread / 2); outside it the
/// emission towards the point is zero (`spread_factor`). The window is the disc's bounding
/// square clipped to the triangle's bounding box, in the triangle's plane, and points are
/// drawn uniformly in it (those off the triangle are no sample): where it is smaller than the
/// triangle, this puts more of the samples where the light reaches the point.
#[derive(Clone, Copy, Debug)]
pub struct SpreadWindow {
    /// The triangle's first corner and the plane's axes (x along its first edge).
    origin: Vec3,
    x: Vec3,
    y: Vec3,
    /// The triangle's second and third corners in the plane (its first at the origin).
    second: f32,
    third: Vec2,
    /// The window, in the plane's coordinates.
    lo: Vec2,
    hi: Vec2,
}

impl SpreadWindow {
    /// The window of triangle `v` (world space) seen from `p` through a spread of `spread`
    /// radians; `None` where it is no smaller than the triangle (a wide spread, or a point
    /// far from the plane), and sampling the whole triangle is as good.
    pub fn new(v: [Vec3; 3], p: Vec3, spread: f32) -> Option<SpreadWindow> {
        let half = 0.5 * spread.max(MIN_SPREAD);
        if !(half < 1.5) {
            return None;
        }
        let (edge1, edge2) = (v[1] - v[0], v[2] - v[0]);
        let second = edge1.length();
        let n = edge1.cross(edge2).normalize_or_zero();
        if !(second > 0.0) || n == Vec3::ZERO {
            return None;
        }
        let x = edge1 / second;
        let y = n.cross(x);
        let third = Vec2::new(edge2.dot(x), edge2.dot(y));
        let rel = p - v[0];
        let centre = Vec2::new(rel.dot(x), rel.dot(y));
        let radius = rel.dot(n).abs() * half.tan();
        let box_lo = Vec2::new(third.x.min(0.0), third.y.min(0.0));
        let box_hi = Vec2::new(third.x.max(second), third.y.max(0.0));
        let window = SpreadWindow {
            origin: v[0],
            x,
            y,
            second,
            third,
            lo: (centre - Vec2::splat(radius)).max(box_lo),
            hi: (centre + Vec2::splat(radius)).min(box_hi),
        };
        let triangle = 0.5 * second * third.y.abs();
        (window.area() < triangle).then_some(window)
    }

    /// The window's area (zero when the disc misses the triangle's box).
    pub fn area(&self) -> f32 {
        let size = (self.hi - self.lo).max(Vec2::ZERO);
        size.x * size.y
    }

    /// The barycentric coordinates (of the second and third corners) of the point drawn
    /// uniformly in the window with `u`; `None` when it falls off the triangle.
    pub fn sample(&self, u: Vec2) -> Option<Vec2> {
        if !(self.area() > 0.0) {
            return None;
        }
        let q = self.lo + (self.hi - self.lo) * u;
        let b2 = q.y / self.third.y;
        let b1 = (q.x - b2 * self.third.x) / self.second;
        (b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0).then_some(Vec2::new(b1, b2))
    }

    /// Whether `point` (on the triangle's plane) lies in the window.
    pub fn contains(&self, point: Vec3) -> bool {
        let rel = point - self.origin;
        let q = Vec2::new(rel.dot(self.x), rel.dot(self.y));
        q.cmpge(self.lo).all() && q.cmple(self.hi).all()
    }
}

/// Emitted radiance of a surface towards `wo` (unit, pointing away from the surface), whose
/// material evaluated there emits `emission` (`SurfaceMaterial::emission`).
pub fn emitted_radiance(scene: &Scene, hit: &SurfaceHit, wo: Vec3, emission: Vec3) -> Vec3 {
    let material = &scene.materials[hit.material as usize];
    if !material.is_emissive() {
        return Vec3::ZERO;
    }
    if !material.double_sided && wo.dot(hit.ng) <= 0.0 {
        return Vec3::ZERO;
    }
    let spread = crate::accel::hit_mesh(scene, &hit.hit).emission_spread;
    emission * spread_factor(spread, wo.dot(hit.ng).abs())
}

/// A material's emitted radiance at texture coordinate `uv` (emission × emissive texture).
pub(super) fn material_emission(
    scene: &Scene,
    material: &crate::scene::Material,
    uv: Vec2,
) -> Vec3 {
    match &material.emissive_texture {
        Some(tex) => {
            material.emission
                * scene.textures[tex.texture as usize]
                    .sample(tex.apply(uv))
                    .truncate()
        }
        None => material.emission,
    }
}

/// The emission of `surface` towards unit direction `wo` at a point whose shading normal `n`
/// faces `wo`'s side, as Cycles evaluates an emitter it samples as a light: dimmed by the
/// coat's tint seen from `wo`, but not by the coat's or the sheen's reflection (Cycles
/// evaluates a sampled emitter without allocating closures, so those layers' albedos are not
/// computed; a ray that meets the surface sees both, as `integrator::shading::Shading` dims
/// it). Light sampling and photon emission read it here.
pub(super) fn sampled_emission(surface: &SurfaceMaterial, n: Vec3, wo: Vec3) -> Vec3 {
    if surface.coat_weight <= 0.0 || surface.coat_tint == Vec3::ONE {
        return surface.emission;
    }
    let toward = |v: Vec3| if v.dot(n) < 0.0 { -v } else { v };
    let frame = Frame::from_normal(surface.normal.map_or(n, toward));
    let mut bsdf = Bsdf::new(surface);
    if let Some(c) = surface.coat_normal {
        bsdf = bsdf.with_coat_normal(frame.to_local(toward(c)));
    }
    surface.emission * bsdf.coat_tint_seen(frame.to_local(wo))
}

/// A point drawn uniformly on an emissive triangle.
#[derive(Clone, Copy, Debug)]
pub struct EmitterPoint {
    /// Position with its error bound and the unit winding normal (zero if degenerate).
    pub point: LightPoint,
    /// Emitted radiance there (towards the sides the material emits to).
    pub radiance: Vec3,
}

/// A point drawn on an emitter (`LightSource::Triangle` or `Instance`) at some moment.
#[derive(Clone, Copy, Debug)]
pub struct EmitterSample {
    pub emitter: EmitterPoint,
    /// One over the point's density per unit area: the triangle's area divided by the
    /// probability of picking it (an instance's triangle, at the sample's moment).
    pub area: f32,
    pub two_sided: bool,
    /// The emitting mesh's area-light spread (`Mesh::emission_spread`).
    pub spread: Option<f32>,
}

/// Draw a point uniformly on triangle `triangle` of mesh `m` with `u`: the one routine both
/// light sampling and photon emission use. `placed` takes a prototype's triangle, deformed as
/// at moment `time`, to world space (an instance at that moment; `None` for a world-space
/// mesh). A node tree's
/// emission, and the dimming by a coat's tint above it (`sampled_emission`), are
/// evaluated as seen from `seen_from` (light sampling: the shaded point, its distance and the
/// path there, as Cycles evaluates a sampled emitter), or head-on at distance 0 by a ray of no
/// kind (photons leave in a direction drawn afterwards: their coat dimming is the head-on one).
pub fn sample_emitter_point(
    scene: &Scene,
    m: &Mesh,
    triangle: u32,
    placed: Option<Affine3A>,
    time: f32,
    u: Vec2,
    seen_from: Option<(Vec3, RayPath)>,
) -> EmitterPoint {
    let b = square_to_triangle(u);
    emitter_point_at(scene, m, triangle, placed, time, b, seen_from)
}

/// `sample_emitter_point`'s point at barycentric coordinates `b` (of the triangle's second and
/// third corners) instead of a drawn one.
pub fn emitter_point_at(
    scene: &Scene,
    m: &Mesh,
    triangle: u32,
    placed: Option<Affine3A>,
    time: f32,
    b: Vec2,
    seen_from: Option<(Vec3, RayPath)>,
) -> EmitterPoint {
    let idx = m.indices[triangle as usize];
    let v = m.triangle_at(triangle, time).map(|q| match placed {
        Some(to_world) => to_world.transform_point3(q),
        None => q,
    });
    let b0 = 1.0 - b.x - b.y;
    let p = v[0] * b0 + v[1] * b.x + v[2] * b.y;
    let p_error =
        crate::math::gamma(6) * ((v[0] * b0).abs() + (v[1] * b.x).abs() + (v[2] * b.y).abs());
    let mut n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
    if placed.is_some_and(|to_world| to_world.matrix3.determinant() < 0.0) {
        // A mirrored instance keeps the side of its winding, as `SurfaceHit::new` does.
        n = -n;
    }
    let uv = if m.uvs.is_empty() {
        Vec2::ZERO
    } else {
        let t = idx.map(|i| m.uvs[i as usize]);
        t[0] * b0 + t[1] * b.x + t[2] * b.y
    };
    let material = &scene.materials[m.material as usize];
    // glTF's clearcoat has no tint: only a node tree's coat dims a sampled emitter.
    let radiance = if let Some(program) = &material.nodes {
        let linear = placed.map(|to_world| Mat3::from(to_world.matrix3));
        let normal = |i: u32| match linear {
            Some(l) => l.inverse().transpose() * m.normals[i as usize],
            None => m.normals[i as usize],
        };
        let shading_n = crate::accel::interpolate(idx.map(normal), b.x, b.y).normalize_or(n);
        let view = match seen_from {
            Some((o, path)) => {
                let wo = (o - p).normalize_or(shading_n);
                crate::interaction::View {
                    wo,
                    backfacing: wo.dot(n) < 0.0,
                    path: path.emission(),
                    ray_length: o.distance(p),
                }
            }
            None => crate::interaction::View {
                wo: shading_n,
                backfacing: false,
                path: RayPath::default(),
                ray_length: 0.0,
            },
        };
        let facing = if view.backfacing {
            -shading_n
        } else {
            shading_n
        };
        let at = crate::interaction::node_inputs(m, triangle, b.x, b.y, p, facing, view, linear);
        let surface = from_closure(material, &program.eval(&at, &scene.textures, 0.5));
        sampled_emission(&surface, facing, view.wo)
    } else {
        material_emission(scene, material, uv)
    };
    EmitterPoint {
        point: LightPoint {
            p,
            p_error,
            n,
            distant: false,
        },
        radiance,
    }
}

/// Area of the triangle `p`; zero when not finite.
pub(super) fn area(p: [Vec3; 3]) -> f32 {
    let a = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
    if a.is_finite() {
        a
    } else {
        0.0
    }
}

/// Areas of `mesh`'s triangles in its own space.
pub(super) fn triangle_areas(mesh: &Mesh) -> Vec<f32> {
    (mesh.indices.iter())
        .map(|idx| area(idx.map(|i| mesh.positions[i as usize])))
        .collect()
}

/// Area of `mesh`'s triangle `triangle` deformed as at `time` and placed by `to_world`.
pub(super) fn placed_area(mesh: &Mesh, triangle: u32, to_world: Affine3A, time: f32) -> f32 {
    area(
        mesh.triangle_at(triangle, time)
            .map(|q| to_world.transform_point3(q)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points drawn in a spread window estimate the light a point receives from the
    /// triangle as points drawn on the whole triangle do (same mean), for points near and far
    /// from the light, and a window is used only where it is smaller than the triangle.
    #[test]
    fn spread_windows_estimate_what_the_whole_triangle_does() {
        let v = [
            Vec3::new(0.0, 0.0, 2.0),
            Vec3::new(1.5, 0.0, 2.0),
            Vec3::new(0.2, 1.2, 2.0),
        ];
        let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        let spread = 20f32.to_radians();
        let received = |p: Vec3, q: Vec3| {
            let d = q - p;
            let cos_l = d.normalize().dot(n).abs();
            spread_factor(Some(spread), cos_l) * cos_l / d.length_squared()
        };
        let mut rng = crate::rng::Rng::new(3);
        for p in [Vec3::new(0.5, 0.4, 0.0), Vec3::new(0.9, 0.2, 1.2)] {
            let window = SpreadWindow::new(v, p, spread).expect("narrower than the triangle");
            let samples = 400_000;
            let (mut whole, mut windowed) = (0.0f64, 0.0f64);
            for _ in 0..samples {
                let u = Vec2::new(rng.uniform(), rng.uniform());
                let b = square_to_triangle(u);
                let q = v[0] * (1.0 - b.x - b.y) + v[1] * b.x + v[2] * b.y;
                whole += (received(p, q) * area(v)) as f64;
                if let Some(b) = window.sample(u) {
                    let q = v[0] * (1.0 - b.x - b.y) + v[1] * b.x + v[2] * b.y;
                    assert!(window.contains(q));
                    windowed += (received(p, q) * window.area()) as f64;
                }
            }
            let (whole, windowed) = (whole / samples as f64, windowed / samples as f64);
            assert!(whole > 0.0);
            assert!(
                (windowed - whole).abs() < 0.02 * whole,
                "{p}: window {windowed} vs whole triangle {whole}"
            );
        }
        // Far below, the cone covers the triangle: no window.
        assert!(SpreadWindow::new(v, Vec3::new(0.5, 0.4, -20.0), spread).is_none());
    }

    /// The spread keeps the light's power: ∫ factor · cos dω over the hemisphere is π, for wide
    /// and narrow spreads (the narrow ones through the series branch).
    #[test]
    fn spread_factor_keeps_the_power() {
        for degrees in [170.0f32, 90.0, 30.0, 5.0, 1.0] {
            let spread = Some(degrees.to_radians());
            let half = 0.5 * degrees.to_radians();
            let n = 200_000;
            // Midpoint rule in θ over [0, h] (the factor is zero beyond).
            let dtheta = half / n as f32;
            let mut integral = 0.0f64;
            for i in 0..n {
                let theta = (i as f32 + 0.5) * dtheta;
                let f = spread_factor(spread, theta.cos());
                integral += (f * theta.cos() * theta.sin() * dtheta) as f64 * std::f64::consts::TAU;
            }
            let ratio = integral / std::f64::consts::PI;
            assert!((ratio - 1.0).abs() < 2e-3, "{degrees}°: {ratio}");
            assert_eq!(spread_factor(spread, (half * 1.01).cos()), 0.0);
        }
        assert_eq!(spread_factor(None, 0.3), 1.0);
    }
}
