//! The Wave Texture (Cycles' `svm_wave`), its distortion a Perlin fBm (`noise`).

use super::inputs::{input, splat, Operands, Socket, Ty};
use super::noise::{fbm, Fractal};
use crate::math::{Vec3, Vec4};
use std::f32::consts::PI;

/// The Wave node's inputs.
pub(super) const WAVE_INPUTS: &[Socket] = &[
    Socket::vector("Vector", Vec4::ZERO),
    Socket::float("Scale", 5.0),
    Socket::float("Distortion", 0.0),
    Socket::float("Detail", 2.0),
    Socket::float("Detail Scale", 1.0),
    Socket::float("Detail Roughness", 0.5),
    Socket::float("Phase Offset", 0.0),
];

/// The Wave node's outputs.
pub(super) const WAVE_OUTPUTS: &[Socket] = &[
    Socket::output("Color", Ty::Color),
    Socket::output("Fac", Ty::Float),
];

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum WaveProfile {
    Sine,
    Saw,
    Triangle,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct WaveKind {
    pub(super) bands: bool,
    /// Bands: X, Y, Z, diagonal; rings: X, Y, Z, spherical.
    pub(super) direction: u8,
    pub(super) profile: WaveProfile,
}

/// Cycles' `svm_wave` on the scaled point; `detail` holds Distortion, Detail, Detail Scale,
/// Detail Roughness and Phase Offset.
pub(super) fn wave(kind: WaveKind, p: Vec3, detail: [f32; 5]) -> f32 {
    let [distortion, octaves, detail_scale, detail_roughness, phase] = detail;
    let p = (p + Vec3::splat(0.000_001)) * 0.999_999;
    let mut n = if kind.bands {
        match kind.direction {
            0 => p.x * 20.0,
            1 => p.y * 20.0,
            2 => p.z * 20.0,
            _ => (p.x + p.y + p.z) * 10.0,
        }
    } else {
        let rp = match kind.direction {
            0 => p * Vec3::new(0.0, 1.0, 1.0),
            1 => p * Vec3::new(1.0, 0.0, 1.0),
            2 => p * Vec3::new(1.0, 1.0, 0.0),
            _ => p,
        };
        rp.length() * 20.0
    };
    n += phase;
    if distortion != 0.0 {
        let f = Fractal {
            detail: octaves,
            roughness: detail_roughness,
            lacunarity: 2.0,
            normalize: true,
        };
        n += distortion * (fbm(3, p * detail_scale, 0.0, &f) * 2.0 - 1.0);
    }
    match kind.profile {
        WaveProfile::Sine => 0.5 + 0.5 * (n - std::f32::consts::FRAC_PI_2).sin(),
        WaveProfile::Saw => {
            let n = n / (2.0 * PI);
            n - n.floor()
        }
        WaveProfile::Triangle => {
            let n = n / (2.0 * PI);
            (n - (n + 0.5).floor()).abs() * 2.0
        }
    }
}

/// The Wave Texture: Vector, Scale, Distortion, Detail, Detail Scale, Detail Roughness,
/// Phase Offset to Color and Fac.
#[inline(always)]
pub(super) fn eval_wave(kind: WaveKind, ins: &impl Operands) -> [Vec4; 2] {
    const VECTOR: usize = input(WAVE_INPUTS, "Vector");
    const SCALE: usize = input(WAVE_INPUTS, "Scale");
    const DISTORTION: usize = input(WAVE_INPUTS, "Distortion");
    const DETAIL: usize = input(WAVE_INPUTS, "Detail");
    const DETAIL_SCALE: usize = input(WAVE_INPUTS, "Detail Scale");
    const DETAIL_ROUGHNESS: usize = input(WAVE_INPUTS, "Detail Roughness");
    const PHASE_OFFSET: usize = input(WAVE_INPUTS, "Phase Offset");
    let p = ins.vector(VECTOR) * ins.float(SCALE);
    let fac = wave(
        kind,
        p,
        [
            ins.float(DISTORTION),
            ins.float(DETAIL).clamp(0.0, 15.0),
            ins.float(DETAIL_SCALE),
            ins.float(DETAIL_ROUGHNESS),
            ins.float(PHASE_OFFSET),
        ],
    );
    [splat(fac), splat(fac)]
}
