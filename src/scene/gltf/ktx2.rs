//! `KHR_texture_basisu`: KTX2 images holding Basis Universal data (ETC1S or UASTC, as `basisu`
//! and `toktx` write them) transcoded to 8-bit RGBA by the `basisu` crate, a pure-Rust port of
//! Binomial's reference transcoder (no paper). Only the base mip level is read (Photon filters
//! textures itself); the texel count is bounded before the transcoder allocates, and anything
//! the transcoder refuses (or fails on) is an error naming the image.

use basisu::{DecodeFlags, TargetFormat, Transcoder};

/// The 12-byte identifier every KTX2 file starts with.
pub(super) const KTX2_MAGIC: [u8; 12] = [
    0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A,
];

/// Texels a KTX2 image may decode to (1 GiB of RGBA8).
const MAX_TEXELS: u64 = 1 << 28;

/// Width, height and RGBA8 texels (top row first, as stored) of the KTX2 image `bytes`.
pub(super) fn decode(bytes: &[u8]) -> std::result::Result<(u32, u32, Vec<[u8; 4]>), String> {
    // A panic inside the transcoder on a damaged file is reported as that file's error.
    std::panic::catch_unwind(|| transcode(bytes)).unwrap_or_else(|_| {
        Err("the KTX2 transcoder failed on this file: it is damaged".to_string())
    })
}

fn transcode(bytes: &[u8]) -> std::result::Result<(u32, u32, Vec<[u8; 4]>), String> {
    let refused = |e: basisu::Error| format!("cannot decode the KTX2 image: {e:?}");
    let texture = Transcoder::new(bytes).map_err(refused)?;
    let (width, height) = texture.base_dimensions();
    if width == 0 || height == 0 || width as u64 * height as u64 > MAX_TEXELS {
        return Err(format!(
            "the KTX2 image is {width} × {height} texels; Photon reads 1 to {MAX_TEXELS} texels"
        ));
    }
    if texture.layer_count() > 1 || texture.face_count() > 1 {
        return Err("the KTX2 image is an array or a cube map; glTF textures are 2D".into());
    }
    let rgba = texture
        .transcode(0, TargetFormat::Rgba32, DecodeFlags::NONE)
        .map_err(refused)?;
    let texels: Vec<[u8; 4]> = rgba
        .chunks_exact(4)
        .map(|t| [t[0], t[1], t[2], t[3]])
        .collect();
    if texels.len() as u64 != width as u64 * height as u64 {
        return Err("the KTX2 image's texels do not fill its size: it is damaged".into());
    }
    Ok((width, height, texels))
}

#[cfg(test)]
mod tests {
    use super::*;

    const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/ktx2/");

    /// The 16 × 16 stripes PNG the KTX2 files were encoded from (`tests/data/ktx2/README.md`).
    fn stripes() -> Vec<[u8; 4]> {
        let png = std::fs::read(format!("{DATA}stripes.png")).unwrap();
        let image = image::load_from_memory(&png).unwrap().to_rgba8();
        image.pixels().map(|p| p.0).collect()
    }

    #[test]
    fn etc1s_and_uastc_textures_decode_to_the_image_they_were_made_from() {
        let expected = stripes();
        for (file, tolerance) in [("stripes_uastc.ktx2", 4), ("stripes_etc1s.ktx2", 12)] {
            let bytes = std::fs::read(format!("{DATA}{file}")).unwrap();
            assert!(bytes.starts_with(&KTX2_MAGIC));
            let (width, height, texels) = decode(&bytes).unwrap();
            assert_eq!((width, height), (16, 16));
            let worst = texels
                .iter()
                .zip(&expected)
                .flat_map(|(a, b)| (0..4).map(move |c| a[c].abs_diff(b[c])))
                .max()
                .unwrap();
            assert!(worst <= tolerance, "{file}: a texel is {worst} levels off");
        }
    }

    #[test]
    fn damaged_ktx2_files_are_errors() {
        let bytes = std::fs::read(format!("{DATA}stripes_etc1s.ktx2")).unwrap();
        assert!(decode(&bytes[..40]).is_err());
        assert!(decode(&KTX2_MAGIC).is_err());
        let mut rng = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..2000 {
            let mut damaged = bytes.clone();
            for _ in 0..4 {
                rng ^= rng << 13;
                rng ^= rng >> 7;
                rng ^= rng << 17;
                let at = (rng % damaged.len() as u64) as usize;
                damaged[at] = (rng >> 40) as u8;
            }
            // Loads or fails with a message; never panics.
            let _ = decode(&damaged);
        }
    }
}
