//! Measuring the ranges an integer blob is quantised with ([`write_integer`](super::write_integer)):
//! run the float actor on observations the policy meets and note, per range, the smallest and
//! largest value seen (host side; no allocation, so a test of a `no_std` build can call it).

use crate::error::Error;
use crate::model::Model;

/// Widens `ranges` (one per range: `depth + 2`, start them at `(+∞, −∞)`) with what the actor
/// `model` (f32, f16 or int8) computes on `observations` (flattened: one observation after
/// another): first the normalised observations, then each layer's outputs before the
/// activation. `scratch` is the model's slice scratch ([`Model::scratch_floats`] floats).
///
/// A NaN or infinite observation component is [`Error::Calibration`] with the observation's
/// index (the runtime reads such a component as the mean, which says nothing about the range),
/// and so is a non-finite pre-activation, an observation count that is not a multiple of the
/// blob's observation size, or no observation at all.
///
/// ```
/// use policy_core::{blob, model::Model};
/// static F32: &[u8] = include_bytes!("../../tests/golden/actor_4x48.postcard");
/// let model = Model::from_blob(F32).unwrap();
/// let mut ranges = [(f32::INFINITY, f32::NEG_INFINITY); 6]; // input, 4 hidden, output
/// blob::calibrate_into(&model, &[4.0, -2.5, 0.0, 0.0], &mut [0.0; 96], &mut ranges).unwrap();
/// assert!(ranges.iter().all(|(lo, hi)| lo <= hi));
/// let nan = blob::calibrate_into(&model, &[f32::NAN, 0.0], &mut [0.0; 96], &mut ranges);
/// assert!(matches!(nan, Err(policy_core::Error::Calibration { index: 0, .. })));
/// ```
pub fn calibrate_into(
    model: &Model<'_>,
    observations: &[f32],
    scratch: &mut [f32],
    ranges: &mut [(f32, f32)],
) -> Result<(), Error> {
    let s = usize::from(model.header().shape.observations);
    if observations.is_empty() || observations.len() % s != 0 {
        return Err(Error::Calibration {
            what:
                "the observations are not a non-empty whole number of the blob's observation size",
            index: observations.len(),
        });
    }
    for (n, obs) in observations.chunks_exact(s).enumerate() {
        if obs.iter().any(|v| !v.is_finite()) {
            return Err(Error::Calibration {
                what: "a NaN or infinite observation in the calibration data",
                index: n,
            });
        }
        let mut finite = true;
        model.pre_activations_in(obs, scratch, &mut |l, values| {
            if let Some((lo, hi)) = ranges.get_mut(l) {
                for &v in values {
                    finite &= v.is_finite();
                    (*lo, *hi) = (lo.min(v), hi.max(v));
                }
            }
        })?;
        if !finite {
            return Err(Error::Calibration {
                what: "a layer's output is NaN or infinite for this observation",
                index: n,
            });
        }
    }
    Ok(())
}

/// [`calibrate_into`] on the actor blob `bytes`, into new ranges (host side).
///
/// ```
/// use policy_core::blob;
/// static F32: &[u8] = include_bytes!("../../tests/golden/actor_4x48.postcard");
/// let ranges = blob::calibrate(F32, &[4.0, -2.5, 0.0, 0.0]).unwrap();
/// assert_eq!(ranges.len(), 6); // the input, four hidden layers, the output
/// assert!(blob::calibrate(F32, &[f32::NAN, 0.0]).is_err());
/// ```
#[cfg(feature = "std")]
pub fn calibrate(bytes: &[u8], observations: &[f32]) -> Result<std::vec::Vec<(f32, f32)>, Error> {
    let model = Model::from_blob(bytes)?;
    let depth = usize::from(model.header().shape.depth);
    let mut ranges = std::vec![(f32::INFINITY, f32::NEG_INFINITY); depth + 2];
    let mut scratch = std::vec![0.0f32; model.scratch_floats()];
    calibrate_into(&model, observations, &mut scratch, &mut ranges)?;
    Ok(ranges)
}
