//! The weight-blob format: one definition, used by the loader on the chip and the writer on the
//! host. `docs/blob-format.md` specifies it byte by byte.
//!
//! ```text
//! blob    = header padding payload crc
//! header  = postcard(Header)            magic "DCPB", version 2 (f32) or 3 (f16, int8), kind,
//!                                       encoding, shape, activation, label, payload length
//! padding = 0 to 3 zero bytes           so that the payload starts at a multiple of 4
//! payload = every parameter             f32: 4 bytes little-endian each; f16 and int8 store
//!                                       the layers' weights in 2 or 1 bytes (see [`Encoding`])
//! crc     = u32 little-endian           CRC-32/ISO-HDLC of everything before it
//! ```
//!
//! Version 1 blobs (no encoding field, no `choices` in the shape, no padding) still load.
//!
//! Loading checks, in order: magic, version, header, limits, length, padding, checksum; then
//! ([`crate::model::Model::from_blob`] or [`load_into`]) kind, shape, finite values and the
//! parameter rules. Nothing runs, and nothing is written to a slot, unless every check passed.

use heapless::String;
use serde::{Deserialize, Serialize};

use crate::{crc32, Activation, Error};

/// The four bytes every blob starts with.
pub const MAGIC: [u8; 4] = *b"DCPB";
/// The format version of an f32 blob (the version this build writes for [`Encoding::F32`]).
pub const VERSION: u16 = 2;
/// The format version of a blob with quantised weights ([`Encoding::F16`], [`Encoding::Int8`]).
/// An f32 blob stays version 2, byte for byte; a reader that predates quantisation reports a
/// quantised blob as an unsupported version instead of misreading it.
pub const VERSION_QUANTISED: u16 = 3;
/// The format versions this build reads.
pub const VERSIONS_READ: [u16; 3] = [1, 2, 3];
/// Capacity of the free-text label in the header, in bytes.
pub const LABEL_CAPACITY: usize = 32;
/// Bytes of the trailing checksum.
pub const CRC_LEN: usize = 4;
/// The largest encoded header with its padding: magic 4, version 3, kind 1, encoding 1, shape 13,
/// activation 1, label 33, payload length 5 (postcard varints at their widest), padding 3.
pub const MAX_HEADER_LEN: usize = 64;
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
    /// A discrete policy (DQN): normaliser, action bounds, a table of `choices` action vectors
    /// and a Q network with one output per row; the action is the row of the largest Q value.
    /// Version 2 only.
    Discrete,
}

impl core::fmt::Display for ModelKind {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            ModelKind::Actor => "actor",
            ModelKind::Critic => "critic",
            ModelKind::Discrete => "discrete policy",
        })
    }
}

/// How the payload stores the layers' weights. Everything else (normaliser, bounds, action
/// table, biases, scales) is always f32; activations are always f32.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Encoding {
    /// 4-byte little-endian IEEE-754 single precision (format version 2).
    F32,
    /// IEEE-754 half precision, 2 bytes little-endian, decoded exactly to f32
    /// ([`crate::half::f16_to_f32`]); a layer computes what f32 computes with those weights
    /// (format version 3).
    F16,
    /// Signed bytes with one f32 scale per output: `W[o, j] = scale[o] · q[j, o]`, computed as
    /// `y[o] = b[o] + scale[o] · Σ_j q[j, o] · x[j]` (format version 3).
    Int8,
}

impl Encoding {
    /// Every encoding, in header order.
    pub const ALL: [Encoding; 3] = [Encoding::F32, Encoding::F16, Encoding::Int8];

    /// The format version a blob of this encoding has.
    pub fn version(self) -> u16 {
        match self {
            Encoding::F32 => VERSION,
            Encoding::F16 | Encoding::Int8 => VERSION_QUANTISED,
        }
    }

    /// Bytes one weight takes.
    pub fn weight_bytes(self) -> usize {
        match self {
            Encoding::F32 => 4,
            Encoding::F16 => 2,
            Encoding::Int8 => 1,
        }
    }
}

impl core::fmt::Display for Encoding {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Encoding::F32 => "f32",
            Encoding::F16 => "f16",
            Encoding::Int8 => "int8",
        })
    }
}

