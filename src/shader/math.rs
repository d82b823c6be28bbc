//! The Math, Map Range and Clamp nodes, with Blender's safe definitions (Cycles' `svm_math`,
//! `svm_node_map_range`).

use super::inputs::{input, splat, Operands, Socket, Ty};
use crate::math::Vec4;
use std::f32::consts::PI;

/// The Math node's inputs.
pub(super) const MATH_INPUTS: &[Socket] = &[
    Socket::float("Value", 0.5),
    Socket::float("Value_001", 0.5),
    Socket::float("Value_002", 0.5),
];

/// The Math node's outputs.
pub(super) const MATH_OUTPUTS: &[Socket] = &[Socket::output("Value", Ty::Float)];

/// The Map Range node's inputs.
pub(super) const MAP_RANGE_INPUTS: &[Socket] = &[
    Socket::float("Value", 1.0),
    Socket::float("From Min", 0.0),
    Socket::float("From Max", 1.0),
    Socket::float("To Min", 0.0),
    Socket::float("To Max", 1.0),
    Socket::float("Steps", 4.0),
];

/// The Map Range node's outputs.
pub(super) const MAP_RANGE_OUTPUTS: &[Socket] = &[Socket::output("Result", Ty::Float)];

/// The Clamp node's inputs.
pub(super) const CLAMP_INPUTS: &[Socket] = &[
    Socket::float("Value", 1.0),
    Socket::float("Min", 0.0),
    Socket::float("Max", 1.0),
];

