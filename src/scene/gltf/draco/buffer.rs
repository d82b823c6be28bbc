//! Reading a Draco bitstream (Draco bitstream specification 2.2, Galligan 2017, "Core
//! functions"): little-endian integers and floats, unsigned LEB128 varints, and the bit reader
//! that reads values least significant bit first. Every read checks the bytes left, so a cut
//! stream is an error, never a read past the end.

/// What every decoder returns: the value, or why the stream cannot be decoded.
pub(super) type Decoded<T> = std::result::Result<T, String>;

/// The error of a stream that ends before a value it announces.
pub(super) fn cut(what: &str) -> String {
    format!("the Draco data ends inside {what}: the file is damaged")
}

/// A cursor over a Draco stream.
#[derive(Clone)]
pub(super) struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    pub(super) fn new(data: &'a [u8]) -> Reader<'a> {
        Reader { data, pos: 0 }
    }

    pub(super) fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    /// The next `n` bytes, consumed.
    pub(super) fn bytes(&mut self, n: usize, what: &str) -> Decoded<&'a [u8]> {
        if n > self.remaining() {
            return Err(cut(what));
        }
        let out = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(out)
    }

    pub(super) fn u8(&mut self, what: &str) -> Decoded<u8> {
        Ok(self.bytes(1, what)?[0])
    }

    pub(super) fn u16(&mut self, what: &str) -> Decoded<u16> {
        let b = self.bytes(2, what)?;
        Ok(u16::from_le_bytes([b[0], b[1]]))
    }

    pub(super) fn u32(&mut self, what: &str) -> Decoded<u32> {
        let b = self.bytes(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    pub(super) fn i32(&mut self, what: &str) -> Decoded<i32> {
        Ok(self.u32(what)? as i32)
    }

    pub(super) fn f32(&mut self, what: &str) -> Decoded<f32> {
        Ok(f32::from_bits(self.u32(what)?))
    }

    /// An unsigned LEB128 varint of at most 64 bits.
    pub(super) fn varint64(&mut self, what: &str) -> Decoded<u64> {
        let mut value = 0u64;
        for shift in (0..64).step_by(7) {
            let byte = self.u8(what)?;
            value |= u64::from(byte & 0x7f) << shift;
            if byte & 0x80 == 0 {
                return Ok(value);
            }
        }
        Err(format!(
            "{what} is a varint longer than 64 bits: the file is damaged"
        ))
    }

    /// An unsigned LEB128 varint that must fit 32 bits.
    pub(super) fn varint(&mut self, what: &str) -> Decoded<u32> {
        let value = self.varint64(what)?;
        u32::try_from(value)
            .map_err(|_| format!("{what} is {value}, more than 32 bits: the file is damaged"))
    }

    /// A varint count of at most `max` elements.
    pub(super) fn count(&mut self, what: &str, max: usize) -> Decoded<usize> {
        let value = self.varint(what)? as usize;
        if value > max {
            return Err(format!(
                "{what} is {value}, more than the {max} the data can hold: the file is damaged"
            ));
        }
        Ok(value)
    }

    /// A bit reader over the rest of the stream; `finish_bits` moves past the bytes it read.
    pub(super) fn bits(&self) -> BitReader<'a> {
        BitReader {
            data: &self.data[self.pos..],
            bit: 0,
        }
    }

    /// Move past the whole bytes `bits` read.
    pub(super) fn finish_bits(&mut self, bits: &BitReader<'a>) {
        let bytes = bits.bit.div_ceil(8).min(self.remaining());
        self.pos += bytes;
    }

    /// A bit reader over a length-prefixed block (a varint byte count, then the bits); the
    /// cursor moves past the block.
    pub(super) fn sized_bits(&mut self, what: &str) -> Decoded<BitReader<'a>> {
        let size = self.varint64(what)?;
        let size = usize::try_from(size)
            .ok()
            .filter(|&s| s <= self.remaining())
            .ok_or_else(|| cut(what))?;
        let data = self.bytes(size, what)?;
        Ok(BitReader { data, bit: 0 })
    }
}

/// Bits read least significant first from each byte; past the end every bit is 0 (as
/// Draco's own reader gives them), and every caller reads a bounded number of bits.
pub(super) struct BitReader<'a> {
    data: &'a [u8],
    bit: usize,
}

impl BitReader<'_> {
    fn bit(&mut self) -> u32 {
        match self.data.get(self.bit >> 3) {
            Some(byte) => {
                let b = (byte >> (self.bit & 7)) & 1;
                self.bit += 1;
                u32::from(b)
            }
            None => 0,
        }
    }

    /// `n` (at most 32) bits, the first read the least significant.
    pub(super) fn read(&mut self, n: u32) -> u32 {
        let mut value = 0u32;
        for i in 0..n.min(32) {
            value |= self.bit() << i;
        }
        value
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn varints_and_bits_read_as_the_specification_writes_them() {
        let mut r = Reader::new(&[0xe5, 0x8e, 0x26, 0x7f]);
        assert_eq!(r.varint("x").unwrap(), 624_485);
        assert_eq!(r.varint("y").unwrap(), 127);
        assert!(r.varint("z").unwrap_err().contains("ends inside z"));
        let mut r = Reader::new(&[0b1011_0110, 0x01]);
        let mut bits = r.bits();
        assert_eq!(bits.read(1), 0);
        assert_eq!(bits.read(3), 0b011);
        assert_eq!(bits.read(6), 0b01_1011);
        r.finish_bits(&bits);
        assert_eq!(r.remaining(), 0);
        let mut too_long = Reader::new(&[0xff; 6]);
        assert!(too_long.varint("v").is_err());
    }
}
