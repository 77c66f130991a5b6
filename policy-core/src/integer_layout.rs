//! Where the parts of an [`Encoding::Integer`](crate::Encoding::Integer) payload lie: the input
//! quantisation after the f32 prefix, then one block per layer (docs/blob-format.md, "The
//! integer encoding"). Pure offset arithmetic, checked against overflow, like
//! [`LayerLayout`](crate::blob::LayerLayout) for the other encodings; the reader
//! (`blob/integer.rs`), the writer and the runtime all find the bytes through it.

use crate::format::{ModelKind, Shape};
use crate::mlp::activation::Activation;
use crate::mlp::integer::IntegerDense;

/// Entries of an activation table: one per int8 code, `table[code + 128]`.
pub const TABLE_LEN: usize = 256;

/// The input quantisation of an integer actor, in bytes from the payload's start: `S` f32
/// input scales, `S` f32 input offsets (the normaliser folded into the first layer's input
/// quantisation: `code = round(x · scale + offset)`), then the input zero point as an i32.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IntegerInput {
    /// Observations.
    pub observations: usize,
    /// Offset of the `observations` f32 input scales.
    pub scales: usize,
    /// Offset of the `observations` f32 input offsets.
    pub offsets: usize,
    /// Offset of the input zero point (i32, in `-128..=127`).
    pub zero: usize,
    /// Offset just past the block: the first layer's.
    pub end: usize,
}

impl IntegerInput {
    /// The input block of `observations` inputs starting at byte `start`, or `None` on overflow.
    pub fn of(observations: usize, start: usize) -> Option<Self> {
        let offsets = start.checked_add(observations.checked_mul(4)?)?;
        let zero = offsets.checked_add(observations.checked_mul(4)?)?;
        Some(IntegerInput {
            observations,
            scales: start,
            offsets,
            zero,
            end: zero.checked_add(4)?,
        })
    }
}

/// Where one layer of an integer payload lies, in bytes from the payload's start:
/// `output_zero multipliers shifts [padding] weights [padding] biases [table]`.
///
/// The output zero point is an i32; the multipliers `outputs` i32; the shifts `outputs` i8 and
/// zero bytes to a multiple of 4; the weights `inputs × outputs` i8, column-major, and zero
/// bytes to a multiple of 4; the biases `outputs` i32; the table, when the layer's output goes
/// through tanh (every layer of a tanh actor, the output layer of any actor), 256 i8.
///
/// ```
/// use policy_core::blob::IntegerLayer;
/// let l = IntegerLayer::of(2, 3, true, 100).unwrap();
/// // zero 4, multipliers 12, shifts 3 + 1, weights 6 + 2, biases 12, table 256
/// assert_eq!((l.multipliers, l.shifts, l.weights, l.bias), (104, 116, 120, 128));
/// assert_eq!((l.table, l.end), (Some(140), 396));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IntegerLayer {
    /// Inputs of the layer.
    pub inputs: usize,
    /// Outputs of the layer.
    pub outputs: usize,
    /// Offset of the output zero point (i32).
    pub zero: usize,
    /// Offset of the `outputs` requantisation multipliers (i32).
    pub multipliers: usize,
    /// Offset of the `outputs` requantisation shifts (i8).
    pub shifts: usize,
    /// Offset of the zero padding after the shifts (equal to `weights` when there is none).
    pub shift_padding: usize,
    /// Offset of the weights (i8, column-major).
    pub weights: usize,
    /// Offset of the zero padding after the weights (equal to `bias` when there is none).
    pub weight_padding: usize,
    /// Offset of the `outputs` biases (i32).
    pub bias: usize,
    /// Offset of the 256-entry tanh table, if the layer has one.
    pub table: Option<usize>,
    /// Offset just past the layer.
    pub end: usize,
}

impl IntegerLayer {
    /// The layer with `inputs` and `outputs` (and a tanh table if `table`) starting at byte
    /// `start`, or `None` on overflow.
    pub fn of(inputs: usize, outputs: usize, table: bool, start: usize) -> Option<Self> {
        let words = outputs.checked_mul(4)?;
        let multipliers = start.checked_add(4)?;
        let shifts = multipliers.checked_add(words)?;
        let shift_padding = shifts.checked_add(outputs)?;
        let weights = shifts.checked_add(outputs.checked_next_multiple_of(4)?)?;
        let weight_bytes = inputs.checked_mul(outputs)?;
        let weight_padding = weights.checked_add(weight_bytes)?;
        let bias = weights.checked_add(weight_bytes.checked_next_multiple_of(4)?)?;
        let after_bias = bias.checked_add(words)?;
        let (table, end) = if table {
            (Some(after_bias), after_bias.checked_add(TABLE_LEN)?)
        } else {
            (None, after_bias)
        };
        Some(IntegerLayer {
            inputs,
            outputs,
            zero: start,
            multipliers,
            shifts,
            shift_padding,
            weights,
            weight_padding,
            bias,
            table,
            end,
        })
    }

    /// The layer's parts in `payload` (the verified integer payload it was laid out in), as
    /// the integer forward pass reads them. A layer without a table is a ReLU layer when `relu`
    /// (a hidden layer of a ReLU network), whose clamp starts at its zero point: the fused
    /// ReLU. Parts past the payload's end read as empty (a verified payload holds them all).
    pub fn dense<'a>(&self, payload: &'a [u8], relu: bool) -> IntegerDense<'a> {
        let part = |from: usize, to: usize| payload.get(from..to).unwrap_or_default();
        let output_zero = part(self.zero, self.zero + 4)
            .try_into()
            .map_or(0, i32::from_le_bytes);
        let table = self.table.map(|at| part(at, at + TABLE_LEN));
        IntegerDense {
            multipliers: part(self.multipliers, self.shifts),
            shifts: part(self.shifts, self.shift_padding),
            weights: part(self.weights, self.weight_padding),
            bias: part(self.bias, self.bias + 4 * self.outputs),
            output_zero,
            lower: if relu && table.is_none() {
                output_zero
            } else {
                -128
            },
            table,
        }
    }
}

/// Whether layer `l` (of `depth` hidden layers and the output layer) ends in a tanh table: every
/// hidden layer of a tanh network, and the output layer, which an actor always squashes.
pub fn has_table(l: usize, depth: usize, activation: Activation) -> bool {
    l >= depth || activation == Activation::Tanh
}

/// The input block and every layer of an integer actor, in payload order; `None` for another
/// kind or a layout that overflows. `visit` is called with each layer's index and layout.
pub fn layers(
    kind: ModelKind,
    shape: Shape,
    activation: Activation,
    mut visit: impl FnMut(usize, IntegerLayer),
) -> Option<(IntegerInput, usize)> {
    if kind != ModelKind::Actor {
        return None;
    }
    let prefix = shape.prefix_count(kind).checked_mul(4)?;
    let input = IntegerInput::of(shape.observations as usize, prefix)?;
    let depth = shape.depth as usize;
    let mut at = input.end;
    let mut l = 0;
    while let Some((inputs, outputs)) = shape.layer(kind, l) {
        let layer = IntegerLayer::of(inputs, outputs, has_table(l, depth, activation), at)?;
        visit(l, layer);
        at = layer.end;
        l += 1;
    }
    Some((input, at))
}

/// Bytes of an integer payload: the f32 prefix, the input block and every layer.
pub(crate) fn payload_len(kind: ModelKind, shape: Shape, activation: Activation) -> Option<usize> {
    shape.param_count(kind)?; // the same overflow checks as every encoding
    layers(kind, shape, activation, |_, _| {}).map(|(_, end)| end)
}
