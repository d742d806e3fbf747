//! Compact HDR encodings of the radiance totals: shared-exponent RGB9E5 (4 bytes per texel)
//! and IEEE half-float RGB (6 bytes per texel). Both store unsigned colours: negative
//! components are written as 0 (radiance is never negative; this absorbs `-0.0` and float
//! noise), components above the format's maximum are clamped to it, and NaN or ±∞ cannot be
//! written (the writer rejects them with an error naming the texel).
//!
//! Rounding is to nearest (RGB9E5: half away from zero as in the `EXT_texture_shared_exponent`
//! reference; half floats: ties to even, as IEEE 754). See `docs/FORMAT.md` for the error
//! measurements behind the default.

use serde::Serialize;

/// Radiance encoding of a file, stored in the header by its [`id`](Self::id).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub enum RadianceEncoding {
    /// Shared-exponent RGB9E5: 9-bit mantissas, 5-bit exponent (bias 15), one `u32` per texel
    /// (r in bits 0–8, g in 9–17, b in 18–26, exponent in 27–31), the layout of
    /// `DXGI_FORMAT_R9G9B9E5_SHAREDEXP` / wgpu `Rgb9e5Ufloat`. Id 1.
    Rgb9e5,
    /// IEEE 754 binary16 r, g, b (three `u16`, 6 bytes per texel). Id 2.
    RgbF16,
}

/// The encoding light fields are kept in after a bake (`bake::assemble`) and written in by
/// `format::write_atomic`.
pub const DEFAULT_ENCODING: RadianceEncoding = RadianceEncoding::RgbF16;

impl RadianceEncoding {
    /// Every encoding this build reads.
    pub const ALL: [RadianceEncoding; 2] = [RadianceEncoding::Rgb9e5, RadianceEncoding::RgbF16];

    /// The on-disk id.
    pub fn id(self) -> u32 {
        match self {
            RadianceEncoding::Rgb9e5 => 1,
            RadianceEncoding::RgbF16 => 2,
        }
    }

    /// The encoding with on-disk id `id`.
    pub fn from_id(id: u32) -> Option<Self> {
        Self::ALL.into_iter().find(|e| e.id() == id)
    }

