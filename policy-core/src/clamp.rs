//! Clamping that cannot panic.
//!
//! `f32::clamp` asserts `min <= max` and panics otherwise (or on a NaN bound). The normaliser
//! and the action bounds are public fields a host can fill with anything, and the control path
//! must never panic, so they clamp with this function instead.

/// `f32::clamp` without its assertion: the same comparisons in the same order, so for valid
/// bounds (`lo <= hi`, neither NaN) the result is bit-identical to `x.clamp(lo, hi)`.
/// For invalid bounds it returns a value and never panics.
#[inline]
pub(crate) fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    let mut v = x;
    if v < lo {
        v = lo;
    }
    if v > hi {
        v = hi;
    }
    v
}

#[cfg(test)]
mod tests {
    use super::clamp;

    #[test]
    fn matches_std_clamp_bit_for_bit_on_valid_bounds() {
        let xs = [
            0.0,
            -0.0,
            1.5,
            -1.5,
            7.0,
            -7.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        for &x in &xs {
            for (lo, hi) in [(-5.0f32, 5.0f32), (0.0, 0.0), (-0.0, 0.0), (2.0, 3.0)] {
                assert_eq!(
                    clamp(x, lo, hi).to_bits(),
                    x.clamp(lo, hi).to_bits(),
                    "{x} {lo} {hi}"
                );
            }
        }
    }

    #[test]
    fn inverted_or_nan_bounds_do_not_panic() {
        assert_eq!(clamp(0.5, 1.0, -1.0), -1.0);
        assert_eq!(clamp(0.5, f32::NAN, f32::NAN), 0.5);
    }
}
