//! Image textures: 8-bit RGBA texels, decoded to linear on lookup (sRGB for colour textures,
//! as glTF requires for base colour and emission), or 16-bit and float texels converted to
//! linear floats when loaded (as Cycles converts every image but 8-bit ones); bilinear
//! filtering with glTF wrap modes, and KHR_texture_transform applied to UVs.

use crate::math::{srgb_to_linear, Vec2, Vec4};
use std::sync::OnceLock;

/// glTF sampler wrap mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Repeat,
    MirroredRepeat,
    ClampToEdge,
}

/// An image's texels, row by row.
#[derive(Clone, Debug, PartialEq)]
pub enum Texels {
    /// 8-bit RGBA, sRGB-encoded when the texture is (`Texture::srgb`).
    Bytes(Vec<[u8; 4]>),
    /// Linear RGBA (16-bit and float images, decoded when loaded).
    Linear(Vec<[f32; 4]>),
}

/// An image in memory. Row 0 is the top row of the image, as in PNG, JPEG and WebP files.
#[derive(Clone, Debug)]
pub struct Texture {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub texels: Texels,
    /// True when RGB is sRGB-encoded (colour data; 8-bit texels only, the others are decoded
    /// already); alpha is always linear.
    pub srgb: bool,
    pub wrap_s: Wrap,
    pub wrap_t: Wrap,
    /// False for nearest-neighbour (glTF magFilter NEAREST).
    pub bilinear: bool,
}

/// A material's use of a texture: which texture and the UV transform (KHR_texture_transform).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    pub texture: u32,
    /// Row-major 2×3 affine matrix applied to UV0: uv' = [a b c; d e f]·(u, v, 1).
    pub transform: [f32; 6],
}

impl TextureRef {
    pub const IDENTITY: [f32; 6] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

    pub fn new(texture: u32) -> Self {
        TextureRef {
            texture,
            transform: Self::IDENTITY,
        }
    }

    /// The transform KHR_texture_transform describes: translate · rotate · scale, with the
    /// rotation counter-clockwise in UV space as the extension's reference matrix states.
    pub fn with_transform(texture: u32, offset: Vec2, rotation: f32, scale: Vec2) -> Self {
        let (s, c) = rotation.sin_cos();
        TextureRef {
            texture,
            transform: [
                c * scale.x,
                s * scale.y,
                offset.x,
                -s * scale.x,
                c * scale.y,
                offset.y,
            ],
        }
    }

    pub fn apply(&self, uv: Vec2) -> Vec2 {
        let m = &self.transform;
        Vec2::new(
            m[0] * uv.x + m[1] * uv.y + m[2],
            m[3] * uv.x + m[4] * uv.y + m[5],
        )
    }
}

fn srgb_table() -> &'static [f32; 256] {
    static TABLE: OnceLock<[f32; 256]> = OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)))
}

fn wrap(i: i64, n: u32, mode: Wrap) -> u32 {
    let n = n as i64;
    match mode {
        Wrap::Repeat => i.rem_euclid(n) as u32,
        Wrap::ClampToEdge => i.clamp(0, n - 1) as u32,
        Wrap::MirroredRepeat => {
            let period = 2 * n;
            let k = i.rem_euclid(period);
            (if k < n { k } else { period - 1 - k }) as u32
        }
    }
}

impl Texture {
    fn index(&self, x: u32, y: u32) -> usize {
        (y as usize) * self.width as usize + x as usize
    }

    fn texel(&self, x: u32, y: u32) -> Vec4 {
        let t = match &self.texels {
            Texels::Bytes(texels) => texels[self.index(x, y)],
            Texels::Linear(texels) => return Vec4::from(texels[self.index(x, y)]),
        };
        if self.srgb {
            let lut = srgb_table();
            Vec4::new(
                lut[t[0] as usize],
                lut[t[1] as usize],
                lut[t[2] as usize],
                t[3] as f32 / 255.0,
            )
        } else {
            Vec4::new(t[0] as f32, t[1] as f32, t[2] as f32, t[3] as f32) / 255.0
        }
    }

