//! `host-trainer inspect`: what a blob holds, read with policy-core's runtime model.
//!
//! The blob is verified completely ([`Model::from_blob`]: header, limits, length, padding,
//! CRC, every parameter) before anything is printed, so a file that inspects cleanly is one the
//! firmware boots.

use std::fmt::Write as _;

use policy_core::blob::CRC_LEN;
use policy_core::model::Model;
use policy_core::{Encoding, ModelKind};

use crate::Error;

/// A readable description of a blob: kind, shape, activation, encoding, format version, label,
/// parameter count, byte size, CRC, the normaliser, and the action bounds (actor, discrete) or
/// action table (discrete). An invalid blob is policy-core's one-line error.
///
/// ```
/// use host_trainer::blob::inspect::describe;
/// let mut p = policy_core::Policy::<2, 32, 1, 2>::ZERO;
/// p.normalizer = policy_core::Normalizer::identity(5.0);
/// p.bounds = policy_core::ActionBounds::symmetric(0.25);
/// let text = describe(&p.to_blob("demo").unwrap()).unwrap();
/// assert!(text.contains("kind        actor\n"), "{text}");
/// assert!(text.contains("parameters  1227\n"), "{text}");
/// assert!(text.contains("bounds      low [-0.25, -0.25], high [0.25, 0.25]\n"), "{text}");
/// assert!(describe(b"DCPB").is_err());
/// ```
pub fn describe(bytes: &[u8]) -> Result<String, policy_core::Error> {
    let model = Model::from_blob(bytes)?;
    let h = model.header();
    let s = &h.shape;
    let (obs, act) = (s.observations as usize, s.actions as usize);
    let values: Vec<f32> = model.values().collect();
    let payload = h.payload_len as usize;
    let crc = bytes
        .last_chunk::<CRC_LEN>()
        .map_or(0, |c| u32::from_le_bytes(*c));
    let mut out = String::new();
    let mut line = |key: &str, value: String| {
        let _ = writeln!(out, "{key:<11} {value}");
    };
    line("kind", h.kind.to_string());
    line("shape", s.to_string());
    line("activation", h.activation.to_string());
    line("encoding", h.encoding.to_string());
    line("version", h.version.to_string());
    line("label", format!("{:?}", h.label.as_str()));
    // An integer blob's decoded values are its f32 prefix only; count the model's parameters.
    let parameters = s.param_count(h.kind).unwrap_or(values.len());
    line("parameters", parameters.to_string());
    line(
        "bytes",
        format!(
            "{} (header {}, payload {payload}, CRC {CRC_LEN})",
            bytes.len(),
            bytes.len() - payload - CRC_LEN
        ),
    );
    line("crc", format!("{crc:#010x}"));
    let mut rest = values.as_slice();
    let mut take = |n: usize| {
        let (head, tail) = rest.split_at(n.min(rest.len()));
        rest = tail;
        head
    };
    let (mean, inv_std, clip) = (take(obs), take(obs), take(1));
    line(
        "normaliser",
        format!(
            "mean {mean:?}, inv_std {inv_std:?}, clip {:?}",
            clip.first().copied().unwrap_or(0.0)
        ),
    );
    if h.kind != ModelKind::Critic {
        let (low, high) = (take(act), take(act));
        line("bounds", format!("low {low:?}, high {high:?}"));
    }
    if h.kind == ModelKind::Discrete {
        for row in 0..s.choices as usize {
            line(
                if row == 0 { "actions" } else { "" },
                format!("{row}: {:?}", take(act)),
            );
        }
    }
    if h.encoding == Encoding::Integer {
        out += &describe_integer(bytes)?;
    }
    Ok(out)
}

