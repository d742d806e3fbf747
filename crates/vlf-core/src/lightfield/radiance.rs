//! [`Radiance`]: radiance values kept in their stored encoding.

use std::fmt;

use super::encoding::RadianceEncoding;
use crate::hash::{BLOCK, xxh64};
use crate::parallel;

/// Radiance values (rgb) in a stored encoding: exactly the bytes of a `.vlf` radiance section
/// (little-endian), held in `u32` words so that the buffer is aligned for checksums,
/// validation and upload. Reading a file fills it with one read per section and no decoding;
/// writing it in its own encoding writes these bytes. [`get`](Self::get) and
/// [`to_f32`](Self::to_f32) decode exactly (every stored value is an f32).
///
/// Every value is one a writer produces: finite and non-negative ([`from_f32`](Self::from_f32)
/// rejects NaN and ±∞; the reader rejects other half floats). Equality compares the encoding
/// and the stored bits.
#[derive(Clone, PartialEq, Eq)]
pub struct Radiance {
    encoding: RadianceEncoding,
    len: usize,
    /// `len × bytes_per_texel` bytes in file byte order, zero-padded to a whole word.
    words: Vec<u32>,
}

/// A value that no radiance encoding can store (NaN or ±∞ in a channel).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error("value {index}: {value:?} is not finite (NaN and infinity cannot be stored)")]
pub struct NonFiniteRadiance {
    /// Index of the first non-finite value.
    pub index: usize,
    /// Its rgb.
    pub value: [f32; 3],
}

/// Bytes that are not stored radiance ([`Radiance::from_stored`]).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum InvalidStoredRadiance {
    #[error("{bytes} bytes are not a whole number of {bytes_per_value}-byte values")]
    Length {
        bytes: usize,
        bytes_per_value: usize,
    },
    #[error("value {index}: not a stored {encoding} value (negative, infinite or NaN)")]
    Value {
        index: usize,
        encoding: &'static str,
    },
}

impl Radiance {
    /// No values.
    pub fn new(encoding: RadianceEncoding) -> Self {
        Radiance {
            encoding,
            len: 0,
            words: Vec::new(),
        }
    }

    /// Encodes `values` (rgb; alpha ignored) with the rounding and clamping of the writer (see
    /// [`RadianceEncoding`]); large inputs on several threads. Errors with the first value
    /// holding a NaN or infinity.
    pub fn from_f32(
        values: &[[f32; 4]],
        encoding: RadianceEncoding,
    ) -> Result<Self, NonFiniteRadiance> {
        let n = values.len();
        let bpt = encoding.bytes_per_texel();
        let mut words = vec![0u32; encoding.words_for(n)];
        let results = parallel::blocks_mut(&mut words, BLOCK / 4, n * bpt, |first, w| {
            let t0 = first * (BLOCK / bpt);
            let t1 = (t0 + w.len() * 4 / bpt).min(n);
            let bytes = &mut bytemuck::cast_slice_mut::<u32, u8>(w)[..(t1 - t0) * bpt];
            encoding.encode(&values[t0..t1], bytes).map_err(|i| t0 + i)
        });
        if let Some(index) = results.into_iter().find_map(Result::err) {
            let v = values[index];
            return Err(NonFiniteRadiance {
                index,
                value: [v[0], v[1], v[2]],
            });
        }
        Ok(Radiance {
            encoding,
            len: n,
            words,
        })
    }

    /// From stored bytes (a radiance section's content, little-endian), checked as the reader
    /// checks them. Any RGB9E5 word is a value; half floats must be finite and non-negative.
    pub fn from_stored(
        encoding: RadianceEncoding,
        bytes: &[u8],
    ) -> Result<Self, InvalidStoredRadiance> {
        let bpt = encoding.bytes_per_texel();
        if !bytes.len().is_multiple_of(bpt) {
            return Err(InvalidStoredRadiance::Length {
                bytes: bytes.len(),
                bytes_per_value: bpt,
            });
        }
        let len = bytes.len() / bpt;
        let mut words = vec![0u32; encoding.words_for(len)];
        bytemuck::cast_slice_mut::<u32, u8>(&mut words)[..bytes.len()].copy_from_slice(bytes);
        encoding
            .check_stored(&words, len)
            .map_err(|index| InvalidStoredRadiance::Value {
                index,
                encoding: encoding.name(),
            })?;
        Ok(Radiance {
            encoding,
            len,
            words,
        })
    }

    /// From stored words that the caller has checked ([`RadianceEncoding::check_stored`]),
    /// padding included.
    pub(crate) fn from_checked_words(
        encoding: RadianceEncoding,
        len: usize,
        words: Vec<u32>,
    ) -> Self {
        debug_assert_eq!(words.len(), encoding.words_for(len));
        Radiance {
            encoding,
            len,
            words,
        }
    }

