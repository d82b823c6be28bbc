//! The converter nodes Separate and Combine XYZ, Separate and Combine Color (RGB or HSV).

use super::color::{hsv_to_rgb, rgb_to_hsv};
use super::inputs::{splat, v3, Operands};
use crate::math::{Vec3, Vec4};

/// Separate XYZ: a vector's components.
#[inline(always)]
pub(super) fn separate_xyz(ins: &impl Operands) -> [Vec4; 3] {
    let v = ins.value(0);
    [splat(v.x), splat(v.y), splat(v.z)]
}

/// Combine XYZ: three floats into a vector.
#[inline(always)]
pub(super) fn combine_xyz(ins: &impl Operands) -> Vec4 {
    Vec4::new(ins.float(0), ins.float(1), ins.float(2), 1.0)
}

/// Separate Color: a colour's red, green, blue (or hue, saturation, value).
#[inline(always)]
pub(super) fn separate_color(hsv: bool, ins: &impl Operands) -> [Vec4; 3] {
    let c = ins.vector(0);
    let c = if hsv { rgb_to_hsv(c) } else { c };
    [splat(c.x), splat(c.y), splat(c.z)]
}

/// Combine Color: three floats (red, green, blue or hue, saturation, value) into a colour.
#[inline(always)]
pub(super) fn combine_color(hsv: bool, ins: &impl Operands) -> Vec4 {
    let c = Vec3::new(ins.float(0), ins.float(1), ins.float(2));
    v3(if hsv { hsv_to_rgb(c) } else { c })
}
