//! The Gradient Texture (Cycles' `svm_gradient`).

use super::inputs::{input, splat, Operands, Socket, Ty};
use crate::math::{Vec3, Vec4};
use std::f32::consts::PI;

/// The Gradient node's inputs.
pub(super) const GRADIENT_INPUTS: &[Socket] = &[Socket::vector("Vector", Vec4::ZERO)];

/// The Gradient node's outputs.
pub(super) const GRADIENT_OUTPUTS: &[Socket] = &[
    Socket::output("Color", Ty::Color),
    Socket::output("Fac", Ty::Float),
];

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum GradientKind {
    Linear,
    Quadratic,
    Easing,
    Diagonal,
    Radial,
    QuadraticSphere,
    Spherical,
}

/// Cycles' `svm_gradient`, clamped to [0, 1].
pub(super) fn gradient(kind: GradientKind, p: Vec3) -> f32 {
    let (x, y, z) = (p.x, p.y, p.z);
    let r = match kind {
        GradientKind::Linear => x,
        GradientKind::Quadratic => {
            let r = x.max(0.0);
            r * r
        }
        GradientKind::Easing => {
            let r = x.clamp(0.0, 1.0);
            let t = r * r;
            3.0 * t - 2.0 * t * r
        }
        GradientKind::Diagonal => (x + y) * 0.5,
        GradientKind::Radial => y.atan2(x) / (2.0 * PI) + 0.5,
        GradientKind::QuadraticSphere => {
            let r = (0.999_999 - (x * x + y * y + z * z).sqrt()).max(0.0);
            r * r
        }
        GradientKind::Spherical => (0.999_999 - (x * x + y * y + z * z).sqrt()).max(0.0),
    };
    r.clamp(0.0, 1.0)
}

/// The Gradient Texture: Vector to Color and Fac.
#[inline(always)]
pub(super) fn eval_gradient(kind: GradientKind, ins: &impl Operands) -> [Vec4; 2] {
    const VECTOR: usize = input(GRADIENT_INPUTS, "Vector");
    let fac = gradient(kind, ins.vector(VECTOR));
    [splat(fac), splat(fac)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gradient_kinds_at_known_points() {
        let p = Vec3::new(0.25, 0.75, 0.0);
        assert_eq!(gradient(GradientKind::Linear, p), 0.25);
        assert_eq!(gradient(GradientKind::Quadratic, p), 0.0625);
        assert_eq!(gradient(GradientKind::Diagonal, p), 0.5);
        assert!((gradient(GradientKind::Easing, p) - 0.15625).abs() < 1e-6);
        assert!((gradient(GradientKind::Radial, Vec3::new(0.0, 1.0, 0.0)) - 0.75).abs() < 1e-6);
        assert_eq!(
            gradient(GradientKind::Linear, Vec3::new(2.0, 0.0, 0.0)),
            1.0
        );
        assert!(
            (gradient(GradientKind::Spherical, Vec3::new(0.5, 0.0, 0.0)) - 0.499_999).abs() < 1e-6
        );
    }
}