/// Where one dense layer's parts lie in the payload, in bytes from the payload's start:
/// `[scales] weights [padding] bias`. Scales (int8 only) are `outputs` f32; the weights are
/// `inputs × outputs` values of the encoding, column-major, followed by zero bytes up to a
/// multiple of 4; the bias is `outputs` f32.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LayerLayout {
    /// Inputs of the layer.
    pub inputs: usize,
    /// Outputs of the layer.
    pub outputs: usize,
    /// Offset of the scales (int8; equal to `weights` for the other encodings).
    pub scales: usize,
    /// Offset of the weights.
    pub weights: usize,
    /// Offset of the zero padding after the weights (equal to `bias` when there is none).
    pub padding: usize,
    /// Offset of the bias.
    pub bias: usize,
    /// Offset just past the layer.
    pub end: usize,
}

impl LayerLayout {
    /// The layer with `inputs` and `outputs` starting at byte `start`, or `None` on overflow.
    ///
    /// ```
    /// use policy_core::blob::{Encoding, LayerLayout};
    /// let l = LayerLayout::of(Encoding::Int8, 2, 3, 100).unwrap();
    /// // 3 scales (12 bytes), 6 weights + 2 padding bytes, 3 biases (12 bytes)
    /// assert_eq!((l.scales, l.weights, l.padding, l.bias, l.end), (100, 112, 118, 120, 132));
    /// ```
    pub fn of(encoding: Encoding, inputs: usize, outputs: usize, start: usize) -> Option<Self> {
        let scales = match encoding {
            Encoding::Int8 => outputs.checked_mul(4)?,
            Encoding::F32 | Encoding::F16 => 0,
        };
        let weights = start.checked_add(scales)?;
        let weight_bytes = inputs
            .checked_mul(outputs)?
            .checked_mul(encoding.weight_bytes())?;
        let padding = weights.checked_add(weight_bytes)?;
        let bias = weights.checked_add(weight_bytes.checked_next_multiple_of(4)?)?;
        let end = bias.checked_add(outputs.checked_mul(4)?)?;
        Some(LayerLayout {
            inputs,
            outputs,
            scales: start,
            weights,
            padding,
            bias,
            end,
        })
    }
}

/// The one description of a network's sizes: what a blob header names, what the runtime runs
/// and what a compiled type fixes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shape {
    /// Observation size.
    pub observations: u16,
    /// Action size (of each action-table row, for a discrete policy).
    pub actions: u16,
    /// Hidden width.
    pub width: u16,
    /// Number of hidden layers (the paper's "4" in 4×48).
    pub depth: u8,
    /// Rows of a discrete policy's action table (its Q network's outputs); 0 for actors and
    /// critics.
    pub choices: u16,
}

/// The largest observation size a blob may declare.
pub const MAX_OBSERVATIONS: usize = 1024;
/// The largest action size a blob may declare.
pub const MAX_ACTIONS: usize = 256;
/// The largest hidden width a blob may declare.
pub const MAX_WIDTH: usize = 1024;
/// The most hidden layers a blob may declare.
pub const MAX_DEPTH: usize = 64;
/// The most action-table rows a discrete policy may declare.
pub const MAX_CHOICES: usize = 1024;

