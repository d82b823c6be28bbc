//! The three ways an OpenVDB file stores a value array: raw, zlib (`flate2`), and Blosc 1
//! (Alted 2010) with the LZ4 codec (Collet 2011, decoded by `lz4_flex`) and byte shuffle, as
//! OpenVDB writes it; and IEEE half floats, which OpenVDB writes for grids saved at half
//! precision.

use std::io::Read;

/// Why a compressed chunk could not be decoded.
#[derive(Debug, PartialEq)]
pub enum CodecError {
    /// The chunk is inconsistent (a length, an offset or the decoded size is wrong).
    Damaged(String),
    /// The chunk is valid but uses a codec or filter this reader does not implement.
    Unsupported(String),
}

fn damaged<T>(what: impl Into<String>) -> Result<T, CodecError> {
    Err(CodecError::Damaged(what.into()))
}

/// Inflates a zlib stream into exactly `out.len()` bytes.
pub fn inflate_zlib(src: &[u8], out: &mut [u8]) -> Result<(), CodecError> {
    let mut decoder = flate2::read::ZlibDecoder::new(src);
    if decoder.read_exact(out).is_err() {
        return damaged(format!(
            "a zip-compressed block does not hold the {} bytes it should",
            out.len()
        ));
    }
    Ok(())
}

const BLOSC_HEADER_BYTES: usize = 16;
const BLOSC_DO_SHUFFLE: u8 = 0x1;
const BLOSC_MEMCPYED: u8 = 0x2;
const BLOSC_DO_BIT_SHUFFLE: u8 = 0x4;
const BLOSC_NO_SPLIT: u8 = 0x10;
const BLOSC_LZ4: u8 = 1;
/// Blosc splits a block into one stream per byte of the type when the type is at most this
/// wide and the block holds at least `BLOSC_MIN_SPLIT_ELEMENTS` elements.
const BLOSC_MAX_SPLITS: usize = 16;
const BLOSC_MIN_SPLIT_ELEMENTS: usize = 128;

fn le_u32(bytes: &[u8], at: usize) -> Result<u32, CodecError> {
    match bytes.get(at..at + 4) {
        Some(b) => Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        None => damaged("a blosc block ends inside its header"),
    }
}

/// Decodes one Blosc 1 buffer (header, block offsets, blocks of LZ4 streams) into exactly
/// `out.len()` bytes.
pub fn decompress_blosc(src: &[u8], out: &mut [u8]) -> Result<(), CodecError> {
    if src.len() < BLOSC_HEADER_BYTES {
        return damaged("a blosc block is shorter than its header");
    }
    let flags = src[2];
    let type_size = src[3] as usize;
    let total = le_u32(src, 4)? as usize;
    let block_size = le_u32(src, 8)? as usize;
    let compressed = le_u32(src, 12)? as usize;
    if total != out.len() {
        return damaged(format!(
            "a blosc block decodes to {total} bytes where {} are expected",
            out.len()
        ));
    }
    if compressed > src.len() {
        return damaged("a blosc block is longer than its chunk");
    }
    let src = &src[..compressed];
    if flags & BLOSC_MEMCPYED != 0 {
        match src.get(BLOSC_HEADER_BYTES..BLOSC_HEADER_BYTES + total) {
            Some(bytes) => out.copy_from_slice(bytes),
            None => return damaged("a stored blosc block is shorter than its size"),
        }
        return Ok(());
    }
    let codec = flags >> 5;
    if codec != BLOSC_LZ4 {
        let name = ["blosclz", "lz4", "snappy", "zlib", "zstd"].get(codec as usize);
        return Err(CodecError::Unsupported(format!(
            "blosc codec {}",
            name.unwrap_or(&"unknown")
        )));
    }
    if flags & BLOSC_DO_BIT_SHUFFLE != 0 && flags & BLOSC_DO_SHUFFLE == 0 {
        return Err(CodecError::Unsupported("blosc bit shuffle".into()));
    }
    if total == 0 {
        return Ok(());
    }
    if block_size == 0 || type_size == 0 {
        return damaged("a blosc block has a zero block or type size");
    }
    let blocks = total.div_ceil(block_size);
    if blocks > (src.len() - BLOSC_HEADER_BYTES) / 4 {
        return damaged("a blosc block has more blocks than bytes");
    }
    let shuffle = flags & BLOSC_DO_SHUFFLE != 0 && type_size > 1;
    let mut scratch = vec![0u8; block_size.min(total)];
    for block in 0..blocks {
        let begin = block * block_size;
        let size = block_size.min(total - begin);
        let leftover = size < block_size;
        let splits = if flags & BLOSC_NO_SPLIT == 0
            && type_size <= BLOSC_MAX_SPLITS
            && block_size / type_size >= BLOSC_MIN_SPLIT_ELEMENTS
            && !leftover
        {
            type_size
        } else {
            1
        };
        if !size.is_multiple_of(splits) {
            return damaged("a blosc block does not split evenly");
        }
        let split_size = size / splits;
        let mut at = le_u32(src, BLOSC_HEADER_BYTES + 4 * block)? as usize;
        let target: &mut [u8] = if shuffle {
            &mut scratch[..size]
        } else {
            &mut out[begin..begin + size]
        };
        for part in target.chunks_exact_mut(split_size) {
            let length = le_u32(src, at)? as i32;
            at += 4;
            if length <= 0 {
                // A run of one byte value (zero when the length is zero).
                part.fill((-length) as u8);
                continue;
            }
            let length = length as usize;
            let Some(stream) = src.get(at..at + length) else {
                return damaged("a blosc stream runs past its block");
            };
            at += length;
            if length == split_size {
                part.copy_from_slice(stream);
            } else {
                match lz4_flex::block::decompress_into(stream, part) {
                    Ok(n) if n == split_size => {}
                    _ => return damaged("an LZ4 stream in a blosc block is corrupt"),
                }
            }
        }
        if shuffle {
            unshuffle(&scratch[..size], type_size, &mut out[begin..begin + size]);
        }
    }
    Ok(())
}