    /// Short name (`"rgb9e5"`, `"rgb16f"`).
    pub fn name(self) -> &'static str {
        match self {
            RadianceEncoding::Rgb9e5 => "rgb9e5",
            RadianceEncoding::RgbF16 => "rgb16f",
        }
    }

    /// Bytes per texel on disk.
    pub fn bytes_per_texel(self) -> usize {
        match self {
            RadianceEncoding::Rgb9e5 => 4,
            RadianceEncoding::RgbF16 => 6,
        }
    }

    /// Largest storable component value.
    pub fn max_value(self) -> f32 {
        match self {
            RadianceEncoding::Rgb9e5 => RGB9E5_MAX,
            RadianceEncoding::RgbF16 => F16_MAX,
        }
    }

    /// `u32` words that hold `texels` stored texels: `bytes_per_texel × texels` bytes in file
    /// byte order, zero-padded to a whole word.
    pub fn words_for(self, texels: usize) -> usize {
        (texels * self.bytes_per_texel()).div_ceil(4)
    }

    /// Decodes stored texel `i` of `words` (file byte order; see [`words_for`](Self::words_for)).
    /// Exact: every stored value is an f32. Panics if `i` is beyond `words`.
    #[inline]
    pub fn texel(self, words: &[u32], i: usize) -> [f32; 3] {
        match self {
            RadianceEncoding::Rgb9e5 => rgb9e5_decode(u32::from_le(words[i])),
            RadianceEncoding::RgbF16 => {
                let h = &bytemuck::cast_slice::<u32, u16>(words)[3 * i..3 * i + 3];
                [h[0], h[1], h[2]].map(|x| f16_decode_unsigned(u16::from_le(x)))
            }
        }
    }

    /// Checks that the first `texels` texels of `words` are values a writer produces. Errors
    /// with the first texel that is not (a negative, infinite or NaN half float; every RGB9E5
    /// word is a valid value).
    pub fn check_stored(self, words: &[u32], texels: usize) -> Result<(), usize> {
        match self {
            RadianceEncoding::Rgb9e5 => Ok(()),
            RadianceEncoding::RgbF16 => {
                let halves = &bytemuck::cast_slice::<u32, u16>(words)[..3 * texels];
                // Stored halves are below 0x7C00 (finite, no sign bit): one max finds any other.
                let max = halves.iter().fold(0u16, |m, &h| m.max(u16::from_le(h)));
                if max < 0x7C00 {
                    return Ok(());
                }
                Err(halves
                    .chunks_exact(3)
                    .position(|h| h.iter().any(|&x| !f16_is_stored(u16::from_le(x))))
                    .unwrap_or(0))
            }
        }
    }

    /// Encodes `texels` (rgb; alpha ignored) into `out` (`bytes_per_texel` × `texels.len()`
    /// bytes, little-endian). Returns the index of the first texel with a NaN or infinite
    /// component, in which case `out` is unspecified.
    pub fn encode(self, texels: &[[f32; 4]], out: &mut [u8]) -> Result<(), usize> {
        debug_assert_eq!(out.len(), texels.len() * self.bytes_per_texel());
        let mut bad = false;
        match self {
            RadianceEncoding::Rgb9e5 => {
                for (t, o) in texels.iter().zip(out.chunks_exact_mut(4)) {
                    bad |= !(t[0].is_finite() && t[1].is_finite() && t[2].is_finite());
                    o.copy_from_slice(&rgb9e5_encode([t[0], t[1], t[2]]).to_le_bytes());
                }
            }
            RadianceEncoding::RgbF16 => {
                for (t, o) in texels.iter().zip(out.chunks_exact_mut(6)) {
                    for c in 0..3 {
                        bad |= !t[c].is_finite();
                        o[2 * c..2 * c + 2].copy_from_slice(&f16_encode(t[c]).to_le_bytes());
                    }
                }
            }
        }
        if bad {
            Err(texels
                .iter()
                .position(|t| t[..3].iter().any(|c| !c.is_finite()))
                .unwrap_or(0))
        } else {
            Ok(())
        }
    }

    /// Decodes `bytes` (a whole number of texels) into `out` (alpha = 0). Returns the index of
    /// the first texel that no writer produces (a negative, infinite or NaN half float), in
    /// which case `out` is unspecified. RGB9E5 has no such values.
    pub fn decode(self, bytes: &[u8], out: &mut [[f32; 4]]) -> Result<(), usize> {
        debug_assert_eq!(bytes.len(), out.len() * self.bytes_per_texel());
        let mut words = vec![0u32; bytes.len().div_ceil(4)];
        bytemuck::cast_slice_mut::<u32, u8>(&mut words)[..bytes.len()].copy_from_slice(bytes);
        self.decode_words(&words, out)
    }

    /// Like [`decode`](Self::decode) for bytes held in a `u32` buffer (in file byte order,
    /// `bytes_per_texel × out.len()` bytes used): aligned, so the loops vectorise.
    pub fn decode_words(self, words: &[u32], out: &mut [[f32; 4]]) -> Result<(), usize> {
        match self {
            RadianceEncoding::Rgb9e5 => {
                for (o, &v) in out.iter_mut().zip(words) {
                    let [r, g, b] = rgb9e5_decode(u32::from_le(v));
                    *o = [r, g, b, 0.0];
                }
                Ok(())
            }
            RadianceEncoding::RgbF16 => {
                let halves = &bytemuck::cast_slice::<u32, u16>(words)[..3 * out.len()];
                // Stored halves are below 0x7C00 (finite, no sign bit): one max finds any other.
                let max = halves.iter().fold(0u16, |m, &h| m.max(u16::from_le(h)));
                // Convert flat runs (vectorises), then spread rgb into rgba.
                let mut flat = [0f32; 3 * 256];
                for (o, h) in out.chunks_mut(256).zip(halves.chunks(3 * 256)) {
                    let flat = &mut flat[..h.len()];
                    for (f, &h) in flat.iter_mut().zip(h) {
                        *f = f16_decode_unsigned(u16::from_le(h));
                    }
                    for (o, f) in o.iter_mut().zip(flat.chunks_exact(3)) {
                        *o = [f[0], f[1], f[2], 0.0];
                    }
                }
                if max < 0x7C00 {
                    return Ok(());
                }
                Err(halves
                    .chunks_exact(3)
                    .position(|h| h.iter().any(|&x| !f16_is_stored(u16::from_le(x))))
                    .unwrap_or(0))
            }
        }
    }

    /// What the texels become after a write and a read (encode + decode; alpha = 0).
    /// Errors with the index of the first non-finite texel.
    pub fn quantize(self, texels: &[[f32; 4]]) -> Result<Vec<[f32; 4]>, usize> {
        let mut bytes = vec![0u8; texels.len() * self.bytes_per_texel()];
        self.encode(texels, &mut bytes)?;
        let mut out = vec![[0f32; 4]; texels.len()];
        self.decode(&bytes, &mut out)?;
        Ok(out)
    }
}