impl Shape {
    /// Number of `f32` parameters a model of this kind and shape stores, or `None` if it does
    /// not fit in `usize`.
    ///
    /// ```
    /// use policy_core::{ModelKind, Shape};
    /// let s = Shape { observations: 2, actions: 2, width: 48, depth: 4, choices: 0 };
    /// // normaliser 2+2+1, bounds 2+2, layers 2*48+48 + 3*(48*48+48) + 48*2+2
    /// assert_eq!(s.param_count(ModelKind::Actor), Some(9 + 144 + 7056 + 98));
    /// // A discrete policy with 8 rows adds its table (8*2) and has 8 outputs.
    /// let d = Shape { choices: 8, ..s };
    /// assert_eq!(d.param_count(ModelKind::Discrete), Some(9 + 16 + 144 + 7056 + 8 * 48 + 8));
    /// ```
    pub fn param_count(&self, kind: ModelKind) -> Option<usize> {
        let (s, a, h, k) = (
            self.observations as usize,
            self.actions as usize,
            self.width as usize,
            self.choices as usize,
        );
        let hidden_layers = (self.depth as usize).checked_sub(1)?;
        // Checked throughout: on a 16-bit target even `2 * s` can overflow.
        let (inputs, outputs, bounds, table) = match kind {
            ModelKind::Actor => (s, a, a.checked_mul(2)?, 0),
            ModelKind::Critic => (s.checked_add(a)?, 1, 0, 0),
            ModelKind::Discrete => (s, k, a.checked_mul(2)?, k.checked_mul(a)?),
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
            .checked_add(table)?
            .checked_add(first)?
            .checked_add(hidden)?
            .checked_add(output)
    }

    /// Inputs of the first layer: observations, plus the action for a critic.
    pub fn inputs(&self, kind: ModelKind) -> usize {
        let s = self.observations as usize;
        match kind {
            ModelKind::Critic => s + self.actions as usize,
            ModelKind::Actor | ModelKind::Discrete => s,
        }
    }

    /// Outputs of the last layer: actions, one Q value, or one Q value per table row.
    pub fn outputs(&self, kind: ModelKind) -> usize {
        match kind {
            ModelKind::Actor => self.actions as usize,
            ModelKind::Critic => 1,
            ModelKind::Discrete => self.choices as usize,
        }
    }

    /// The width a runtime scratch buffer needs: the widest vector of the forward pass.
    ///
    /// ```
    /// use policy_core::{ModelKind, Shape};
    /// let s = Shape { observations: 2, actions: 2, width: 48, depth: 4, choices: 0 };
    /// assert_eq!(s.scratch_width(ModelKind::Actor), 48);
    /// ```
    pub fn scratch_width(&self, kind: ModelKind) -> usize {
        self.inputs(kind)
            .max(self.width as usize)
            .max(self.outputs(kind))
            .max(self.actions as usize)
    }

    /// Checks the shape against the format's limits and the kind's rules: at least one hidden
    /// layer of width at least 1, sizes within the documented maxima, and `choices` set for a
    /// discrete policy only.
    ///
    /// ```
    /// use policy_core::{Error, ModelKind, Shape};
    /// let s = Shape { observations: 2, actions: 2, width: 48, depth: 4, choices: 0 };
    /// assert_eq!(s.check(ModelKind::Actor), Ok(()));
    /// let huge = Shape { width: 4096, ..s };
    /// assert!(matches!(huge.check(ModelKind::Actor), Err(Error::ShapeBeyondLimits { .. })));
    /// assert!(s.check(ModelKind::Discrete).is_err()); // a discrete policy needs choices >= 1
    /// ```
    pub fn check(&self, kind: ModelKind) -> Result<(), Error> {
        let limits = [
            (
                "observations",
                self.observations as usize,
                1,
                MAX_OBSERVATIONS,
            ),
            ("actions", self.actions as usize, 1, MAX_ACTIONS),
            ("width", self.width as usize, 1, MAX_WIDTH),
            ("depth", self.depth as usize, 1, MAX_DEPTH),
        ];
        for (what, found, min, max) in limits {
            if found < min || found > max {
                return Err(Error::ShapeBeyondLimits {
                    what,
                    min,
                    max,
                    found,
                });
            }
        }
        let (min, max) = match kind {
            ModelKind::Discrete => (1, MAX_CHOICES),
            ModelKind::Actor | ModelKind::Critic => (0, 0),
        };
        let choices = self.choices as usize;
        if choices < min || choices > max {
            return Err(Error::ShapeBeyondLimits {
                what: "choices",
                min,
                max,
                found: choices,
            });
        }
        Ok(())
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
            choices: 0,
        }
    }

    /// Bytes of the payload (4 per parameter).
    ///
    /// ```
    /// use policy_core::{ModelKind, Shape};
    /// let s = Shape { observations: 2, actions: 2, width: 32, depth: 2, choices: 0 };
    /// assert_eq!(s.payload_len(ModelKind::Critic), Some(4 * (5 + 4 * 32 + 32 + 32 * 32 + 32 + 33)));
    /// ```
    pub fn payload_len(&self, kind: ModelKind) -> Option<usize> {
        self.param_count(kind)?.checked_mul(4)
    }

