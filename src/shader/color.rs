//! The colour nodes: Mix with its blend modes (Cycles' `svm_mix`), Hue/Saturation/Value,
//! Gamma, Brightness/Contrast, Invert Color, RGB Curves and Color Ramp (`rgb_ramp_lookup` over
//! the table the add-on bakes), and the RGB–HSV conversions.

use super::inputs::{input, splat, v3, Operands, Socket, Ty, GREY};
use crate::math::{Vec3, Vec4};

/// The Mix (float) node's inputs.
pub(super) const MIX_FLOAT_INPUTS: &[Socket] = &[
    Socket::float("Factor_Float", 0.5),
    Socket::float("A_Float", 0.0),
    Socket::float("B_Float", 0.0),
];

/// The Mix (float) node's outputs.
pub(super) const MIX_FLOAT_OUTPUTS: &[Socket] = &[Socket::output("Result_Float", Ty::Float)];

/// The Mix (vector) node's inputs.
pub(super) const MIX_VECTOR_INPUTS: &[Socket] = &[
    Socket::float("Factor_Float", 0.5),
    Socket::vector("A_Vector", Vec4::ZERO),
    Socket::vector("B_Vector", Vec4::ZERO),
];

/// The Mix (vector) node's outputs.
pub(super) const MIX_VECTOR_OUTPUTS: &[Socket] = &[Socket::output("Result_Vector", Ty::Vector)];

/// The Mix (colour) node's inputs.
pub(super) const MIX_COLOR_INPUTS: &[Socket] = &[
    Socket::float("Factor_Float", 0.5),
    Socket::color("A_Color", Vec4::new(0.5, 0.5, 0.5, 1.0)),
    Socket::color("B_Color", Vec4::new(0.5, 0.5, 0.5, 1.0)),
];

/// The Mix (colour) node's outputs.
pub(super) const MIX_COLOR_OUTPUTS: &[Socket] = &[Socket::output("Result_Color", Ty::Color)];

/// The RGB Curves node's inputs.
pub(super) const RGB_CURVES_INPUTS: &[Socket] =
    &[Socket::float("Fac", 1.0), Socket::color("Color", Vec4::ONE)];

/// The RGB Curves node's outputs.
pub(super) const RGB_CURVES_OUTPUTS: &[Socket] = &[Socket::output("Color", Ty::Color)];

/// The Color Ramp node's inputs.
pub(super) const COLOR_RAMP_INPUTS: &[Socket] = &[Socket::float("Fac", 0.5)];

/// The Color Ramp node's outputs.
pub(super) const COLOR_RAMP_OUTPUTS: &[Socket] = &[
    Socket::output("Color", Ty::Color),
    Socket::output("Alpha", Ty::Float),
];

/// The Invert node's inputs.
pub(super) const INVERT_INPUTS: &[Socket] = &[
    Socket::float("Fac", 1.0),
    Socket::color("Color", Vec4::ZERO),
];

/// The Invert node's outputs.
pub(super) const INVERT_OUTPUTS: &[Socket] = &[Socket::output("Color", Ty::Color)];

/// The Hue/Saturation/Value node's inputs.
pub(super) const HUE_SATURATION_INPUTS: &[Socket] = &[
    Socket::float("Hue", 0.5),
    Socket::float("Saturation", 1.0),
    Socket::float("Value", 1.0),
    Socket::float("Fac", 1.0),
    Socket::color("Color", GREY),
];

/// The Hue/Saturation/Value node's outputs.
pub(super) const HUE_SATURATION_OUTPUTS: &[Socket] = &[Socket::output("Color", Ty::Color)];

/// The Gamma node's inputs.
pub(super) const GAMMA_INPUTS: &[Socket] = &[
    Socket::color("Color", Vec4::ONE),
    Socket::float("Gamma", 1.0),
];

/// The Gamma node's outputs.
pub(super) const GAMMA_OUTPUTS: &[Socket] = &[Socket::output("Color", Ty::Color)];

