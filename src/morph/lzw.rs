//! GIF's LZW compression of a frame's palette indices, with a hash-table dictionary.
//!
//! The `gif` crate compresses with `weezl`, whose dictionary is a tree searched child by
//! child; on the indices of a photograph (most of 256 values, little repetition) that costs
//! about 60 ns a pixel, more than quantizing the frame. This is the standard GIF variant of
//! LZW (GIF89a specification, appendix F) with the dictionary in an open-addressing table
//! keyed by `(prefix code, byte)`:
//!
//! * the minimum code size `m` is that of the largest index (at least 2, as GIF requires);
//!   codes `0 .. 2^m` are the indices, `2^m` is Clear, `2^m + 1` is End; the stream starts
//!   with Clear, codes start `m + 1` bits wide, least significant bit first;
//! * greedy longest match: the longest known string is extended by the next byte; when the
//!   extension is new it becomes the next code, the known string's code is written, and the
//!   width grows by a bit once the table holds more than `2^width` entries (at most 12 bits);
//! * when the table would exceed 4,096 entries, Clear is written and the table restarts;
//! * at the end the pending code is written (the width grows first if the decoder's extra
//!   entry needs it), then End, padded to a byte.
//!
//! These are `weezl`'s decisions too, except that `weezl` forgets the string that gives a
//! prefix its 17th extension (its node changes representation), so its streams are
//! sometimes a little longer; both decode to the same indices (`tests`: round trips through
//! `weezl`'s decoder, never longer than `weezl`'s stream).

/// Slots of the dictionary table: at most 4,096 entries, so at most half full.
const SLOTS: usize = 8192;
/// An empty slot (no entry packs to it: see [`Dictionary::insert`]).
const EMPTY: u32 = u32::MAX;

/// The dictionary: `(prefix, byte) -> code`, each entry packed as `key << 12 | code` with the
/// 20-bit key `prefix << 8 | byte`.
struct Dictionary {
    slots: Vec<u32>,
}

impl Dictionary {
    #[inline]
    fn slot(key: u32) -> usize {
        (key.wrapping_mul(0x9E37_79B1) >> (32 - 13)) as usize
    }

    /// The code of `key`, if any.
    #[inline]
    fn get(&self, key: u32) -> Option<u16> {
        let mut i = Dictionary::slot(key);
        loop {
            let e = self.slots[i];
            if e == EMPTY {
                return None;
            }
            if e >> 12 == key {
                return Some((e & 0xFFF) as u16);
            }
            i = (i + 1) & (SLOTS - 1);
        }
    }

    /// Adds `key -> code` (`code < 4096`; the entry `0xFFFFF << 12 | 4095` would need prefix
    /// 4095 extended to code 4096, which is never stored).
    #[inline]
    fn insert(&mut self, key: u32, code: u16) {
        let mut i = Dictionary::slot(key);
        while self.slots[i] != EMPTY {
            i = (i + 1) & (SLOTS - 1);
        }
        self.slots[i] = key << 12 | u32::from(code);
    }

    fn clear(&mut self) {
        self.slots.fill(EMPTY);
    }
}

/// Codes packed least significant bit first.
struct Bits {
    out: Vec<u8>,
    acc: u64,
    n: u32,
}

impl Bits {
    #[inline]
    fn put(&mut self, code: u16, width: u32) {
        self.acc |= u64::from(code) << self.n;
        self.n += width;
        while self.n >= 8 {
            self.out.push(self.acc as u8);
            self.acc >>= 8;
            self.n -= 8;
        }
    }

    fn finish(mut self) -> Vec<u8> {
        if self.n > 0 {
            self.out.push(self.acc as u8);
        }
        self.out
    }
}