    /// Parameters before the first layer: the normaliser (2S + 1), then the bounds (2A) of an
    /// actor or discrete policy and the action table (K × A) of a discrete policy.
    pub fn prefix_count(&self, kind: ModelKind) -> usize {
        let (s, a, k) = (
            self.observations as usize,
            self.actions as usize,
            self.choices as usize,
        );
        match kind {
            ModelKind::Actor => 2 * s + 1 + 2 * a,
            ModelKind::Critic => 2 * s + 1,
            ModelKind::Discrete => 2 * s + 1 + 2 * a + k * a,
        }
    }

    /// The `(inputs, outputs)` of layer `l` (from 0; `depth` hidden layers, then the output
    /// layer), or `None` past the last.
    pub fn layer(&self, kind: ModelKind, l: usize) -> Option<(usize, usize)> {
        let (h, depth) = (self.width as usize, self.depth as usize);
        match l {
            0 if depth > 0 => Some((self.inputs(kind), h)),
            l if l < depth => Some((h, h)),
            l if l == depth => Some((h, self.outputs(kind))),
            _ => None,
        }
    }

    /// Bytes of the payload in `encoding`, or `None` if it does not fit in `usize`.
    ///
    /// ```
    /// use policy_core::{Encoding, ModelKind, Shape};
    /// let s = Shape { observations: 2, actions: 2, width: 48, depth: 4, choices: 0 };
    /// assert_eq!(s.payload_len_in(ModelKind::Actor, Encoding::F32), s.payload_len(ModelKind::Actor));
    /// // The prefix (9 floats) and biases stay f32; int8 adds a scale per output.
    /// let int8 = s.payload_len_in(ModelKind::Actor, Encoding::Int8).unwrap();
    /// assert_eq!(int8, 4 * 9 + (2 * 48 + 8 * 48) + 3 * (48 * 48 + 8 * 48) + (48 * 2 + 8 * 2));
    /// ```
    pub fn payload_len_in(&self, kind: ModelKind, encoding: Encoding) -> Option<usize> {
        if encoding == Encoding::F32 {
            return self.payload_len(kind);
        }
        self.param_count(kind)?; // the same overflow checks as f32
        let mut end = self.prefix_count(kind).checked_mul(4)?;
        let mut l = 0;
        while let Some((inputs, outputs)) = self.layer(kind, l) {
            end = LayerLayout::of(encoding, inputs, outputs, end)?.end;
            l += 1;
        }
        Some(end)
    }
}

impl core::fmt::Display for Shape {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "{}x{} hidden, {} observations, {} actions",
            self.depth, self.width, self.observations, self.actions
        )?;
        if self.choices > 0 {
            write!(f, ", {} choices", self.choices)?;
        }
        Ok(())
    }
}