/// The integer encoding's quantisation, as `inspect` prints it: the folded input map
/// (`code = round(x · scale + offset)`) and its zero point, then per layer its output zero
/// point, the range of its real requantisation multipliers `m · 2^(shift − 31)`, its fused ReLU
/// or tanh table.
///
/// ```
/// use host_trainer::blob::{export::encode_integer, inspect::describe};
/// static F32: &[u8] = include_bytes!("../../../policy-core/tests/golden/actor_4x48.postcard");
/// let text = describe(&encode_integer(F32, &[4.0, -2.5, 0.0, 1.0, -6.0, 6.0]).unwrap()).unwrap();
/// assert!(text.contains("encoding    integer\n"), "{text}");
/// assert!(text.contains("input       scales ["), "{text}");
/// assert!(text.contains("layer 4     48x2, output zero point"), "{text}");
/// ```
pub fn describe_integer(bytes: &[u8]) -> Result<String, policy_core::Error> {
    let v = policy_core::blob::verify(bytes)?;
    let (h, p) = (&v.header, v.payload);
    let word = |at: usize| {
        p.get(at..at + 4)
            .and_then(|b| <[u8; 4]>::try_from(b).ok())
            .map_or(0, i32::from_le_bytes)
    };
    let float = |at: usize| f32::from_bits(word(at) as u32);
    let mut out = String::new();
    let mut layers = Vec::new();
    let Some((input, _)) =
        policy_core::blob::integer_layers(h.kind, h.shape, h.activation, |_, l| layers.push(l))
    else {
        return Ok(out);
    };
    let n = input.observations;
    let scales: Vec<f32> = (0..n).map(|i| float(input.scales + 4 * i)).collect();
    let offsets: Vec<f32> = (0..n).map(|i| float(input.offsets + 4 * i)).collect();
    let _ = writeln!(
        out,
        "input       scales {scales:?}, offsets {offsets:?}, zero point {}",
        word(input.zero)
    );
    for (l, layer) in layers.iter().enumerate() {
        let real = |o: usize| {
            let shift = p.get(layer.shifts + o).map_or(0, |&s| i32::from(s as i8));
            policy_core::blob::real_multiplier(word(layer.multipliers + 4 * o), shift)
        };
        let (lo, hi) = (0..layer.outputs)
            .map(real)
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), m| {
                (lo.min(m), hi.max(m))
            });
        let activation = if layer.table.is_some() {
            "tanh table"
        } else {
            "ReLU in the clamp"
        };
        let _ = writeln!(
            out,
            "layer {l}     {}x{}, output zero point {}, multipliers {lo:.4e}..{hi:.4e}, {activation}",
            layer.inputs,
            layer.outputs,
            word(layer.zero),
        );
    }
    Ok(out)
}

/// Per layer of a quantised blob, how far its weights (decoded: an f16 weight exactly, an int8
/// weight as `scale · q`) lie from those of the f32 blob it was made from: `(inputs, outputs,
/// largest |error|, largest |f32 weight|)`. The reference must be an f32 blob of the same kind
/// and shape ([`Error::NotTheReference`] otherwise).
///
/// ```
/// use host_trainer::blob::{export::encode, inspect::weight_errors};
/// use policy_core::Encoding;
/// static F32: &[u8] = include_bytes!("../../../policy-core/tests/golden/actor_2x32.postcard");
/// let int8 = encode(F32, Encoding::Int8).unwrap();
/// for (_, _, error, largest) in weight_errors(&int8, F32).unwrap() {
///     assert!(error <= largest / 127.0 / 2.0 * 1.001); // half a quantisation step at most
/// }
/// // The quantised blob is no reference.
/// assert!(weight_errors(F32, &int8).is_err());
/// ```
pub fn weight_errors(
    quantised: &[u8],
    reference: &[u8],
) -> Result<Vec<(usize, usize, f32, f32)>, Error> {
    let (q, r) = (Model::from_blob(quantised)?, Model::from_blob(reference)?);
    let (hq, hr) = (q.header(), r.header());
    let differs = |difference: String| Err(Error::NotTheReference { difference });
    if hr.encoding != Encoding::F32 {
        return differs(format!("the reference is {}-encoded", hr.encoding));
    }
    if hq.encoding == Encoding::Integer {
        // Its weights' scales live in the multipliers, mixed with the activations': compare
        // its actions instead (`action_errors`).
        return differs("the blob is integer-encoded: it has no decoded weights".into());
    }
    if hq.kind != hr.kind {
        return differs(format!(
            "the reference holds {} and the blob {}",
            with_article(hr.kind),
            with_article(hq.kind)
        ));
    }
    if hq.shape != hr.shape {
        return differs(format!(
            "the reference's network is {} and the blob's {}",
            hr.shape, hq.shape
        ));
    }
    let (vq, vr): (Vec<f32>, Vec<f32>) = (q.values().collect(), r.values().collect());
    let mut first = hq.shape.prefix_count(hq.kind);
    let mut out = Vec::new();
    let mut l = 0;
    while let Some((inputs, outputs)) = hq.shape.layer(hq.kind, l) {
        let range = first..first + inputs * outputs;
        let error = vq[range.clone()]
            .iter()
            .zip(&vr[range.clone()])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        let largest = vr[range].iter().map(|w| w.abs()).fold(0.0f32, f32::max);
        out.push((inputs, outputs, error, largest));
        first += inputs * outputs + outputs;
        l += 1;
    }
    Ok(out)
}