    pub fn encoding(&self) -> RadianceEncoding {
        self.encoding
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Value `i` (rgb), decoded exactly. Panics if `i ≥ len()`.
    #[inline]
    pub fn get(&self, i: usize) -> [f32; 3] {
        assert!(
            i < self.len,
            "radiance index {i} out of range ({})",
            self.len
        );
        self.encoding.texel(&self.words, i)
    }

    /// Every value (rgb), decoded.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = [f32; 3]> + '_ {
        (0..self.len).map(|i| self.encoding.texel(&self.words, i))
    }

    /// All values decoded to f32 RGBA (alpha 0), on several threads when large. 16 bytes per
    /// value: for computations, not for keeping.
    pub fn to_f32(&self) -> Vec<[f32; 4]> {
        let bpt = self.encoding.bytes_per_texel();
        let per_block = BLOCK / bpt;
        let mut out = vec![[0f32; 4]; self.len];
        parallel::blocks_mut(&mut out, per_block, self.byte_len(), |first, o| {
            // Stored values are valid, so decoding cannot fail.
            let _ = self
                .encoding
                .decode_words(&self.words[first * (BLOCK / 4)..], o);
        });
        out
    }

    /// The same values in `encoding`: a copy when it is this one, else decoded and re-encoded
    /// (rounded once more: an f16 value re-encoded as RGB9E5 may differ by one step from the
    /// f32 original encoded directly).
    pub fn to_encoding(&self, encoding: RadianceEncoding) -> Radiance {
        if encoding == self.encoding {
            return self.clone();
        }
        Radiance::from_f32(&self.to_f32(), encoding).expect("stored radiance is finite")
    }

    /// The stored bytes (`len × bytes_per_texel`, little-endian): a `.vlf` section's content.
    pub fn as_bytes(&self) -> &[u8] {
        &bytemuck::cast_slice::<u32, u8>(&self.words)[..self.byte_len()]
    }

    /// The stored bytes as words, zero-padded to a whole word.
    pub fn words(&self) -> &[u32] {
        &self.words
    }

    /// Bytes of the stored values (without the padding).
    pub fn byte_len(&self) -> usize {
        self.len * self.encoding.bytes_per_texel()
    }

    /// For [`RadianceEncoding::RgbF16`]: copies the halves of values `first..first +
    /// out.len()` into RGBA texels (alpha 0, halves in little-endian byte order as in the
    /// file, so the bytes of `out` are an `Rgba16Float` texture's), on several threads when
    /// large. A copy of bits, exact. Panics for another encoding or a range beyond `len()`.
    pub fn rgba16f_into(&self, first: usize, out: &mut [[u16; 4]]) {
        assert_eq!(self.encoding, RadianceEncoding::RgbF16);
        assert!(first + out.len() <= self.len, "values beyond the radiance");
        let halves = &bytemuck::cast_slice::<u32, u16>(&self.words)[3 * first..];
        let per_block = BLOCK / 6;
        let bytes = out.len() * 8;
        parallel::blocks_mut(out, per_block, bytes, |block, o| {
            let h = &halves[3 * block * per_block..];
            for (o, h) in o.iter_mut().zip(h.chunks_exact(3)) {
                *o = [h[0], h[1], h[2], 0];
            }
        });
    }
}

