//! Action bounds: the box the actuator accepts, and the scaling from the network's `[-1, 1]`.

use nalgebra::{ArrayStorage, SVector};

use crate::clamp::clamp;
use crate::error::Error;

/// Per-dimension action bounds `low[i] <= a[i] <= high[i]`.
#[derive(Clone, Debug, PartialEq)]
pub struct ActionBounds<const A: usize> {
    /// Lower bound of each action dimension.
    pub low: SVector<f32, A>,
    /// Upper bound of each action dimension.
    pub high: SVector<f32, A>,
}

impl<const A: usize> ActionBounds<A> {
    /// The degenerate box `[0, 0]`: every action is zero (the safe state).
    pub const ZERO: Self = Self {
        low: SVector::from_array_storage(ArrayStorage([[0.0; A]; 1])),
        high: SVector::from_array_storage(ArrayStorage([[0.0; A]; 1])),
    };

    /// The symmetric box `[-limit, limit]` in every dimension.
    pub fn symmetric(limit: f32) -> Self {
        Self {
            low: SVector::repeat(-limit),
            high: SVector::repeat(limit),
        }
    }

    /// Maps a unit action `u ∈ [-1, 1]^A` linearly onto the box; the result is clamped into the
    /// box, and a non-finite `u[i]` maps to the middle of dimension `i`.
    ///
    /// For bounds that pass [`ActionBounds::validate`] the result is finite and inside the box.
    /// Bounds that do not (set by hand) never make it panic, but then nothing is promised.
    ///
    /// ```
    /// use policy_core::ActionBounds;
    /// let b = ActionBounds::<2>::symmetric(0.25);
    /// assert_eq!(b.scale(&[1.0, -1.0]), [0.25, -0.25]);
    /// assert_eq!(b.scale(&[f32::NAN, 0.0]), [0.0, 0.0]);
    /// ```
    #[inline]
    pub fn scale(&self, unit: &[f32; A]) -> [f32; A] {
        let mut out = [0.0; A];
        for (((o, &u), &lo), &hi) in out.iter_mut().zip(unit).zip(&self.low).zip(&self.high) {
            *o = scale_value(u, lo, hi);
        }
        out
    }

    /// Maps an action in the box back to `[-1, 1]` (the inverse of [`ActionBounds::scale`] up to
    /// rounding); a zero-width dimension maps to 0.
    ///
    /// ```
    /// use policy_core::ActionBounds;
    /// let b = ActionBounds::<2>::symmetric(0.25);
    /// assert_eq!(b.unscale(&[0.125, -0.25]), [0.5, -1.0]);
    /// ```
    pub fn unscale(&self, action: &[f32; A]) -> [f32; A] {
        let mut out = [0.0; A];
        for (((o, &a), &lo), &hi) in out.iter_mut().zip(action).zip(&self.low).zip(&self.high) {
            let width = hi - lo;
            let u = if width > 0.0 {
                2.0 * (a - lo) / width - 1.0
            } else {
                0.0
            };
            *o = if u.is_finite() {
                u.clamp(-1.0, 1.0)
            } else {
                0.0
            };
        }
        out
    }

    /// Checks `low <= high` (both finite) and that the box's width and midpoint are
    /// representable.
    ///
    /// ```
    /// use policy_core::{ActionBounds, Error};
    /// assert_eq!(ActionBounds::<2>::symmetric(0.25).validate(), Ok(()));
    /// let inverted = ActionBounds::<2>::symmetric(-0.25);
    /// assert!(matches!(inverted.validate(), Err(Error::InvalidParameter { index: 0, .. })));
    /// ```
    pub fn validate(&self) -> Result<(), Error> {
        check(self.low.iter().copied(), self.high.iter().copied())
    }

    /// Parameters in blob order: low, then high.
    pub fn params(&self) -> [&[f32]; 2] {
        [self.low.as_slice(), self.high.as_slice()]
    }

    /// Mutable parameters, in the order of [`ActionBounds::params`].
    pub fn params_mut(&mut self) -> [&mut [f32]; 2] {
        [self.low.as_mut_slice(), self.high.as_mut_slice()]
    }
}