/// Undoes Blosc's byte shuffle of one block: byte `j` of every element is stored together.
fn unshuffle(src: &[u8], type_size: usize, out: &mut [u8]) {
    let elements = src.len() / type_size;
    for j in 0..type_size {
        let plane = &src[j * elements..(j + 1) * elements];
        for (i, &byte) in plane.iter().enumerate() {
            out[i * type_size + j] = byte;
        }
    }
    let tail = elements * type_size;
    out[tail..].copy_from_slice(&src[tail..]);
}

/// An IEEE 754 binary16 value as f32 (subnormals, infinities and NaN included).
pub fn half_to_f32(bits: u16) -> f32 {
    let sign = ((bits as u32) & 0x8000) << 16;
    let exponent = ((bits >> 10) & 0x1f) as u32;
    let mantissa = (bits & 0x3ff) as u32;
    let magnitude = match exponent {
        0 => {
            let value = mantissa as f32 * 2f32.powi(-24);
            return if sign != 0 { -value } else { value };
        }
        31 => 0x7f80_0000 | (mantissa << 13),
        _ => ((exponent + 127 - 15) << 23) | (mantissa << 13),
    };
    f32::from_bits(sign | magnitude)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_floats_decode_exactly() {
        assert_eq!(half_to_f32(0x3c00), 1.0);
        assert_eq!(half_to_f32(0xc000), -2.0);
        assert_eq!(half_to_f32(0x3555), 0.333_251_95);
        assert_eq!(half_to_f32(0x7bff), 65504.0);
        assert_eq!(half_to_f32(0x0001), 2f32.powi(-24));
        assert_eq!(half_to_f32(0x8001), -(2f32.powi(-24)));
        assert_eq!(half_to_f32(0x7c00), f32::INFINITY);
        assert!(half_to_f32(0x7e00).is_nan());
        assert_eq!(half_to_f32(0x8000).to_bits(), (-0.0f32).to_bits());
    }

    #[test]
    fn unshuffle_restores_elements_and_the_tail() {
        // Three 4-byte elements shuffled into byte planes, then two loose bytes.
        let src = [1, 5, 9, 2, 6, 10, 3, 7, 11, 4, 8, 12, 13, 14];
        let mut out = [0u8; 14];
        unshuffle(&src, 4, &mut out);
        assert_eq!(out, [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14]);
    }

    #[test]
    fn blosc_refuses_a_wrong_size_and_other_codecs() {
        let mut header = [
            2u8,
            1,
            0x20 | BLOSC_DO_SHUFFLE,
            4,
            8,
            0,
            0,
            0,
            8,
            0,
            0,
            0,
            16,
            0,
            0,
            0,
        ];
        let mut out = [0u8; 4];
        assert!(matches!(
            decompress_blosc(&header, &mut out),
            Err(CodecError::Damaged(_))
        ));
        header[2] = 0x60; // zlib codec
        let mut out = [0u8; 8];
        assert!(matches!(
            decompress_blosc(&header, &mut out),
            Err(CodecError::Unsupported(_))
        ));
    }
}
