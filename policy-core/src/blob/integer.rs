//! The integer encoding's parameters: the rules they obey (step 14 of the loading table for a
//! version-4 blob) and the writer that makes them from f32 parameters and calibrated ranges
//! (docs/blob-format.md, "The integer encoding").
//!
//! Quantisation follows TensorFlow Lite's int8 scheme: symmetric int8 weights with one scale per
//! output channel, int32 biases in the accumulator's scale, int8 activations with a scale and a
//! zero point per layer (0.0 exactly representable), and the real multiplier
//! `s_in · s_w[o] / s_out` of each output stored as TFLite's `QuantizeMultiplier` stores it: a
//! Q31 mantissa in `[2^30, 2^31)` and a shift.

use super::params::floats;
use crate::crc32::crc32;
use crate::error::Error;
use crate::format::{Encoding, Header, ModelKind, Params, Spec, CRC_LEN};
use crate::integer_layout::{self, has_table, IntegerInput, IntegerLayer, TABLE_LEN};
use crate::mlp::activation::Activation;

/// The largest |bias| the loader accepts: with it, no accumulator can overflow (see
/// [`crate::mlp::integer`]).
pub const MAX_BIAS: i32 = 1 << 30;
/// The smallest requantisation multiplier mantissa (0.5 in Q31).
pub const MIN_MULTIPLIER: i32 = 1 << 30;
/// The smallest requantisation shift; the largest is 0 (a real multiplier below 1).
pub const MIN_SHIFT: i32 = -31;
/// A tanh layer's input range is cut to `±TANH_RANGE`: past it `127 · tanh` rounds to ±127
/// anyway (from 3.07 on), so a wider range would only coarsen the codes that matter.
pub const TANH_RANGE: f32 = 4.0;

fn i32_at(payload: &[u8], at: usize) -> i32 {
    payload
        .get(at..at + 4)
        .and_then(|b| <[u8; 4]>::try_from(b).ok())
        .map_or(0, i32::from_le_bytes)
}

fn f32_at(payload: &[u8], at: usize) -> f32 {
    f32::from_bits(i32_at(payload, at) as u32)
}

fn invalid(what: &'static str, index: usize) -> Error {
    Error::InvalidParameter { what, index }
}

/// Step 14 for a version-4 blob, in payload order: the f32 prefix finite
/// (`NonFiniteParameter`, index = parameter), then the input block and every layer's fields,
/// each refused with `InvalidParameter` (index = observation, output or table entry; a layer's
/// zero point: the layer) or, for padding that is not zero, `Malformed`.
pub(super) fn check(h: &Header, payload: &[u8]) -> Result<(), Error> {
    let prefix = h.shape.prefix_count(h.kind);
    if let Some(index) = floats(payload, 0, prefix).position(|v| !v.is_finite()) {
        return Err(Error::NonFiniteParameter { index });
    }
    let malformed = Error::Malformed {
        what: "integer layout does not fit in memory",
    };
    let (input, _) =
        integer_layout::layers(h.kind, h.shape, h.activation, |_, _| {}).ok_or(malformed)?;
    check_input(payload, &input)?;
    let mut failure: Option<Error> = None;
    integer_layout::layers(h.kind, h.shape, h.activation, |l, layer| {
        if failure.is_none() {
            failure = check_layer(payload, l, &layer).err();
        }
    });
    failure.map_or(Ok(()), Err)
}

/// The input block: scales positive, normal and finite (a zero scale would ignore an
/// observation, a subnormal one lose its precision), offsets finite, the zero point an int8.
fn check_input(payload: &[u8], input: &IntegerInput) -> Result<(), Error> {
    let n = input.observations;
    let scales = floats(payload, input.scales / 4, n);
    if let Some(i) = scales.into_iter().position(|s| !(s.is_normal() && s > 0.0)) {
        return Err(invalid(
            "input scale that is not a positive normal finite number",
            i,
        ));
    }
    let offsets = floats(payload, input.offsets / 4, n);
    if let Some(i) = offsets.into_iter().position(|o| !o.is_finite()) {
        return Err(invalid("input offset that is not finite", i));
    }
    if !(-128..=127).contains(&i32_at(payload, input.zero)) {
        return Err(invalid("input zero point outside -128..=127", 0));
    }
    Ok(())
}

