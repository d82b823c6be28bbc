//! Draco's entropy coding (Draco bitstream specification 2.2, "rANS decoding" and "Symbol
//! decoding"; the coders are Duda's asymmetric numeral systems, 2013): the rANS symbol decoder
//! with its probability table, the binary rABS decoder Draco uses for flags, and
//! `decode_symbols`, the tagged and raw schemes that carry integer values. States and table
//! sizes are checked, so damaged data gives an error or wrong values, never a panic or a loop
//! longer than the number of symbols asked for.

use super::buffer::{cut, Decoded, Reader};

const IO_BASE: u32 = 256;

/// The rANS state after `ans_read_init`: the bytes before the state, read backwards.
struct AnsState<'a> {
    data: &'a [u8],
    offset: usize,
    state: u32,
}

impl<'a> AnsState<'a> {
    /// The last one to four bytes of `data` hold the initial state (two high bits: how many).
    fn new(data: &'a [u8], l_base: u32, allow_four: bool) -> Decoded<AnsState<'a>> {
        let bad = || "an rANS stream does not start correctly: the file is damaged".to_string();
        let n = data.len();
        let last = *data.last().ok_or_else(bad)?;
        let (offset, state) = match last >> 6 {
            0 => (n - 1, u32::from(last & 0x3f)),
            1 if n >= 2 => (
                n - 2,
                u32::from(u16::from_le_bytes([data[n - 2], last])) & 0x3fff,
            ),
            2 if n >= 3 => (
                n - 3,
                u32::from_le_bytes([data[n - 3], data[n - 2], last, 0]) & 0x3f_ffff,
            ),
            3 if allow_four && n >= 4 => (
                n - 4,
                u32::from_le_bytes([data[n - 4], data[n - 3], data[n - 2], last]) & 0x3fff_ffff,
            ),
            _ => return Err(bad()),
        };
        let state = state + l_base;
        if u64::from(state) >= u64::from(l_base) * u64::from(IO_BASE) {
            return Err(bad());
        }
        Ok(AnsState {
            data,
            offset,
            state,
        })
    }
}

/// Draco's binary decoder (rABS with an 8-bit probability of zero).
pub(super) struct BitDecoder<'a> {
    ans: AnsState<'a>,
    prob_zero: u8,
}

const L_BASE: u32 = 4096;

impl<'a> BitDecoder<'a> {
    /// Read the probability and the coded bytes of a bit stream from `r`.
    pub(super) fn start(r: &mut Reader<'a>) -> Decoded<BitDecoder<'a>> {
        let prob_zero = r.u8("a bit coder's probability")?;
        let size = r.varint("a bit coder's size")? as usize;
        if size > r.remaining() {
            return Err(cut("a bit coder's data"));
        }
        let data = r.bytes(size, "a bit coder's data")?;
        Ok(BitDecoder {
            ans: AnsState::new(data, L_BASE, false)?,
            prob_zero,
        })
    }

    pub(super) fn next(&mut self) -> bool {
        let p = 256 - u32::from(self.prob_zero);
        let ans = &mut self.ans;
        if ans.state < L_BASE && ans.offset > 0 {
            ans.offset -= 1;
            ans.state = ans.state * IO_BASE + u32::from(ans.data[ans.offset]);
        }
        let x = ans.state;
        let (quot, rem) = (x / 256, x % 256);
        let xn = quot * p;
        let bit = rem < p;
        ans.state = if bit { xn + rem } else { x - xn - p };
        bit
    }
}

/// A probability table and the rANS state of one symbol stream.
struct SymbolDecoder<'a> {
    precision: u32,
    /// (probability, cumulative probability) of each symbol.
    table: Vec<(u32, u32)>,
    /// The symbol of each slot of the precision range.
    lookup: Vec<u32>,
    ans: AnsState<'a>,
}