/// One action component: the unit value `u` (clamped into `[-1, 1]`; non-finite reads as 0)
/// mapped linearly onto `[lo, hi]` and clamped there. The one definition the compiled
/// [`ActionBounds`], the runtime model and the trainer all use.
///
/// ```
/// use policy_core::bounds::scale_value;
/// assert_eq!(scale_value(1.0, -0.25, 0.25), 0.25);
/// assert_eq!(scale_value(f32::NAN, -0.25, 0.25), 0.0);
/// assert_eq!(scale_value(7.0, 0.0, 2.0), 2.0);
/// ```
#[inline]
pub fn scale_value(u: f32, lo: f32, hi: f32) -> f32 {
    let u = if u.is_finite() {
        u.clamp(-1.0, 1.0)
    } else {
        0.0
    };
    clamp(lo + (u + 1.0) * 0.5 * (hi - lo), lo, hi)
}

/// The rules loaded bounds obey (see [`ActionBounds::validate`]), over `low` and `high` in blob
/// order, so the compiled type and the runtime model check them in one place.
pub(crate) fn check(
    low: impl Iterator<Item = f32>,
    high: impl Iterator<Item = f32>,
) -> Result<(), Error> {
    for (index, (lo, hi)) in low.zip(high).enumerate() {
        let what = if !lo.is_finite() || !hi.is_finite() {
            "non-finite action bound"
        } else if inverted(lo, hi) {
            "action bound low > high"
        } else if too_wide(lo, hi) {
            "action bounds too wide for f32"
        } else {
            continue;
        };
        return Err(Error::InvalidParameter { what, index });
    }
    Ok(())
}

/// Whether the bounds rules are decided with integer arithmetic only (feature
/// `float-free-verify`).
///
/// The bounds rules are float rules, decided two ways with the same outcome for every pair of
/// finite values (tested): by the float expressions, or on the values' bits with integer
/// arithmetic only ([`above`], [`sum_overflows`]). A firmware that runs the integer entry and
/// links no float at all (firmware-m0) asks for the integer route: the float expressions linked
/// `__aeabi_fcmpgt`, `__aeabi_fsub` and `__aeabi_fadd` into its image, 508 B of its flash. Every
/// other build keeps the float expressions, which are smaller where float arithmetic is linked
/// anyway (the integer route added 590 to 660 B to the firmware of the M4F, the M3 and the
/// RV32, and 496 B to the C firmware on the M0).
const INTEGER_RULES: bool = cfg!(feature = "float-free-verify");

/// `lo > hi`, for finite values.
fn inverted(lo: f32, hi: f32) -> bool {
    if INTEGER_RULES {
        above(lo, hi)
    } else {
        lo > hi
    }
}

/// `hi - lo` or `hi + lo` not finite, for finite values.
fn too_wide(lo: f32, hi: f32) -> bool {
    if INTEGER_RULES {
        sum_overflows(hi, negated(lo)) || sum_overflows(hi, lo)
    } else {
        !(hi - lo).is_finite() || !(hi + lo).is_finite()
    }
}

/// `-x`, by its sign bit.
fn negated(x: f32) -> f32 {
    f32::from_bits(x.to_bits() ^ 0x8000_0000)
}

/// `a > b` for finite `a` and `b`, on their bits: sign and magnitude mapped to one signed
/// integer in the same order, `-0` and `+0` both to 0 (they are equal as floats).
fn above(a: f32, b: f32) -> bool {
    let key = |x: f32| {
        let bits = x.to_bits() as i32;
        if bits < 0 {
            -(bits & i32::MAX)
        } else {
            bits
        }
    };
    key(a) > key(b)
}

