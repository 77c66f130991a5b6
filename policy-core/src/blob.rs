//! The weight-blob format: one definition, used by the loader on the chip and the writer on the
//! host. `docs/blob-format.md` specifies it byte by byte.
//!
//! ```text
//! blob    = header payload crc
//! header  = postcard(Header)            magic "DCPB", version, kind, shape, activation,
//!                                       label, payload length in bytes
//! payload = postcard((f32, f32, ...))   every parameter, 4 bytes little-endian each
//! crc     = u32 little-endian           CRC-32/ISO-HDLC of header and payload
//! ```
//!
//! Loading checks, in order: magic, version, header, length, checksum, kind, shape, finite
//! values, parameter rules; it then copies the parameters into the caller's slot. Nothing is
//! written to the slot unless every check passed.

use heapless::String;
use serde::{Deserialize, Serialize};

use crate::{crc32, Activation, Error};

/// The four bytes every blob starts with.
pub const MAGIC: [u8; 4] = *b"DCPB";
/// The format version this build reads and writes.
pub const VERSION: u16 = 1;
/// Capacity of the free-text label in the header, in bytes.
pub const LABEL_CAPACITY: usize = 32;
/// Bytes of the trailing checksum.
pub const CRC_LEN: usize = 4;
/// The largest encoded header: magic 4, version 3, kind 1, shape 10, activation 1, label 33,
/// payload length 5 (postcard varints at their widest).
pub const MAX_HEADER_LEN: usize = 57;
/// The largest payload the format allows: 16 MiB, four million `f32` parameters, far above any
/// network a microcontroller can hold. A header declaring more is malformed, so a reader can
/// refuse an oversized file before reading it whole.
pub const MAX_PAYLOAD_LEN: usize = 16 << 20;
/// The largest blob the format allows: the widest header, [`MAX_PAYLOAD_LEN`] and the CRC.
pub const MAX_BLOB_LEN: usize = MAX_HEADER_LEN + MAX_PAYLOAD_LEN + CRC_LEN;

/// What a blob holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ModelKind {
    /// A policy: normaliser, actor network, action bounds.
    Actor,
    /// A critic Q(s, a): normaliser and Q network.
    Critic,
}

impl core::fmt::Display for ModelKind {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            ModelKind::Actor => "actor",
            ModelKind::Critic => "critic",
        })
    }
}

/// The sizes of a network, as the blob names them and as the compiled types fix them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shape {
    /// Observation size.
    pub observations: u16,
    /// Action size.
    pub actions: u16,
    /// Hidden width.
    pub width: u16,
    /// Number of hidden layers (the paper's "4" in 4×48).
    pub depth: u8,
}

impl Shape {
    /// Number of `f32` parameters a model of this kind and shape stores, or `None` if it does
    /// not fit in `usize`.
    ///
    /// ```
    /// use policy_core::{ModelKind, Shape};
    /// let s = Shape { observations: 2, actions: 2, width: 48, depth: 4 };
    /// // normaliser 2+2+1, bounds 2+2, layers 2*48+48 + 3*(48*48+48) + 48*2+2
    /// assert_eq!(s.param_count(ModelKind::Actor), Some(9 + 144 + 7056 + 98));
    /// ```
    pub fn param_count(&self, kind: ModelKind) -> Option<usize> {
        let (s, a, h) = (
            self.observations as usize,
            self.actions as usize,
            self.width as usize,
        );
        let hidden_layers = (self.depth as usize).checked_sub(1)?;
        // Checked throughout: on a 16-bit target even `2 * s` can overflow.
        let (inputs, outputs, bounds) = match kind {
            ModelKind::Actor => (s, a, a.checked_mul(2)?),
            ModelKind::Critic => (s.checked_add(a)?, 1, 0),
        };
        let normalizer = s.checked_mul(2)?.checked_add(1)?;
        let first = inputs.checked_mul(h)?.checked_add(h)?;
        let hidden = h
            .checked_mul(h)?
            .checked_add(h)?
            .checked_mul(hidden_layers)?;
        let output = h.checked_mul(outputs)?.checked_add(outputs)?;
        normalizer
            .checked_add(bounds)?
            .checked_add(first)?
            .checked_add(hidden)?
            .checked_add(output)
    }

    /// The shape of a compiled model; used only in `const` items, where an assertion failure is
    /// a compile error: a type whose sizes do not fit the header's fields cannot be built, so it
    /// can never be confused with a smaller shape after truncation.
    pub(crate) const fn compiled(s: usize, a: usize, h: usize, hidden_to_hidden: usize) -> Shape {
        let max16 = u16::MAX as usize;
        assert!(
            s <= max16 && a <= max16 && h <= max16,
            "sizes must fit in u16"
        );
        assert!(hidden_to_hidden < u8::MAX as usize, "depth must fit in u8");
        Shape {
            observations: s as u16,
            actions: a as u16,
            width: h as u16,
            depth: (hidden_to_hidden + 1) as u8,
        }
    }

