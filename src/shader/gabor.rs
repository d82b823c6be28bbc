//! The Gabor Texture (Blender 4.3+): sparse Gabor convolution noise (Lagae, Lefebvre, Drettakis
//! & Dutré 2009) with a fixed number of impulses per cell and Bernoulli weights (Tavernier et
//! al. 2019), evaluated as a phasor so that its phase and intensity can be read (Tricard et al.
//! 2019), as Cycles defines it (`svm_node_tex_gabor`): a Hann-windowed unit Gaussian envelope,
//! eight impulses per cell over the 3×3 (or 3×3×3) neighbouring cells, each impulse's
//! orientation, centre and sign drawn from Jenkins' lookup3 of the cell and the impulse's
//! number, normalised by six times the noise's standard deviation.

use super::hash::{hash3, hash4, unit};
use super::inputs::{input, splat, Operands, Socket, Ty};
use crate::math::{Vec2, Vec3, Vec4};
use std::f32::consts::{FRAC_PI_4, PI, SQRT_2};

/// The Gabor node's inputs.
pub(super) const GABOR_INPUTS: &[Socket] = &[
    Socket::vector("Vector", Vec4::ZERO),
    Socket::float("Scale", 5.0),
    Socket::float("Frequency", 2.0),
    Socket::float("Anisotropy", 1.0),
    Socket::float("Orientation 2D", FRAC_PI_4),
    Socket::vector("Orientation 3D", Vec4::new(SQRT_2, SQRT_2, 0.0, 1.0)),
];

/// The Gabor node's outputs.
pub(super) const GABOR_OUTPUTS: &[Socket] = &[
    Socket::output("Value", Ty::Float),
    Socket::output("Phase", Ty::Float),
    Socket::output("Intensity", Ty::Float),
];

/// Impulses per cell.
const IMPULSES: u32 = 8;

fn hash_of3(x: f32, y: f32, z: f32) -> f32 {
    unit(hash3(x.to_bits(), y.to_bits(), z.to_bits()))
}

fn hash_of4(x: f32, y: f32, z: f32, w: f32) -> f32 {
    unit(hash4(x.to_bits(), y.to_bits(), z.to_bits(), w.to_bits()))
}

/// The windowed Gaussian envelope at squared distance `d2` times the phasor of `angle`.
fn kernel(d2: f32, angle: f32) -> Vec2 {
    let window = 0.5 + 0.5 * (PI * d2).cos();
    let envelope = (-PI * d2).exp() * window;
    Vec2::new(envelope * angle.cos(), envelope * angle.sin())
}

/// The sum of the impulses of 2D cell `cell` at `p` (relative to the cell's corner).
fn cell_2d(cell: Vec2, p: Vec2, frequency: f32, isotropy: f32, orientation: f32) -> Vec2 {
    let mut sum = Vec2::ZERO;
    for i in 0..IMPULSES {
        let seed = |k: u32| (i * 3 + k) as f32;
        let turn = (hash_of3(cell.x, cell.y, seed(0)) - 0.5) * PI;
        let angle_of_impulse = orientation + turn * isotropy;
        let centre = Vec2::new(
            hash_of3(cell.x, cell.y, seed(1)),
            hash_of3(seed(1), cell.x, cell.y),
        );
        let d = p - centre;
        let d2 = d.dot(d);
        if d2 >= 1.0 {
            continue;
        }
        let sign = if hash_of3(cell.x, cell.y, seed(2)) < 0.5 {
            -1.0
        } else {
            1.0
        };
        let direction = Vec2::new(angle_of_impulse.cos(), angle_of_impulse.sin());
        sum += sign * kernel(d2, 2.0 * PI * d.dot(frequency * direction));
    }
    sum
}

/// The impulse's direction in 3D: `base` turned by random inclination and azimuth steps of up
/// to π times `isotropy` (in spherical coordinates), drawn from `seed`.
fn direction_3d(base: Vec3, isotropy: f32, seed: [f32; 4]) -> Vec3 {
    if isotropy == 0.0 {
        return base;
    }
    let [x, y, z, w] = seed;
    let mut inclination = base.z.acos();
    let sign = if base.y < 0.0 { -1.0 } else { 1.0 };
    let mut azimuth = sign * (base.x / Vec2::new(base.x, base.y).length()).acos();
    inclination += hash_of4(x, y, z, w) * PI * isotropy;
    azimuth += hash_of4(z, x, w, y) * PI * isotropy;
    let s = inclination.sin();
    Vec3::new(s * azimuth.cos(), s * azimuth.sin(), inclination.cos())
}

