//! A verified payload's parameters: the rules they obey (checked once, at load) and their values
//! decoded in blob order. The runtime [`Model`](crate::model::Model), the compiled types'
//! loader ([`load_into`](crate::blob::load_into)) and `encode` all go through these, so they accept
//! exactly the same blobs and read the same numbers.

use super::read::payload_values;
use crate::error::Error;
use crate::format::{Encoding, Header, LayerLayout, ModelKind};
use crate::half::f16_to_f32;
use crate::{bounds, normalizer};

/// The parameter rules: finite values (for quantised weights: finite f16 values, usable int8
/// scales, zero padding), then the normaliser's and the bounds' own rules (`normalizer::check`,
/// `bounds::check`, shared with the compiled types), and an action table inside the bounds.
///
/// ```
/// use policy_core::{blob, Error};
/// static BLOB: &[u8] = include_bytes!("../../tests/golden/actor_2x32.postcard");
/// let v = blob::verify(BLOB).unwrap();
/// assert_eq!(blob::check_parameters(&v.header, v.payload), Ok(()));
/// ```
pub fn check_parameters(header: &Header, payload: &[u8]) -> Result<(), Error> {
    // One dispatch on the encoding, the ones this build leaves out refused in it (`verify` refused
    // such a blob already; a caller that built the header itself is refused too): 40 B smaller
    // at opt-level "z" than a separate `is_compiled` test before it.
    let e = header.encoding;
    if e == Encoding::F32 && cfg!(feature = "f32") {
        let mut values = payload_values(payload);
        if let Some(index) = values.position(|v| !v.is_finite()) {
            return Err(Error::NonFiniteParameter { index });
        }
    } else if e == Encoding::Integer && cfg!(feature = "integer") {
        super::integer::check(header, payload)?;
    } else if (e == Encoding::F16 && cfg!(feature = "f16"))
        || (e == Encoding::Int8 && cfg!(feature = "int8"))
    {
        check_quantised(header, payload)?;
    } else {
        return Err(Error::EncodingNotCompiled { found: e });
    }
    let p = Prefix::of(header);
    let s = p.observations;
    normalizer::check(
        floats(payload, 0, s),
        floats(payload, s, s),
        floats(payload, 2 * s, 1).next().unwrap_or(0.0),
    )?;
    if header.kind == ModelKind::Critic {
        return Ok(());
    }
    bounds::check(
        floats(payload, p.bounds, p.actions),
        floats(payload, p.bounds + p.actions, p.actions),
    )?;
    if header.kind == ModelKind::Discrete {
        check_table(header, payload)?;
    }
    Ok(())
}

/// Every parameter, in blob order, decoded: an f16 weight as its exact f32 value, an int8
/// weight as `scale · q` (the value the layer's arithmetic stands for; it computes
/// `scale · Σ q x` instead), everything else as stored. An [`Encoding::Integer`] blob's f32
/// parameters are its prefix (normaliser, bounds) only: its layers are integers, which
/// [`IntegerLayer`](crate::blob::IntegerLayer) locates.
///
/// ```
/// use policy_core::blob;
/// static BLOB: &[u8] = include_bytes!("../../tests/golden/actor_2x32.postcard");
/// let v = blob::verify(BLOB).unwrap();
/// assert_eq!(blob::values(&v.header, v.payload).nth(4), Some(5.0)); // the normaliser's clip
/// ```
pub fn values<'a>(header: &Header, payload: &'a [u8]) -> impl Iterator<Item = f32> + 'a {
    let (kind, shape, encoding) = (header.kind, header.shape, header.encoding);
    let quantised = encoding != Encoding::F32;
    let prefix = 4 * shape.prefix_count(kind);
    // f32: the payload as it is. Quantised: the f32 prefix, then layer by layer.
    let head = if quantised {
        payload.get(..prefix).unwrap_or_default()
    } else {
        payload
    };
    let layers = if quantised && encoding != Encoding::Integer {
        shape.depth as usize + 1
    } else {
        0
    };
    let mut start = prefix;
    payload_values(head).chain((0..layers).flat_map(move |l| {
        let (inputs, outputs) = shape.layer(kind, l).unwrap_or((0, 0));
        let layer = LayerLayout::of(encoding, inputs, outputs, start);
        start = layer.map_or(start, |x| x.end);
        layer_values(payload, encoding, layer)
    }))
}

/// Where the parts before the first layer start, in parameters from the payload's start.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Prefix {
    /// Observation size (the normaliser holds `2 · observations + 1` values).
    pub(crate) observations: usize,
    /// Action size.
    pub(crate) actions: usize,
    /// Offset of the action bounds (actor, discrete): low then high.
    pub(crate) bounds: usize,
    /// Offset of the action table (discrete): one row of `actions` values per choice.
    pub(crate) table: usize,
}

impl Prefix {
    pub(crate) fn of(header: &Header) -> Prefix {
        let (observations, actions) = (
            header.shape.observations as usize,
            header.shape.actions as usize,
        );
        let bounds = 2 * observations + 1;
        Prefix {
            observations,
            actions,
            bounds,
            table: bounds + 2 * actions,
        }
    }
}

/// `len` f32 parameters from parameter `index` (nothing past the end, which verified layouts
/// never reach).
pub(crate) fn floats(payload: &[u8], index: usize, len: usize) -> impl Iterator<Item = f32> + '_ {
    payload_values(
        payload
            .get(4 * index..4 * (index + len))
            .unwrap_or_default(),
    )
}

