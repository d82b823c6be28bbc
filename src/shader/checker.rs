//! The Checker Texture (Cycles' `svm_checker`).

use super::inputs::{splat, Operands};
use crate::math::{Vec3, Vec4};

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
    let p = ins.vector(0) * ins.float(3);
    let fac = checker(p);
    let color = if fac == 1.0 {
        ins.value(1)
    } else {
        ins.value(2)
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