/// One layer's fields in payload order: zero point, multipliers, shifts, shift padding, weight
/// padding, biases, table.
fn check_layer(payload: &[u8], l: usize, layer: &IntegerLayer) -> Result<(), Error> {
    if !(-128..=127).contains(&i32_at(payload, layer.zero)) {
        return Err(invalid("layer output zero point outside -128..=127", l));
    }
    for o in 0..layer.outputs {
        if i32_at(payload, layer.multipliers + 4 * o) < MIN_MULTIPLIER {
            return Err(invalid(
                "requantisation multiplier outside 2^30..=2^31-1",
                o,
            ));
        }
    }
    let shifts = payload
        .get(layer.shifts..layer.shift_padding)
        .unwrap_or_default();
    if let Some(o) = shifts
        .iter()
        .position(|&s| !(MIN_SHIFT..=0).contains(&i32::from(s as i8)))
    {
        return Err(invalid("requantisation shift outside -31..=0", o));
    }
    let zero = |from: usize, to: usize| payload.get(from..to).unwrap_or_default();
    if zero(layer.shift_padding, layer.weights)
        .iter()
        .chain(zero(layer.weight_padding, layer.bias))
        .any(|&b| b != 0)
    {
        return Err(Error::Malformed {
            what: "padding after a layer's shifts or weights is not zero",
        });
    }
    for o in 0..layer.outputs {
        if !(-MAX_BIAS..=MAX_BIAS).contains(&i32_at(payload, layer.bias + 4 * o)) {
            return Err(invalid("bias outside -2^30..=2^30", o));
        }
    }
    if let Some(at) = layer.table {
        check_table(payload.get(at..at + TABLE_LEN).unwrap_or_default())?;
    }
    Ok(())
}

/// A tanh table: unit codes in `-127..=127` (so `code / 127` is in `[-1, 1]`), non-decreasing
/// as tanh is.
fn check_table(table: &[u8]) -> Result<(), Error> {
    let mut previous = -127;
    for (k, &t) in table.iter().enumerate() {
        let t = i32::from(t as i8);
        if t < -127 {
            return Err(invalid("table entry -128 (unit codes are -127..=127)", k));
        }
        if t < previous {
            return Err(invalid("table entry below the one before it", k));
        }
        previous = t;
    }
    Ok(())
}

// ------------------------------------------------------------------------------------------
// Writing.

/// An int8 quantisation: `real = scale · (code − zero)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantisation {
    /// Real value of one code step (> 0).
    pub scale: f64,
    /// The code of 0.0, in `-128..=127`.
    pub zero: i32,
}

impl Quantisation {
    /// TFLite's asymmetric int8 quantisation of `[lo, hi]` (widened to hold 0): 255 steps, the
    /// zero point rounded so that 0.0 is a code. `None` for an empty range.
    fn of_range(lo: f64, hi: f64) -> Option<Quantisation> {
        let (lo, hi) = (lo.min(0.0), hi.max(0.0));
        let scale = (hi - lo) / 255.0;
        if !(scale > 0.0 && scale.is_finite()) {
            return None;
        }
        Some(Quantisation {
            scale,
            zero: Self::zero_for(lo, scale),
        })
    }

    fn zero_for(lo: f64, scale: f64) -> i32 {
        libm::round(-128.0 - lo / scale).clamp(-128.0, 127.0) as i32
    }

    /// The codes of a tanh table's output: `u = code / 127`.
    const UNIT: Quantisation = Quantisation {
        scale: 1.0 / 127.0,
        zero: 0,
    };
}

/// TFLite's `QuantizeMultiplier`: `real = multiplier · 2^(shift − 31)` with the multiplier in
/// `[2^30, 2^31)`. `None` unless `real` is in `[2^-32, 1)` less a rounding margin, the range the
/// format stores (shifts `-31..=0`).
fn quantize_multiplier(real: f64) -> Option<(i32, i32)> {
    let (fraction, mut shift) = libm::frexp(real);
    let mut q = libm::round(fraction * (1u64 << 31) as f64) as i64;
    if q == 1 << 31 {
        q /= 2;
        shift += 1;
    }
    let fits = (i64::from(MIN_MULTIPLIER)..=i64::from(i32::MAX)).contains(&q)
        && (MIN_SHIFT..=0).contains(&shift);
    fits.then_some((q as i32, shift))
}

/// What the writer chose for one layer.
#[derive(Clone, Copy, Debug, Default)]
struct LayerChoice {
    /// The input codes' quantisation.
    input: Option<Quantisation>,
    /// The output codes' (pre-table) quantisation.
    output: Option<Quantisation>,
}

