//! The Mapping and Vector Math nodes, and Blender's Euler rotations (Cycles' `svm_mapping`,
//! `svm_vector_math`).

use super::inputs::{input, splat, v3, Operands, Socket, Ty};
use crate::math::{Vec3, Vec4};

/// The Mapping node's inputs.
pub(super) const MAPPING_INPUTS: &[Socket] = &[
    Socket::vector("Vector", Vec4::ZERO),
    Socket::vector("Location", Vec4::ZERO),
    Socket::vector("Rotation", Vec4::ZERO),
    Socket::vector("Scale", Vec4::ONE),
];

/// The Mapping node's outputs.
pub(super) const MAPPING_OUTPUTS: &[Socket] = &[Socket::output("Vector", Ty::Vector)];

/// The Vector Math node's inputs.
pub(super) const VECTOR_MATH_INPUTS: &[Socket] = &[
    Socket::vector("Vector", Vec4::ZERO),
    Socket::vector("Vector_001", Vec4::ZERO),
    Socket::vector("Vector_002", Vec4::ZERO),
    Socket::float("Scale", 1.0),
];

/// The Vector Math node's outputs.
pub(super) const VECTOR_MATH_OUTPUTS: &[Socket] = &[
    Socket::output("Vector", Ty::Vector),
    Socket::output("Value", Ty::Float),
];

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum MappingKind {
    Point,
    Texture,
    Vector,
    Normal,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum VectorOp {
    Add,
    Subtract,
    Multiply,
    Divide,
    MultiplyAdd,
    Cross,
    Project,
    Reflect,
    Dot,
    Distance,
    Length,
    Scale,
    Normalize,
    Absolute,
    Minimum,
    Maximum,
    Floor,
    Ceil,
    Fraction,
    Modulo,
    Snap,
    Sine,
    Cosine,
    Tangent,
}

/// A rotation by Euler angles, as its angles' sines and cosines.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Euler {
    pub(super) sin: Vec3,
    pub(super) cos: Vec3,
}

impl Euler {
    pub(super) fn new(r: Vec3) -> Euler {
        let (sx, cx) = r.x.sin_cos();
        let (sy, cy) = r.y.sin_cos();
        let (sz, cz) = r.z.sin_cos();
        Euler {
            sin: Vec3::new(sx, sy, sz),
            cos: Vec3::new(cx, cy, cz),
        }
    }
}

/// `v` turned about axis `axis` (0 X, 1 Y, 2 Z) by the angle of sine `s` and cosine `c`.
pub(super) fn turn(v: Vec3, axis: usize, s: f32, c: f32) -> Vec3 {
    match axis {
        0 => Vec3::new(v.x, c * v.y - s * v.z, s * v.y + c * v.z),
        1 => Vec3::new(c * v.x + s * v.z, v.y, -s * v.x + c * v.z),
        _ => Vec3::new(c * v.x - s * v.y, s * v.x + c * v.y, v.z),
    }
}

/// Blender's Euler XYZ rotation (X first, then Y, then Z).
pub(super) fn euler_xyz(r: &Euler, v: Vec3) -> Vec3 {
    (0..3).fold(v, |v, k| turn(v, k, r.sin[k], r.cos[k]))
}

/// The inverse of `euler_xyz`.
pub(super) fn euler_xyz_inverse(r: &Euler, v: Vec3) -> Vec3 {
    (0..3).rev().fold(v, |v, k| turn(v, k, -r.sin[k], r.cos[k]))
}

pub(super) fn safe_divide3(a: Vec3, b: Vec3) -> Vec3 {
    let d = |x: f32, y: f32| if y != 0.0 { x / y } else { 0.0 };
    Vec3::new(d(a.x, b.x), d(a.y, b.y), d(a.z, b.z))
}

/// The Mapping node (Cycles' `svm_mapping`).
pub(super) fn mapping(kind: MappingKind, v: Vec3, loc: Vec3, rot: &Euler, scale: Vec3) -> Vec3 {
    match kind {
        MappingKind::Point => euler_xyz(rot, v * scale) + loc,
        MappingKind::Texture => safe_divide3(euler_xyz_inverse(rot, v - loc), scale),
        MappingKind::Vector => euler_xyz(rot, v * scale),
        MappingKind::Normal => euler_xyz(rot, safe_divide3(v, scale)).normalize_or_zero(),
    }
}