/// How far an integer actor's actions lie from the f32 actor's it was made from, in the
/// action's units: per action dimension the largest and the 99th-percentile |difference|, and
/// the mean over every dimension and observation.
#[derive(Clone, Debug, PartialEq)]
pub struct ActionErrors {
    /// Largest |difference| per action dimension.
    pub largest: Vec<f32>,
    /// 99th percentile of |difference| per action dimension.
    pub p99: Vec<f32>,
    /// Mean |difference|.
    pub mean: f32,
}

/// [`ActionErrors`] of an integer actor against the f32 actor it was made from, over
/// `observations` (flattened).
///
/// ```
/// use host_trainer::blob::{export::encode_integer, inspect::action_errors};
/// static F32: &[u8] = include_bytes!("../../../policy-core/tests/golden/actor_4x48.postcard");
/// let obs = [4.0, -2.5, 0.0, 1.0, -6.0, 6.0];
/// let e = action_errors(&encode_integer(F32, &obs).unwrap(), F32, &obs).unwrap();
/// assert!(e.largest.iter().all(|&e| e < 0.01), "{e:?}"); // bounds are ±0.25
/// ```
pub fn action_errors(
    integer: &[u8],
    reference: &[u8],
    observations: &[f32],
) -> Result<ActionErrors, Error> {
    let (q, r) = (Model::from_blob(integer)?, Model::from_blob(reference)?);
    let (hq, hr) = (q.header(), r.header());
    if hq.kind != hr.kind || hq.shape != hr.shape || hr.encoding != Encoding::F32 {
        return Err(Error::NotTheReference {
            difference: format!(
                "the reference is {} {} of {}, the blob {} {} of {}",
                hr.encoding, hr.kind, hr.shape, hq.encoding, hq.kind, hq.shape
            ),
        });
    }
    let (s, a) = (
        usize::from(hq.shape.observations),
        usize::from(hq.shape.actions),
    );
    let mut scratch = vec![0.0f32; q.scratch_floats().max(r.scratch_floats())];
    let mut differences: Vec<Vec<f32>> = vec![Vec::new(); a];
    let (mut x, mut y) = (vec![0.0f32; a], vec![0.0f32; a]);
    for obs in observations.chunks_exact(s) {
        q.act_in(obs, &mut scratch, &mut x)?;
        r.act_in(obs, &mut scratch, &mut y)?;
        for ((d, xi), yi) in differences.iter_mut().zip(&x).zip(&y) {
            d.push((xi - yi).abs());
        }
    }
    let count = differences.iter().map(Vec::len).sum::<usize>().max(1);
    let sum: f64 = differences.iter().flatten().map(|&d| f64::from(d)).sum();
    for d in &mut differences {
        d.sort_by(f32::total_cmp);
    }
    let at = |d: &Vec<f32>, q: f64| {
        let i = ((d.len().saturating_sub(1)) as f64 * q).round() as usize;
        d.get(i).copied().unwrap_or(0.0)
    };
    Ok(ActionErrors {
        largest: differences.iter().map(|d| at(d, 1.0)).collect(),
        p99: differences.iter().map(|d| at(d, 0.99)).collect(),
        mean: (sum / count as f64) as f32,
    })
}

/// Observations spread over an actor's input box: `count` of them, each component uniform in
/// `mean ± clip / inv_std` (the normaliser's whole clipped range), from a fixed seed.
pub fn normaliser_box(bytes: &[u8], count: usize) -> Result<Vec<f32>, Error> {
    let model = Model::from_blob(bytes)?;
    let s = usize::from(model.header().shape.observations);
    let values: Vec<f32> = model.values().take(2 * s + 1).collect();
    let clip = values.get(2 * s).copied().unwrap_or(1.0);
    let mut rng = firmware_sim::seed::training_stream(0, "normaliser box");
    let mut out = Vec::with_capacity(count * s);
    for _ in 0..count {
        for i in 0..s {
            let (mean, inv_std) = (values[i], values[s + i]);
            let half = if inv_std > 0.0 { clip / inv_std } else { 0.0 };
            out.push(mean + half * firmware_sim::seed::uniform_in(&mut rng, -1.0, 1.0));
        }
    }
    Ok(out)
}