    /// Bytes of the payload (4 per parameter).
    ///
    /// ```
    /// use policy_core::{ModelKind, Shape};
    /// let s = Shape { observations: 2, actions: 2, width: 32, depth: 2 };
    /// assert_eq!(s.payload_len(ModelKind::Critic), Some(4 * (5 + 4 * 32 + 32 + 32 * 32 + 32 + 33)));
    /// ```
    pub fn payload_len(&self, kind: ModelKind) -> Option<usize> {
        self.param_count(kind)?.checked_mul(4)
    }
}

impl core::fmt::Display for Shape {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "{}x{} hidden, {} observations, {} actions",
            self.depth, self.width, self.observations, self.actions
        )
    }
}

/// The blob header. `payload_len` lets a reader tell a truncated blob from a corrupt one.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Header {
    /// Always [`MAGIC`].
    pub magic: [u8; 4],
    /// Format version, [`VERSION`].
    pub version: u16,
    /// Actor or critic.
    pub kind: ModelKind,
    /// Network sizes.
    pub shape: Shape,
    /// Hidden-layer activation.
    pub activation: Activation,
    /// Free text (task, algorithm, seed), at most [`LABEL_CAPACITY`] bytes of UTF-8.
    pub label: String<LABEL_CAPACITY>,
    /// Bytes of payload that follow the header.
    pub payload_len: u32,
}

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
    if version != VERSION {
        return Err(Error::UnsupportedVersion {
            supported: VERSION,
            found: version,
        });
    }
    let (header, rest) = postcard::take_from_bytes::<Header>(bytes).map_err(header_error)?;
    let payload_len = checked_payload_len(&header)?;
    let header_len = bytes.len() - rest.len();
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
    let stored = u32::from_le_bytes(*crc);
    let computed = crc32(body);
    if stored != computed {
        return Err(Error::ChecksumMismatch { stored, computed });
    }
    let payload = body.get(header_len..).unwrap_or_default();
    Ok(Verified { header, payload })
}

