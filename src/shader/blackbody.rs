//! The Blackbody node: Cycles' piecewise fit of Planck's law in Rec. 709.

use super::inputs::{input, v3, Operands, Socket, Ty};
use crate::color_space::WorkingSpace;
use crate::math::{Vec3, Vec4};

/// The Blackbody node's inputs.
pub(super) const BLACKBODY_INPUTS: &[Socket] = &[Socket::float("Temperature", 1500.0)];

/// The Blackbody node's outputs.
pub(super) const BLACKBODY_OUTPUTS: &[Socket] = &[Socket::output("Color", Ty::Color)];

/// Fits of the black-body colour in Rec.709 (Cycles' `blackbody_table_r/g/b`, fitted to
/// Planck's law normalised to unit luminance), per temperature interval: R and G as
/// a/T + b·T + c, B as ((a·T + b)·T + c)·T + d.
pub(super) const BLACKBODY_R: [[f32; 3]; 7] = [
    [1.619191e3, -2.0501092e-3, 5.029958],
    [2.4884546e3, -1.1133091e-3, 3.2262154],
    [3.341432e3, -4.865512e-4, 1.7648677],
    [4.0946174e3, -1.2744658e-4, 7.257316e-1],
    [4.6702803e3, 2.912582e-5, 1.2670344e-1],
    [4.595092e3, 2.8749564e-5, 1.5034503e-1],
    [3.7871746e3, 9.359078e-6, 3.9907587e-1],
];
pub(super) const BLACKBODY_G: [[f32; 3]; 7] = [
    [-4.8899976e2, 6.0433074e-4, -7.558075e-2],
    [-7.5599426e2, 3.167301e-4, 4.7830614e-1],
    [-1.0236398e3, 1.2022347e-4, 9.366623e-1],
    [-1.2657131e3, 4.873409e-6, 1.270545],
    [-1.4252933e3, -4.0115043e-5, 1.4397278],
    [-1.1755482e3, -2.1637805e-5, 1.3040802],
    [-5.0079956e2, -4.59832e-6, 1.0909877],
];
pub(super) const BLACKBODY_B: [[f32; 4]; 7] = [
    [5.9694534e-11, -4.857429e-8, -9.706223e-5, -4.0793614e-3],
    [2.4043037e-11, 5.5502106e-8, -1.9850371e-4, 2.8931286e-2],
    [-1.40949735e-11, 1.8987897e-7, -3.5663284e-4, 9.107678e-2],
    [-3.6146086e-11, 2.8482202e-7, -4.932113e-4, 1.5672344e-1],
    [-1.9707574e-11, 1.7535935e-7, -2.5054283e-4, -2.2278327e-2],
    [-1.6199795e-13, -1.64216e-8, 3.8621627e-4, -7.380774e-1],
    [6.726503e-13, -2.730788e-8, 4.2409825e-4, -7.5233567e-1],
];

/// The Blackbody node's colour at `t` kelvin (Rec.709, unit luminance, may be negative
/// outside the gamut): Cycles' piecewise fit over 800–12000 K, constant beyond.
pub(super) fn blackbody(t: f32) -> Vec3 {
    if t >= 12000.0 {
        return Vec3::new(0.826_295_5, 0.994_508, 1.566_307_7);
    }
    if t < 800.0 || t.is_nan() {
        return Vec3::new(5.413_294_5, -0.203_193_9, -0.082_253_52);
    }
    let i = [965.0, 1167.0, 1449.0, 1902.0, 3315.0, 6365.0]
        .iter()
        .filter(|&&edge| t >= edge)
        .count();
    let (r, g, b) = (BLACKBODY_R[i], BLACKBODY_G[i], BLACKBODY_B[i]);
    Vec3::new(
        r[0] / t + r[1] * t + r[2],
        g[0] / t + g[1] * t + g[2],
        ((b[0] * t + b[1]) * t + b[2]) * t + b[3],
    )
}

/// The Blackbody node: Temperature to Color in the working colour space `space` (negative
/// channels clipped), as Cycles takes its Rec.709 fit into the scene's space.
#[inline(always)]
pub(super) fn eval_blackbody(space: WorkingSpace, ins: &impl Operands) -> Vec4 {
    const TEMPERATURE: usize = input(BLACKBODY_INPUTS, "Temperature");
    v3(space
        .convert_rec709(blackbody(ins.float(TEMPERATURE)))
        .max(Vec3::ZERO))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blackbody_matches_cycles_values() {
        // Values of Cycles' fit at 6500 K and 3315 K, and its constants past both ends.
        let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 2e-4;
        assert!(close(
            blackbody(6500.0),
            Vec3::new(1.042_552, 0.984_052_5, 1.035_271_5)
        ));
        assert!(close(
            blackbody(3315.0),
            Vec3::new(1.631_801, 0.877_736, 0.355_867)
        ));
        assert_eq!(blackbody(20000.0), blackbody(12000.0));
        assert_eq!(blackbody(100.0).x, 5.413_294_5);
        // Nearly continuous across the fit's intervals.
        for edge in [965.0, 1167.0, 1449.0, 1902.0, 3315.0, 6365.0] {
            let jump = (blackbody(edge - 0.01) - blackbody(edge))
                .abs()
                .max_element();
            assert!(jump < 5e-3, "{edge}: {jump}");
        }
    }
}