/// [`weight_errors`] as the lines `inspect --against` prints; for an integer blob, whose
/// weights have no stored scale, [`action_errors`] over 10,000 observations of the
/// normaliser's box ([`normaliser_box`]).
pub fn describe_errors(quantised: &[u8], reference: &[u8]) -> Result<String, Error> {
    let mut out = String::new();
    if Model::from_blob(quantised)?.header().encoding == Encoding::Integer {
        let observations = normaliser_box(reference, 10_000)?;
        let e = action_errors(quantised, reference, &observations)?;
        let list = |v: &[f32]| {
            let v: Vec<String> = v.iter().map(|e| format!("{e:.3e}")).collect();
            v.join(", ")
        };
        let _ = writeln!(
            out,
            "actions     over 10000 observations of the normaliser's box, |error| per dimension: \
             largest [{}], 99th percentile [{}]; mean {:.3e}",
            list(&e.largest),
            list(&e.p99),
            e.mean
        );
        return Ok(out);
    }
    for (l, (inputs, outputs, error, largest)) in
        weight_errors(quantised, reference)?.into_iter().enumerate()
    {
        let _ = writeln!(
            out,
            "layer {l}     {inputs}x{outputs}: largest weight error {error:.3e} (largest |weight| {largest:.3e})"
        );
    }
    Ok(out)
}

/// "an actor", "a critic", "a discrete policy".
fn with_article(kind: ModelKind) -> String {
    let name = kind.to_string();
    let article = if name.starts_with(['a', 'e', 'i', 'o', 'u']) {
        "an"
    } else {
        "a"
    };
    format!("{article} {name}")
}

#[cfg(test)]
mod tests {
    use super::*;
    use policy_core::blob::{self, Spec};
    use policy_core::{Activation, Shape};

    #[test]
    fn a_discrete_blob_lists_its_action_table() {
        let shape = Shape {
            observations: 1,
            actions: 2,
            width: 2,
            depth: 1,
            choices: 3,
        };
        let spec = Spec {
            kind: ModelKind::Discrete,
            encoding: policy_core::Encoding::F32,
            shape,
            activation: Activation::Relu,
            label: "dqn",
        };
        let mut params = vec![0.5, 2.0, 4.0, -1.0, -1.0, 1.0, 1.0];
        params.extend([-1.0, 0.0, 0.0, 1.0, 1.0, -1.0]); // 3 rows of 2
        params.extend([0.0; 2 + 2 + 2 * 3 + 3]);
        let bytes = blob::to_vec_with(&spec, &mut |sink| sink(&params)).expect("blob");
        let text = describe(&bytes).expect("describe");
        assert!(text.starts_with("kind        discrete policy\n"), "{text}");
        assert!(
            text.contains("shape       1x2 hidden, 1 observations, 2 actions, 3 choices\n"),
            "{text}"
        );
        assert!(
            text.contains("normaliser  mean [0.5], inv_std [2.0], clip 4.0\n"),
            "{text}"
        );
        assert!(
            text.contains("bounds      low [-1.0, -1.0], high [1.0, 1.0]\n"),
            "{text}"
        );
        assert!(text.contains("actions     0: [-1.0, 0.0]\n            1: [0.0, 1.0]\n            2: [1.0, -1.0]\n"), "{text}");
        assert!(
            text.contains(&format!("parameters  {}\n", params.len())),
            "{text}"
        );
    }

    #[test]
    fn a_critic_has_no_bounds_and_a_bad_crc_is_an_error() {
        let critic = policy_core::Critic::<2, 8, 1, 2> {
            normalizer: policy_core::Normalizer::identity(3.0),
            ..policy_core::Critic::ZERO
        };
        let mut bytes = critic.to_blob("q").expect("blob");
        let text = describe(&bytes).expect("describe");
        assert!(
            text.contains("kind        critic\n") && !text.contains("bounds"),
            "{text}"
        );
        let crc = u32::from_le_bytes(bytes[bytes.len() - 4..].try_into().expect("4 bytes"));
        assert!(
            text.contains(&format!("crc         {crc:#010x}\n")),
            "{text}"
        );
        let mid = bytes.len() / 2;
        bytes[mid] ^= 1;
        let err = describe(&bytes).expect_err("corrupt");
        assert!(err.to_string().contains("checksum"), "{err}");
    }
}