/// The header's payload length, after checking it is the one its kind and shape imply.
fn checked_payload_len(header: &Header) -> Result<usize, Error> {
    let expected = header.shape.payload_len(header.kind);
    if header.shape.depth == 0 || header.shape.width == 0 || expected.is_none() {
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
            what: "payload length does not match the shape",
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
/// static BLOB: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
/// let v = blob::verify(BLOB).unwrap();
/// let clip = blob::payload_values(v.payload).nth(4).unwrap(); // after mean[2], inv_std[2]
/// assert_eq!(clip, 5.0);
/// ```
pub fn payload_values(payload: &[u8]) -> impl Iterator<Item = f32> + '_ {
    payload
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
}

/// A model that can be stored in a blob: its kind, its compiled shape, and its parameters in
/// blob order. [`Policy`](crate::Policy) and [`Critic`](crate::Critic) implement it.
pub trait Model {
    /// Actor or critic.
    const KIND: ModelKind;
    /// The shape fixed by the const generics.
    const SHAPE: Shape;
    /// The hidden activation.
    fn activation(&self) -> Activation;
    /// Sets the hidden activation (from a blob header).
    fn set_activation(&mut self, activation: Activation);
    /// Visits every parameter slice in blob order.
    fn params<'a>(&'a self, f: &mut dyn FnMut(&'a [f32]));
    /// Visits every parameter slice mutably, in blob order.
    fn params_mut(&mut self, f: &mut dyn FnMut(&mut [f32]));
    /// Checks the rules on the leading parameters (normaliser, bounds) taken from `values`,
    /// before anything is written to the model.
    fn validate_prefix(values: &mut dyn Iterator<Item = f32>) -> Result<(), Error>;
}

/// Loads a verified blob into `slot`; `slot` is untouched unless the whole load succeeds.
///
/// The generic form of [`Policy::load_into`](crate::Policy::load_into) and
/// [`Critic::load_into`](crate::Critic::load_into).
///
/// ```
/// use policy_core::{blob, Policy};
/// static BLOB: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
/// let mut slot = Policy::<2, 32, 1, 2>::ZERO;
/// blob::load_into(&mut slot, BLOB).unwrap();
/// assert_eq!(slot.normalizer.clip, 5.0);
/// ```
pub fn load_into<M: Model>(slot: &mut M, bytes: &[u8]) -> Result<(), Error> {
    let Verified { header, payload } = verify(bytes)?;
    if header.kind != M::KIND {
        return Err(Error::WrongKind {
            expected: M::KIND,
            found: header.kind,
        });
    }
    if header.shape != M::SHAPE {
        return Err(Error::ShapeMismatch {
            expected: M::SHAPE,
            found: header.shape,
        });
    }
    check_param_count(slot)?;
    if let Some(index) = payload_values(payload).position(|v| !v.is_finite()) {
        return Err(Error::NonFiniteParameter { index });
    }
    M::validate_prefix(&mut payload_values(payload))?;
    let mut values = payload_values(payload);
    slot.params_mut(&mut |dst| {
        for (d, v) in dst.iter_mut().zip(&mut values) {
            *d = v;
        }
    });
    slot.set_activation(header.activation);
    Ok(())
}

/// Guards against a [`Model`] implementation whose `params` disagree with its `SHAPE` (a bug in
/// that implementation, never in a blob): loading or writing it would silently misplace values.
fn check_param_count<M: Model>(model: &M) -> Result<(), Error> {
    let mut count = 0usize;
    model.params(&mut |p| count = count.saturating_add(p.len()));
    if Some(count) != M::SHAPE.param_count(M::KIND) {
        return Err(Error::Malformed {
            what: "model parameters do not match its declared shape",
        });
    }
    Ok(())
}

/// Bytes a blob of this model with this label occupies.
///
/// ```
/// use policy_core::{blob, Policy};
/// let policy = Policy::<2, 48, 3, 2>::ZERO;
/// let n = blob::blob_len(&policy, "nav").unwrap();
/// assert_eq!(n, 18 + 4 * 7307 + 4); // 18-byte header (3-byte label), 7307 parameters, CRC
/// ```
pub fn blob_len<M: Model>(model: &M, label: &str) -> Result<usize, Error> {
    let header = header_for(model, label)?;
    let mut scratch = [0u8; MAX_HEADER_LEN];
    let header_len = postcard::to_slice(&header, &mut scratch)
        .map_err(|_| Error::Malformed {
            what: "header cannot be encoded",
        })?
        .len();
    M::SHAPE
        .payload_len(M::KIND)
        .and_then(|n| n.checked_add(header_len + CRC_LEN))
        .ok_or(Error::Malformed {
            what: "model too large for a blob",
        })
}

/// Writes `model` as a blob into `out`; returns the number of bytes written.
///
/// Only `out[..n]` is written. A label longer than [`LABEL_CAPACITY`] bytes is an error, as is
/// a buffer shorter than [`blob_len`].
///
/// ```
/// use policy_core::{blob, Error, Policy};
/// let policy = Policy::<1, 2, 0, 1>::ZERO;
/// let mut out = [0u8; 16];
/// assert!(matches!(blob::write_into(&policy, "x", &mut out), Err(Error::BufferTooSmall { .. })));
/// let mut out = [0u8; 128];
/// let n = blob::write_into(&policy, "x", &mut out).unwrap();
/// assert_eq!(n, 66); // 14-byte header, 12 parameters, CRC
/// ```
pub fn write_into<M: Model>(model: &M, label: &str, out: &mut [u8]) -> Result<usize, Error> {
    let needed = blob_len(model, label)?;
    check_param_count(model)?;
    let too_small = Error::BufferTooSmall {
        needed,
        found: out.len(),
    };
    let out = out.get_mut(..needed).ok_or(too_small)?;
    let header = header_for(model, label)?;
    let header_len = postcard::to_slice(&header, out)
        .map_err(|_| Error::Malformed {
            what: "header cannot be encoded",
        })?
        .len();
    let (body, crc) = out.split_last_chunk_mut::<CRC_LEN>().ok_or(too_small)?;
    let mut slots = body
        .get_mut(header_len..)
        .unwrap_or_default()
        .chunks_exact_mut(4);
    model.params(&mut |src| {
        // `src` first: `zip` polls its left side first, so an exhausted `src` must not cost
        // a slot.
        for (v, dst) in src.iter().zip(&mut slots) {
            dst.copy_from_slice(&v.to_le_bytes());
        }
    });
    *crc = crc32(body).to_le_bytes();
    Ok(needed)
}

fn header_for<M: Model>(model: &M, label: &str) -> Result<Header, Error> {
    let label = String::try_from(label).map_err(|_| Error::Malformed {
        what: "label longer than 32 bytes",
    })?;
    let payload_len = M::SHAPE
        .payload_len(M::KIND)
        .and_then(|n| u32::try_from(n).ok())
        .ok_or(Error::Malformed {
            what: "model too large for a blob",
        })?;
    Ok(Header {
        magic: MAGIC,
        version: VERSION,
        kind: M::KIND,
        shape: M::SHAPE,
        activation: model.activation(),
        label,
        payload_len,
    })
}

/// Writes `model` as a blob into a new vector (host side).
///
/// ```
/// use policy_core::{blob, Policy};
/// let bytes = blob::to_vec(&Policy::<1, 2, 0, 1>::ZERO, "x").unwrap();
/// assert_eq!(bytes.len(), 66);
/// ```
#[cfg(feature = "std")]
pub fn to_vec<M: Model>(model: &M, label: &str) -> Result<std::vec::Vec<u8>, Error> {
    let mut out = std::vec![0u8; blob_len(model, label)?];
    let n = write_into(model, label, &mut out)?;
    out.truncate(n);
    Ok(out)
}
