//! IEEE-754 half precision (binary16) to and from `f32`, for blobs with f16 weights.
//!
//! Decoding is exact (every binary16 value is a binary32 value), so an f16 blob computes what
//! an f32 blob computes with the decoded weights. Encoding rounds to the nearest binary16,
//! ties to even, as IEEE-754 and every hardware converter do; values beyond 65504 become
//! infinity (the blob writer refuses them).

/// The `f32` value of the binary16 bits `h`.
///
/// ```
/// use policy_core::half::f16_to_f32;
/// assert_eq!(f16_to_f32(0x3c00), 1.0);
/// assert_eq!(f16_to_f32(0xc000), -2.0);
/// assert_eq!(f16_to_f32(0x0001), 2f32.powi(-24)); // the smallest subnormal
/// assert_eq!(f16_to_f32(0x7bff), 65504.0); // the largest finite
/// assert!(f16_to_f32(0x7c00).is_infinite());
/// ```
#[inline]
pub fn f16_to_f32(h: u16) -> f32 {
    let sign = u32::from(h >> 15) << 31;
    let exponent = u32::from((h >> 10) & 0x1f);
    let mantissa = u32::from(h & 0x3ff);
    let bits = match exponent {
        0 if mantissa == 0 => sign,
        0 => {
            // Subnormal: mantissa × 2^-24, exact in f32.
            let v = mantissa as f32 * (1.0 / 16_777_216.0);
            return if sign != 0 { -v } else { v };
        }
        31 => sign | 0x7f80_0000 | (mantissa << 13),
        _ => sign | ((exponent + 112) << 23) | (mantissa << 13),
    };
    f32::from_bits(bits)
}

/// [`f16_to_f32`] for a *finite* binary16, without branches: the magnitude's bits moved into
/// the f32 exponent and mantissa fields, scaled by 2^112 (an exact multiply: it only rebiases the
/// exponent, and turns an f16 subnormal, which lands among the f32 subnormals, into the right
/// normal number), then the sign. Equal to [`f16_to_f32`] bit for bit on every finite input (the
/// tests check all of them); an infinity or NaN decodes to a finite number, which is why the
/// loader checks every weight with [`f16_to_f32`] first. The layers' inner loop uses this one:
/// on a Cortex-M4F it costs a few integer instructions and one multiply instead of a branch.
///
/// ```
/// use policy_core::half::{f16_to_f32, f16_to_f32_finite};
/// for h in [0x3c00u16, 0xc000, 0x0001, 0x7bff, 0x8000] {
///     assert_eq!(f16_to_f32_finite(h).to_bits(), f16_to_f32(h).to_bits());
/// }
/// ```
#[inline(always)]
pub fn f16_to_f32_finite(h: u16) -> f32 {
    const TWO_POW_112: f32 = f32::from_bits((112 + 127) << 23);
    let h = u32::from(h);
    let magnitude = f32::from_bits((h & 0x7fff) << 13) * TWO_POW_112;
    f32::from_bits(magnitude.to_bits() | ((h & 0x8000) << 16))
}

/// The binary16 nearest to `x` (ties to even); beyond the range, infinity; NaN stays NaN.
///
/// ```
/// use policy_core::half::{f16_to_f32, f32_to_f16};
/// assert_eq!(f32_to_f16(1.0), 0x3c00);
/// assert_eq!(f16_to_f32(f32_to_f16(0.1)), 0.099975586); // the nearest binary16 to 0.1
/// assert_eq!(f32_to_f16(1.0 + 2f32.powi(-11)), 0x3c00); // a tie rounds to even
/// assert_eq!(f32_to_f16(70000.0), 0x7c00); // overflow: infinity
/// ```
pub fn f32_to_f16(x: f32) -> u16 {
    let bits = x.to_bits();
    let sign = ((bits >> 16) & 0x8000) as u16;
    let exponent = ((bits >> 23) & 0xff) as i32;
    let mantissa = bits & 0x007f_ffff;
    if exponent == 0xff {
        // Infinity, or NaN with a quiet bit so that it stays NaN.
        return sign | 0x7c00 | if mantissa != 0 { 0x0200 } else { 0 };
    }
    let e = exponent - 127 + 15; // the binary16 exponent field if normal
    if e >= 0x1f {
        return sign | 0x7c00;
    }
    if e <= 0 {
        // Subnormal or zero in binary16: shift the full significand right.
        if e < -10 {
            return sign; // below half the smallest subnormal: rounds to zero
        }
        let significand = mantissa | 0x0080_0000;
        let shift = (14 - e) as u32; // 13 + (1 - e)
        let half = 1u32 << (shift - 1);
        let rest = significand & ((1u32 << shift) - 1);
        let mut h = significand >> shift;
        if rest > half || (rest == half && h & 1 == 1) {
            h += 1; // may carry into the smallest normal: still the right bits
        }
        return sign | h as u16;
    }
    let rest = mantissa & 0x1fff;
    let mut h = ((e as u32) << 10) | (mantissa >> 13);
    if rest > 0x1000 || (rest == 0x1000 && h & 1 == 1) {
        h += 1; // may carry into the exponent, up to infinity: still the right bits
    }
    sign | h as u16
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every binary16 value decodes and encodes back to itself (NaNs stay NaN).
    #[test]
    fn every_f16_round_trips() {
        for h in 0..=u16::MAX {
            let x = f16_to_f32(h);
            if x.is_nan() {
                assert!(f16_to_f32(f32_to_f16(x)).is_nan(), "{h:#06x}");
            } else {
                assert_eq!(f32_to_f16(x), h, "{h:#06x} = {x}");
            }
        }
    }

    /// The branch-free decoder agrees with the exact one on every finite binary16.
    #[test]
    fn the_fast_decoder_agrees_on_every_finite_value() {
        for h in 0..=u16::MAX {
            let exact = f16_to_f32(h);
            if exact.is_finite() {
                assert_eq!(f16_to_f32_finite(h).to_bits(), exact.to_bits(), "{h:#06x}");
            }
        }
    }

    /// Between every pair of neighbouring binary16 values, encoding rounds to the nearer one,
    /// and a value exactly halfway to the one with an even last bit.
    #[test]
    fn encoding_rounds_to_nearest_even() {
        for h in 0u16..0x7bff {
            let (lo, hi) = (f16_to_f32(h), f16_to_f32(h + 1));
            let mid = lo + (hi - lo) / 2.0; // exact: one more bit than binary16 has
            let even = if h & 1 == 0 { h } else { h + 1 };
            assert_eq!(
                f32_to_f16(mid),
                even,
                "halfway between {h:#06x} and the next"
            );
            let below = f32::from_bits(mid.to_bits() - 1);
            let above = f32::from_bits(mid.to_bits() + 1);
            assert_eq!(f32_to_f16(below), h, "just below halfway after {h:#06x}");
            assert_eq!(
                f32_to_f16(above),
                h + 1,
                "just above halfway after {h:#06x}"
            );
            assert_eq!(f32_to_f16(-below), h | 0x8000);
        }
    }
}
