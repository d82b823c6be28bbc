//! The Image Texture node (flat projection) over the scene's textures.

use super::inputs::{input, splat, Operands, Socket, Ty};
use crate::math::{Vec2, Vec4};
use crate::scene::texture::Texture;

/// The Image node's inputs.
pub(super) const IMAGE_INPUTS: &[Socket] = &[Socket::vector("Vector", Vec4::ZERO)];

/// The Image node's outputs.
pub(super) const IMAGE_OUTPUTS: &[Socket] = &[
    Socket::output("Color", Ty::Color),
    Socket::output("Alpha", Ty::Float),
];

/// The Image Texture: Vector (UV) to Color and Alpha; transparent black outside [0, 1]² with
/// `clip`, magenta when the texture is missing.
#[inline(always)]
pub(super) fn eval_image(
    texture: u32,
    clip: bool,
    textures: &[Texture],
    ins: &impl Operands,
) -> [Vec4; 2] {
    const VECTOR: usize = input(IMAGE_INPUTS, "Vector");
    let uv = ins.value(VECTOR);
    let outside = !(0.0..=1.0).contains(&uv.x) || !(0.0..=1.0).contains(&uv.y);
    // Blender's image rows go up from the bottom; Photon's from the top.
    let c = match textures.get(texture as usize) {
        Some(_) if clip && outside => Vec4::ZERO,
        Some(t) => t.sample_encoded(Vec2::new(uv.x, 1.0 - uv.y)),
        None => Vec4::new(1.0, 0.0, 1.0, 1.0),
    };
    [c, splat(c.w)]
}
