//! Blender's Ambient Occlusion node as Cycles 4.5 evaluates it (`svm_ao`): the fraction of
//! `samples` cosine-weighted rays over the hemisphere around the normal that travel Distance
//! without meeting a surface (any surface that casts shadows, or with Only Local the point's
//! own object alone); Inside turns the hemisphere into the surface. The AO output is that
//! fraction and Color the Color input times it. The rays come from the scene the integrator
//! gives the tree (`Tracing`); without one the node reads 1, as Cycles' shaders that cannot
//! trace do.

use super::inputs::{input, normal_input, splat, v3, Operands, SceneRays, ShadingInputs};
use super::inputs::{Socket, Tracing, Ty};
use crate::math::{Frame, Vec2, Vec3, Vec4};
use crate::sampling::square_to_cosine_hemisphere;

pub(super) const AO_INPUTS: &[Socket] = &[
    Socket::color("Color", Vec4::ONE),
    Socket::float("Distance", 1.0),
    Socket::vector("Normal", Vec4::ZERO),
];
pub(super) const AO_OUTPUTS: &[Socket] = &[
    Socket::output("Color", Ty::Color),
    Socket::output("AO", Ty::Float),
];

/// The node's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct AmbientOcclusion {
    /// Rays per evaluation (Blender's 1 to 128).
    pub(super) samples: u32,
    /// Rays go into the surface, against the normal.
    pub(super) inside: bool,
    /// Only the shading point's own object occludes.
    pub(super) only_local: bool,
}

/// The node's outputs (Color, AO) at the shading point `at`; `stream` names the node's random
/// numbers (`Tracing::point`).
pub(super) fn eval_ambient_occlusion(
    ao: &AmbientOcclusion,
    at: &ShadingInputs,
    tracing: Option<&Tracing>,
    stream: u64,
    ins: &impl Operands,
) -> [Vec4; 2] {
    const COLOR: usize = input(AO_INPUTS, "Color");
    const DISTANCE: usize = input(AO_INPUTS, "Distance");
    const NORMAL: usize = input(AO_INPUTS, "Normal");
    let fraction = match tracing {
        Some(t) => {
            let normal = normal_input(ins.value(NORMAL), at.normal);
            let normal = if ao.inside { -normal } else { normal };
            unoccluded_fraction(t.scene, normal, ins.float(DISTANCE), ao, |k| {
                t.point(stream, k)
            })
        }
        None => 1.0,
    };
    [v3(ins.vector(COLOR) * fraction), splat(fraction)]
}

/// The fraction of `ao.samples` cosine-weighted directions around the unit `normal` (the k-th
/// from `point(k)`) along which `scene` is clear for `distance`; 1 for no distance or no
/// samples.
pub(super) fn unoccluded_fraction(
    scene: &dyn SceneRays,
    normal: Vec3,
    distance: f32,
    ao: &AmbientOcclusion,
    point: impl Fn(u32) -> Vec2,
) -> f32 {
    if !(distance > 0.0) || ao.samples == 0 {
        return 1.0;
    }
    let frame = Frame::from_normal(normal);
    let clear = (0..ao.samples)
        .filter(|&k| {
            let direction = frame.to_world(square_to_cosine_hemisphere(point(k)));
            !scene.occluded(direction.normalize(), distance, ao.only_local)
        })
        .count();
    clear as f32 / ao.samples as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::inputs::LocalHit;

    /// A shading point at the origin under an infinite ceiling at height `height` (the plane
    /// z = height), which belongs to another object than the point's.
    struct UnderCeiling {
        height: f32,
    }

    impl SceneRays for UnderCeiling {
        fn occluded(&self, direction: Vec3, distance: f32, local: bool) -> bool {
            !local && direction.z > 0.0 && self.height / direction.z < distance
        }
        fn local_hits(&self, _: Vec3, _: Vec3, _: f32, _: &mut dyn FnMut(LocalHit)) {}
        fn geometric_normal(&self) -> Vec3 {
            Vec3::Z
        }
    }

    const CEILING: UnderCeiling = UnderCeiling { height: 0.5 };

    fn fraction(normal: Vec3, distance: f32, samples: u32, inside: bool, local: bool) -> f32 {
        let ao = AmbientOcclusion {
            samples,
            inside,
            only_local: local,
        };
        let tracing = Tracing {
            scene: &CEILING,
            seed: 7,
        };
        let at = ShadingInputs {
            normal,
            ..ShadingInputs::default()
        };
        let distance = crate::shader::inputs::splat(distance);
        let ins = [Vec4::ONE, distance, Vec4::ZERO];
        eval_ambient_occlusion(&ao, &at, Some(&tracing), 3, &ins)[1].x
    }

    #[test]
    fn ceiling_leaves_the_cosine_weighted_share_below_its_height_over_distance() {
        // A cosine-weighted direction of elevation cosine μ reaches the ceiling within D when
        // μ > h / D, which it does with probability 1 − (h / D)²: the clear share is (h / D)².
        for distance in [0.6f32, 1.0, 2.0, 4.0] {
            let expected = (CEILING.height / distance).powi(2);
            let got = fraction(Vec3::Z, distance, 1024, false, false);
            assert!(
                (got - expected).abs() < 0.01,
                "D {distance}: {got} vs {expected}"
            );
        }
        // Closer than the ceiling, nothing occludes.
        assert_eq!(fraction(Vec3::Z, 0.5, 64, false, false), 1.0);
    }

    #[test]
    fn inside_only_local_and_no_scene_see_no_ceiling() {
        // Inside: the hemisphere below, away from the ceiling.
        assert_eq!(fraction(Vec3::Z, 4.0, 64, true, false), 1.0);
        // The ceiling is another object.
        assert_eq!(fraction(Vec3::Z, 4.0, 64, false, true), 1.0);
        // A normal along the ceiling: half the hemisphere faces it.
        let half = fraction(Vec3::X, 1e6, 1024, false, false);
        assert!((half - 0.5).abs() < 0.01, "{half}");
        let ao = AmbientOcclusion {
            samples: 16,
            inside: false,
            only_local: false,
        };
        let ins = [Vec4::new(0.2, 0.4, 0.6, 1.0), splat(1.0), Vec4::ZERO];
        let out = eval_ambient_occlusion(&ao, &ShadingInputs::default(), None, 0, &ins);
        assert_eq!(out, [ins[0], splat(1.0)]);
    }
}
