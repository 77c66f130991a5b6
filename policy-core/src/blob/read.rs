//! Reading a blob: [`verify`] checks magic, version (version 1 included), header, that this
//! build reads the blob's weight encoding (its cargo feature), limits, length, padding and
//! checksum, without knowing the shape in advance; the parameter rules
//! come after it, in `params.rs`.

use super::header;
use crate::crc32::crc32;
use crate::error::Error;
use crate::format::{
    padded_header_len, Encoding, Header, ModelKind, CRC_LEN, MAGIC, MAX_PAYLOAD_LEN,
};

/// A header and the payload bytes it describes, after the length and checksum checks.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Verified<'a> {
    /// The decoded header.
    pub header: Header,
    /// The payload bytes (`header.payload_len` of them).
    pub payload: &'a [u8],
}

/// Decodes and checks a blob's header, length and checksum without knowing its shape.
///
/// A loader that supports several compiled shapes reads the header with this, picks the type
/// that matches `header.shape`, then loads into it.
///
/// ```
/// use policy_core::{blob, ModelKind, Policy};
/// let policy = Policy::<2, 32, 1, 2>::ZERO;
/// let mut buf = [0u8; 8192];
/// let n = policy.write_blob("demo", &mut buf).unwrap();
/// let v = blob::verify(&buf[..n]).unwrap();
/// assert_eq!(v.header.kind, ModelKind::Actor);
/// assert_eq!((v.header.shape.depth, v.header.shape.width), (2, 32));
/// assert_eq!(v.header.label.as_str(), "demo");
/// ```
pub fn verify(bytes: &[u8]) -> Result<Verified<'_>, Error> {
    let Some((magic, _)) = bytes.split_first_chunk::<4>() else {
        return Err(Error::Truncated {
            needed: MAGIC.len(),
            found: bytes.len(),
        });
    };
    if *magic != MAGIC {
        return Err(Error::WrongMagic { found: *magic });
    }
    let (header, encoded_len) = header::decode(bytes)?;
    if header.version != 1 && header.encoding.version() != header.version {
        return Err(Error::Malformed {
            // Short: every byte of a message is flash on the chip; the format page gives the pairs.
            what: "encoding does not match the format version",
        });
    }
    // Gated: a build without the integer encoding refuses such a blob just below.
    if cfg!(feature = "integer")
        && header.encoding == Encoding::Integer
        && header.kind != ModelKind::Actor
    {
        return Err(Error::Malformed {
            what: "the integer encoding holds actors only",
        });
    }
    // Before any check that depends on the encoding: the rest of the crate may assume every
    // blob it meets has an encoding compiled in.
    if !header.encoding.is_compiled() {
        return Err(Error::EncodingNotCompiled {
            found: header.encoding,
        });
    }
    header.shape.check(header.kind)?;
    let payload_len = checked_payload_len(&header)?;
    let header_len = padded_header_len(header.version, encoded_len);
    // Checked: on a 32-bit chip a hostile `payload_len` near `u32::MAX` must not wrap.
    let total = header_len
        .checked_add(payload_len)
        .and_then(|n| n.checked_add(CRC_LEN))
        .ok_or(Error::Malformed {
            what: "payload length does not fit in memory",
        })?;
    if bytes.len() < total {
        return Err(Error::Truncated {
            needed: total,
            found: bytes.len(),
        });
    }
    if bytes.len() > total {
        return Err(Error::TrailingBytes {
            expected: total,
            found: bytes.len(),
        });
    }
    let Some((body, crc)) = bytes.split_last_chunk::<CRC_LEN>() else {
        return Err(Error::Truncated {
            needed: total,
            found: bytes.len(),
        });
    };
    if body
        .get(encoded_len..header_len)
        .is_some_and(|pad| pad.iter().any(|&b| b != 0))
    {
        return Err(Error::Malformed {
            what: "padding after the header is not zero",
        });
    }
    let stored = u32::from_le_bytes(*crc);
    let computed = crc32(body);
    if stored != computed {
        return Err(Error::ChecksumMismatch { stored, computed });
    }
    let payload = body.get(header_len..).unwrap_or_default();
    Ok(Verified { header, payload })
}

/// The header's payload length, after checking it is the one its kind, shape and encoding imply.
fn checked_payload_len(header: &Header) -> Result<usize, Error> {
    let expected = header
        .shape
        .payload_len_for(header.kind, header.encoding, header.activation);
    if expected.is_none() {
        return Err(Error::Malformed {
            what: "shape has no hidden layer or is too large",
        });
    }
    if expected.is_some_and(|n| n > MAX_PAYLOAD_LEN) {
        return Err(Error::Malformed {
            what: "payload larger than the format's 16 MiB maximum",
        });
    }
    let found = usize::try_from(header.payload_len).ok();
    if expected != found {
        return Err(Error::Malformed {
            what: "payload length does not match the shape and encoding",
        });
    }
    found.ok_or(Error::Malformed {
        what: "payload length does not fit in memory",
    })
}

/// The `f32` parameters of a payload, decoded from their 4-byte little-endian postcard encoding.
///
/// ```
/// use policy_core::blob;
/// static BLOB: &[u8] = include_bytes!("../../tests/golden/actor_2x32.postcard");
/// let v = blob::verify(BLOB).unwrap();
/// let clip = blob::payload_values(v.payload).nth(4).unwrap(); // after mean[2], inv_std[2]
/// assert_eq!(clip, 5.0);
/// ```
pub fn payload_values(payload: &[u8]) -> impl Iterator<Item = f32> + '_ {
    // Each chunk has 4 bytes, so the 0.0 never happens; indexing `c[0]`..`c[3]` instead gave the
    // closure, where LLVM keeps it out of line, bounds checks and a panic path (about 1.3 KB of
    // a firmware at opt-level "z"). `as_chunks` would say it directly, but is newer than the MSRV.
    payload
        .chunks_exact(4)
        .map(|c| <[u8; 4]>::try_from(c).map_or(0.0, f32::from_le_bytes))
}
