//! Quantising f32 weights into a payload of another [`Encoding`]: f16 (nearest, ties to even)
//! or int8 (one scale per output, `max |w| / 127`, `q = round(w / scale)`); everything else
//! stays f32.

use crate::error::Error;
use crate::format::{Encoding, LayerLayout, ModelKind, Params, Shape, Spec};
use crate::half::{f16_to_f32, f32_to_f16};

/// Where parameter `n` (in blob order) lies in a payload.
#[derive(Clone, Copy, Debug)]
enum Place {
    /// An f32 at this byte offset (normaliser, bounds, table, bias).
    F32(usize),
    /// Weight `i` (column-major) of a layer.
    Weight(LayerLayout, usize),
}

fn locate(kind: ModelKind, shape: Shape, encoding: Encoding, n: usize) -> Option<Place> {
    let prefix = shape.prefix_count(kind);
    if n < prefix {
        return Some(Place::F32(4 * n));
    }
    let (mut first, mut start, mut l) = (prefix, 4 * prefix, 0);
    while let Some((inputs, outputs)) = shape.layer(kind, l) {
        let layout = LayerLayout::of(encoding, inputs, outputs, start)?;
        let weights = inputs * outputs;
        if n < first + weights {
            return Some(Place::Weight(layout, n - first));
        }
        if n < first + weights + outputs {
            return Some(Place::F32(layout.bias + 4 * (n - first - weights)));
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
pub(super) fn quantise(
    spec: &Spec<'_>,
    params: &mut Params<'_>,
    payload: &mut [u8],
) -> Result<(), Error> {
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
                if let Some(Place::Weight(l, i)) = locate(spec.kind, spec.shape, spec.encoding, n) {
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
                Some(Place::F32(at)) => put_f32(payload, at, v),
                Some(Place::Weight(l, i)) => match spec.encoding {
                    Encoding::F16 => {
                        let h = f32_to_f16(v);
                        if !f16_to_f32(h).is_finite() && failure.is_none() {
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
                    Encoding::Int8 | Encoding::F32 | Encoding::Integer => {
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
