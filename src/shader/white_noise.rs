//! The White Noise Texture: Cycles' `hash_floatN_to_float` and `hash_floatN_to_float3` of the
//! coordinates' bits (Jenkins' lookup3, `hash`).

use super::hash::{hash1, hash2, hash3, hash4, unit};
use super::inputs::{input, splat, v3, Operands, Socket, Ty};
use crate::math::{Vec3, Vec4};

/// The White Noise node's inputs.
pub(super) const WHITE_NOISE_INPUTS: &[Socket] = &[
    Socket::vector("Vector", Vec4::ZERO),
    Socket::float("W", 0.0),
];

/// The White Noise node's outputs.
pub(super) const WHITE_NOISE_OUTPUTS: &[Socket] = &[
    Socket::output("Value", Ty::Float),
    Socket::output("Color", Ty::Color),
];

/// `hash_floatN_to_float` and `hash_floatN_to_float3` of the White Noise texture: the value
/// and colour of the hash of the point's (and W's) bits, 1D reading W only, 2D x and y.
pub(super) fn white_noise(dimensions: u8, p: Vec3, w: f32) -> (f32, Vec3) {
    let (x, y, z, w) = (p.x.to_bits(), p.y.to_bits(), p.z.to_bits(), w.to_bits());
    let (one, two) = (1f32.to_bits(), 2f32.to_bits());
    let hashes = match dimensions {
        1 => [hash1(w), hash2(w, one), hash2(w, two)],
        2 => [hash2(x, y), hash3(x, y, one), hash3(x, y, two)],
        3 => [hash3(x, y, z), hash4(x, y, z, one), hash4(x, y, z, two)],
        _ => [hash4(x, y, z, w), hash4(z, x, w, y), hash4(w, z, y, x)],
    };
    let [a, b, c] = hashes.map(unit);
    (a, Vec3::new(a, b, c))
}

/// The White Noise Texture: Vector, W to Value and Color.
#[inline(always)]
pub(super) fn eval_white_noise(dimensions: u8, ins: &impl Operands) -> [Vec4; 2] {
    const VECTOR: usize = input(WHITE_NOISE_INPUTS, "Vector");
    const W: usize = input(WHITE_NOISE_INPUTS, "W");
    let (value, color) = white_noise(dimensions, ins.vector(VECTOR), ins.float(W));
    [splat(value), v3(color)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shader::magic::magic;

    #[test]
    fn white_noise_colour_starts_with_its_value_and_magic_without_distortion_is_grey() {
        let p = Vec3::new(1.0, 2.0, 3.0);
        for d in 1..=4 {
            let (v, c) = white_noise(d, p, 0.5);
            assert_eq!(v, c.x);
            assert!((0.0..=1.0).contains(&v) && c.y != c.z);
        }
        assert_ne!(white_noise(3, p, 0.0).0, white_noise(2, p, 0.0).0);
        assert_eq!(magic(p, 5.0, 4, 0.0), Vec3::splat(0.5));
    }
}