    /// Linear RGBA at texture coordinate `uv` (glTF: (0,0) is the top-left of the image).
    pub fn sample(&self, uv: Vec2) -> Vec4 {
        self.filter(uv, |x, y| self.texel(x, y))
    }

    /// RGBA at `uv` as Cycles' Image Texture node reads an image: an 8-bit one's stored
    /// (encoded) values filtered, then sRGB-decoded when the image is sRGB; the linear values of
    /// the others filtered.
    pub fn sample_encoded(&self, uv: Vec2) -> Vec4 {
        let Texels::Bytes(texels) = &self.texels else {
            return self.sample(uv);
        };
        let raw = |x: u32, y: u32| {
            let t = texels[self.index(x, y)];
            Vec4::new(t[0] as f32, t[1] as f32, t[2] as f32, t[3] as f32) / 255.0
        };
        let c = self.filter(uv, raw);
        if self.srgb {
            Vec4::new(
                srgb_to_linear(c.x),
                srgb_to_linear(c.y),
                srgb_to_linear(c.z),
                c.w,
            )
        } else {
            c
        }
    }

    /// Filter the texels `texel` returns at `uv` (nearest or bilinear, with the wrap modes).
    fn filter(&self, uv: Vec2, texel: impl Fn(u32, u32) -> Vec4) -> Vec4 {
        if self.width == 0 || self.height == 0 || !uv.is_finite() {
            return Vec4::ONE;
        }
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        if !self.bilinear {
            let xi = wrap((x + 0.5).floor() as i64, self.width, self.wrap_s);
            let yi = wrap((y + 0.5).floor() as i64, self.height, self.wrap_t);
            return texel(xi, yi);
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let xa = wrap(x0, self.width, self.wrap_s);
        let xb = wrap(x0 + 1, self.width, self.wrap_s);
        let ya = wrap(y0, self.height, self.wrap_t);
        let yb = wrap(y0 + 1, self.height, self.wrap_t);
        let top = texel(xa, ya) * (1.0 - fx) + texel(xb, ya) * fx;
        let bottom = texel(xa, yb) * (1.0 - fx) + texel(xb, yb) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker() -> Texture {
        Texture {
            name: "checker".into(),
            width: 2,
            height: 2,
            texels: Texels::Bytes(vec![
                [255, 0, 0, 255],
                [0, 255, 0, 255],
                [0, 0, 255, 255],
                [255, 255, 255, 0],
            ]),
            srgb: false,
            wrap_s: Wrap::Repeat,
            wrap_t: Wrap::Repeat,
            bilinear: true,
        }
    }

    #[test]
    fn texel_centres_return_texels_and_wrap_repeats() {
        let t = checker();
        assert!((t.sample(Vec2::new(0.25, 0.25)) - Vec4::new(1.0, 0.0, 0.0, 1.0)).length() < 1e-6);
        assert!((t.sample(Vec2::new(0.75, 0.75)) - Vec4::new(1.0, 1.0, 1.0, 0.0)).length() < 1e-6);
        assert!(
            (t.sample(Vec2::new(1.25, -0.75)) - t.sample(Vec2::new(0.25, 0.25))).length() < 1e-6
        );
        // Halfway between the two top texels.
        assert!((t.sample(Vec2::new(0.5, 0.25)) - Vec4::new(0.5, 0.5, 0.0, 1.0)).length() < 1e-6);
    }

    #[test]
    fn srgb_texels_are_decoded() {
        let mut t = checker();
        t.srgb = true;
        t.texels = Texels::Bytes(vec![[188, 188, 188, 255]; 4]);
        let v = t.sample(Vec2::new(0.3, 0.6));
        assert!((v.x - 0.5029).abs() < 1e-3 && (v.w - 1.0).abs() < 1e-6);
    }

    #[test]
    fn texture_transform_scales_then_offsets() {
        let r = TextureRef::with_transform(0, Vec2::new(0.5, 0.25), 0.0, Vec2::new(2.0, 3.0));
        let uv = r.apply(Vec2::new(0.1, 0.2));
        assert!((uv - Vec2::new(0.7, 0.85)).length() < 1e-6);
    }
}