/// The most layers an integer blob has: `MAX_DEPTH` hidden layers and the output layer.
const MAX_LAYERS: usize = super::limits::MAX_DEPTH + 1;

/// Margin that keeps every real multiplier below 1 after rounding to Q31.
const MULTIPLIER_MARGIN: f64 = 1.0 + 1.0 / (1u64 << 20) as f64;

/// Where parameter `n` (in blob order) of an integer actor goes.
#[derive(Clone, Copy, Debug)]
enum Place {
    /// An f32 of the prefix, at this byte offset.
    Prefix(usize),
    /// Weight `i` (column-major) of layer `l`.
    Weight(usize, IntegerLayer, usize),
    /// Bias `o` of layer `l`.
    Bias(usize, IntegerLayer, usize),
}

fn locate(spec: &Spec<'_>, n: usize) -> Option<Place> {
    let prefix = spec.shape.prefix_count(spec.kind);
    if n < prefix {
        return Some(Place::Prefix(4 * n));
    }
    let mut first = prefix;
    let mut found = None;
    integer_layout::layers(spec.kind, spec.shape, spec.activation, |l, layer| {
        let weights = layer.inputs * layer.outputs;
        if found.is_none() && n >= first {
            if n < first + weights {
                found = Some(Place::Weight(l, layer, n - first));
            } else if n < first + weights + layer.outputs {
                found = Some(Place::Bias(l, layer, n - first - weights));
            }
        }
        first += weights + layer.outputs;
    })?;
    found
}

/// Writes the blob of an integer actor into `out` from its spec (kind actor, encoding
/// [`Encoding::Integer`]), the calibrated ranges and its f32 parameters in blob order (as
/// [`write()`](super::write()) takes them); returns the number of bytes written.
///
/// `ranges` holds `depth + 2` closed intervals, as observed on states the policy visits: first
/// the normalised observations' (all components together), then each layer's pre-activation
/// outputs', hidden layers then the output layer. Each is widened to hold 0; a ReLU layer's is
/// cut below at 0 (its codes are the fused ReLU's outputs), a tanh layer's (every layer of a
/// tanh actor, the output layer of any actor) to `±`[`TANH_RANGE`], the input's to the
/// normaliser's clip. A range that is then empty is [`Error::Calibration`] with its index in
/// `ranges`; so is a NaN, an infinity or `lo > hi`.
///
/// Per output channel `o`: `s_w = max_j |W[o, j]| / 127`, `q = round(W / s_w)` (ties away from
/// zero), `bias = round(b / (s_in · s_w))` clamped to ±2³⁰, and the multiplier of
/// `s_in · s_w / s_out`; a layer's output scale is widened, if need be, to keep every multiplier
/// below 1, and an output whose multiplier would be below 2⁻³¹ (or whose weights are all 0)
/// gets zero weights and the multiplier 0.5.
///
/// ```
/// use policy_core::{blob::{self, Spec}, model::Model, Activation, Encoding, ModelKind, Shape};
/// let shape = Shape { observations: 1, actions: 1, width: 2, depth: 1, choices: 0 };
/// let spec = Spec { kind: ModelKind::Actor, encoding: Encoding::Integer, shape, activation: Activation::Tanh, label: "tiny" };
/// let params = [0.5, 2.0, 5.0, -0.25, 0.25, 1.0, -1.0, 0.0, 0.5, 0.75, -0.5, 0.125];
/// let ranges = [(-1.0, 1.0), (-1.0, 1.5), (-0.5, 0.9)];
/// let mut out = [0u8; 1024];
/// let n = blob::write_integer(&spec, &ranges, &mut |sink| sink(&params), &mut out).unwrap();
/// let model = Model::from_blob(&out[..n]).unwrap();
/// let mut action = [0.0f32];
/// model.act(&[1.0], &mut policy_core::model::Scratch::<2>::new(), &mut action).unwrap();
/// assert!((action[0] - 0.18233).abs() < 0.005); // the f32 actor's 0.18233
/// ```
pub fn write_integer(
    spec: &Spec<'_>,
    ranges: &[(f32, f32)],
    params: &mut Params<'_>,
    out: &mut [u8],
) -> Result<usize, Error> {
    if spec.kind != ModelKind::Actor {
        return Err(Error::WrongKind {
            expected: ModelKind::Actor,
            found: spec.kind,
        });
    }
    if spec.encoding != Encoding::Integer {
        return Err(Error::WrongEncoding {
            expected: Encoding::Integer,
            found: spec.encoding,
        });
    }
    let depth = spec.shape.depth as usize;
    if ranges.len() != depth + 2 {
        return Err(Error::Calibration {
            what: "expected one range for the input and one per layer (depth + 2)",
            index: ranges.len(),
        });
    }
    if let Some(i) = ranges
        .iter()
        .position(|&(lo, hi)| !(lo.is_finite() && hi.is_finite() && lo <= hi))
    {
        return Err(Error::Calibration {
            what: "a range with a NaN or infinite end, or low above high",
            index: i,
        });
    }
    let (needed, header_len) = super::write::header_into(spec, out)?;
    let Some((body, crc)) = out
        .get_mut(..needed)
        .and_then(|o| o.split_last_chunk_mut::<CRC_LEN>())
    else {
        return Err(Error::Malformed {
            what: "header longer than the blob",
        });
    };
    let payload = body.get_mut(header_len..).unwrap_or_default();
    payload.fill(0);
    gather(spec, params, payload)?;
    let mut choices = [LayerChoice::default(); MAX_LAYERS];
    let input = choose_quantisations(spec, ranges, payload, &mut choices)?;
    quantise_layers(spec, params, payload, &choices)?;
    finish(spec, payload, &choices, input)?;
    *crc = crc32(body).to_le_bytes();
    Ok(needed)
}

