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
        } else if lo > hi {
            "action bound low > high"
        } else if !(hi - lo).is_finite() || !(hi + lo).is_finite() {
            "action bounds too wide for f32"
        } else {
            continue;
        };
        return Err(Error::InvalidParameter { what, index });
    }
    Ok(())
}