/// The f32 at byte `at` of the payload (0.0 past the end, which verified layouts never reach).
fn f32_at(payload: &[u8], at: usize) -> f32 {
    payload
        .get(at..at + 4)
        .and_then(|b| <[u8; 4]>::try_from(b).ok())
        .map_or(0.0, f32::from_le_bytes)
}

/// A quantised blob's parameters, layer by layer without decoding into a list: the f32
/// prefix and biases finite, every f16 weight finite, every int8 scale a positive number
/// small enough that `scale · q` stays finite (zero would silence an output, a negative one
/// flip it), and the padding after each layer's weights zero, so that one model has one
/// encoding. `NonFiniteParameter` indices count parameters in blob order, as [`values`] lists
/// them.
fn check_quantised(h: &Header, payload: &[u8]) -> Result<(), Error> {
    let non_finite = |index| Error::NonFiniteParameter { index };
    let prefix = h.shape.prefix_count(h.kind);
    let mut head = payload_values(payload.get(..4 * prefix).unwrap_or_default());
    if let Some(index) = head.position(|v| !v.is_finite()) {
        return Err(non_finite(index));
    }
    let (mut at, mut first, mut l) = (4 * prefix, prefix, 0);
    while let Some((inputs, outputs)) = h.shape.layer(h.kind, l) {
        let layer = LayerLayout::of(h.encoding, inputs, outputs, at).ok_or(Error::Malformed {
            what: "layer does not fit in memory",
        })?;
        let weights = payload
            .get(layer.weights..layer.padding)
            .unwrap_or_default();
        // The `cfg!` guards let the optimiser drop the checks of encodings this build does not
        // read (`check_parameters` refused those blobs before calling this).
        match h.encoding {
            Encoding::Int8 if cfg!(feature = "int8") => {
                for o in 0..outputs {
                    let scale = f32_at(payload, layer.scales + 4 * o);
                    // Every decoded weight `scale · q` (|q| ≤ 128) must be finite too.
                    if !(scale * 128.0).is_finite() || scale <= 0.0 {
                        return Err(Error::InvalidParameter {
                            what: "int8 scale that is not a positive number below f32::MAX / 128",
                            index: o,
                        });
                    }
                }
            }
            Encoding::F16 if cfg!(feature = "f16") => {
                let mut halves = weights.chunks_exact(2);
                let bad =
                    halves.position(|p| !f16_to_f32(u16::from_le_bytes([p[0], p[1]])).is_finite());
                if let Some(i) = bad {
                    return Err(non_finite(first + i));
                }
            }
            Encoding::Int8 | Encoding::F16 | Encoding::F32 | Encoding::Integer => {}
        }
        let mut bias = payload_values(payload.get(layer.bias..layer.end).unwrap_or_default());
        if let Some(o) = bias.position(|v| !v.is_finite()) {
            return Err(non_finite(first + inputs * outputs + o));
        }
        let padding = payload.get(layer.padding..layer.bias).unwrap_or_default();
        if padding.iter().any(|&b| b != 0) {
            return Err(Error::Malformed {
                what: "padding after a layer's weights is not zero",
            });
        }
        at = layer.end;
        first += inputs * outputs + outputs;
        l += 1;
    }
    Ok(())
}

/// Every row of a discrete policy's action table lies inside its bounds.
fn check_table(h: &Header, payload: &[u8]) -> Result<(), Error> {
    let p = Prefix::of(h);
    let outputs = h.shape.outputs(h.kind);
    for row in 0..outputs {
        let low = floats(payload, p.bounds, p.actions);
        let high = floats(payload, p.bounds + p.actions, p.actions);
        let inside = floats(payload, p.table + row * p.actions, p.actions)
            .zip(low.zip(high))
            .all(|(v, (lo, hi))| lo <= v && v <= hi);
        if !inside {
            return Err(Error::InvalidParameter {
                what: "action-table row outside the action bounds",
                index: row,
            });
        }
    }
    Ok(())
}

/// One layer's parameters decoded, in blob order (weights, then biases); nothing for a layer
/// that does not fit (verified blobs always fit).
fn layer_values(
    payload: &[u8],
    encoding: Encoding,
    layer: Option<LayerLayout>,
) -> impl Iterator<Item = f32> + '_ {
    let (weights, outputs, l) = match layer {
        Some(l) => (l.inputs * l.outputs, l.outputs.max(1), Some(l)),
        None => (0, 1, None),
    };
    let byte = move |at: usize| payload.get(at).copied().unwrap_or(0);
    let word =
        move |at: usize| f32::from_le_bytes([byte(at), byte(at + 1), byte(at + 2), byte(at + 3)]);
    let (w0, s0, bias, end) = l.map_or((0, 0, 0, 0), |l| (l.weights, l.scales, l.bias, l.end));
    (0..weights)
        // An encoding this build does not read never gets here (refused at `verify`); its
        // `cfg!`-guarded arm is dropped from the binary, and the fallback arm is never taken.
        .map(move |i| match encoding {
            Encoding::F32 if cfg!(feature = "f32") => word(w0 + 4 * i),
            Encoding::F16 if cfg!(feature = "f16") => {
                f16_to_f32(u16::from_le_bytes([byte(w0 + 2 * i), byte(w0 + 2 * i + 1)]))
            }
            Encoding::Int8 if cfg!(feature = "int8") => {
                word(s0 + 4 * (i % outputs)) * f32::from(byte(w0 + i) as i8)
            }
            Encoding::F32 | Encoding::F16 | Encoding::Int8 | Encoding::Integer => 0.0,
        })
        .chain(payload_values(payload.get(bias..end).unwrap_or_default()))
}