/// Pass 1: the prefix into place, each output's largest |weight| into its multiplier slot and
/// each bias (as f32 bits) into its bias slot, for the passes that follow.
fn gather(spec: &Spec<'_>, params: &mut Params<'_>, payload: &mut [u8]) -> Result<(), Error> {
    let mismatch = Error::Malformed {
        what: "parameters do not match the declared shape",
    };
    let mut failure: Option<Error> = None;
    let mut n = 0usize;
    params(&mut |src| {
        for &v in src {
            if !v.is_finite() && failure.is_none() {
                failure = Some(Error::NonFiniteParameter { index: n });
            }
            match locate(spec, n) {
                Some(Place::Prefix(at)) => put(payload, at, v.to_bits()),
                Some(Place::Weight(_, layer, i)) => {
                    let at = layer.multipliers + 4 * (i % layer.outputs);
                    let largest = f32_at(payload, at).max(v.abs());
                    put(payload, at, largest.to_bits());
                }
                Some(Place::Bias(_, layer, o)) => put(payload, layer.bias + 4 * o, v.to_bits()),
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

fn put(payload: &mut [u8], at: usize, bits: u32) {
    if let Some(dst) = payload.get_mut(at..at + 4) {
        dst.copy_from_slice(&bits.to_le_bytes());
    }
}

/// Every layer's input and output quantisation from the ranges (and the weights' maxima, for
/// the widening that keeps multipliers below 1); returns the input's.
fn choose_quantisations(
    spec: &Spec<'_>,
    ranges: &[(f32, f32)],
    payload: &[u8],
    choices: &mut [LayerChoice; MAX_LAYERS],
) -> Result<Quantisation, Error> {
    let empty = |index| {
        Error::Calibration {
        what: "a range that is empty once widened to 0 and cut (a layer whose outputs are all equal, or a ReLU layer never positive)",
        index,
    }
    };
    let s = spec.shape.observations as usize;
    let clip = f64::from(f32_at(payload, 4 * 2 * s));
    let (lo, hi) = ranges.first().copied().unwrap_or_default();
    let input = Quantisation::of_range(f64::from(lo).max(-clip), f64::from(hi).min(clip))
        .ok_or(empty(0))?;
    let depth = spec.shape.depth as usize;
    let mut x = input;
    let mut failure = None;
    integer_layout::layers(spec.kind, spec.shape, spec.activation, |l, layer| {
        let (lo, hi) = ranges.get(l + 1).copied().unwrap_or_default();
        let (mut lo, mut hi) = (f64::from(lo), f64::from(hi));
        if has_table(l, depth, spec.activation) {
            let r = f64::from(TANH_RANGE);
            (lo, hi) = (lo.max(-r), hi.min(r));
        } else if spec.activation == Activation::Relu {
            lo = 0.0;
        }
        let Some(mut y) = Quantisation::of_range(lo, hi) else {
            failure = failure.or(Some(empty(l + 1)));
            return;
        };
        let widest = (0..layer.outputs)
            .map(|o| f64::from(f32_at(payload, layer.multipliers + 4 * o)) / 127.0)
            .fold(0.0, f64::max);
        let needed = x.scale * widest * MULTIPLIER_MARGIN;
        if y.scale < needed {
            y = Quantisation {
                scale: needed,
                zero: Quantisation::zero_for(lo.min(0.0), needed),
            };
        }
        if let Some(c) = choices.get_mut(l) {
            *c = LayerChoice {
                input: Some(x),
                output: Some(y),
            };
        }
        x = if layer.table.is_some() {
            Quantisation::UNIT
        } else {
            y
        };
    });
    failure.map_or(Ok(input), Err)
}

/// Output `o`'s weight scale from its largest |weight|, or `None` for an output quantised to
/// zero weights (all zero, or a multiplier below 2⁻³¹).
fn weight_scale(largest: f32, c: &LayerChoice) -> Option<f64> {
    let (x, y) = (c.input?, c.output?);
    let s_w = f64::from(largest) / 127.0;
    let real = x.scale * s_w / y.scale;
    (largest > 0.0 && real >= 1.0 / (1u64 << 31) as f64).then_some(s_w)
}

/// The weight scale an output quantised to zero weights stands for: its multiplier is 0.5.
fn zero_row_scale(c: &LayerChoice) -> f64 {
    match (c.input, c.output) {
        (Some(x), Some(y)) => 0.5 * y.scale / x.scale,
        _ => 1.0,
    }
}

/// Pass 2: weights to int8 and biases to int32, reading each output's largest |weight| from its
/// multiplier slot.
fn quantise_layers(
    spec: &Spec<'_>,
    params: &mut Params<'_>,
    payload: &mut [u8],
    choices: &[LayerChoice; MAX_LAYERS],
) -> Result<(), Error> {
    let mut n = 0usize;
    params(&mut |src| {
        for &v in src {
            match locate(spec, n) {
                Some(Place::Weight(l, layer, i)) => {
                    let c = choices.get(l).copied().unwrap_or_default();
                    let largest = f32_at(payload, layer.multipliers + 4 * (i % layer.outputs));
                    let q = weight_scale(largest, &c).map_or(0.0, |s_w| {
                        libm::round(f64::from(v) / s_w).clamp(-127.0, 127.0)
                    });
                    if let Some(dst) = payload.get_mut(layer.weights + i) {
                        *dst = q as i8 as u8;
                    }
                }
                Some(Place::Bias(l, layer, o)) => {
                    let c = choices.get(l).copied().unwrap_or_default();
                    let largest = f32_at(payload, layer.multipliers + 4 * o);
                    let s_w = weight_scale(largest, &c).unwrap_or_else(|| zero_row_scale(&c));
                    let s_in = c.input.map_or(1.0, |x| x.scale);
                    let bound = f64::from(MAX_BIAS);
                    let b = libm::round(f64::from(v) / (s_in * s_w)).clamp(-bound, bound);
                    put(payload, layer.bias + 4 * o, b as i32 as u32);
                }
                Some(Place::Prefix(_)) | None => {}
            }
            n += 1;
        }
    });
    Ok(())
}

/// Pass 3: multipliers, shifts, zero points, tables and the folded input quantisation.
fn finish(
    spec: &Spec<'_>,
    payload: &mut [u8],
    choices: &[LayerChoice; MAX_LAYERS],
    input: Quantisation,
) -> Result<(), Error> {
    let mut failure = None;
    let (block, _) = integer_layout::layers(spec.kind, spec.shape, spec.activation, |l, layer| {
        let c = choices.get(l).copied().unwrap_or_default();
        let (Some(x), Some(y)) = (c.input, c.output) else {
            return;
        };
        put(payload, layer.zero, y.zero as u32);
        for o in 0..layer.outputs {
            let largest = f32_at(payload, layer.multipliers + 4 * o);
            let s_w = weight_scale(largest, &c).unwrap_or_else(|| zero_row_scale(&c));
            match quantize_multiplier(x.scale * s_w / y.scale) {
                Some((m, shift)) => {
                    put(payload, layer.multipliers + 4 * o, m as u32);
                    if let Some(dst) = payload.get_mut(layer.shifts + o) {
                        *dst = shift as i8 as u8;
                    }
                }
                None => {
                    failure = failure.or(Some(Error::Calibration {
                        what: "a requantisation multiplier outside the format's range",
                        index: l + 1,
                    }))
                }
            }
        }
        if let Some(at) = layer.table {
            for (k, dst) in payload
                .get_mut(at..at + TABLE_LEN)
                .unwrap_or_default()
                .iter_mut()
                .enumerate()
            {
                *dst = tanh_entry(k, y) as u8;
            }
        }
    })
    .ok_or(Error::Malformed {
        what: "integer layout does not fit in memory",
    })?;
    if let Some(e) = failure {
        return Err(e);
    }
    fold_normaliser(payload, &block, input)
}

/// Entry `k` of the tanh table of a layer whose output codes have quantisation `y`: the unit
/// code `round(127 · tanh(y.scale · (k − 128 − y.zero)))`, within ±127.
pub fn tanh_entry(k: usize, y: Quantisation) -> i8 {
    let code = k as f64 - 128.0;
    let u = libm::tanh(y.scale * (code - f64::from(y.zero)));
    libm::round(127.0 * u).clamp(-127.0, 127.0) as i8
}

/// The input block: per observation `scale = inv_std / s_in` and `offset = zero − mean · scale`,
/// so `round(x · scale + offset)` is the code of the normalised observation; then the zero point.
fn fold_normaliser(
    payload: &mut [u8],
    block: &IntegerInput,
    input: Quantisation,
) -> Result<(), Error> {
    let s = block.observations;
    for i in 0..s {
        let mean = f64::from(f32_at(payload, 4 * i));
        let inv_std = f64::from(f32_at(payload, 4 * (s + i)));
        let scale = (inv_std / input.scale) as f32;
        let offset = (f64::from(input.zero) - mean * inv_std / input.scale) as f32;
        if !(scale.is_normal() && scale > 0.0) {
            return Err(invalid(
                "an observation whose input scale inv_std / s_in is not a positive normal f32 (inv_std 0?)",
                i,
            ));
        }
        if !offset.is_finite() {
            return Err(invalid(
                "an observation whose input offset overflows f32",
                i,
            ));
        }
        put(payload, block.scales + 4 * i, scale.to_bits());
        put(payload, block.offsets + 4 * i, offset.to_bits());
    }
    put(payload, block.zero, input.zero as u32);
    Ok(())
}

/// The quantisations a written integer blob stands for, as the writer chose them, read back
/// from its fields for people (inspect): per layer the real multipliers `m · 2^(shift − 31)`.
pub fn real_multiplier(multiplier: i32, shift: i32) -> f64 {
    f64::from(multiplier) * libm::exp2(f64::from(shift) - 31.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantize_multiplier_is_tflites() {
        assert_eq!(quantize_multiplier(0.5), Some((1 << 30, 0)));
        assert_eq!(quantize_multiplier(0.75), Some((3 << 29, 0)));
        assert_eq!(quantize_multiplier(0.1875), Some((3 << 29, -2)));
        // A mantissa that rounds up to 2^31 moves to the next power of two (TFLite's rule).
        let just_below_half = 0.5 - 1e-12;
        assert_eq!(quantize_multiplier(just_below_half), Some((1 << 30, 0)));
        assert_eq!(quantize_multiplier(1.0), None);
        assert_eq!(quantize_multiplier(1e-12), None);
        let (m, s) = quantize_multiplier(0.3).expect("in range");
        assert!((real_multiplier(m, s) - 0.3).abs() < 1e-9);
    }

    #[test]
    fn a_range_holds_zero_exactly() {
        let q = Quantisation::of_range(0.3, 2.0).expect("a range");
        assert_eq!(q.zero, -128);
        let q = Quantisation::of_range(-1.0, 3.0).expect("a range");
        assert!((q.scale * f64::from(0 - q.zero) - 1.0).abs() < q.scale);
        assert_eq!(Quantisation::of_range(0.0, 0.0), None);
    }

    #[test]
    fn tanh_tables_are_monotone_unit_codes() {
        let y = Quantisation {
            scale: 8.0 / 255.0,
            zero: 0,
        };
        let table: Vec<u8> = (0..TABLE_LEN).map(|k| tanh_entry(k, y) as u8).collect();
        assert_eq!(check_table(&table), Ok(()));
        assert_eq!(tanh_entry(128, y), 0);
        assert_eq!((tanh_entry(0, y), tanh_entry(255, y)), (-127, 127));
    }
}
