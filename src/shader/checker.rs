//! The Checker Texture (Cycles' `svm_checker`).

use super::inputs::{input, splat, Operands, Socket, Ty, GREY};
use crate::math::{Vec3, Vec4};

/// The Checker node's inputs.
pub(super) const CHECKER_INPUTS: &[Socket] = &[
    Socket::vector("Vector", Vec4::ZERO),
    Socket::color("Color1", GREY),
    Socket::color("Color2", Vec4::new(0.2, 0.2, 0.2, 1.0)),
    Socket::float("Scale", 5.0),
];

/// The Checker node's outputs.
pub(super) const CHECKER_OUTPUTS: &[Socket] = &[
    Socket::output("Color", Ty::Color),
    Socket::output("Fac", Ty::Float),
];

/// Cycles' `svm_checker`: 1 on the cells of Color1, 0 on those of Color2.
pub fn checker(p: Vec3) -> f32 {
    let p = (p + Vec3::splat(0.000_001)) * 0.999_999;
    let xi = (p.x.floor() as i32).abs();
    let yi = (p.y.floor() as i32).abs();
    let zi = (p.z.floor() as i32).abs();
    if (xi % 2 == yi % 2) == (zi % 2 == 1) {
        1.0
    } else {
        0.0
    }
}

/// The Checker Texture: Vector, Color1, Color2, Scale to Color and Fac.
#[inline(always)]
pub(super) fn eval_checker(ins: &impl Operands) -> [Vec4; 2] {
    const VECTOR: usize = input(CHECKER_INPUTS, "Vector");
    const COLOR1: usize = input(CHECKER_INPUTS, "Color1");
    const COLOR2: usize = input(CHECKER_INPUTS, "Color2");
    const SCALE: usize = input(CHECKER_INPUTS, "Scale");
    let p = ins.vector(VECTOR) * ins.float(SCALE);
    let fac = checker(p);
    let color = if fac == 1.0 {
        ins.value(COLOR1)
    } else {
        ins.value(COLOR2)
    };
    [color, splat(fac)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checker_alternates_cells_as_cycles() {
        assert_eq!(checker(Vec3::new(0.5, 0.5, 0.5)), 0.0);
        assert_eq!(checker(Vec3::new(1.5, 0.5, 0.5)), 1.0);
        assert_eq!(checker(Vec3::new(0.5, 1.5, 0.5)), 1.0);
        assert_eq!(checker(Vec3::new(1.5, 1.5, 0.5)), 0.0);
        assert_eq!(checker(Vec3::new(0.5, 0.5, 1.5)), 1.0);
        // Negative cells mirror: |floor(−0.5)| = 1.
        assert_eq!(checker(Vec3::new(-0.5, 0.5, 0.5)), 1.0);
    }
}
