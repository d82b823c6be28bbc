//! The Brick Texture (Cycles' `svm_brick`, with Blender's integer noise for each brick's
//! tint).

use super::inputs::{input, splat, v3, Operands, Socket, Ty, GREY};
use crate::math::{Vec3, Vec4};

/// The Brick node's inputs.
pub(super) const BRICK_INPUTS: &[Socket] = &[
    Socket::vector("Vector", Vec4::ZERO),
    Socket::color("Color1", GREY),
    Socket::color("Color2", Vec4::new(0.2, 0.2, 0.2, 1.0)),
    Socket::color("Mortar", Vec4::new(0.0, 0.0, 0.0, 1.0)),
    Socket::float("Scale", 5.0),
    Socket::float("Mortar Size", 0.02),
    Socket::float("Mortar Smooth", 0.1),
    Socket::float("Bias", 0.0),
    Socket::float("Brick Width", 0.5),
    Socket::float("Row Height", 0.25),
];

/// The Brick node's outputs.
pub(super) const BRICK_OUTPUTS: &[Socket] = &[
    Socket::output("Color", Ty::Color),
    Socket::output("Fac", Ty::Float),
];

/// The Brick texture's settings (node properties, not sockets).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct BrickLayout {
    pub(super) offset: f32,
    pub(super) offset_frequency: i32,
    pub(super) squash: f32,
    pub(super) squash_frequency: i32,
}

/// The integer noise of Blender's Brick texture (a brick's tint), in [0, 1).
pub(super) fn brick_noise(n: u32) -> f32 {
    let n = n.wrapping_add(1013) & 0x7fff_ffff;
    let n = (n >> 13) ^ n;
    let nn = n
        .wrapping_mul(
            n.wrapping_mul(n)
                .wrapping_mul(60493)
                .wrapping_add(19_990_303),
        )
        .wrapping_add(1_376_312_589)
        & 0x7fff_ffff;
    0.5 * (nn as f32 / 1_073_741_824.0)
}

/// Cycles' `svm_brick` on the scaled point: the brick's tint (bias added, in [0, 1]) and the
/// mortar factor. `sizes` holds Mortar Size, Mortar Smooth, Bias, Brick Width, Row Height.
/// Every `offset_frequency`-th row is shifted by `offset` bricks and every
/// `squash_frequency`-th row's bricks are `squash` times as wide.
pub(super) fn brick(layout: &BrickLayout, p: Vec3, sizes: [f32; 5]) -> (f32, f32) {
    let [mortar_size, mortar_smooth, bias, mut width, row_height] = sizes;
    let row = (p.y / row_height).floor() as i32;
    let mut offset = 0.0;
    if layout.offset_frequency != 0 && layout.squash_frequency != 0 {
        if row % layout.squash_frequency == 0 {
            width *= layout.squash;
        }
        if row % layout.offset_frequency == 0 {
            offset = width * layout.offset;
        }
    }
    let column = ((p.x + offset) / width).floor() as i32;
    let x = (p.x + offset) - width * column as f32;
    let y = p.y - row_height * row as f32;
    let id = (row.wrapping_shl(16)).wrapping_add(column & 0xffff) as u32;
    let tint = (brick_noise(id) + bias).clamp(0.0, 1.0);
    let edge = x.min(y).min((width - x).min(row_height - y));
    let mortar = if edge >= mortar_size {
        0.0
    } else if mortar_smooth == 0.0 {
        1.0
    } else {
        let t = ((1.0 - edge / mortar_size) / mortar_smooth).clamp(0.0, 1.0);
        t * t * (3.0 - 2.0 * t)
    };
    (tint, mortar)
}

/// The Brick Texture: Vector, Color1, Color2, Mortar, Scale, Mortar Size, Mortar Smooth,
/// Bias, Brick Width, Row Height to Color and Fac.
#[inline(always)]
pub(super) fn eval_brick(layout: &BrickLayout, ins: &impl Operands) -> [Vec4; 2] {
    const VECTOR: usize = input(BRICK_INPUTS, "Vector");
    const COLOR1: usize = input(BRICK_INPUTS, "Color1");
    const COLOR2: usize = input(BRICK_INPUTS, "Color2");
    const MORTAR: usize = input(BRICK_INPUTS, "Mortar");
    const SCALE: usize = input(BRICK_INPUTS, "Scale");
    let p = ins.vector(VECTOR) * ins.float(SCALE);
    const MORTAR_SIZE: usize = input(BRICK_INPUTS, "Mortar Size");
    const MORTAR_SMOOTH: usize = input(BRICK_INPUTS, "Mortar Smooth");
    const BIAS: usize = input(BRICK_INPUTS, "Bias");
    const BRICK_WIDTH: usize = input(BRICK_INPUTS, "Brick Width");
    const ROW_HEIGHT: usize = input(BRICK_INPUTS, "Row Height");
    let [size, smooth, bias, width, height] =
        [MORTAR_SIZE, MORTAR_SMOOTH, BIAS, BRICK_WIDTH, ROW_HEIGHT].map(|k| ins.float(k));
    let (tint, mortar) = brick(layout, p, [size, smooth, bias, width, height]);
    let (c1, c2, mortar_color) = (ins.value(COLOR1), ins.value(COLOR2), ins.value(MORTAR));
    let brick_color = if mortar != 1.0 {
        c1.truncate().lerp(c2.truncate(), tint)
    } else {
        c1.truncate()
    };
    [
        v3(brick_color.lerp(mortar_color.truncate(), mortar)),
        splat(mortar),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn brick_tints_stay_in_range_and_mortar_lines_the_bricks() {
        let layout = BrickLayout {
            offset: 0.5,
            offset_frequency: 2,
            squash: 1.0,
            squash_frequency: 2,
        };
        let sizes = [0.02, 0.0, 0.0, 0.5, 0.25];
        let mut tints = Vec::new();
        for i in 0..200 {
            let p = Vec3::new(i as f32 * 0.37 - 30.0, i as f32 * 0.11 - 10.0, 0.0);
            let (tint, _) = brick(&layout, p, sizes);
            assert!((0.0..1.0).contains(&tint));
            tints.push(tint);
        }
        assert!(tints.iter().any(|&t| t != tints[0]), "bricks differ");
        // Inside a brick no mortar; on its edge (hard mortar) full mortar.
        assert_eq!(brick(&layout, Vec3::new(0.25, 0.35, 0.0), sizes).1, 0.0);
        assert_eq!(brick(&layout, Vec3::new(0.01, 0.35, 0.0), sizes).1, 1.0);
        // Row 0 is shifted by half a brick: its x = 0.25 is an edge.
        assert_eq!(brick(&layout, Vec3::new(0.25, 0.1, 0.0), sizes).1, 1.0);
    }
}