/// The blob header (version 2). `payload_len` lets a reader tell a truncated blob from a corrupt
/// one.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Header {
    /// Always [`MAGIC`].
    pub magic: [u8; 4],
    /// Format version: [`VERSION`] when written; a version-1 blob reads as version 1.
    pub version: u16,
    /// Actor, critic or discrete policy.
    pub kind: ModelKind,
    /// How the parameters are stored.
    pub encoding: Encoding,
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
    let (header, rest) = match version {
        1 => {
            let (v1, rest) = postcard::take_from_bytes::<HeaderV1>(bytes).map_err(header_error)?;
            (v1.into_current()?, rest)
        }
        VERSION | VERSION_QUANTISED => {
            postcard::take_from_bytes::<Header>(bytes).map_err(header_error)?
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

/// The header's length with the padding that aligns the payload to 4 bytes (version 2 on;
/// version 1 had none).
fn padded_header_len(version: u16, encoded_len: usize) -> usize {
    if version == 1 {
        encoded_len
    } else {
        encoded_len.next_multiple_of(4)
    }
}

/// The version-1 header: no encoding field (always f32) and no `choices` in the shape.
#[derive(Deserialize)]
struct HeaderV1 {
    magic: [u8; 4],
    version: u16,
    kind: ModelKind,
    shape: ShapeV1,
    activation: Activation,
    label: String<LABEL_CAPACITY>,
    payload_len: u32,
}

#[derive(Deserialize)]
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

/// A model whose shape is fixed at compile time ([`Policy`](crate::Policy),
/// [`Critic`](crate::Critic)): its kind, its shape, and its parameters in blob order. The runtime
/// [`Model`](crate::model::Model) needs none of this; compiled types remain for code that wants
/// the sizes in its types.
pub trait Compiled {
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
}

/// Loads a verified blob into `slot`; `slot` is untouched unless the whole load succeeds.
///
/// The generic form of [`Policy::load_into`](crate::Policy::load_into) and
/// [`Critic::load_into`](crate::Critic::load_into). The parameter rules are the runtime model's
/// ([`Model::from_blob`](crate::model::Model::from_blob)), so both accept exactly the same blobs.
///
/// ```
/// use policy_core::{blob, Policy};
/// static BLOB: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
/// let mut slot = Policy::<2, 32, 1, 2>::ZERO;
/// blob::load_into(&mut slot, BLOB).unwrap();
/// assert_eq!(slot.normalizer.clip, 5.0);
/// ```
pub fn load_into<M: Compiled>(slot: &mut M, bytes: &[u8]) -> Result<(), Error> {
    let model = crate::model::Model::from_blob(bytes)?;
    let header = model.header();
    if header.encoding != Encoding::F32 {
        return Err(Error::WrongEncoding {
            expected: Encoding::F32,
            found: header.encoding,
        });
    }
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
    let mut values = model.values();
    slot.params_mut(&mut |dst| {
        for (d, v) in dst.iter_mut().zip(&mut values) {
            *d = v;
        }
    });
    slot.set_activation(header.activation);
    Ok(())
}

/// Guards against a [`Compiled`] implementation whose `params` disagree with its `SHAPE` (a bug
/// in that implementation, never in a blob): loading or writing it would misplace values.
fn check_param_count<M: Compiled>(model: &M) -> Result<(), Error> {
    let mut count = 0usize;
    model.params(&mut |p| count = count.saturating_add(p.len()));
    if Some(count) != M::SHAPE.param_count(M::KIND) {
        return Err(Error::Malformed {
            what: "model parameters do not match its declared shape",
        });
    }
    Ok(())
}

/// The parameters of a blob being written: called once with a sink, it passes every parameter
/// in blob order to the sink, in slices of any length.
pub type Params<'p> = dyn FnMut(&mut dyn FnMut(&[f32])) + 'p;

/// What a blob to be written is: everything in the header except the lengths.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Spec<'a> {
    /// Actor, critic or discrete policy.
    pub kind: ModelKind,
    /// How the weights are stored (the writer quantises f32 weights into it).
    pub encoding: Encoding,
    /// Network sizes.
    pub shape: Shape,
    /// Hidden activation.
    pub activation: Activation,
    /// Free text, at most [`LABEL_CAPACITY`] bytes.
    pub label: &'a str,
}

impl<'a> Spec<'a> {
    /// The spec of the blob `header` describes, with its weights in `encoding` (how a blob is
    /// re-encoded or written back).
    pub fn like(header: &'a Header, encoding: Encoding) -> Spec<'a> {
        Spec {
            kind: header.kind,
            encoding,
            shape: header.shape,
            activation: header.activation,
            label: header.label.as_str(),
        }
    }
}

impl Spec<'_> {
    fn header(&self) -> Result<Header, Error> {
        self.shape.check(self.kind)?;
        let label = String::try_from(self.label).map_err(|_| Error::Malformed {
            what: "label longer than 32 bytes",
        })?;
        let payload_len = self
            .shape
            .payload_len_in(self.kind, self.encoding)
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
    let needed = encoded_len(spec)?;
    let header = spec.header()?;
    let too_small = Error::BufferTooSmall {
        needed,
        found: out.len(),
    };
    let out = out.get_mut(..needed).ok_or(too_small)?;
    let encoded = postcard::to_slice(&header, out)
        .map_err(|_| Error::Malformed {
            what: "header cannot be encoded",
        })?
        .len();
    let header_len = padded_header_len(header.version, encoded);
    let (body, crc) = out.split_last_chunk_mut::<CRC_LEN>().ok_or(too_small)?;
    body.get_mut(encoded..header_len)
        .unwrap_or_default()
        .fill(0);
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

/// Where parameter `n` (in blob order) lies in a payload.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Slot {
    /// An f32 at this byte offset (normaliser, bounds, table, bias).
    F32(usize),
    /// Weight `i` (column-major) of a layer.
    Weight(LayerLayout, usize),
}

pub(crate) fn locate(kind: ModelKind, shape: Shape, encoding: Encoding, n: usize) -> Option<Slot> {
    let prefix = shape.prefix_count(kind);
    if n < prefix {
        return Some(Slot::F32(4 * n));
    }
    let (mut first, mut start, mut l) = (prefix, 4 * prefix, 0);
    while let Some((inputs, outputs)) = shape.layer(kind, l) {
        let layout = LayerLayout::of(encoding, inputs, outputs, start)?;
        let weights = inputs * outputs;
        if n < first + weights {
            return Some(Slot::Weight(layout, n - first));
        }
        if n < first + weights + outputs {
            return Some(Slot::F32(layout.bias + 4 * (n - first - weights)));
        }
        first += weights + outputs;
        start = layout.end;
        l += 1;
    }
    None
}

/// Writes the parameters into a zeroed quantised payload: f32 where the format keeps f32, the
/// weights converted. For int8 a first pass over the parameters finds each output's largest
/// |weight| (stored in its scale slot), so that `scale = max / 127` (1 for an all-zero output)
/// and `q = round(w / scale)`.
fn quantise(spec: &Spec<'_>, params: &mut Params<'_>, payload: &mut [u8]) -> Result<(), Error> {
    let mismatch = Error::Malformed {
        what: "parameters do not match the declared shape",
    };
    let put_f32 = |payload: &mut [u8], at: usize, v: f32| {
        if let Some(dst) = payload.get_mut(at..at + 4) {
            dst.copy_from_slice(&v.to_le_bytes());
        }
    };
    let get_f32 = |payload: &[u8], at: usize| {
        payload
            .get(at..at + 4)
            .and_then(|b| <[u8; 4]>::try_from(b).ok())
            .map_or(0.0, f32::from_le_bytes)
    };
    let mut failure: Option<Error> = None;
    if spec.encoding == Encoding::Int8 {
        let mut n = 0usize;
        params(&mut |src| {
            for &v in src {
                if let Some(Slot::Weight(l, i)) = locate(spec.kind, spec.shape, spec.encoding, n) {
                    let at = l.scales + 4 * (i % l.outputs);
                    let largest = get_f32(payload, at).max(v.abs());
                    put_f32(payload, at, largest);
                }
                n += 1;
            }
        });
        // Maxima into scales, layer by layer.
        let mut l = 0;
        let mut start = 4 * spec.shape.prefix_count(spec.kind);
        while let Some((inputs, outputs)) = spec.shape.layer(spec.kind, l) {
            let layout = LayerLayout::of(spec.encoding, inputs, outputs, start).ok_or(mismatch)?;
            for o in 0..outputs {
                let at = layout.scales + 4 * o;
                let largest = get_f32(payload, at);
                if !largest.is_finite() {
                    return Err(Error::NonFiniteParameter { index: o });
                }
                let scale = if largest > 0.0 { largest / 127.0 } else { 1.0 };
                put_f32(payload, at, scale);
            }
            start = layout.end;
            l += 1;
        }
    }
    let mut n = 0usize;
    params(&mut |src| {
        for &v in src {
            if !v.is_finite() && failure.is_none() {
                failure = Some(Error::NonFiniteParameter { index: n });
            }
            match locate(spec.kind, spec.shape, spec.encoding, n) {
                Some(Slot::F32(at)) => put_f32(payload, at, v),
                Some(Slot::Weight(l, i)) => match spec.encoding {
                    Encoding::F16 => {
                        let h = crate::half::f32_to_f16(v);
                        if !crate::half::f16_to_f32(h).is_finite() && failure.is_none() {
                            failure = Some(Error::InvalidParameter {
                                what: "weight beyond the f16 range (|w| > 65504)",
                                index: n,
                            });
                        }
                        let at = l.weights + 2 * i;
                        if let Some(dst) = payload.get_mut(at..at + 2) {
                            dst.copy_from_slice(&h.to_le_bytes());
                        }
                    }
                    Encoding::Int8 | Encoding::F32 => {
                        let scale = get_f32(payload, l.scales + 4 * (i % l.outputs));
                        let q = libm::roundf(v / scale).clamp(-127.0, 127.0) as i8;
                        if let Some(dst) = payload.get_mut(l.weights + i) {
                            *dst = q as u8;
                        }
                    }
                },
                None => {
                    if failure.is_none() {
                        failure = Some(mismatch);
                    }
                }
            }
            n += 1;
        }
    });
    if let Some(e) = failure {
        return Err(e);
    }
    if Some(n) != spec.shape.param_count(spec.kind) {
        return Err(mismatch);
    }
    Ok(())
}

/// [`write()`] into a new vector (host side).
#[cfg(feature = "std")]
pub fn to_vec_with(spec: &Spec<'_>, params: &mut Params<'_>) -> Result<std::vec::Vec<u8>, Error> {
    let mut out = std::vec![0u8; encoded_len(spec)?];
    let n = write(spec, params, &mut out)?;
    out.truncate(n);
    Ok(out)
}

/// The blob `bytes` (f32 weights) with its weights stored in `encoding` instead (host side): the
/// same kind, shape, activation, label, normaliser, bounds, action table and biases; [`write()`]
/// converts the weights (f16: nearest, ties to even; int8: one scale per output, max |w| / 127,
/// `q = round(w / scale)`). Deterministic: the same f32 blob gives the same bytes. A blob that is
/// already quantised is [`Error::WrongEncoding`] (quantising twice compounds the rounding). The
/// one definition behind `host-trainer export --encoding` and the firmware check's `encode`.
///
/// ```
/// use policy_core::{blob, model::Model, Encoding};
/// static F32: &[u8] = include_bytes!("../tests/golden/actor_4x48.postcard");
/// let int8 = blob::encode(F32, Encoding::Int8).unwrap();
/// assert!(int8.len() < F32.len() / 3);
/// assert_eq!(Model::from_blob(&int8).unwrap().header().encoding, Encoding::Int8);
/// assert_eq!(blob::encode(F32, Encoding::F32).unwrap(), F32);
/// assert!(blob::encode(&int8, Encoding::F16).is_err());
/// ```
#[cfg(feature = "std")]
pub fn encode(bytes: &[u8], encoding: Encoding) -> Result<std::vec::Vec<u8>, Error> {
    let model = crate::model::Model::from_blob(bytes)?;
    let h = model.header();
    if h.encoding != Encoding::F32 {
        return Err(Error::WrongEncoding {
            expected: Encoding::F32,
            found: h.encoding,
        });
    }
    let params: std::vec::Vec<f32> = model.values().collect();
    let out = to_vec_with(&Spec::like(h, encoding), &mut |sink| sink(&params))?;
    crate::model::Model::from_blob(&out)?;
    Ok(out)
}

fn spec_of<'a, M: Compiled>(model: &M, label: &'a str) -> Spec<'a> {
    Spec {
        kind: M::KIND,
        encoding: Encoding::F32,
        shape: M::SHAPE,
        activation: model.activation(),
        label,
    }
}

