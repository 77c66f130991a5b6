//! Observation normalisation, frozen at export: `z = clip((x - mean) * inv_std)`.

use nalgebra::{ArrayStorage, SVector};

use crate::clamp::clamp;
use crate::error::Error;

/// Per-dimension affine normalisation of observations, clipped to `[-clip, clip]`.
///
/// A non-finite observation component (a sensor dropout reported as NaN or ±Inf) is replaced by
/// the mean, i.e. it normalises to exactly 0: the network sees "no information" on that input
/// rather than an extreme value, and nothing non-finite ever enters the forward pass.
#[derive(Clone, Debug, PartialEq)]
pub struct Normalizer<const S: usize> {
    /// Mean subtracted from each observation component.
    pub mean: SVector<f32, S>,
    /// Reciprocal of the standard deviation of each component (`>= 0`).
    pub inv_std: SVector<f32, S>,
    /// Normalised values are clipped to `[-clip, clip]` (`> 0`).
    pub clip: f32,
}

impl<const S: usize> Normalizer<S> {
    /// Maps every observation to zero; the state of a slot before a blob is loaded.
    pub const ZERO: Self = Self {
        mean: SVector::from_array_storage(ArrayStorage([[0.0; S]; 1])),
        inv_std: SVector::from_array_storage(ArrayStorage([[0.0; S]; 1])),
        clip: 0.0,
    };

    /// The identity normaliser (mean 0, inverse std 1) with the given clip.
    ///
    /// ```
    /// use policy_core::Normalizer;
    /// let n = Normalizer::<2>::identity(5.0);
    /// let z = n.normalize(&[1.0, 9.0]);
    /// assert_eq!(z.as_slice(), &[1.0, 5.0]);
    /// ```
    pub fn identity(clip: f32) -> Self {
        Self {
            mean: SVector::zeros(),
            inv_std: SVector::repeat(1.0),
            clip,
        }
    }

    /// Normalises one observation; the result is always finite and inside `[-clip, clip]`.
    ///
    /// ```
    /// use policy_core::Normalizer;
    /// let n = Normalizer::<2>::identity(5.0);
    /// let z = n.normalize(&[f32::NAN, f32::NEG_INFINITY]);
    /// assert_eq!(z.as_slice(), &[0.0, 0.0]);
    /// ```
    #[inline]
    pub fn normalize(&self, obs: &[f32; S]) -> SVector<f32, S> {
        let mut z = SVector::<f32, S>::zeros();
        for (((zi, &x), &m), &k) in z.iter_mut().zip(obs).zip(&self.mean).zip(&self.inv_std) {
            *zi = normalize_value(x, m, k, self.clip);
        }
        z
    }

    /// Checks the rules a loaded normaliser obeys: every value finite, `inv_std >= 0`,
    /// `clip > 0`. The loader calls it; a host building a normaliser by hand may too.
    ///
    /// ```
    /// use policy_core::{Error, Normalizer};
    /// assert_eq!(Normalizer::<2>::identity(5.0).validate(), Ok(()));
    /// assert!(matches!(Normalizer::<2>::ZERO.validate(), Err(Error::InvalidParameter { .. })));
    /// ```
    pub fn validate(&self) -> Result<(), Error> {
        check(
            self.mean.iter().copied(),
            self.inv_std.iter().copied(),
            self.clip,
        )
    }

    /// Visits the parameters in blob order: mean, inverse std, clip.
    pub fn params(&self) -> [&[f32]; 3] {
        [
            self.mean.as_slice(),
            self.inv_std.as_slice(),
            core::slice::from_ref(&self.clip),
        ]
    }

    /// Mutable parameters, in the order of [`Normalizer::params`].
    pub fn params_mut(&mut self) -> [&mut [f32]; 3] {
        [
            self.mean.as_mut_slice(),
            self.inv_std.as_mut_slice(),
            core::slice::from_mut(&mut self.clip),
        ]
    }
}

/// One normalised component: `clip((x - mean) * inv_std)`. A non-finite input, or 0 × ∞ after an
/// overflowing subtraction, carries no information: it becomes the mean (0). This is the one
/// definition the compiled [`Normalizer`], the runtime model and the trainer all use.
///
/// ```
/// use policy_core::normalizer::normalize_value;
/// assert_eq!(normalize_value(3.0, 1.0, 0.5, 5.0), 1.0);
/// assert_eq!(normalize_value(1e9, 0.0, 1.0, 5.0), 5.0);
/// assert_eq!(normalize_value(f32::NAN, 0.0, 1.0, 5.0), 0.0);
/// ```
#[inline]
pub fn normalize_value(x: f32, mean: f32, inv_std: f32, clip: f32) -> f32 {
    let v = (x - mean) * inv_std;
    if !x.is_finite() || v.is_nan() {
        0.0
    } else {
        clamp(v, -clip, clip)
    }
}

/// The rules a loaded normaliser obeys (see [`Normalizer::validate`]), over its values in blob
/// order, so the compiled type and the runtime model check them in one place.
pub(crate) fn check(
    mean: impl Iterator<Item = f32>,
    inv_std: impl Iterator<Item = f32>,
    clip: f32,
) -> Result<(), Error> {
    if let Some(index) = mean.into_iter().position(|m| !m.is_finite()) {
        return Err(Error::InvalidParameter {
            what: "non-finite observation mean",
            index,
        });
    }
    // `!(k >= 0)` also rejects NaN.
    if let Some(index) = inv_std
        .into_iter()
        .position(|k| !(k >= 0.0 && k.is_finite()))
    {
        return Err(Error::InvalidParameter {
            what: "inverse standard deviation must be finite and >= 0",
            index,
        });
    }
    if !(clip > 0.0 && clip.is_finite()) {
        return Err(Error::InvalidParameter {
            what: "normaliser clip must be finite and > 0",
            index: 0,
        });
    }
    Ok(())
}
