//! Re-encoding a verified f32 blob into another weight [`Encoding`] (host side).

use super::params::{check_parameters, values};
use super::read::verify;
use super::write::to_vec_with;
use crate::error::Error;
use crate::format::{Encoding, Header, Spec};

/// The blob `bytes` (f32 weights) with its weights stored in `encoding` instead (host side): the
/// same kind, shape, activation, label, normaliser, bounds, action table and biases; [`write()`](super::write())
/// converts the weights (f16: nearest, ties to even; int8: one scale per output, max |w| / 127,
/// `q = round(w / scale)`). Deterministic: the same f32 blob gives the same bytes. A blob that is
/// already quantised is [`Error::WrongEncoding`] (quantising twice compounds the rounding), and
/// [`Encoding::Integer`] is [`Error::Calibration`]: it needs observations ([`encode_integer`]).
/// The one definition behind `host-trainer export --encoding` and the firmware check's `encode`.
///
/// ```
/// use policy_core::{blob, model::Model, Encoding};
/// static F32: &[u8] = include_bytes!("../../tests/golden/actor_4x48.postcard");
/// let int8 = blob::encode(F32, Encoding::Int8).unwrap();
/// assert!(int8.len() < F32.len() / 3);
/// assert_eq!(Model::from_blob(&int8).unwrap().header().encoding, Encoding::Int8);
/// assert_eq!(blob::encode(F32, Encoding::F32).unwrap(), F32);
/// assert!(blob::encode(&int8, Encoding::F16).is_err());
/// ```
pub fn encode(bytes: &[u8], encoding: Encoding) -> Result<std::vec::Vec<u8>, Error> {
    let (h, params) = f32_source(bytes)?;
    let out = to_vec_with(&Spec::like(&h, encoding), &mut |sink| sink(&params))?;
    check_written(&out)?;
    Ok(out)
}

/// The actor blob `bytes` (f32 weights) in the [`Encoding::Integer`] encoding, quantised with
/// the ranges [`calibrate`](super::calibrate) measures on `observations` (flattened), then verified. The same
/// kind, shape, activation, label, normaliser and bounds. Deterministic: the same blob and
/// observations give the same bytes. The one definition behind `host-trainer export --encoding
/// integer`.
///
/// ```
/// use policy_core::{blob, model::Model, Encoding};
/// static F32: &[u8] = include_bytes!("../../tests/golden/actor_4x48.postcard");
/// let int = blob::encode_integer(F32, &[4.0, -2.5, 0.0, 0.0, -5.0, 5.0]).unwrap();
/// assert_eq!(Model::from_blob(&int).unwrap().header().encoding, Encoding::Integer);
/// assert!(int.len() < F32.len() / 2); // 10,252 bytes beside 29,272 (tanh: five tables)
/// ```
pub fn encode_integer(bytes: &[u8], observations: &[f32]) -> Result<std::vec::Vec<u8>, Error> {
    let (h, params) = f32_source(bytes)?;
    let ranges = super::calibrate(bytes, observations)?;
    let spec = Spec::like(&h, Encoding::Integer);
    let mut out = std::vec![0u8; super::write::encoded_len(&spec)?];
    let n = super::write_integer(&spec, &ranges, &mut |sink| sink(&params), &mut out)?;
    out.truncate(n);
    check_written(&out)?;
    Ok(out)
}

/// The header and parameters of `bytes`, verified, which must be an f32 blob: what both
/// re-encodings start from.
fn f32_source(bytes: &[u8]) -> Result<(Header, std::vec::Vec<f32>), Error> {
    let verified = verify(bytes)?;
    check_parameters(&verified.header, verified.payload)?;
    let h = verified.header;
    if h.encoding != Encoding::F32 {
        return Err(Error::WrongEncoding {
            expected: Encoding::F32,
            found: h.encoding,
        });
    }
    let params = values(&h, verified.payload).collect();
    Ok((h, params))
}

/// Loads a re-encoded blob as a chip would: a writer's mistake is an error, never a bad blob.
fn check_written(out: &[u8]) -> Result<(), Error> {
    let written = verify(out)?;
    check_parameters(&written.header, written.payload)
}