/// The Clamp node's outputs.
pub(super) const CLAMP_OUTPUTS: &[Socket] = &[Socket::output("Result", Ty::Float)];

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum MathOp {
    Add,
    Subtract,
    Multiply,
    Divide,
    MultiplyAdd,
    Power,
    Logarithm,
    Sqrt,
    InverseSqrt,
    Absolute,
    Exponent,
    Minimum,
    Maximum,
    LessThan,
    GreaterThan,
    Sign,
    Compare,
    SmoothMin,
    SmoothMax,
    Round,
    Floor,
    Ceil,
    Trunc,
    Fraction,
    Modulo,
    FlooredModulo,
    Wrap,
    Snap,
    PingPong,
    Sine,
    Cosine,
    Tangent,
    Arcsine,
    Arccosine,
    Arctangent,
    Arctan2,
    Sinh,
    Cosh,
    Tanh,
    Radians,
    Degrees,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum MapRangeKind {
    Linear,
    Stepped,
    Smoothstep,
    Smootherstep,
}

pub(super) fn math_op(name: &str) -> Option<MathOp> {
    use MathOp::*;
    Some(match name {
        "ADD" => Add,
        "SUBTRACT" => Subtract,
        "MULTIPLY" => Multiply,
        "DIVIDE" => Divide,
        "MULTIPLY_ADD" => MultiplyAdd,
        "POWER" => Power,
        "LOGARITHM" => Logarithm,
        "SQRT" => Sqrt,
        "INVERSE_SQRT" => InverseSqrt,
        "ABSOLUTE" => Absolute,
        "EXPONENT" => Exponent,
        "MINIMUM" => Minimum,
        "MAXIMUM" => Maximum,
        "LESS_THAN" => LessThan,
        "GREATER_THAN" => GreaterThan,
        "SIGN" => Sign,
        "COMPARE" => Compare,
        "SMOOTH_MIN" => SmoothMin,
        "SMOOTH_MAX" => SmoothMax,
        "ROUND" => Round,
        "FLOOR" => Floor,
        "CEIL" => Ceil,
        "TRUNC" => Trunc,
        "FRACT" => Fraction,
        "MODULO" => Modulo,
        "FLOORED_MODULO" => FlooredModulo,
        "WRAP" => Wrap,
        "SNAP" => Snap,
        "PINGPONG" => PingPong,
        "SINE" => Sine,
        "COSINE" => Cosine,
        "TANGENT" => Tangent,
        "ARCSINE" => Arcsine,
        "ARCCOSINE" => Arccosine,
        "ARCTANGENT" => Arctangent,
        "ARCTAN2" => Arctan2,
        "SINH" => Sinh,
        "COSH" => Cosh,
        "TANH" => Tanh,
        "RADIANS" => Radians,
        "DEGREES" => Degrees,
        _ => return None,
    })
}

/// Blender's Math node, with its safe definitions (division by zero gives 0, and so on).
pub(super) fn math(op: MathOp, a: f32, b: f32, c: f32) -> f32 {
    use MathOp::*;
    let safe_div = |x: f32, y: f32| if y != 0.0 { x / y } else { 0.0 };
    let safe_mod = |x: f32, y: f32| if y != 0.0 { x % y } else { 0.0 };
    let floored_mod = |x: f32, y: f32| {
        if y != 0.0 {
            x - (x / y).floor() * y
        } else {
            0.0
        }
    };
    let smoothmin = |a: f32, b: f32, c: f32| {
        if c != 0.0 {
            let h = (c - (a - b).abs()).max(0.0) / c;
            a.min(b) - h * h * h * c * (1.0 / 6.0)
        } else {
            a.min(b)
        }
    };
    let wrap = |v: f32, max: f32, min: f32| {
        let range = max - min;
        if range != 0.0 {
            v - range * ((v - min) / range).floor()
        } else {
            min
        }
    };
    match op {
        Add => a + b,
        Subtract => a - b,
        Multiply => a * b,
        Divide => safe_div(a, b),
        MultiplyAdd => a * b + c,
        Power => {
            if a >= 0.0 {
                a.powf(b)
            } else {
                let fraction = b % 1.0;
                if !(0.001..=0.999).contains(&fraction) {
                    let r = a.abs().powf(b.round());
                    if (b.round() as i64) % 2 != 0 {
                        -r
                    } else {
                        r
                    }
                } else {
                    0.0
                }
            }
        }
        Logarithm => {
            if a > 0.0 && b > 0.0 {
                safe_div(a.ln(), b.ln())
            } else {
                0.0
            }
        }
        Sqrt => {
            if a > 0.0 {
                a.sqrt()
            } else {
                0.0
            }
        }
        InverseSqrt => {
            if a > 0.0 {
                1.0 / a.sqrt()
            } else {
                0.0
            }
        }
        Absolute => a.abs(),
        Exponent => a.exp(),
        Minimum => a.min(b),
        Maximum => a.max(b),
        LessThan => (a < b) as u8 as f32,
        GreaterThan => (a > b) as u8 as f32,
        Sign => {
            if a > 0.0 {
                1.0
            } else if a < 0.0 {
                -1.0
            } else {
                0.0
            }
        }
        Compare => ((a - b).abs() <= c.max(1e-5)) as u8 as f32,
        SmoothMin => smoothmin(a, b, c),
        SmoothMax => -smoothmin(-a, -b, c),
        Round => (a + 0.5).floor(),
        Floor => a.floor(),
        Ceil => a.ceil(),
        Trunc => a.trunc(),
        Fraction => a - a.floor(),
        Modulo => safe_mod(a, b),
        FlooredModulo => floored_mod(a, b),
        Wrap => wrap(a, b, c),
        Snap => {
            if b != 0.0 {
                (a / b).floor() * b
            } else {
                0.0
            }
        }
        PingPong => {
            if b != 0.0 {
                (floored_mod(a - b, 2.0 * b) - b).abs()
            } else {
                0.0
            }
        }
        Sine => a.sin(),
        Cosine => a.cos(),
        Tangent => a.tan(),
        Arcsine => {
            if (-1.0..=1.0).contains(&a) {
                a.asin()
            } else {
                0.0
            }
        }
        Arccosine => {
            if (-1.0..=1.0).contains(&a) {
                a.acos()
            } else {
                0.0
            }
        }
        Arctangent => a.atan(),
        Arctan2 => a.atan2(b),
        Sinh => a.sinh(),
        Cosh => a.cosh(),
        Tanh => a.tanh(),
        Radians => a * (PI / 180.0),
        Degrees => a * (180.0 / PI),
    }
}

pub(super) fn smoothstep(edge0: f32, edge1: f32, x: f32) -> f32 {
    if edge0 == edge1 {
        return if x < edge0 { 0.0 } else { 1.0 };
    }
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The Map Range node (float), Cycles' `svm_node_map_range`.
#[allow(clippy::too_many_arguments)]
pub(super) fn map_range(
    kind: MapRangeKind,
    clamp: bool,
    value: f32,
    from_min: f32,
    from_max: f32,
    to_min: f32,
    to_max: f32,
    steps: f32,
) -> f32 {
    if from_max == from_min {
        return 0.0;
    }
    let factor = match kind {
        MapRangeKind::Linear => (value - from_min) / (from_max - from_min),
        MapRangeKind::Stepped => {
            let f = (value - from_min) / (from_max - from_min);
            if steps > 0.0 {
                (f * (steps + 1.0)).floor() / steps
            } else {
                0.0
            }
        }
        MapRangeKind::Smoothstep => {
            if from_min > from_max {
                1.0 - smoothstep(from_max, from_min, value)
            } else {
                smoothstep(from_min, from_max, value)
            }
        }
        MapRangeKind::Smootherstep => {
            if from_min > from_max {
                1.0 - smootherstep(from_max, from_min, value)
            } else {
                smootherstep(from_min, from_max, value)
            }
        }
    };
    let r = to_min + factor * (to_max - to_min);
    if clamp && matches!(kind, MapRangeKind::Linear | MapRangeKind::Stepped) {
        if to_min > to_max {
            r.clamp(to_max, to_min)
        } else {
            r.clamp(to_min, to_max)
        }
    } else {
        r
    }
}

pub(super) fn smootherstep(edge0: f32, edge1: f32, x: f32) -> f32 {
    let t = ((x - edge0) / (edge1 - edge0)).clamp(0.0, 1.0);
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// The Math node: Value, Value_001, Value_002 combined by `op`, clamped to [0, 1] on request.
#[inline(always)]
pub(super) fn eval_math(op: MathOp, clamp: bool, ins: &impl Operands) -> Vec4 {
    const VALUE: usize = input(MATH_INPUTS, "Value");
    const VALUE_001: usize = input(MATH_INPUTS, "Value_001");
    const VALUE_002: usize = input(MATH_INPUTS, "Value_002");
    let r = math(
        op,
        ins.float(VALUE),
        ins.float(VALUE_001),
        ins.float(VALUE_002),
    );
    splat(if clamp { r.clamp(0.0, 1.0) } else { r })
}

/// The Map Range node (float): Value, From Min, From Max, To Min, To Max, Steps.
#[inline(always)]
pub(super) fn eval_map_range(kind: MapRangeKind, clamp: bool, ins: &impl Operands) -> Vec4 {
    const VALUE: usize = input(MAP_RANGE_INPUTS, "Value");
    const FROM_MIN: usize = input(MAP_RANGE_INPUTS, "From Min");
    const FROM_MAX: usize = input(MAP_RANGE_INPUTS, "From Max");
    const TO_MIN: usize = input(MAP_RANGE_INPUTS, "To Min");
    const TO_MAX: usize = input(MAP_RANGE_INPUTS, "To Max");
    const STEPS: usize = input(MAP_RANGE_INPUTS, "Steps");
    let [v, a, b, c, d, steps] =
        [VALUE, FROM_MIN, FROM_MAX, TO_MIN, TO_MAX, STEPS].map(|k| ins.float(k));
    splat(map_range(kind, clamp, v, a, b, c, d, steps))
}

/// The Clamp node: Value between Min and Max (`range`: whichever is smaller first).
#[inline(always)]
pub(super) fn eval_clamp(range: bool, ins: &impl Operands) -> Vec4 {
    const VALUE: usize = input(CLAMP_INPUTS, "Value");
    const MIN: usize = input(CLAMP_INPUTS, "Min");
    const MAX: usize = input(CLAMP_INPUTS, "Max");
    let (v, lo, hi) = (ins.float(VALUE), ins.float(MIN), ins.float(MAX));
    let r = if range && lo > hi {
        v.clamp(hi, lo)
    } else {
        v.max(lo).min(hi)
    };
    splat(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn math_ops_follow_blender() {
        assert_eq!(math(MathOp::Divide, 1.0, 0.0, 0.0), 0.0);
        assert_eq!(math(MathOp::Power, -2.0, 3.0, 0.0), -8.0);
        assert_eq!(math(MathOp::Power, -2.0, 0.5, 0.0), 0.0);
        assert_eq!(math(MathOp::FlooredModulo, -1.0, 3.0, 0.0), 2.0);
        assert_eq!(math(MathOp::Modulo, -1.0, 3.0, 0.0), -1.0);
        assert_eq!(math(MathOp::Wrap, 1.25, 1.0, 0.0), 0.25);
        assert_eq!(math(MathOp::PingPong, 1.5, 1.0, 0.0), 0.5);
        assert_eq!(math(MathOp::Sqrt, -4.0, 0.0, 0.0), 0.0);
        assert_eq!(math(MathOp::Compare, 1.0, 1.05, 0.1), 1.0);
        assert_eq!(math(MathOp::Round, -0.5, 0.0, 0.0), 0.0);
    }
}