/// Bytes a blob of this compiled model with this label occupies.
///
/// ```
/// use policy_core::{blob, Policy};
/// let policy = Policy::<2, 48, 3, 2>::ZERO;
/// let n = blob::blob_len(&policy, "nav").unwrap();
/// assert_eq!(n, 20 + 4 * 7307 + 4); // 20-byte header (3-byte label), 7307 parameters, CRC
/// ```
pub fn blob_len<M: Compiled>(model: &M, label: &str) -> Result<usize, Error> {
    encoded_len(&spec_of(model, label))
}

/// Writes a compiled `model` as a blob into `out`; returns the number of bytes written.
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
/// assert_eq!(n, 68); // 16-byte header (15 + 1 padding), 12 parameters, CRC
/// ```
pub fn write_into<M: Compiled>(model: &M, label: &str, out: &mut [u8]) -> Result<usize, Error> {
    check_param_count(model)?;
    write(
        &spec_of(model, label),
        &mut |sink| model.params(&mut |p| sink(p)),
        out,
    )
}

/// Writes a compiled `model` as a blob into a new vector (host side).
///
/// ```
/// use policy_core::{blob, Policy};
/// let bytes = blob::to_vec(&Policy::<1, 2, 0, 1>::ZERO, "x").unwrap();
/// assert_eq!(bytes.len(), 68);
/// ```
#[cfg(feature = "std")]
pub fn to_vec<M: Compiled>(model: &M, label: &str) -> Result<std::vec::Vec<u8>, Error> {
    let mut out = std::vec![0u8; blob_len(model, label)?];
    let n = write_into(model, label, &mut out)?;
    out.truncate(n);
    Ok(out)
}
