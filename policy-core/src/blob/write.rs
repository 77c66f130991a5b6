//! Writing a blob from its [`Spec`] and its parameters in blob order: header, padding, payload
//! (f32 as it is, or quantised by `quantise.rs`), CRC.

use heapless::String;

use super::quantise::quantise;
use crate::crc32::crc32;
use crate::error::Error;
use crate::format::{
    padded_header_len, Encoding, Header, Params, Spec, CRC_LEN, MAGIC, MAX_HEADER_LEN,
    MAX_PAYLOAD_LEN,
};

impl Spec<'_> {
    fn header(&self) -> Result<Header, Error> {
        self.shape.check(self.kind)?;
        let label = String::try_from(self.label).map_err(|_| Error::Malformed {
            what: "label longer than 32 bytes",
        })?;
        let payload_len = self
            .shape
            .payload_len_for(self.kind, self.encoding, self.activation)
            .filter(|&n| n <= MAX_PAYLOAD_LEN)
            .and_then(|n| u32::try_from(n).ok())
            .ok_or(Error::Malformed {
                what: "payload larger than the format's 16 MiB maximum",
            })?;
        Ok(Header {
            magic: MAGIC,
            version: self.encoding.version(),
            kind: self.kind,
            encoding: self.encoding,
            shape: self.shape,
            activation: self.activation,
            label,
            payload_len,
        })
    }
}

/// Bytes the blob of `spec` occupies: header, padding, payload, CRC.
///
/// ```
/// use policy_core::{blob::{self, Spec}, Activation, Encoding, ModelKind, Shape};
/// let shape = Shape { observations: 2, actions: 2, width: 48, depth: 4, choices: 0 };
/// let spec = Spec { kind: ModelKind::Actor, encoding: Encoding::F32, shape, activation: Activation::Relu, label: "nav" };
/// // 20-byte header (3-byte label; already a multiple of 4), 7307 parameters, CRC
/// assert_eq!(blob::encoded_len(&spec).unwrap(), 20 + 4 * 7307 + 4);
/// ```
pub fn encoded_len(spec: &Spec<'_>) -> Result<usize, Error> {
    let header = spec.header()?;
    let mut scratch = [0u8; MAX_HEADER_LEN];
    let encoded = postcard::to_slice(&header, &mut scratch)
        .map_err(|_| Error::Malformed {
            what: "header cannot be encoded",
        })?
        .len();
    Ok(padded_header_len(header.version, encoded) + header.payload_len as usize + CRC_LEN)
}

/// Writes a blob into `out` from its spec and its parameters in blob order (`params` calls its
/// argument with slices that together hold exactly the shape's parameter count); returns the
/// number of bytes written. Only `out[..n]` is written. The runtime shape needs no compiled type.
///
/// ```
/// use policy_core::{blob::{self, Spec}, model::Model, Activation, Encoding, ModelKind, Shape};
/// let shape = Shape { observations: 1, actions: 1, width: 2, depth: 1, choices: 0 };
/// let spec = Spec { kind: ModelKind::Actor, encoding: Encoding::F32, shape, activation: Activation::Tanh, label: "x" };
/// // normaliser (mean, inv_std, clip), bounds (low, high), layer 1 (2 + 2), output (2 + 1)
/// let params = [0.0, 1.0, 5.0, -1.0, 1.0, 0.5, -0.5, 0.0, 0.0, 1.0, 1.0, 0.0];
/// let mut out = [0u8; 128];
/// let n = blob::write(&spec, &mut |sink| sink(&params), &mut out).unwrap();
/// assert_eq!(n, 16 + 4 * 12 + 4);
/// let model = Model::from_blob(&out[..n]).unwrap();
/// assert_eq!(model.header().shape, shape);
/// ```
pub fn write(spec: &Spec<'_>, params: &mut Params<'_>, out: &mut [u8]) -> Result<usize, Error> {
    if spec.encoding == Encoding::Integer {
        return Err(Error::Calibration {
            what: "the integer encoding needs the activations' ranges: write it with blob::write_integer",
            index: 0,
        });
    }
    let (needed, header_len) = header_into(spec, out)?;
    let too_small = Error::BufferTooSmall {
        needed,
        found: out.len(),
    };
    let out = out.get_mut(..needed).ok_or(too_small)?;
    let (body, crc) = out.split_last_chunk_mut::<CRC_LEN>().ok_or(too_small)?;
    if spec.encoding != Encoding::F32 {
        quantise(spec, params, body.get_mut(header_len..).unwrap_or_default())?;
        *crc = crc32(body).to_le_bytes();
        return Ok(needed);
    }
    let mut slots = body
        .get_mut(header_len..)
        .unwrap_or_default()
        .chunks_exact_mut(4);
    let mut written = 0usize;
    params(&mut |src| {
        // `src` first: `zip` polls its left side first, so an exhausted `src` must not cost
        // a slot.
        for (v, dst) in src.iter().zip(&mut slots) {
            dst.copy_from_slice(&v.to_le_bytes());
            written += 1;
        }
    });
    if slots.next().is_some() || Some(written) != spec.shape.param_count(spec.kind) {
        return Err(Error::Malformed {
            what: "parameters do not match the declared shape",
        });
    }
    *crc = crc32(body).to_le_bytes();
    Ok(needed)
}

/// Writes the header of `spec` and its zero padding at the start of `out`, after checking that
/// `out` holds the whole blob; returns the blob's length and the payload's offset.
pub(super) fn header_into(spec: &Spec<'_>, out: &mut [u8]) -> Result<(usize, usize), Error> {
    let needed = encoded_len(spec)?;
    let header = spec.header()?;
    let found = out.len();
    let out = out
        .get_mut(..needed)
        .ok_or(Error::BufferTooSmall { needed, found })?;
    let encoded = postcard::to_slice(&header, out)
        .map_err(|_| Error::Malformed {
            what: "header cannot be encoded",
        })?
        .len();
    let header_len = padded_header_len(header.version, encoded);
    out.get_mut(encoded..header_len).unwrap_or_default().fill(0);
    Ok((needed, header_len))
}

/// [`write()`] into a new vector (host side).
#[cfg(feature = "std")]
pub fn to_vec_with(spec: &Spec<'_>, params: &mut Params<'_>) -> Result<std::vec::Vec<u8>, Error> {
    let mut out = std::vec![0u8; encoded_len(spec)?];
    let n = write(spec, params, &mut out)?;
    out.truncate(n);
    Ok(out)
}