/// Whether `a + b` rounded to the nearest f32 overflows to ±∞, for finite `a` and `b`: exactly
/// when `|a + b| >= 2^128 - 2^103`, half-way between `f32::MAX` and `2^128` (a tie rounds to
/// `2^128`, whose significand is even, and so overflows). Decided on `floor(x / 2^73)` of each
/// value, in which that threshold is the integer `2^55 - 2^30`: the sum of the floors reaches it
/// exactly when the sum does, because only a value below `2^97` has a fraction there, and two
/// such values are far below the threshold.
fn sum_overflows(a: f32, b: f32) -> bool {
    const LIMIT: i64 = (1 << 55) - (1 << 30);
    floor_units(a) + floor_units(b) >= LIMIT
        || floor_units(negated(a)) + floor_units(negated(b)) >= LIMIT
}

/// `floor(x / 2^73)` for a finite `x`, exactly, below `2^55` in magnitude.
fn floor_units(x: f32) -> i64 {
    let bits = x.to_bits();
    let (biased, fraction) = ((bits >> 23) & 0xFF, bits & 0x7F_FFFF);
    // x = ±m · 2^(e - 150), the hidden bit in m for a normal number (e = 1 for a subnormal).
    let (m, e) = if biased == 0 {
        (fraction, 1)
    } else {
        (fraction | 0x80_0000, biased)
    };
    // x / 2^73 = ±m · 2^(e - 223).
    let (magnitude, exact) = if e >= 223 {
        (u64::from(m) << (e - 223), true)
    } else {
        let shift = 223 - e;
        let kept = m.checked_shr(shift).unwrap_or(0);
        (u64::from(kept), kept.checked_shl(shift).unwrap_or(0) == m)
    };
    if bits >> 31 == 1 {
        -(magnitude as i64) - i64::from(!exact)
    } else {
        magnitude as i64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The float rules the integer ones decide.
    fn reference(lo: f32, hi: f32) -> (bool, bool) {
        (lo > hi, !(hi - lo).is_finite() || !(hi + lo).is_finite())
    }

    fn integer(lo: f32, hi: f32) -> (bool, bool) {
        (
            above(lo, hi),
            sum_overflows(hi, negated(lo)) || sum_overflows(hi, lo),
        )
    }

    /// Finite floats spread over every binade, with the largest ones (where sums overflow) and
    /// the zeros and subnormals (where the order has its edge cases) drawn often.
    fn finite() -> impl Strategy<Value = f32> {
        let top = (0x7F00_0000u32..=0x7F7F_FFFF, any::<bool>())
            .prop_map(|(m, neg)| f32::from_bits(m | u32::from(neg) << 31));
        let small = (0u32..=0x0080_0000, any::<bool>())
            .prop_map(|(m, neg)| f32::from_bits(m | u32::from(neg) << 31));
        let any_finite = any::<u32>()
            .prop_map(f32::from_bits)
            .prop_filter("finite", |x| x.is_finite());
        prop_oneof![top, small, any_finite]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        #[test]
        fn integer_rules_match_the_float_rules(lo in finite(), hi in finite()) {
            prop_assert_eq!(integer(lo, hi), reference(lo, hi));
        }
    }

    /// The threshold itself: `MAX + MAX/2^24`-style ties, the largest sums that stay finite,
    /// and the zeros' order.
    #[test]
    fn the_edges_match_the_float_rules() {
        let max = f32::MAX;
        let ulp = f32::from_bits(0x7380_0000); // 2^104, the ulp of MAX
        let edges = [
            0.0,
            -0.0,
            f32::from_bits(1),
            -f32::from_bits(1),
            f32::MIN_POSITIVE,
            1.0,
            max,
            -max,
            max / 2.0,
            -max / 2.0,
            f32::from_bits(0x7F00_0000), // 2^127
            -f32::from_bits(0x7F00_0000),
            ulp,
            ulp / 2.0, // 2^103: MAX + 2^103 is the tie
            -ulp / 2.0,
            f32::from_bits(0x7F7F_FFFE),
            f32::from_bits(0x7EFF_FFFF),
            -f32::from_bits(0x7EFF_FFFF),
            f32::from_bits(0x5000_0000),
        ];
        for &lo in &edges {
            for &hi in &edges {
                assert_eq!(integer(lo, hi), reference(lo, hi), "lo {lo:e} hi {hi:e}");
            }
        }
    }
}
