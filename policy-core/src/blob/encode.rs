//! Re-encoding a verified f32 blob into another weight [`Encoding`] (host side).

use super::params::{check_parameters, values};
use super::read::verify;
use super::write::to_vec_with;
use crate::error::Error;
use crate::format::{Encoding, Spec};

/// The blob `bytes` (f32 weights) with its weights stored in `encoding` instead (host side): the
/// same kind, shape, activation, label, normaliser, bounds, action table and biases; [`write()`](super::write())
/// converts the weights (f16: nearest, ties to even; int8: one scale per output, max |w| / 127,
/// `q = round(w / scale)`). Deterministic: the same f32 blob gives the same bytes. A blob that is
/// already quantised is [`Error::WrongEncoding`] (quantising twice compounds the rounding). The
/// one definition behind `host-trainer export --encoding` and the firmware check's `encode`.
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
    let verified = verify(bytes)?;
    check_parameters(&verified.header, verified.payload)?;
    let h = &verified.header;
    if h.encoding != Encoding::F32 {
        return Err(Error::WrongEncoding {
            expected: Encoding::F32,
            found: h.encoding,
        });
    }
    let params: std::vec::Vec<f32> = values(h, verified.payload).collect();
    let out = to_vec_with(&Spec::like(h, encoding), &mut |sink| sink(&params))?;
    let written = verify(&out)?;
    check_parameters(&written.header, written.payload)?;
    Ok(out)
}
