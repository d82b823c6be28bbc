//! Encoded images decoded to texels: PNG, JPEG and WebP with the image crate (8-bit images as
//! bytes, 16-bit ones as floats that keep their 16 bits), KTX2 by `ktx2`. Where the bytes come
//! from (buffer views, data URIs, files) is `textures`' business.

use crate::scene::texture::Texels;
use image::{DynamicImage, ImageFormat};

/// An image as decoded, before it becomes a texture of the scene.
#[derive(Clone)]
pub(super) struct DecodedImage {
    pub(super) name: String,
    pub(super) width: u32,
    pub(super) height: u32,
    /// As stored: `Texels::Linear` holds 16-bit and float values still sRGB-encoded when the
    /// texture is (`push_texture` decodes them).
    pub(super) texels: Texels,
}

/// The first bytes of an OpenEXR file.
pub(super) const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// PNG, JPEG or WebP, from the bytes' signature.
fn sniff_image_format(bytes: &[u8]) -> Option<ImageFormat> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some(ImageFormat::Png)
    } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        Some(ImageFormat::Jpeg)
    } else if bytes.len() >= 12 && bytes.starts_with(b"RIFF") && &bytes[8..12] == b"WEBP" {
        Some(ImageFormat::WebP)
    } else {
        None
    }
}

fn format_name(format: ImageFormat) -> &'static str {
    match format {
        ImageFormat::Png => "PNG",
        ImageFormat::Jpeg => "JPEG",
        _ => "WebP",
    }
}

/// Decode an encoded PNG, JPEG or WebP image (`claimed`: the MIME type the file states, named
/// when the bytes are none of these); `label` names it.
pub(super) fn decode_bytes(
    encoded: &[u8],
    label: String,
    claimed: Option<String>,
) -> std::result::Result<DecodedImage, String> {
    if encoded.starts_with(&super::ktx2::KTX2_MAGIC) {
        let (width, height, texels) = super::ktx2::decode(encoded)?;
        let texels = Texels::Bytes(texels);
        return Ok(DecodedImage {
            name: label,
            width,
            height,
            texels,
        });
    }
    let format = sniff_image_format(encoded).ok_or_else(|| {
        let claimed = claimed.unwrap_or_else(|| "unknown format".into());
        format!("unsupported image format ({claimed}); Photon reads PNG, JPEG and WebP")
    })?;
    let image = image::load_from_memory_with_format(encoded, format)
        .map_err(|e| format!("cannot decode the {} image: {e}", format_name(format)))?;
    let (width, height) = (image.width(), image.height());
    let texels = to_texels(image)?;
    Ok(DecodedImage {
        name: label,
        width,
        height,
        texels,
    })
}

/// The decoder's pixels as texels: 8-bit ones as bytes, 16-bit ones as floats in [0, 1] (still
/// encoded: `Loader::push_texture` decodes sRGB). Grey and grey-alpha images are spread to RGBA,
/// RGB ones gain an opaque alpha.
pub(super) fn to_texels(image: DynamicImage) -> std::result::Result<Texels, String> {
    Ok(match image {
        DynamicImage::ImageLuma8(i) => Texels::Bytes(i.pixels().map(|p| grey(p[0], 255)).collect()),
        DynamicImage::ImageLumaA8(i) => {
            Texels::Bytes(i.pixels().map(|p| grey(p[0], p[1])).collect())
        }
        DynamicImage::ImageRgb8(i) => {
            Texels::Bytes(i.pixels().map(|p| [p[0], p[1], p[2], 255]).collect())
        }
        DynamicImage::ImageRgba8(i) => Texels::Bytes(i.pixels().map(|p| p.0).collect()),
        DynamicImage::ImageLuma16(i) => {
            Texels::Linear(i.pixels().map(|p| grey(unit(p[0]), 1.0)).collect())
        }
        DynamicImage::ImageLumaA16(i) => {
            Texels::Linear(i.pixels().map(|p| grey(unit(p[0]), unit(p[1]))).collect())
        }
        DynamicImage::ImageRgb16(i) => Texels::Linear(
            i.pixels()
                .map(|p| [unit(p[0]), unit(p[1]), unit(p[2]), 1.0])
                .collect(),
        ),
        DynamicImage::ImageRgba16(i) => Texels::Linear(i.pixels().map(|p| p.0.map(unit)).collect()),
        other => return Err(format!("unsupported pixel format {:?}", other.color())),
    })
}

/// A grey level and alpha as RGBA.
fn grey<T: Copy>(level: T, alpha: T) -> [T; 4] {
    [level, level, level, alpha]
}

/// A 16-bit sample as a float in [0, 1].
fn unit(value: u16) -> f32 {
    value as f32 / 65535.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sixteen_bit_images_keep_their_sixteen_bits() {
        let rgb = image::ImageBuffer::from_raw(1, 1, vec![0x1234u16, 0xABCD, 0xFFFF]).unwrap();
        let Ok(Texels::Linear(texels)) = to_texels(DynamicImage::ImageRgb16(rgb)) else {
            panic!("16-bit texels are kept as floats");
        };
        let expected = [0x1234 as f32 / 65535.0, 0xABCD as f32 / 65535.0, 1.0, 1.0];
        assert_eq!(texels, vec![expected]);
        let grey_alpha = image::ImageBuffer::from_raw(1, 1, vec![0x12u8, 0xAB]).unwrap();
        assert!(matches!(
            to_texels(DynamicImage::ImageLumaA8(grey_alpha)),
            Ok(Texels::Bytes(t)) if t == vec![[0x12, 0x12, 0x12, 0xAB]]
        ));
    }
}