/// The Brightness/Contrast node's inputs.
pub(super) const BRIGHT_CONTRAST_INPUTS: &[Socket] = &[
    Socket::color("Color", Vec4::ONE),
    Socket::float("Bright", 0.0),
    Socket::float("Contrast", 0.0),
];

/// The Brightness/Contrast node's outputs.
pub(super) const BRIGHT_CONTRAST_OUTPUTS: &[Socket] = &[Socket::output("Color", Ty::Color)];

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum MixData {
    Float,
    Vector,
    Color,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Blend {
    Mix,
    Add,
    Multiply,
    Subtract,
    Screen,
    Divide,
    Difference,
    Exclusion,
    Darken,
    Lighten,
    Overlay,
    Dodge,
    Burn,
    Hue,
    Saturation,
    Value,
    Color,
    SoftLight,
    LinearLight,
}

pub(super) fn blend_mode(name: &str) -> Option<Blend> {
    use Blend::*;
    Some(match name {
        "MIX" => Mix,
        "ADD" => Add,
        "MULTIPLY" => Multiply,
        "SUBTRACT" => Subtract,
        "SCREEN" => Screen,
        "DIVIDE" => Divide,
        "DIFFERENCE" => Difference,
        "EXCLUSION" => Exclusion,
        "DARKEN" => Darken,
        "LIGHTEN" => Lighten,
        "OVERLAY" => Overlay,
        "DODGE" => Dodge,
        "BURN" => Burn,
        "HUE" => Hue,
        "SATURATION" => Saturation,
        "VALUE" => Value,
        "COLOR" => Color,
        "SOFT_LIGHT" => SoftLight,
        "LINEAR_LIGHT" => LinearLight,
        _ => return None,
    })
}

pub(super) fn gray(c: Vec4) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

pub(super) fn rgb_to_hsv(c: Vec3) -> Vec3 {
    let cmax = c.max_element();
    let cmin = c.min_element();
    let delta = cmax - cmin;
    let v = cmax;
    let s = if cmax != 0.0 { delta / cmax } else { 0.0 };
    if s == 0.0 {
        return Vec3::new(0.0, 0.0, v);
    }
    let cv = (Vec3::splat(cmax) - c) / delta;
    let h = if c.x == cmax {
        cv.z - cv.y
    } else if c.y == cmax {
        2.0 + cv.x - cv.z
    } else {
        4.0 + cv.y - cv.x
    };
    let mut h = h / 6.0;
    if h < 0.0 {
        h += 1.0;
    }
    Vec3::new(h, s, v)
}

pub(super) fn hsv_to_rgb(hsv: Vec3) -> Vec3 {
    let (mut h, s, v) = (hsv.x, hsv.y, hsv.z);
    if s == 0.0 {
        return Vec3::splat(v);
    }
    if h == 1.0 {
        h = 0.0;
    }
    h *= 6.0;
    let i = h.floor();
    let f = h - i;
    let p = v * (1.0 - s);
    let q = v * (1.0 - s * f);
    let t = v * (1.0 - s * (1.0 - f));
    match i as i32 {
        0 => Vec3::new(v, t, p),
        1 => Vec3::new(q, v, p),
        2 => Vec3::new(p, v, t),
        3 => Vec3::new(p, q, v),
        4 => Vec3::new(t, p, v),
        _ => Vec3::new(v, p, q),
    }
}

/// The Mix node's colour blend modes (Cycles' `svm_mix`, Blender's `ramp_blend`).
pub(super) fn mix_color(blend: Blend, t: f32, a: Vec3, b: Vec3) -> Vec3 {
    use Blend::*;
    let tm = 1.0 - t;
    let per = |f: &dyn Fn(f32, f32) -> f32| Vec3::new(f(a.x, b.x), f(a.y, b.y), f(a.z, b.z));
    match blend {
        Mix => a.lerp(b, t),
        Add => a + t * b,
        Multiply => a * (Vec3::splat(tm) + t * b),
        Subtract => a - t * b,
        Screen => Vec3::ONE - (Vec3::splat(tm) + t * (Vec3::ONE - b)) * (Vec3::ONE - a),
        Divide => per(&|x, y| if y != 0.0 { tm * x + t * x / y } else { x }),
        Difference => a.lerp((a - b).abs(), t),
        Exclusion => a.lerp(a + b - 2.0 * a * b, t).max(Vec3::ZERO),
        Darken => a.lerp(a.min(b), t),
        Lighten => a.lerp(a.max(b), t),
        Overlay => per(&|x, y| {
            if x < 0.5 {
                x * (tm + 2.0 * t * y)
            } else {
                1.0 - (tm + 2.0 * t * (1.0 - y)) * (1.0 - x)
            }
        }),
        Dodge => per(&|x, y| {
            if x != 0.0 {
                let tmp = 1.0 - t * y;
                if tmp <= 0.0 {
                    1.0
                } else {
                    let r = x / tmp;
                    if r > 1.0 {
                        1.0
                    } else {
                        r
                    }
                }
            } else {
                x
            }
        }),
        Burn => per(&|x, y| {
            let tmp = tm + t * y;
            if tmp <= 0.0 {
                0.0
            } else {
                let r = 1.0 - (1.0 - x) / tmp;
                r.clamp(0.0, 1.0)
            }
        }),
        Hue => {
            let hb = rgb_to_hsv(b);
            if hb.y != 0.0 {
                let ha = rgb_to_hsv(a);
                let c = hsv_to_rgb(Vec3::new(hb.x, ha.y, ha.z));
                a.lerp(c, t)
            } else {
                a
            }
        }
        Saturation => {
            let ha = rgb_to_hsv(a);
            if ha.y != 0.0 {
                let hb = rgb_to_hsv(b);
                hsv_to_rgb(Vec3::new(ha.x, tm * ha.y + t * hb.y, ha.z))
            } else {
                a
            }
        }
        Value => {
            let ha = rgb_to_hsv(a);
            let hb = rgb_to_hsv(b);
            hsv_to_rgb(Vec3::new(ha.x, ha.y, tm * ha.z + t * hb.z))
        }
        Color => {
            let hb = rgb_to_hsv(b);
            if hb.y != 0.0 {
                let ha = rgb_to_hsv(a);
                let c = hsv_to_rgb(Vec3::new(hb.x, hb.y, ha.z));
                a.lerp(c, t)
            } else {
                a
            }
        }
        SoftLight => {
            let scr = Vec3::ONE - (Vec3::ONE - b) * (Vec3::ONE - a);
            tm * a + t * ((Vec3::ONE - a) * b * a + a * scr)
        }
        LinearLight => a + t * (2.0 * b - Vec3::ONE),
    }
}

/// Cycles' `rgb_ramp_lookup` over the baked table (linear interpolation between entries, or
/// the entry below for Constant).
pub(super) fn ramp_lookup(table: &[Vec4], fac: f32, interpolate: bool) -> Vec4 {
    let n = table.len();
    let fac = if fac.is_finite() {
        fac.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = fac * (n - 1) as f32;
    let i = (x as usize).min(n - 1);
    let t = x - i as f32;
    if interpolate && t > 0.0 && i + 1 < n {
        table[i] * (1.0 - t) + table[i + 1] * t
    } else {
        table[i]
    }
}

/// `ramp_lookup` with Cycles' linear extrapolation beyond [0, 1] (curves).
pub(super) fn ramp_extrapolated(table: &[Vec4], f: f32) -> Vec4 {
    let n = table.len();
    if f < 0.0 {
        table[0] + (table[0] - table[1]) * (-f * (n - 1) as f32)
    } else if f > 1.0 {
        table[n - 1] + (table[n - 1] - table[n - 2]) * ((f - 1.0) * (n - 1) as f32)
    } else {
        ramp_lookup(table, f, true)
    }
}

/// The Mix node: Factor, A, B of its data type.
#[inline(always)]
pub(super) fn eval_mix(
    data: MixData,
    blend: Blend,
    clamp_factor: bool,
    clamp_result: bool,
    ins: &impl Operands,
) -> Vec4 {
    const FACTOR: usize = input(MIX_FLOAT_INPUTS, "Factor_Float");
    const A: usize = input(MIX_FLOAT_INPUTS, "A_Float");
    const B: usize = input(MIX_FLOAT_INPUTS, "B_Float");
    const _: () = assert!(
        A == input(MIX_VECTOR_INPUTS, "A_Vector") && A == input(MIX_COLOR_INPUTS, "A_Color")
    );
    const _: () = assert!(
        B == input(MIX_VECTOR_INPUTS, "B_Vector") && B == input(MIX_COLOR_INPUTS, "B_Color")
    );
    let mut t = ins.float(FACTOR);
    if clamp_factor {
        t = t.clamp(0.0, 1.0);
    }
    let (a, b) = (ins.value(A), ins.value(B));
    match data {
        MixData::Float => splat(a.x + (b.x - a.x) * t),
        MixData::Vector => v3(a.truncate().lerp(b.truncate(), t)),
        MixData::Color => {
            let c = mix_color(blend, t, a.truncate(), b.truncate());
            let c = if clamp_result {
                c.clamp(Vec3::ZERO, Vec3::ONE)
            } else {
                c
            };
            c.extend(a.w)
        }
    }
}

/// RGB Curves: Fac, Color through the baked curves over [min_x, min_x + range].
#[inline(always)]
pub(super) fn eval_rgb_curves(table: &[Vec4], min_x: f32, range: f32, ins: &impl Operands) -> Vec4 {
    const FAC: usize = input(RGB_CURVES_INPUTS, "Fac");
    const COLOR: usize = input(RGB_CURVES_INPUTS, "Color");
    let fac = ins.float(FAC);
    let c = ins.value(COLOR);
    let rel = (c.truncate() - Vec3::splat(min_x)) / range;
    let curve = Vec3::new(
        ramp_extrapolated(table, rel.x).x,
        ramp_extrapolated(table, rel.y).y,
        ramp_extrapolated(table, rel.z).z,
    );
    ((1.0 - fac) * c.truncate() + fac * curve).extend(c.w)
}

/// Color Ramp: Fac to Color and Alpha.
#[inline(always)]
pub(super) fn eval_color_ramp(table: &[Vec4], interpolate: bool, ins: &impl Operands) -> [Vec4; 2] {
    const FAC: usize = input(COLOR_RAMP_INPUTS, "Fac");
    let c = ramp_lookup(table, ins.float(FAC), interpolate);
    [c, splat(c.w)]
}

/// Invert Color: Fac, Color.
#[inline(always)]
pub(super) fn eval_invert(ins: &impl Operands) -> Vec4 {
    const FAC: usize = input(INVERT_INPUTS, "Fac");
    const COLOR: usize = input(INVERT_INPUTS, "Color");
    let t = ins.float(FAC);
    let c = ins.value(COLOR);
    let inv = Vec3::ONE - c.truncate();
    c.truncate().lerp(inv, t).extend(c.w)
}

/// Hue/Saturation/Value: Hue, Saturation, Value, Fac, Color.
#[inline(always)]
pub(super) fn eval_hue_saturation(ins: &impl Operands) -> Vec4 {
    const HUE: usize = input(HUE_SATURATION_INPUTS, "Hue");
    const SATURATION: usize = input(HUE_SATURATION_INPUTS, "Saturation");
    const VALUE: usize = input(HUE_SATURATION_INPUTS, "Value");
    const FAC: usize = input(HUE_SATURATION_INPUTS, "Fac");
    const COLOR: usize = input(HUE_SATURATION_INPUTS, "Color");
    let (hue, sat, val, fac) = (
        ins.float(HUE),
        ins.float(SATURATION),
        ins.float(VALUE),
        ins.float(FAC),
    );
    let input = ins.value(COLOR);
    let mut hsv = rgb_to_hsv(input.truncate());
    hsv.x = (hsv.x + hue + 0.5) % 1.0;
    hsv.y = (hsv.y * sat).clamp(0.0, 1.0);
    hsv.z *= val;
    let c = hsv_to_rgb(hsv);
    let c = (fac * c + (1.0 - fac) * input.truncate()).max(Vec3::ZERO);
    c.extend(input.w)
}

/// Gamma: Color, Gamma (positive channels raised to it).
#[inline(always)]
pub(super) fn eval_gamma(ins: &impl Operands) -> Vec4 {
    const COLOR: usize = input(GAMMA_INPUTS, "Color");
    const GAMMA: usize = input(GAMMA_INPUTS, "Gamma");
    let c = ins.value(COLOR);
    let g = ins.float(GAMMA);
    let p = |x: f32| if x > 0.0 { x.powf(g) } else { x };
    Vec4::new(p(c.x), p(c.y), p(c.z), c.w)
}

/// Brightness/Contrast: Color, Bright, Contrast.
#[inline(always)]
pub(super) fn eval_bright_contrast(ins: &impl Operands) -> Vec4 {
    const COLOR: usize = input(BRIGHT_CONTRAST_INPUTS, "Color");
    const BRIGHT: usize = input(BRIGHT_CONTRAST_INPUTS, "Bright");
    const CONTRAST: usize = input(BRIGHT_CONTRAST_INPUTS, "Contrast");
    let c = ins.value(COLOR);
    let (bright, contrast) = (ins.float(BRIGHT), ins.float(CONTRAST));
    let a = 1.0 + contrast;
    let b = bright - contrast * 0.5;
    (a * c.truncate() + Vec3::splat(b))
        .max(Vec3::ZERO)
        .extend(c.w)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn color_ramp_interpolates_the_table_as_cycles() {
        let table = vec![Vec4::ZERO, Vec4::ONE, Vec4::new(1.0, 0.0, 0.0, 1.0)];
        assert_eq!(ramp_lookup(&table, 0.25, true), Vec4::splat(0.5));
        assert_eq!(ramp_lookup(&table, 0.25, false), Vec4::ZERO);
        assert_eq!(
            ramp_lookup(&table, 0.75, true),
            Vec4::new(1.0, 0.5, 0.5, 1.0)
        );
        assert_eq!(ramp_lookup(&table, 7.0, true), table[2]);
        assert_eq!(ramp_lookup(&table, f32::NAN, true), table[0]);
        // Curves extrapolate linearly beyond the table (one entry step per 1/(n − 1)).
        assert_eq!(ramp_extrapolated(&table, -0.5), Vec4::splat(-1.0));
        assert_eq!(
            ramp_extrapolated(&table, 1.5),
            Vec4::new(1.0, -1.0, -1.0, 1.0)
        );
    }

    #[test]
    fn mix_color_blend_modes() {
        let a = Vec3::new(0.2, 0.4, 0.6);
        let b = Vec3::new(0.5, 0.5, 0.5);
        assert!((mix_color(Blend::Multiply, 1.0, a, b) - a * 0.5).length() < 1e-6);
        assert!((mix_color(Blend::Add, 0.5, a, b) - (a + 0.25)).length() < 1e-6);
        assert!(
            (mix_color(Blend::Screen, 1.0, a, b) - (Vec3::ONE - 0.5 * (Vec3::ONE - a))).length()
                < 1e-6
        );
        assert!((mix_color(Blend::Mix, 0.5, a, b) - (a + b) * 0.5).length() < 1e-6);
        let c = Vec3::new(0.8, 0.2, 0.1);
        assert!((hsv_to_rgb(rgb_to_hsv(c)) - c).length() < 1e-6);
    }
}
