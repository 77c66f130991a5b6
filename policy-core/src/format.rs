//! The format's type definitions: what a blob says about itself (kind, weight encoding, shape,
//! header), where a layer lies in a payload, and the [`Spec`] of a blob to write. Pure
//! arithmetic that cannot fail in a way that needs an [`Error`](crate::error::Error): the
//! reader (`blob/read.rs`) and the limits (`blob/limits.rs`) check, the writer
//! (`blob/write.rs`) builds. It sits below `error` and `blob`, which both name its types; the
//! public paths are `blob::ModelKind`, `blob::Shape` and so on.

use heapless::String;
use serde::{Deserialize, Serialize};

use crate::mlp::activation::Activation;

/// The four bytes every blob starts with.
pub const MAGIC: [u8; 4] = *b"DCPB";
/// The format version of an f32 blob (the version this build writes for [`Encoding::F32`]).
pub const VERSION: u16 = 2;
/// The format version of a blob with quantised weights ([`Encoding::F16`], [`Encoding::Int8`]).
/// An f32 blob stays version 2, byte for byte; a reader that predates quantisation reports a
/// quantised blob as an unsupported version instead of misreading it.
pub const VERSION_QUANTISED: u16 = 3;
/// The format version of a blob in the [`Encoding::Integer`] encoding, whose forward pass is
/// integer arithmetic throughout. A version of its own, so that a reader of versions 1–3 reports
/// it as an unsupported version instead of misreading it; versions 1–3 are unchanged.
pub const VERSION_INTEGER: u16 = 4;
/// The format versions this build reads.
pub const VERSIONS_READ: [u16; 4] = [1, 2, 3, 4];
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

/// How the payload stores the layers' weights. For f32, f16 and int8 everything else
/// (normaliser, bounds, action table, biases, scales) is f32 and so is every activation;
/// [`Encoding::Integer`] stores and computes the layers in integers (docs/blob-format.md, "The
/// integer encoding").
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
    /// Integer arithmetic throughout (format version 4, actors only): int8 weights with one
    /// fixed-point requantisation multiplier per output, int32 biases and accumulators, int8
    /// activations with a zero point per layer, ReLU fused into the requantisation clamp, tanh
    /// by a 256-entry table, and the observation normaliser folded into the input quantisation.
    /// A chip without an FPU runs it without software floats ([`crate::mlp::integer`]).
    Integer,
}

impl Encoding {
    /// Every encoding, in header order.
    pub const ALL: [Encoding; 4] = [
        Encoding::F32,
        Encoding::F16,
        Encoding::Int8,
        Encoding::Integer,
    ];

    /// The encodings that store weights only, everything else staying f32: the ones
    /// [`blob::write`](crate::blob::write()) and `blob::encode` (host side) make from
    /// f32 parameters alone. [`Encoding::Integer`] also needs the activations' ranges
    /// ([`blob::write_integer`](crate::blob::write_integer)).
    pub const WEIGHTS_ONLY: [Encoding; 3] = [Encoding::F32, Encoding::F16, Encoding::Int8];

    /// The format version a blob of this encoding has.
    pub fn version(self) -> u16 {
        match self {
            Encoding::F32 => VERSION,
            Encoding::F16 | Encoding::Int8 => VERSION_QUANTISED,
            Encoding::Integer => VERSION_INTEGER,
        }
    }

    /// The cargo feature of policy-core that reads and runs this encoding: `f32`, `f16`,
    /// `int8` or `integer`, the encoding's name.
    pub const fn feature(self) -> &'static str {
        match self {
            Encoding::F32 => "f32",
            Encoding::F16 => "f16",
            Encoding::Int8 => "int8",
            Encoding::Integer => "integer",
        }
    }

    /// Whether this build reads and runs this encoding (its [`feature`](Encoding::feature) is
    /// on; all three are by default). A blob of an encoding not compiled in is refused by
    /// [`verify`](crate::blob::verify) with
    /// [`Error::EncodingNotCompiled`](crate::Error::EncodingNotCompiled), so the runtime never
    /// meets one and the optimiser drops that encoding's checks and kernel from the binary.
    pub const fn is_compiled(self) -> bool {
        match self {
            Encoding::F32 => cfg!(feature = "f32"),
            Encoding::F16 => cfg!(feature = "f16"),
            Encoding::Int8 => cfg!(feature = "int8"),
            Encoding::Integer => cfg!(feature = "integer"),
        }
    }

    /// Bytes one weight takes.
    pub fn weight_bytes(self) -> usize {
        match self {
            Encoding::F32 => 4,
            Encoding::F16 => 2,
            Encoding::Int8 | Encoding::Integer => 1,
        }
    }
}

impl core::fmt::Display for Encoding {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Encoding::F32 => "f32",
            Encoding::F16 => "f16",
            Encoding::Int8 => "int8",
            Encoding::Integer => "integer",
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
    /// The layer with `inputs` and `outputs` starting at byte `start`, or `None` on overflow
    /// and for [`Encoding::Integer`], whose layers have their own layout
    /// ([`IntegerLayer`](crate::blob::IntegerLayer)).
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
            Encoding::Integer => return None,
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

    /// Bytes of the payload in `encoding`, or `None` if it does not fit in `usize`, and for
    /// [`Encoding::Integer`], whose length also depends on the activation (tanh layers carry a
    /// table): [`Shape::payload_len_for`] takes it.
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
        match encoding {
            Encoding::F32 => return self.payload_len(kind),
            Encoding::Integer => return None,
            Encoding::F16 | Encoding::Int8 => {}
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

impl Shape {
    /// Bytes of the payload of a blob of this kind, encoding and hidden activation, or `None`
    /// if it does not fit in `usize` (or, for [`Encoding::Integer`], the kind is not an actor or
    /// the build lacks the `integer` feature).
    /// The one length rule [`verify`](crate::blob::verify) and the writers apply.
    ///
    /// ```
    /// use policy_core::{Activation, Encoding, ModelKind, Shape};
    /// let s = Shape { observations: 2, actions: 2, width: 48, depth: 4, choices: 0 };
    /// let tanh = s.payload_len_for(ModelKind::Actor, Encoding::Integer, Activation::Tanh).unwrap();
    /// let relu = s.payload_len_for(ModelKind::Actor, Encoding::Integer, Activation::Relu).unwrap();
    /// assert_eq!(tanh - relu, 4 * 256); // four hidden tanh tables
    /// ```
    pub fn payload_len_for(
        &self,
        kind: ModelKind,
        encoding: Encoding,
        activation: Activation,
    ) -> Option<usize> {
        match encoding {
            // A build without the integer encoding refuses such blobs before their length
            // (`EncodingNotCompiled`), so its layout code can go.
            Encoding::Integer if cfg!(feature = "integer") => {
                crate::integer_layout::payload_len(kind, *self, activation)
            }
            Encoding::Integer => None,
            Encoding::F32 | Encoding::F16 | Encoding::Int8 => self.payload_len_in(kind, encoding),
        }
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

/// The header's length with the padding that aligns the payload to 4 bytes (version 2 on;
/// version 1 had none).
pub(crate) fn padded_header_len(version: u16, encoded_len: usize) -> usize {
    if version == 1 {
        encoded_len
    } else {
        encoded_len.next_multiple_of(4)
    }
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