impl fmt::Debug for Radiance {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        const SHOWN: usize = 4;
        let head: Vec<[f32; 3]> = self.iter().take(SHOWN).collect();
        f.debug_struct("Radiance")
            .field("encoding", &self.encoding.name())
            .field("len", &self.len)
            .field(if self.len > SHOWN { "first" } else { "values" }, &head)
            .field("xxh64", &format_args!("{:016x}", xxh64(self.as_bytes(), 0)))
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn values(n: usize) -> Vec<[f32; 4]> {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        (0..n)
            .map(|i| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                let l = ((s >> 40) as f32 / (1u64 << 24) as f32 * 13.8 - 9.2).exp();
                if i % 11 == 0 {
                    [0.0, -1.0, 1e9, 7.0] // negative → 0, clamped, alpha ignored
                } else {
                    [l * 0.3, l, l * (s & 0xff) as f32 / 255.0, 0.0]
                }
            })
            .collect()
    }

    #[test]
    fn accessors_agree_with_the_encoding_for_every_length() {
        for enc in RadianceEncoding::ALL {
            // Odd and even counts (f16 pads to a whole word), and more than one block.
            for n in [
                0,
                1,
                2,
                3,
                7,
                131_073,
                2 * BLOCK / enc.bytes_per_texel() + 5,
            ] {
                let v = values(n);
                let r = Radiance::from_f32(&v, enc).unwrap();
                assert_eq!((r.len(), r.is_empty(), r.encoding()), (n, n == 0, enc));
                assert_eq!(r.byte_len(), n * enc.bytes_per_texel());
                assert_eq!(r.as_bytes().len(), r.byte_len());
                assert_eq!(r.words().len(), enc.words_for(n));
                let want = enc.quantize(&v).unwrap();
                let mut bytes = vec![0u8; n * enc.bytes_per_texel()];
                enc.encode(&v, &mut bytes).unwrap();
                assert!(r.as_bytes() == bytes.as_slice(), "n = {n}");
                // Padding is zero, so equal values give equal words.
                let pad = &bytemuck::cast_slice::<u32, u8>(r.words())[r.byte_len()..];
                assert!(pad.iter().all(|&b| b == 0));
                assert!(r.to_f32() == want, "n = {n}");
                assert!(r.iter().eq(want.iter().map(|w| [w[0], w[1], w[2]])));
                for i in [0, n / 2, n.saturating_sub(1)] {
                    if i < n {
                        assert_eq!(r.get(i), [want[i][0], want[i][1], want[i][2]]);
                    }
                }
                assert_eq!(r.to_encoding(enc), r);
                assert_eq!(
                    Radiance::from_f32(&r.to_f32(), enc).unwrap(),
                    r,
                    "re-encoding is idempotent"
                );
                let other = RadianceEncoding::ALL
                    .into_iter()
                    .find(|&e| e != enc)
                    .unwrap();
                let o = r.to_encoding(other);
                assert_eq!(o.encoding(), other);
                assert_eq!(o, Radiance::from_f32(&want, other).unwrap());
            }
        }
    }

    #[test]
    fn from_stored_checks_like_the_reader() {
        let r = Radiance::from_f32(&values(5), RadianceEncoding::RgbF16).unwrap();
        assert_eq!(
            Radiance::from_stored(RadianceEncoding::RgbF16, r.as_bytes()).unwrap(),
            r
        );
        let mut bad = r.as_bytes().to_vec();
        bad[6 * 3 + 5] = 0xFC; // -inf in texel 3
        assert_eq!(
            Radiance::from_stored(RadianceEncoding::RgbF16, &bad)
                .unwrap_err()
                .to_string(),
            "value 3: not a stored rgb16f value (negative, infinite or NaN)"
        );
        assert!(matches!(
            Radiance::from_stored(RadianceEncoding::RgbF16, &bad[..7]),
            Err(InvalidStoredRadiance::Length { bytes: 7, .. })
        ));
        // Every RGB9E5 word is a value, also ones no encoder produces (denormalised mantissas).
        let w = [0xFFFF_FFFFu32, 1 << 27 | 3];
        let r = Radiance::from_stored(RadianceEncoding::Rgb9e5, bytemuck::cast_slice(&w)).unwrap();
        assert_eq!(r.get(1), [3.0 * 2f32.powi(-23), 0.0, 0.0]);
    }

    #[test]
    fn rgba16f_copies_the_halves() {
        let v = values(2 * BLOCK / 6 + 3);
        let r = Radiance::from_f32(&v, RadianceEncoding::RgbF16).unwrap();
        let mut out = vec![[7u16; 4]; r.len() + 2];
        r.rgba16f_into(0, &mut out[..r.len()]);
        let halves = bytemuck::cast_slice::<u8, u16>(r.as_bytes());
        for (i, o) in out[..r.len()].iter().enumerate() {
            assert_eq!(o[..3], halves[3 * i..3 * i + 3], "texel {i}");
            assert_eq!(o[3], 0);
            let f = o.map(|h| crate::lightfield::encoding::f16_decode(u16::from_le(h)));
            assert_eq!([f[0], f[1], f[2]], r.get(i));
        }
        assert_eq!(out[r.len()..], [[7; 4]; 2]);
        // A range.
        let mut part = vec![[7u16; 4]; 5];
        r.rgba16f_into(BLOCK / 6 - 2, &mut part);
        assert_eq!(part, out[BLOCK / 6 - 2..BLOCK / 6 + 3]);
    }

    #[test]
    fn rejects_non_finite_and_debug_is_short() {
        let mut v = values(10);
        v[3][2] = f32::NAN;
        v[6][0] = f32::INFINITY;
        let e = Radiance::from_f32(&v, RadianceEncoding::Rgb9e5).unwrap_err();
        assert_eq!(e.index, 3);
        assert!(e.to_string().starts_with("value 3: ["), "{e}");
        let r = Radiance::from_f32(&values(1000), RadianceEncoding::RgbF16).unwrap();
        let d = format!("{r:?}");
        assert!(
            d.starts_with("Radiance { encoding: \"rgb16f\", len: 1000, first: ["),
            "{d}"
        );
        assert!(d.len() < 300, "{d}");
        // A difference beyond the values shown still shows (in the hash).
        let mut w = values(1000);
        w[999][0] += 1.0;
        let other = Radiance::from_f32(&w, RadianceEncoding::RgbF16).unwrap();
        assert_ne!(d, format!("{other:?}"));
    }
}
