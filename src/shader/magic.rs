//! The Magic Texture (Cycles' `svm_magic`).

use super::inputs::{input, splat, v3, Operands, Socket, Ty};
use crate::math::{Vec3, Vec4};
use std::f32::consts::PI;

/// The Magic node's inputs.
pub(super) const MAGIC_INPUTS: &[Socket] = &[
    Socket::vector("Vector", Vec4::ZERO),
    Socket::float("Scale", 5.0),
    Socket::float("Distortion", 1.0),
];

/// The Magic node's outputs.
pub(super) const MAGIC_OUTPUTS: &[Socket] = &[
    Socket::output("Color", Ty::Color),
    Socket::output("Fac", Ty::Float),
];

/// Cycles' `svm_magic`: Blender's Magic texture, `depth` rounds of sines and cosines feeding
/// each other, the coordinates first wrapped to one period (2π) to keep precision.
pub(super) fn magic(p: Vec3, scale: f32, depth: u8, distortion: f32) -> Vec3 {
    let wrap = |v: f32| v % (2.0 * PI);
    let (px, py, pz) = (wrap(p.x), wrap(p.y), wrap(p.z));
    let mut x = ((px + py + pz) * 5.0 * scale).sin();
    let mut y = ((-px + py - pz) * 5.0 * scale).cos();
    let mut z = -((-px - py + pz) * 5.0 * scale).cos();
    let d = distortion;
    if depth > 0 {
        x *= d;
        y *= d;
        z *= d;
        y = -(x - y + z).cos() * d;
        // Each further round rewrites one channel from the three.
        for round in 2..=depth.min(10) {
            match round {
                2 => x = (x - y - z).cos() * d,
                3 => z = (-x - y - z).sin() * d,
                4 => x = -(-x + y - z).cos() * d,
                5 => y = -(-x + y + z).sin() * d,
                6 => y = -(-x + y + z).cos() * d,
                7 => x = (x + y + z).cos() * d,
                8 => z = (x + y - z).sin() * d,
                9 => x = -(-x - y + z).cos() * d,
                _ => y = -(x - y + z).sin() * d,
            }
        }
    }
    if d != 0.0 {
        x /= 2.0 * d;
        y /= 2.0 * d;
        z /= 2.0 * d;
    }
    Vec3::new(0.5 - x, 0.5 - y, 0.5 - z)
}

/// The Magic Texture: Vector, Scale, Distortion to Color and Fac.
#[inline(always)]
pub(super) fn eval_magic(depth: u8, ins: &impl Operands) -> [Vec4; 2] {
    const VECTOR: usize = input(MAGIC_INPUTS, "Vector");
    const SCALE: usize = input(MAGIC_INPUTS, "Scale");
    const DISTORTION: usize = input(MAGIC_INPUTS, "Distortion");
    let c = magic(
        ins.vector(VECTOR),
        ins.float(SCALE),
        depth,
        ins.float(DISTORTION),
    );
    [v3(c), splat((c.x + c.y + c.z) / 3.0)]
}
