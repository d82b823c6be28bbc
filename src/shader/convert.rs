//! The converter nodes Separate and Combine XYZ, Separate and Combine Color (RGB or HSV).

use super::color::{hsv_to_rgb, rgb_to_hsv};
use super::inputs::{input, splat, v3, Operands, Socket, Ty, GREY};
use crate::math::{Vec3, Vec4};

/// The Separate XYZ node's inputs.
pub(super) const SEPARATE_XYZ_INPUTS: &[Socket] = &[Socket::vector("Vector", Vec4::ZERO)];

/// The Separate XYZ node's outputs.
pub(super) const SEPARATE_XYZ_OUTPUTS: &[Socket] = &[
    Socket::output("X", Ty::Float),
    Socket::output("Y", Ty::Float),
    Socket::output("Z", Ty::Float),
];

/// The Combine XYZ node's inputs.
pub(super) const COMBINE_XYZ_INPUTS: &[Socket] = &[
    Socket::float("X", 0.0),
    Socket::float("Y", 0.0),
    Socket::float("Z", 0.0),
];

/// The Combine XYZ node's outputs.
pub(super) const COMBINE_XYZ_OUTPUTS: &[Socket] = &[Socket::output("Vector", Ty::Vector)];

/// The Separate Color node's inputs.
pub(super) const SEPARATE_COLOR_INPUTS: &[Socket] = &[Socket::color("Color", GREY)];

/// The Separate Color node's outputs.
pub(super) const SEPARATE_COLOR_OUTPUTS: &[Socket] = &[
    Socket::output("Red", Ty::Float),
    Socket::output("Green", Ty::Float),
    Socket::output("Blue", Ty::Float),
];

/// The Combine Color node's inputs.
pub(super) const COMBINE_COLOR_INPUTS: &[Socket] = &[
    Socket::float("Red", 0.0),
    Socket::float("Green", 0.0),
    Socket::float("Blue", 0.0),
];

/// The Combine Color node's outputs.
pub(super) const COMBINE_COLOR_OUTPUTS: &[Socket] = &[Socket::output("Color", Ty::Color)];

/// Separate XYZ: a vector's components.
#[inline(always)]
pub(super) fn separate_xyz(ins: &impl Operands) -> [Vec4; 3] {
    const VECTOR: usize = input(SEPARATE_XYZ_INPUTS, "Vector");
    let v = ins.value(VECTOR);
    [splat(v.x), splat(v.y), splat(v.z)]
}

/// Combine XYZ: three floats into a vector.
#[inline(always)]
pub(super) fn combine_xyz(ins: &impl Operands) -> Vec4 {
    const X: usize = input(COMBINE_XYZ_INPUTS, "X");
    const Y: usize = input(COMBINE_XYZ_INPUTS, "Y");
    const Z: usize = input(COMBINE_XYZ_INPUTS, "Z");
    Vec4::new(ins.float(X), ins.float(Y), ins.float(Z), 1.0)
}

/// Separate Color: a colour's red, green, blue (or hue, saturation, value).
#[inline(always)]
pub(super) fn separate_color(hsv: bool, ins: &impl Operands) -> [Vec4; 3] {
    const COLOR: usize = input(SEPARATE_COLOR_INPUTS, "Color");
    let c = ins.vector(COLOR);
    let c = if hsv { rgb_to_hsv(c) } else { c };
    [splat(c.x), splat(c.y), splat(c.z)]
}

/// Combine Color: three floats (red, green, blue or hue, saturation, value) into a colour.
#[inline(always)]
pub(super) fn combine_color(hsv: bool, ins: &impl Operands) -> Vec4 {
    const RED: usize = input(COMBINE_COLOR_INPUTS, "Red");
    const GREEN: usize = input(COMBINE_COLOR_INPUTS, "Green");
    const BLUE: usize = input(COMBINE_COLOR_INPUTS, "Blue");
    let c = Vec3::new(ins.float(RED), ins.float(GREEN), ins.float(BLUE));
    v3(if hsv { hsv_to_rgb(c) } else { c })
}