// ----- RGB9E5 ------------------------------------------------------------------------------

const RGB9E5_MANTISSA_BITS: i32 = 9;
const RGB9E5_BIAS: i32 = 15;
const RGB9E5_MAX_EXP: i32 = 31;

/// Largest RGB9E5 component: 511/512 × 2¹⁶ = 65408.
pub const RGB9E5_MAX: f32 = 65408.0;

/// 2^e for an integer `e` in the normal f32 range (exact).
fn exp2i(e: i32) -> f32 {
    f32::from_bits(((e + 127) as u32) << 23)
}

/// Encodes an rgb triple as RGB9E5 (round to nearest; negatives → 0, values above
/// [`RGB9E5_MAX`] → the maximum; NaN → 0: callers reject NaN and ∞ first).
pub fn rgb9e5_encode(rgb: [f32; 3]) -> u32 {
    // NaN → 0, +∞ → MAX, −∞ → 0.
    let c = rgb.map(|x| if x > 0.0 { x.min(RGB9E5_MAX) } else { 0.0 });
    let maxc = c[0].max(c[1]).max(c[2]);
    // floor(log2(maxc)), clamped below at −B−1 (every smaller value shares exponent 0).
    let floor_log2 = if maxc < exp2i(-RGB9E5_BIAS - 1) {
        -RGB9E5_BIAS - 1
    } else {
        ((maxc.to_bits() >> 23) as i32) - 127
    };
    let mut exp = floor_log2.max(-RGB9E5_BIAS - 1) + 1 + RGB9E5_BIAS;
    // Round in f64: x < 2^10 with 24 significant bits, so x + 0.5 is exact.
    let quant = |x: f32, exp: i32| -> u32 {
        let scaled = f64::from(x) * f64::from(exp2i(RGB9E5_BIAS + RGB9E5_MANTISSA_BITS - exp));
        (scaled + 0.5).floor() as u32
    };
    if quant(maxc, exp) == 1 << RGB9E5_MANTISSA_BITS {
        exp += 1;
    }
    debug_assert!((0..=RGB9E5_MAX_EXP).contains(&exp));
    let m = c.map(|x| quant(x, exp).min(511));
    m[0] | (m[1] << 9) | (m[2] << 18) | ((exp as u32) << 27)
}

/// Decodes an RGB9E5 value (exact in f32).
#[inline(always)]
pub fn rgb9e5_decode(v: u32) -> [f32; 3] {
    let exp = (v >> 27) as i32;
    let scale = exp2i(exp - RGB9E5_BIAS - RGB9E5_MANTISSA_BITS);
    [
        (v & 511) as f32 * scale,
        ((v >> 9) & 511) as f32 * scale,
        ((v >> 18) & 511) as f32 * scale,
    ]
}

// ----- binary16 ----------------------------------------------------------------------------

/// Largest finite half float, 65504.
pub const F16_MAX: f32 = 65504.0;

/// Encodes a non-negative value as an IEEE binary16 (round to nearest, ties to even; subnormal
/// results where due; negatives → +0; values above [`F16_MAX`] → the maximum, never ∞;
/// NaN → +0: callers reject NaN and ∞ first).
pub fn f16_encode(x: f32) -> u16 {
    if x.is_nan() || x <= 0.0 {
        return 0;
    }
    let bits = x.to_bits();
    // 65520 = 65504 + half an ulp: from there on, rounding would give ∞.
    if bits >= 0x477F_F000 {
        return 0x7BFF;
    }
    let exp = (bits >> 23) as i32; // biased f32 exponent
    if exp >= 113 {
        // Normal half: rebias the exponent (127 → 15) and round away 13 mantissa bits.
        let m = bits - (112 << 23);
        let rounded = m + 0x0FFF + ((m >> 13) & 1);
        return (rounded >> 13) as u16;
    }
    // Subnormal half: value = q × 2⁻²⁴ with q = mant × 2^(exp − 126).
    if exp < 102 {
        // Below 2⁻²⁵ (half the smallest subnormal): rounds to 0.
        return 0;
    }
    let mant = (bits & 0x007F_FFFF) | 0x0080_0000;
    let shift = (126 - exp) as u32; // 14..=24
    let q = mant >> shift;
    let rem = mant & ((1 << shift) - 1);
    let half = 1 << (shift - 1);
    let q = if rem > half || (rem == half && q & 1 == 1) {
        q + 1
    } else {
        q
    };
    q as u16
}