/// The sum of the impulses of 3D cell `cell` at `p` (relative to the cell's corner).
fn cell_3d(cell: Vec3, p: Vec3, frequency: f32, isotropy: f32, base: Vec3) -> Vec2 {
    let mut sum = Vec2::ZERO;
    let (x, y, z) = (cell.x, cell.y, cell.z);
    for i in 0..IMPULSES {
        let seed = |k: u32| (i * 3 + k) as f32;
        let direction = direction_3d(base, isotropy, [x, y, z, seed(0)]);
        let w = seed(1);
        let centre = Vec3::new(
            hash_of4(x, y, z, w),
            hash_of4(z, x, w, y),
            hash_of4(w, z, y, x),
        );
        let d = p - centre;
        let d2 = d.dot(d);
        if d2 >= 1.0 {
            continue;
        }
        let sign = if hash_of4(x, y, z, seed(2)) < 0.5 {
            -1.0
        } else {
            1.0
        };
        sum += sign * kernel(d2, 2.0 * PI * d.dot(frequency * direction));
    }
    sum
}

/// The Gabor noise phasor at `p` (2D reads x and y) and its normalisation (six standard
/// deviations of the noise's value).
pub(super) fn gabor(
    three_d: bool,
    p: Vec3,
    frequency: f32,
    isotropy: f32,
    angle: f32,
    direction: Vec3,
) -> (Vec2, f32) {
    let mut sum = Vec2::ZERO;
    if three_d {
        let cell = p.floor();
        let local = p - cell;
        let direction = direction.normalize();
        for k in -1..=1 {
            for j in -1..=1 {
                for i in -1..=1 {
                    let offset = Vec3::new(i as f32, j as f32, k as f32);
                    sum += cell_3d(
                        cell + offset,
                        local - offset,
                        frequency,
                        isotropy,
                        direction,
                    );
                }
            }
        }
        let integral = 1.0 / (4.0 * SQRT_2);
        (sum, 6.0 * (IMPULSES as f32 * 0.5 * integral).sqrt())
    } else {
        let q = Vec2::new(p.x, p.y);
        let cell = q.floor();
        let local = q - cell;
        for j in -1..=1 {
            for i in -1..=1 {
                let offset = Vec2::new(i as f32, j as f32);
                sum += cell_2d(cell + offset, local - offset, frequency, isotropy, angle);
            }
        }
        (sum, 6.0 * (IMPULSES as f32 * 0.5 * 0.25).sqrt())
    }
}

/// The Gabor Texture: Value (the phasor's imaginary part, mapped from [−1, 1] to [0, 1]),
/// Phase (its angle over a turn) and Intensity (its length).
#[inline(always)]
pub(super) fn eval_gabor(three_d: bool, ins: &impl Operands) -> [Vec4; 3] {
    const VECTOR: usize = input(GABOR_INPUTS, "Vector");
    const SCALE: usize = input(GABOR_INPUTS, "Scale");
    const FREQUENCY: usize = input(GABOR_INPUTS, "Frequency");
    const ANISOTROPY: usize = input(GABOR_INPUTS, "Anisotropy");
    const ORIENTATION_2D: usize = input(GABOR_INPUTS, "Orientation 2D");
    const ORIENTATION_3D: usize = input(GABOR_INPUTS, "Orientation 3D");
    let (phasor, normalisation) = gabor(
        three_d,
        ins.vector(VECTOR) * ins.float(SCALE),
        ins.float(FREQUENCY).max(0.001),
        1.0 - ins.float(ANISOTROPY).clamp(0.0, 1.0),
        ins.float(ORIENTATION_2D),
        ins.vector(ORIENTATION_3D),
    );
    [
        splat(phasor.y / normalisation * 0.5 + 0.5),
        splat((phasor.y.atan2(phasor.x) + PI) / (2.0 * PI)),
        splat(phasor.length() / normalisation),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gabor_noise_is_centred_bounded_and_anisotropic_along_its_orientation() {
        // Fully anisotropic 2D noise oriented along x is constant along y within a cell's
        // impulses' reach only where the envelope is; its value stays in [0, 1] and averages ½.
        let mut mean = 0.0;
        let n = 400;
        for k in 0..n {
            let p = Vec3::new(k as f32 * 0.137, k as f32 * 0.071, 0.0);
            for three_d in [false, true] {
                let (phasor, norm) = gabor(three_d, p, 2.0, 0.5, 0.3, Vec3::X);
                let value = phasor.y / norm * 0.5 + 0.5;
                assert!((-0.2..=1.2).contains(&value), "{value} at {p}");
                mean += value / (2 * n) as f32;
            }
        }
        assert!((mean - 0.5).abs() < 0.05, "{mean}");
        // A frequency of zero leaves only the envelope: no imaginary part.
        let (phasor, _) = gabor(false, Vec3::new(0.3, 0.7, 0.0), 0.0, 0.0, 0.0, Vec3::X);
        assert!(phasor.y.abs() < 1e-6 && phasor.x != 0.0);
    }
}