impl<'a> SymbolDecoder<'a> {
    /// Read a probability table and start decoding the coded bytes that follow it.
    fn start(r: &mut Reader<'a>, precision_bits: u32) -> Decoded<SymbolDecoder<'a>> {
        let precision = 1u32 << precision_bits;
        // A table byte stands for at most 64 symbols (a run of zero probabilities).
        let num_symbols = r.count("a symbol table's size", r.remaining().saturating_mul(64))?;
        let mut probabilities = Vec::with_capacity(num_symbols);
        while probabilities.len() < num_symbols {
            let byte = r.u8("a symbol table")?;
            let token = byte & 3;
            if token == 3 {
                let zeros = usize::from(byte >> 2) + 1;
                if probabilities.len() + zeros > num_symbols {
                    return Err("a symbol table runs past its size: the file is damaged".into());
                }
                probabilities.extend(std::iter::repeat_n(0, zeros));
            } else {
                let mut p = u32::from(byte >> 2);
                for b in 0..u32::from(token) {
                    p |= u32::from(r.u8("a symbol table")?) << (8 * (b + 1) - 2);
                }
                probabilities.push(p);
            }
        }
        let mut table = Vec::with_capacity(num_symbols);
        let mut lookup = Vec::with_capacity(precision as usize);
        let mut cumulative = 0u32;
        for (symbol, &p) in probabilities.iter().enumerate() {
            table.push((p, cumulative));
            cumulative = cumulative.saturating_add(p);
            if cumulative > precision {
                return Err(
                    "a symbol table's probabilities exceed one: the file is damaged".into(),
                );
            }
            lookup.extend(std::iter::repeat_n(symbol as u32, p as usize));
        }
        if cumulative != precision {
            return Err(
                "a symbol table's probabilities do not sum to one: the file is damaged".into(),
            );
        }
        let size = r.varint64("a symbol stream's size")?;
        let size = usize::try_from(size)
            .ok()
            .filter(|&s| s <= r.remaining())
            .ok_or_else(|| cut("a symbol stream"))?;
        let data = r.bytes(size, "a symbol stream")?;
        let ans = AnsState::new(data, 4 * precision, true)?;
        Ok(SymbolDecoder {
            precision,
            table,
            lookup,
            ans,
        })
    }

    fn next(&mut self) -> u32 {
        let l_base = 4 * self.precision;
        let ans = &mut self.ans;
        while ans.state < l_base && ans.offset > 0 {
            ans.offset -= 1;
            ans.state = ans.state * IO_BASE + u32::from(ans.data[ans.offset]);
        }
        let (quot, rem) = (ans.state / self.precision, ans.state % self.precision);
        let symbol = self.lookup[rem as usize];
        let (p, cum) = self.table[symbol as usize];
        ans.state = quot.wrapping_mul(p).wrapping_add(rem - cum);
        symbol
    }
}

/// The rANS precision Draco uses for symbols of `bits` bits.
fn precision_bits(bits: u32) -> u32 {
    ((3 * bits) / 2).clamp(12, 20)
}

/// `count` values coded by `DecodeSymbols` (tagged or raw scheme), `components` per element.
/// `count` has been bounded by the caller.
pub(super) fn decode_symbols(
    r: &mut Reader<'_>,
    count: usize,
    components: usize,
) -> Decoded<Vec<u32>> {
    if count == 0 {
        return Ok(Vec::new());
    }
    let mut out = Vec::with_capacity(count);
    match r.u8("a symbol scheme")? {
        0 => {
            let mut tags = SymbolDecoder::start(r, precision_bits(5))?;
            let mut bits = r.bits();
            let components = components.max(1);
            while out.len() < count {
                let length = tags.next();
                if length > 32 {
                    return Err(format!(
                        "a tagged value of {length} bits: the file is damaged"
                    ));
                }
                for _ in 0..components.min(count - out.len()) {
                    out.push(bits.read(length));
                }
            }
            r.finish_bits(&bits);
        }
        1 => {
            let max_bits = u32::from(r.u8("a symbol bit length")?);
            if !(1..=18).contains(&max_bits) {
                return Err(format!(
                    "raw symbols of {max_bits} bits are not in Draco's range 1-18: the file is damaged"
                ));
            }
            let mut symbols = SymbolDecoder::start(r, precision_bits(max_bits))?;
            if symbols.table.is_empty() {
                return Err("a symbol stream without symbols: the file is damaged".into());
            }
            for _ in 0..count {
                out.push(symbols.next());
            }
        }
        other => {
            return Err(format!(
                "symbol scheme {other} is neither tagged (0) nor raw (1): the file is damaged"
            ))
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_one_symbol_table_decodes_that_symbol_every_time() {
        // Raw scheme, 1-bit symbols (precision 12): one symbol of probability 4096 (token 1:
        // one extra byte, 4096 = 0 | 16 << 8 ... written as (p & 63) << 2 | 1, p >> 6).
        let p = 4096u32;
        let mut data = vec![1u8, 1, 1, ((p & 63) << 2 | 1) as u8, (p >> 6) as u8];
        data.extend([1, 0]); // one byte of state: 0 (+ l_base)
        let mut r = Reader::new(&data);
        assert_eq!(decode_symbols(&mut r, 5, 1).unwrap(), vec![0; 5]);
        assert_eq!(r.remaining(), 0);
        // Probabilities summing to less than one are refused.
        let data = [1u8, 1, 1, 4 << 2, 1, 0];
        assert!(decode_symbols(&mut Reader::new(&data), 1, 1).is_err());
    }
}