/// Decodes any IEEE binary16 (sign, subnormals, ±∞ and NaN included).
pub fn f16_decode(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = u32::from((h >> 10) & 0x1F);
    let mant = u32::from(h & 0x03FF);
    let mag = match exp {
        0 => mant as f32 * exp2i(-24),
        31 if mant == 0 => f32::INFINITY,
        31 => f32::NAN,
        _ => f32::from_bits(((exp + 112) << 23) | (mant << 13)),
    };
    sign * mag
}

/// Whether `h` is a value the writer produces: finite and without the sign bit.
#[inline(always)]
fn f16_is_stored(h: u16) -> bool {
    h < 0x7C00
}

/// Fast decode of a stored half (see [`f16_is_stored`]; other inputs give a finite garbage
/// value, and the caller rejects the file): the magnitude bits shifted into an f32 and scaled
/// by 2¹¹², exact for normals and subnormals alike.
#[inline(always)]
fn f16_decode_unsigned(h: u16) -> f32 {
    f32::from_bits(u32::from(h & 0x7FFF) << 13) * exp2i(112)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f16_every_value_round_trips() {
        for h in 0..0x7C00u16 {
            let x = f16_decode(h);
            assert_eq!(f16_encode(x), h, "h = {h:#06x}, x = {x:e}");
            assert_eq!(
                f16_decode_unsigned(h).to_bits(),
                x.to_bits(),
                "h = {h:#06x}"
            );
        }
        assert_eq!(f16_decode(0x7C00), f32::INFINITY);
        assert!(f16_decode(0x7E00).is_nan());
        assert_eq!(f16_decode(0xC000), -2.0);
    }

    #[test]
    fn f16_rounds_to_nearest_even() {
        // Between consecutive halves a < b: just below the midpoint → a, just above → b,
        // the midpoint itself → the even one.
        for h in 0..0x7BFFu16 {
            let (a, b) = (f64::from(f16_decode(h)), f64::from(f16_decode(h + 1)));
            let mid = ((a + b) / 2.0) as f32; // exact: halves have 11 significant bits
            assert_eq!(f64::from(mid), (a + b) / 2.0);
            let even = if h & 1 == 0 { h } else { h + 1 };
            assert_eq!(f16_encode(mid), even, "midpoint after {h:#06x}");
            assert_eq!(f16_encode(f32::from_bits(mid.to_bits() - 1)), h);
            assert_eq!(f16_encode(f32::from_bits(mid.to_bits() + 1)), h + 1);
        }
    }

    #[test]
    fn f16_edges() {
        assert_eq!(f16_encode(0.0), 0);
        assert_eq!(f16_encode(-0.0), 0);
        assert_eq!(f16_encode(-5.0), 0);
        assert_eq!(f16_encode(f32::NAN), 0);
        assert_eq!(f16_encode(65504.0), 0x7BFF);
        assert_eq!(f16_encode(65519.99), 0x7BFF);
        assert_eq!(f16_encode(65520.0), 0x7BFF); // would round to ∞: clamped
        assert_eq!(f16_encode(1e30), 0x7BFF);
        assert_eq!(f16_encode(f32::INFINITY), 0x7BFF);
        assert_eq!(f16_encode(f32::MIN_POSITIVE), 0); // f32 subnormal range → 0
        assert_eq!(f16_encode(f32::from_bits(1)), 0);
        assert_eq!(f16_encode(2f32.powi(-24)), 1); // smallest subnormal
        assert_eq!(f16_encode(2f32.powi(-25)), 0); // tie → even (0)
        assert_eq!(f16_encode(2f32.powi(-25) * 1.0001), 1);
        assert_eq!(f16_encode(1.5 * 2f32.powi(-24)), 2); // tie → even (2)
        assert_eq!(f16_encode(2f32.powi(-14)), 0x0400); // smallest normal
        assert_eq!(f16_encode(1.0), 0x3C00);
        assert_eq!(f16_encode(1.0 + 2f32.powi(-11)), 0x3C00); // tie → even
        assert_eq!(f16_encode(1.0 + 3.0 * 2f32.powi(-11)), 0x3C02); // tie → even
    }

    fn rgb9e5_reference(rgb: [f32; 3]) -> [f64; 3] {
        // Nearest representable triple by brute force over the shared exponent chosen by the
        // spec: the exponent is fixed by the largest component, mantissas rounded.
        let c = rgb.map(|x| f64::from(x.clamp(0.0, RGB9E5_MAX)));
        let maxc = c[0].max(c[1]).max(c[2]);
        let mut exp = (maxc.log2().floor() as i32).max(-16) + 16;
        if maxc > 0.0 && (maxc / 2f64.powi(exp - 24) + 0.5).floor() >= 512.0 {
            exp += 1;
        }
        c.map(|x| (x / 2f64.powi(exp - 24) + 0.5).floor().min(511.0) * 2f64.powi(exp - 24))
    }

    #[test]
    fn rgb9e5_matches_reference_and_bounds() {
        let mut s = 0x1234_5678_9abc_def0u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        for i in 0..200_000 {
            let mut rgb = [0f32; 3];
            for c in &mut rgb {
                let r = next();
                let e = (r % 40) as i32 - 24; // 2^-24 .. 2^16
                *c = (1.0 + (r >> 40) as f32 / (1u64 << 24) as f32) * 2f32.powi(e);
                if i % 7 == 0 {
                    *c = 0.0;
                }
            }
            let v = rgb9e5_encode(rgb);
            let d = rgb9e5_decode(v);
            let r = rgb9e5_reference(rgb);
            for c in 0..3 {
                assert_eq!(f64::from(d[c]), r[c], "{rgb:?} → {d:?} (ref {r:?})");
            }
            let maxc = rgb.iter().fold(0f32, |a, &b| a.max(b)).min(RGB9E5_MAX);
            let maxd = d.iter().fold(0f32, |a, &b| a.max(b));
            if maxc >= 2f32.powi(-15) {
                assert!((maxd - maxc).abs() <= maxc / 512.0, "{rgb:?} → {d:?}");
            }
        }
    }

    #[test]
    fn rgb9e5_edges() {
        assert_eq!(rgb9e5_encode([0.0; 3]), 0);
        assert_eq!(rgb9e5_decode(0), [0.0; 3]);
        assert_eq!(rgb9e5_decode(rgb9e5_encode([-1.0, -0.0, 0.0])), [0.0; 3]);
        assert_eq!(
            rgb9e5_decode(rgb9e5_encode([1.0, 0.5, 0.25])),
            [1.0, 0.5, 0.25]
        );
        assert_eq!(
            rgb9e5_decode(rgb9e5_encode([1e9, 0.0, 0.0])),
            [RGB9E5_MAX, 0.0, 0.0]
        );
        assert_eq!(
            rgb9e5_decode(rgb9e5_encode([RGB9E5_MAX; 3])),
            [RGB9E5_MAX; 3]
        );
        assert_eq!(rgb9e5_decode(u32::MAX), [RGB9E5_MAX; 3]);
        // Smallest step: 2^-24; f32 subnormals round to 0.
        assert_eq!(
            rgb9e5_decode(rgb9e5_encode([2f32.powi(-24), 0.0, 0.0]))[0],
            2f32.powi(-24)
        );
        assert_eq!(
            rgb9e5_decode(rgb9e5_encode([f32::from_bits(5); 3])),
            [0.0; 3]
        );
        // Rounding up into the next exponent: 511.6/512 → 1.0.
        assert_eq!(
            rgb9e5_decode(rgb9e5_encode([0.9995, 0.0, 0.0])),
            [1.0, 0.0, 0.0]
        );
        // Every exponent and mantissa decodes to an exactly re-encodable value.
        for e in 0..32u32 {
            for m in [1u32, 255, 256, 300, 511] {
                let v = m | (e << 27);
                let d = rgb9e5_decode(v);
                assert_eq!(rgb9e5_decode(rgb9e5_encode(d)), d, "e = {e}, m = {m}");
            }
        }
    }

    #[test]
    fn encode_rejects_non_finite_and_decode_rejects_bad_halves() {
        let t = [[1.0, 2.0, 3.0, 0.0], [0.0, f32::NAN, 0.0, 0.0]];
        for e in RadianceEncoding::ALL {
            let mut out = vec![0u8; 2 * e.bytes_per_texel()];
            assert_eq!(e.encode(&t, &mut out), Err(1));
            let inf = [[0.0, 0.0, f32::INFINITY, 0.0]];
            assert_eq!(e.quantize(&inf), Err(0));
            assert_eq!(RadianceEncoding::from_id(e.id()), Some(e));
        }
        let bytes = [0, 0x3C, 0, 0, 0, 0, 0, 0, 0, 0x7C, 0, 0];
        let mut out = [[0f32; 4]; 2];
        assert_eq!(RadianceEncoding::RgbF16.decode(&bytes, &mut out), Err(1));
        let neg = [0, 0xBC, 0, 0, 0, 0];
        assert_eq!(RadianceEncoding::RgbF16.decode(&neg, &mut out[..1]), Err(0));
    }
}