/// Blender's Vector Math node: the vector and the value outputs.
pub(super) fn vector_math(op: VectorOp, a: Vec3, b: Vec3, c: Vec3, scale: f32) -> (Vec3, f32) {
    use VectorOp::*;
    let per = |f: &dyn Fn(f32, f32) -> f32| Vec3::new(f(a.x, b.x), f(a.y, b.y), f(a.z, b.z));
    match op {
        Add => (a + b, 0.0),
        Subtract => (a - b, 0.0),
        Multiply => (a * b, 0.0),
        Divide => (safe_divide3(a, b), 0.0),
        MultiplyAdd => (a * b + c, 0.0),
        Cross => (a.cross(b), 0.0),
        Project => {
            let len2 = b.length_squared();
            let v = if len2 != 0.0 {
                b * (a.dot(b) / len2)
            } else {
                Vec3::ZERO
            };
            (v, 0.0)
        }
        Reflect => {
            let n = b.normalize_or_zero();
            (a - 2.0 * a.dot(n) * n, 0.0)
        }
        Dot => (Vec3::ZERO, a.dot(b)),
        Distance => (Vec3::ZERO, a.distance(b)),
        Length => (Vec3::ZERO, a.length()),
        Scale => (a * scale, 0.0),
        Normalize => (a.normalize_or_zero(), 0.0),
        Absolute => (a.abs(), 0.0),
        Minimum => (a.min(b), 0.0),
        Maximum => (a.max(b), 0.0),
        Floor => (a.floor(), 0.0),
        Ceil => (a.ceil(), 0.0),
        Fraction => (a - a.floor(), 0.0),
        Modulo => (per(&|x, y| if y != 0.0 { x % y } else { 0.0 }), 0.0),
        Snap => (
            per(&|x, y| if y != 0.0 { (x / y).floor() * y } else { 0.0 }),
            0.0,
        ),
        Sine => (Vec3::new(a.x.sin(), a.y.sin(), a.z.sin()), 0.0),
        Cosine => (Vec3::new(a.x.cos(), a.y.cos(), a.z.cos()), 0.0),
        Tangent => (Vec3::new(a.x.tan(), a.y.tan(), a.z.tan()), 0.0),
    }
}

/// The Mapping node: Vector, Location, Rotation, Scale; `fixed` the rotation's sines and
/// cosines when the Rotation input is constant.
#[inline(always)]
pub(super) fn eval_mapping(kind: MappingKind, fixed: &Option<Euler>, ins: &impl Operands) -> Vec4 {
    const VECTOR: usize = input(MAPPING_INPUTS, "Vector");
    const LOCATION: usize = input(MAPPING_INPUTS, "Location");
    const ROTATION: usize = input(MAPPING_INPUTS, "Rotation");
    const SCALE: usize = input(MAPPING_INPUTS, "Scale");
    let v = ins.vector(VECTOR);
    let loc = ins.vector(LOCATION);
    let rot = fixed.unwrap_or_else(|| Euler::new(ins.vector(ROTATION)));
    let scale = ins.vector(SCALE);
    v3(mapping(kind, v, loc, &rot, scale))
}

/// The Vector Math node: its Vector and Value outputs.
#[inline(always)]
pub(super) fn eval_vector_math(op: VectorOp, ins: &impl Operands) -> [Vec4; 2] {
    const VECTOR: usize = input(VECTOR_MATH_INPUTS, "Vector");
    const VECTOR_001: usize = input(VECTOR_MATH_INPUTS, "Vector_001");
    const VECTOR_002: usize = input(VECTOR_MATH_INPUTS, "Vector_002");
    const SCALE: usize = input(VECTOR_MATH_INPUTS, "Scale");
    let (v, value) = vector_math(
        op,
        ins.vector(VECTOR),
        ins.vector(VECTOR_001),
        ins.vector(VECTOR_002),
        ins.float(SCALE),
    );
    [v3(v), splat(value)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    #[test]
    fn mapping_point_and_texture_are_inverse() {
        let (loc, rot, scale) = (
            Vec3::new(0.3, -1.0, 2.0),
            Vec3::new(0.4, 0.9, -1.2),
            Vec3::new(2.0, 0.5, 3.0),
        );
        let v = Vec3::new(0.7, 0.2, -0.4);
        let rot = Euler::new(rot);
        let p = mapping(MappingKind::Point, v, loc, &rot, scale);
        let back = mapping(MappingKind::Texture, p, loc, &rot, scale);
        assert!((back - v).length() < 1e-5);
        // A 90° turn about Z takes X to Y.
        let r = euler_xyz(&Euler::new(Vec3::new(0.0, 0.0, PI / 2.0)), Vec3::X);
        assert!((r - Vec3::Y).length() < 1e-6);
    }
}
