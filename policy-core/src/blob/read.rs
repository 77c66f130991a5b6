//! Reading a blob: [`verify`] checks magic, version (version 1 included), header, that this
//! build reads the blob's weight encoding (its cargo feature), limits, length, padding and
//! checksum, without knowing the shape in advance; the parameter rules
//! come after it, in `params.rs`.

use heapless::String;
use serde::{Deserialize, Serialize};

use crate::crc32::crc32;
use crate::error::Error;
use crate::format::{
    padded_header_len, Encoding, Header, ModelKind, Shape, CRC_LEN, LABEL_CAPACITY, MAGIC,
    MAX_PAYLOAD_LEN, VERSION, VERSION_QUANTISED,
};
use crate::mlp::activation::Activation;

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
    let Some((magic, after_magic)) = bytes.split_first_chunk::<4>() else {
        return Err(Error::Truncated {
            needed: MAGIC.len(),
            found: bytes.len(),
        });
    };
    if *magic != MAGIC {
        return Err(Error::WrongMagic { found: *magic });
    }
    // The version is read on its own first so that a future format whose header differs is
    // reported as a version problem, not as garbage.
    let (version, _) = postcard::take_from_bytes::<u16>(after_magic).map_err(header_error)?;
    let (header, rest) = match version {
        1 => {
            let (v1, rest) = postcard::take_from_bytes::<HeaderV1>(bytes).map_err(header_error)?;
            check_canonical(&v1, bytes, rest)?;
            (v1.into_current()?, rest)
        }
        VERSION | VERSION_QUANTISED => {
            let (header, rest) =
                postcard::take_from_bytes::<Header>(bytes).map_err(header_error)?;
            check_canonical(&header, bytes, rest)?;
            (header, rest)
        }
        found => {
            return Err(Error::UnsupportedVersion {
                supported: VERSION_QUANTISED,
                found,
            })
        }
    };
    if header.version != 1 && header.encoding.version() != header.version {
        return Err(Error::Malformed {
            what: "encoding does not match the format version (f32: 2, f16 and int8: 3)",
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
    let encoded_len = bytes.len() - rest.len();
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

/// Refuses a header that is not byte for byte postcard's encoding of its own values: postcard
/// decodes a varint padded with extra `0x80` groups (a version written `82 00`, a 5-byte enum
/// value), so without this one model would have many headers and the header's size would have
/// no bound. Re-encoding the decoded header and comparing the bytes holds every field to the
/// shortest form the writer emits, whatever field a future version adds.
fn check_canonical<T: Serialize>(decoded: &T, bytes: &[u8], rest: &[u8]) -> Result<(), Error> {
    let stored = bytes.get(..bytes.len() - rest.len()).unwrap_or_default();
    // The longest encoding of any header value: magic 4, varints 3 + 5 + 5 + 3 + 3 + 3, depth 1,
    // choices 3, activation 5, label 1 + 32, payload length 5 = 73 bytes.
    let mut buf = [0u8; 80];
    let canonical = postcard::to_slice(decoded, &mut buf).map_err(|_| Error::Malformed {
        what: "header cannot be re-encoded",
    })?;
    if *canonical != *stored {
        return Err(Error::Malformed {
            what: "header is not in canonical form (a varint longer than its shortest encoding)",
        });
    }
    Ok(())
}

/// The version-1 header: no encoding field (always f32) and no `choices` in the shape.
#[derive(Serialize, Deserialize)]
struct HeaderV1 {
    magic: [u8; 4],
    version: u16,
    kind: ModelKind,
    shape: ShapeV1,
    activation: Activation,
    label: String<LABEL_CAPACITY>,
    payload_len: u32,
}

#[derive(Serialize, Deserialize)]
struct ShapeV1 {
    observations: u16,
    actions: u16,
    width: u16,
    depth: u8,
}

impl HeaderV1 {
    fn into_current(self) -> Result<Header, Error> {
        if self.kind == ModelKind::Discrete {
            // Version 1 knew two kinds; the third enum value was invalid then.
            return Err(Error::Malformed {
                what: "unknown kind or activation",
            });
        }
        Ok(Header {
            magic: self.magic,
            version: self.version,
            kind: self.kind,
            encoding: Encoding::F32,
            shape: Shape {
                observations: self.shape.observations,
                actions: self.shape.actions,
                width: self.shape.width,
                depth: self.shape.depth,
                choices: 0,
            },
            activation: self.activation,
            label: self.label,
            payload_len: self.payload_len,
        })
    }
}

/// The header's payload length, after checking it is the one its kind, shape and encoding imply.
fn checked_payload_len(header: &Header) -> Result<usize, Error> {
    let expected = header.shape.payload_len_in(header.kind, header.encoding);
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

fn header_error(e: postcard::Error) -> Error {
    match e {
        postcard::Error::DeserializeUnexpectedEnd => Error::Malformed {
            what: "header ends early (truncated blob)",
        },
        postcard::Error::DeserializeBadEnum => Error::Malformed {
            what: "unknown kind or activation",
        },
        postcard::Error::DeserializeBadUtf8 => Error::Malformed {
            what: "label is not UTF-8",
        },
        _ => Error::Malformed {
            what: "header fields cannot be decoded",
        },
    }
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
    payload
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
}