/// The LZW data of a GIF image block for the palette indices `data`: the minimum code size
/// byte, then the codes (see the module docs); what [`gif::Frame::make_lzw_pre_encoded`]
/// makes, for [`gif::Encoder::write_lzw_pre_encoded_frame`].
pub(crate) fn gif_lzw(data: &[u8]) -> Vec<u8> {
    let max = data.iter().copied().max().unwrap_or(0);
    let m = (u32::from(max) + 1).max(4).next_power_of_two().trailing_zeros();
    let (clear, end) = (1u16 << m, (1u16 << m) + 1);
    let first = (1usize << m) + 2;
    let mut bits = Bits { out: Vec::with_capacity(data.len() / 2 + 16), acc: 0, n: 0 };
    bits.out.push(m as u8);
    let mut dict = Dictionary { slots: vec![EMPTY; SLOTS] };
    let mut width = m + 1;
    bits.put(clear, width);
    let Some((&b0, rest)) = data.split_first() else {
        bits.put(end, width);
        return bits.finish();
    };
    let mut len = first;
    let mut cur = u16::from(b0);
    for &b in rest {
        let key = u32::from(cur) << 8 | u32::from(b);
        if let Some(c) = dict.get(key) {
            cur = c;
            continue;
        }
        if len < 4096 {
            dict.insert(key, len as u16);
        }
        len += 1;
        bits.put(cur, width);
        if len > 1 << width && width < 12 {
            width += 1;
        }
        if len > 4096 {
            bits.put(clear, width);
            dict.clear();
            len = first;
            width = m + 1;
        }
        cur = u16::from(b);
    }
    bits.put(cur, width);
    if len >= 1 << width && width < 12 {
        width += 1;
    }
    bits.put(end, width);
    bits.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn weezl(data: &[u8]) -> Vec<u8> {
        let mut f = gif::Frame { buffer: std::borrow::Cow::Borrowed(data), ..Default::default() };
        f.make_lzw_pre_encoded();
        f.buffer.into_owned()
    }

    /// Decodes with `weezl`, checks the stream ends with End right at its last byte, returns
    /// the indices.
    fn decode(lzw: &[u8]) -> Vec<u8> {
        let mut d = weezl::decode::Decoder::new(weezl::BitOrder::Lsb, lzw[0]);
        let mut out = vec![0u8; 200_000];
        let (mut input, mut n) = (&lzw[1..], 0);
        loop {
            let r = d.decode_bytes(input, &mut out[n..]);
            input = &input[r.consumed_in..];
            n += r.consumed_out;
            match r.status {
                Ok(weezl::LzwStatus::Done) => break,
                Ok(weezl::LzwStatus::Ok) if r.consumed_in + r.consumed_out > 0 => {}
                s => panic!("{s:?} with {} bytes left", input.len()),
            }
        }
        assert!(input.is_empty(), "bytes after End");
        out.truncate(n);
        out
    }

    /// Random indices over every alphabet size, long runs, and inputs long enough for many
    /// dictionary restarts: decoded back exactly, with `weezl`'s minimum code size, in no
    /// more bytes than `weezl`'s stream.
    #[test]
    fn round_trips_through_weezl_and_is_never_longer() {
        let mut state = 0x1234_5678u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut shorter = 0;
        for max in [0u64, 1, 3, 4, 15, 16, 100, 127, 128, 200, 255] {
            for n in [0usize, 1, 2, 3, 17, 4096, 70_000] {
                let noise: Vec<u8> = (0..n).map(|_| (next() % (max + 1)) as u8).collect();
                let runs: Vec<u8> = (0..n).map(|k| ((k / 37) as u64 % (max + 1)) as u8).collect();
                for (what, d) in [("noise", &noise), ("runs", &runs)] {
                    let (ours, theirs) = (gif_lzw(d), weezl(d));
                    assert_eq!(&decode(&ours), d, "{what}, max {max}, {n} bytes");
                    assert_eq!(ours[0], theirs[0], "{what}, max {max}: minimum code size");
                    assert!(ours.len() <= theirs.len(), "{what}, max {max}, {n} bytes");
                    shorter += usize::from(ours.len() < theirs.len());
                }
            }
        }
        // Where no prefix reaches 17 extensions the streams are the same bytes.
        assert_eq!(
            gif_lzw(&[3, 1, 3, 1, 3, 1, 2, 2, 2, 2]),
            weezl(&[3, 1, 3, 1, 3, 1, 2, 2, 2, 2])
        );
        assert!(shorter > 0);
    }

    proptest! {
        #[test]
        fn round_trips_any_input(data in proptest::collection::vec(any::<u8>(), 0..20_000), mask in any::<u8>()) {
            let d: Vec<u8> = data.iter().map(|b| b & mask).collect();
            let ours = gif_lzw(&d);
            prop_assert_eq!(decode(&ours), d.clone());
            prop_assert!(ours.len() <= weezl(&d).len());
        }
    }
}
