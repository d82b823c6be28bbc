//! The Fresnel and Layer Weight nodes (Cycles' `fresnel_dielectric_cos`).

use super::inputs::{input, normal_input, splat, Operands, ShadingInputs, Socket, Ty};
use crate::math::Vec4;

/// The Fresnel node's inputs.
pub(super) const FRESNEL_INPUTS: &[Socket] = &[
    Socket::float("IOR", 1.5),
    Socket::vector("Normal", Vec4::ZERO),
];

/// The Fresnel node's outputs.
pub(super) const FRESNEL_OUTPUTS: &[Socket] = &[Socket::output("Fac", Ty::Float)];

/// The Layer Weight node's inputs.
pub(super) const LAYER_WEIGHT_INPUTS: &[Socket] = &[
    Socket::float("Blend", 0.5),
    Socket::vector("Normal", Vec4::ZERO),
];

/// The Layer Weight node's outputs.
pub(super) const LAYER_WEIGHT_OUTPUTS: &[Socket] = &[
    Socket::output("Fresnel", Ty::Float),
    Socket::output("Facing", Ty::Float),
];

/// Cycles' `fresnel_dielectric_cos`: unpolarised Fresnel reflectance at cosine `cos` for
/// relative IOR `eta` (1 under total internal reflection).
pub(super) fn fresnel_dielectric_cos(cos: f32, eta: f32) -> f32 {
    let c = cos.abs();
    let g = eta * eta - 1.0 + c * c;
    if g > 0.0 {
        let g = g.sqrt();
        let a = (g - c) / (g + c);
        let b = (c * (g + c) - 1.0) / (c * (g - c) + 1.0);
        0.5 * a * a * (1.0 + b * b)
    } else {
        1.0
    }
}

/// The Fresnel node: IOR, Normal.
#[inline(always)]
pub(super) fn eval_fresnel(inputs: &ShadingInputs, ins: &impl Operands) -> Vec4 {
    const IOR: usize = input(FRESNEL_INPUTS, "IOR");
    const NORMAL: usize = input(FRESNEL_INPUTS, "Normal");
    let n = normal_input(ins.value(NORMAL), inputs.normal);
    let eta = ins.float(IOR).max(1e-5);
    let eta = if inputs.backfacing { 1.0 / eta } else { eta };
    splat(fresnel_dielectric_cos(inputs.incoming.dot(n), eta))
}

/// The Layer Weight node: Blend, Normal to Fresnel and Facing.
#[inline(always)]
pub(super) fn eval_layer_weight(inputs: &ShadingInputs, ins: &impl Operands) -> [Vec4; 2] {
    const BLEND: usize = input(LAYER_WEIGHT_INPUTS, "Blend");
    const NORMAL: usize = input(LAYER_WEIGHT_INPUTS, "Normal");
    let n = normal_input(ins.value(NORMAL), inputs.normal);
    let blend = ins.float(BLEND);
    let eta = (1.0 - blend).max(1e-5);
    let eta = if inputs.backfacing { eta } else { 1.0 / eta };
    let cos = inputs.incoming.dot(n);
    let fresnel = splat(fresnel_dielectric_cos(cos, eta));
    let mut facing = cos.abs();
    if blend != 0.5 {
        let b = blend.clamp(0.0, 1.0 - 1e-5);
        let b = if b < 0.5 { 2.0 * b } else { 0.5 / (1.0 - b) };
        facing = facing.powf(b);
    }
    [fresnel, splat(1.0 - facing)]
}
