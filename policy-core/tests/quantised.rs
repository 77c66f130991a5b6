//! f16 and int8 blobs: what the writer stores, what the runtime computes (against an
//! independent reference), what the loader refuses, and that no flip or truncation loads.

use policy_core::blob::{self, Spec};
use policy_core::half::{f16_to_f32, f32_to_f16};
use policy_core::model::{Model, Scratch};
use policy_core::{Activation, Encoding, Error, ModelKind, Shape};

use crate::support::{runtime_params, write_vec, SplitMix64};

const SHAPES: [(ModelKind, Shape); 4] = [
    (ModelKind::Actor, shape(2, 2, 32, 2, 0)),
    (ModelKind::Actor, shape(2, 2, 48, 4, 0)),
    (ModelKind::Critic, shape(2, 2, 17, 3, 0)),
    (ModelKind::Discrete, shape(2, 2, 16, 2, 8)),
];

const fn shape(s: u16, a: u16, h: u16, d: u8, k: u16) -> Shape {
    Shape {
        observations: s,
        actions: a,
        width: h,
        depth: d,
        choices: k,
    }
}

fn spec(kind: ModelKind, shape: Shape, encoding: Encoding) -> Spec<'static> {
    Spec {
        kind,
        encoding,
        shape,
        activation: Activation::Relu,
        label: "quantised",
    }
}

/// (layer inputs, outputs, first parameter index of its weights) for every layer.
fn layers(kind: ModelKind, shape: Shape) -> Vec<(usize, usize, usize)> {
    let mut first = shape.prefix_count(kind);
    let mut out = Vec::new();
    let mut l = 0;
    while let Some((i, o)) = shape.layer(kind, l) {
        out.push((i, o, first));
        first += i * o + o;
        l += 1;
    }
    out
}

/// The per-output scales the writer must choose: max |w| / 127 (1 for an all-zero output).
fn scales(params: &[f32], inputs: usize, outputs: usize, first: usize) -> Vec<f32> {
    (0..outputs)
        .map(|o| {
            let m = (0..inputs)
                .map(|j| params[first + j * outputs + o].abs())
                .fold(0.0f32, f32::max);
            if m > 0.0 {
                m / 127.0
            } else {
                1.0
            }
        })
        .collect()
}

/// An independent forward pass of an int8 model from the f32 parameters: the quantised weights
/// recomputed here, then acc = Σ q x in input order and y = b + scale · acc. `action` is the
/// critic's second input (empty for the other kinds).
fn int8_reference(
    kind: ModelKind,
    shape: Shape,
    params: &[f32],
    obs: &[f32],
    action: &[f32],
) -> Vec<f32> {
    let s = shape.observations as usize;
    let clip = params[2 * s];
    let mut x: Vec<f32> = (0..s)
        .map(|i| {
            let z = (obs[i] - params[i]) * params[s + i];
            z.clamp(-clip, clip)
        })
        .chain(action.iter().copied())
        .collect();
    let all = layers(kind, shape);
    for (n, &(inputs, outputs, first)) in all.iter().enumerate() {
        let sc = scales(params, inputs, outputs, first);
        let mut y = vec![0.0f32; outputs];
        for (j, &xj) in x.iter().enumerate().take(inputs) {
            for o in 0..outputs {
                let q = (params[first + j * outputs + o] / sc[o])
                    .round()
                    .clamp(-127.0, 127.0);
                y[o] += q * xj;
            }
        }
        let bias = first + inputs * outputs;
        for o in 0..outputs {
            y[o] = params[bias + o] + sc[o] * y[o];
        }
        if n + 1 < all.len() {
            y.iter_mut()
                .for_each(|v| *v = if *v > 0.0 { *v } else { 0.0 });
        }
        x = y;
    }
    x
}

fn observations(rng: &mut SplitMix64) -> Vec<[f32; 2]> {
    (0..200)
        .map(|_| [rng.symmetric() * 7.0, rng.symmetric() * 7.0])
        .collect()
}

/// An f16 blob computes, bit for bit, what the f32 blob of the f16-rounded weights computes.
#[test]
fn f16_blob_equals_f32_blob_of_the_rounded_weights() {
    for (n, &(kind, shape)) in SHAPES.iter().enumerate() {
        let params = runtime_params(kind, shape, &mut SplitMix64(40 + n as u64));
        let mut rounded = params.clone();
        for &(i, o, first) in &layers(kind, shape) {
            for w in &mut rounded[first..first + i * o] {
                *w = f16_to_f32(f32_to_f16(*w));
            }
        }
        let f16 = write_vec(&spec(kind, shape, Encoding::F16), &params).expect("f16 blob");
        let f32 = write_vec(&spec(kind, shape, Encoding::F32), &rounded).expect("f32 blob");
        let (a, b) = (
            Model::from_blob(&f16).expect("f16"),
            Model::from_blob(&f32).expect("f32"),
        );
        assert_eq!(a.header().version, 3);
        assert_eq!(a.header().encoding, Encoding::F16);
        assert_eq!(
            a.values().collect::<Vec<_>>(),
            rounded,
            "decoded parameters"
        );
        let scratch = Scratch::<64>::new();
        for obs in observations(&mut SplitMix64(7)) {
            let out = |m: &Model<'_>| -> Vec<u32> {
                let mut s = scratch.clone();
                match kind {
                    ModelKind::Critic => {
                        vec![m.q(&obs, &[0.3, -0.7], &mut s).expect("q").to_bits()]
                    }
                    _ => {
                        let mut act = [0.0f32; 2];
                        m.act(&obs, &mut s, &mut act).expect("act");
                        act.map(f32::to_bits).to_vec()
                    }
                }
            };
            assert_eq!(out(&a), out(&b), "{kind} {shape} at {obs:?}");
        }
    }
}

/// An int8 blob computes what the independent reference computes (same operations, so the same
/// bits), and its decoded weights lie within half a step of the originals.
#[test]
fn int8_blob_matches_the_reference_forward_pass() {
    for (n, &(kind, shape)) in SHAPES.iter().enumerate() {
        let params = runtime_params(kind, shape, &mut SplitMix64(50 + n as u64));
        let bytes = write_vec(&spec(kind, shape, Encoding::Int8), &params).expect("int8 blob");
        let model = Model::from_blob(&bytes).expect("int8");
        assert_eq!(model.header().encoding, Encoding::Int8);
        let decoded: Vec<f32> = model.values().collect();
        for &(i, o, first) in &layers(kind, shape) {
            let sc = scales(&params, i, o, first);
            for k in 0..i * o {
                let err = (decoded[first + k] - params[first + k]).abs();
                assert!(err <= sc[k % o] * 0.5 * 1.0001, "weight {k}: {err}");
            }
        }
        let mut scratch = Scratch::<64>::new();
        for obs in observations(&mut SplitMix64(8)) {
            let action: &[f32] = if kind == ModelKind::Critic {
                &[0.3, -0.7]
            } else {
                &[]
            };
            let y = int8_reference(kind, shape, &params, &obs, action);
            match kind {
                ModelKind::Critic => {
                    let q = model.q(&obs, action, &mut scratch).expect("q");
                    assert_eq!(q.to_bits(), y[0].to_bits(), "{shape} at {obs:?}");
                }
                ModelKind::Actor => {
                    let mut act = [0.0f32; 2];
                    model.act_unit(&obs, &mut scratch, &mut act).expect("act");
                    let want = y.iter().map(|&v| policy_core::mlp::squash(v).to_bits());
                    assert!(
                        act.iter().map(|a| a.to_bits()).eq(want),
                        "{shape} at {obs:?}"
                    );
                }
                ModelKind::Discrete => {
                    let k = model.choose(&obs, &mut scratch).expect("choose");
                    let best = y.iter().cloned().fold(f32::NEG_INFINITY, f32::max);
                    assert_eq!(y[k], best, "{shape} at {obs:?}");
                }
            }
        }
    }
}

/// Quantised blobs are smaller: f16 halves the weights, int8 quarters them (plus a scale per
/// output).
#[test]
fn quantised_payloads_have_their_documented_sizes() {
    let (kind, shape) = SHAPES[1];
    let f32 = shape.payload_len_in(kind, Encoding::F32).expect("f32");
    let f16 = shape.payload_len_in(kind, Encoding::F16).expect("f16");
    let int8 = shape.payload_len_in(kind, Encoding::Int8).expect("int8");
    assert_eq!(f32, 4 * 7307);
    let weights = 2 * 48 + 3 * 48 * 48 + 48 * 2;
    let rest = 9 + 4 * 48 + 2; // prefix and biases
    assert_eq!(f16, 4 * rest + 2 * weights);
    assert_eq!(int8, 4 * rest + weights + 4 * (4 * 48 + 2));
}

fn int8_bytes() -> (Vec<u8>, usize) {
    let (kind, shape) = SHAPES[0];
    let params = runtime_params(kind, shape, &mut SplitMix64(60));
    let bytes = write_vec(&spec(kind, shape, Encoding::Int8), &params).expect("blob");
    let header_len = bytes.len() - 4 - shape.payload_len_in(kind, Encoding::Int8).expect("len");
    (bytes, header_len)
}

/// Rewrites the CRC after a deliberate change, so the parameter checks are what refuses it.
fn recrc(bytes: &mut [u8]) {
    let n = bytes.len() - 4;
    let crc = policy_core::crc32(&bytes[..n]);
    bytes[n..].copy_from_slice(&crc.to_le_bytes());
}

#[test]
fn an_int8_scale_that_is_zero_negative_or_not_finite_is_refused() {
    let (bytes, header_len) = int8_bytes();
    let (kind, shape) = SHAPES[0];
    let first_scale = header_len + 4 * shape.prefix_count(kind);
    // f32::MAX / 2: finite, but `scale · q` overflows (regression: the layer-by-layer
    // check once accepted it, found by the mutation property test).
    for bad in [0.0f32, -0.01, f32::NAN, f32::INFINITY, f32::MAX / 2.0] {
        let mut b = bytes.clone();
        b[first_scale + 4..first_scale + 8].copy_from_slice(&bad.to_le_bytes());
        recrc(&mut b);
        let err = Model::from_blob(&b).expect_err("bad scale loaded");
        assert!(
            matches!(
                err,
                Error::InvalidParameter { index: 1, .. } | Error::NonFiniteParameter { .. }
            ),
            "{bad}: {err}"
        );
    }
}

#[test]
fn an_f16_weight_that_is_infinite_or_nan_is_refused() {
    let (kind, shape) = SHAPES[0];
    let params = runtime_params(kind, shape, &mut SplitMix64(61));
    let bytes = write_vec(&spec(kind, shape, Encoding::F16), &params).expect("blob");
    let header_len = bytes.len() - 4 - shape.payload_len_in(kind, Encoding::F16).expect("len");
    let first_weight = header_len + 4 * shape.prefix_count(kind);
    for bad in [0x7c00u16, 0xfc00, 0x7e00] {
        let mut b = bytes.clone();
        b[first_weight + 2..first_weight + 4].copy_from_slice(&bad.to_le_bytes());
        recrc(&mut b);
        let err = Model::from_blob(&b).expect_err("bad weight loaded");
        assert_eq!(
            err,
            Error::NonFiniteParameter {
                index: shape.prefix_count(kind) + 1
            }
        );
    }
    // The writer refuses weights beyond the f16 range rather than store infinity.
    let mut huge = params.clone();
    huge[shape.prefix_count(kind)] = 1e6;
    let err = write_vec(&spec(kind, shape, Encoding::F16), &huge).expect_err("1e6 in f16");
    assert!(matches!(err, Error::InvalidParameter { .. }), "{err}");
}

#[test]
fn payload_length_and_padding_must_match_the_encoding() {
    let (bytes, header_len) = int8_bytes();
    // A payload length from another encoding: the header says int8 but the length is f32's.
    let v = blob::verify(&bytes).expect("good");
    let mut header = v.header.clone();
    header.payload_len = 4 * SHAPES[0].1.param_count(SHAPES[0].0).expect("count") as u32;
    let mut b = postcard::to_allocvec(&header).expect("header");
    b.resize(b.len().next_multiple_of(4), 0);
    b.extend_from_slice(&bytes[header_len..bytes.len() - 4]);
    b.extend_from_slice(&[0; 4]);
    recrc(&mut b);
    assert!(matches!(
        Model::from_blob(&b),
        Err(Error::Malformed { .. } | Error::Truncated { .. })
    ));
    // Padding after a layer's weights: 2→32 weights are 64 bytes (no padding), so use a layer
    // of 17 outputs: the critic's 4×17 = 68 bytes... the 2×32 actor's last layer has 32×2 = 64;
    // a 1-output critic layer of 17 inputs has 17 bytes of int8 weights and 3 of padding.
    let (kind, shape) = SHAPES[2];
    let params = runtime_params(kind, shape, &mut SplitMix64(62));
    let bytes = write_vec(&spec(kind, shape, Encoding::Int8), &params).expect("blob");
    let header_len = bytes.len() - 4 - shape.payload_len_in(kind, Encoding::Int8).expect("len");
    let mut at = 4 * shape.prefix_count(kind);
    let mut l = 0;
    let mut padded = None;
    while let Some((i, o)) = shape.layer(kind, l) {
        let layer = blob::LayerLayout::of(Encoding::Int8, i, o, at).expect("layout");
        if layer.padding < layer.bias {
            padded = Some(layer.padding);
        }
        at = layer.end;
        l += 1;
    }
    let pad = padded.expect("a layer with padding");
    let mut b = bytes.clone();
    b[header_len + pad] = 1;
    recrc(&mut b);
    assert!(
        matches!(Model::from_blob(&b), Err(Error::Malformed { what }) if what.contains("padding"))
    );
}

#[test]
fn compiled_types_refuse_quantised_blobs() {
    let (bytes, _) = int8_bytes();
    let err = policy_core::Policy::<2, 32, 1, 2>::from_blob(&bytes).expect_err("int8 into f32");
    assert_eq!(
        err,
        Error::WrongEncoding {
            expected: Encoding::F32,
            found: Encoding::Int8
        }
    );
}

/// Every single-bit flip and every truncation of quantised blobs of every kind is rejected.
#[test]
fn every_flip_and_truncation_of_quantised_blobs_is_rejected() {
    for encoding in [Encoding::F16, Encoding::Int8] {
        for (n, &(kind, shape)) in [SHAPES[0], SHAPES[2], SHAPES[3]].iter().enumerate() {
            let params = runtime_params(kind, shape, &mut SplitMix64(70 + n as u64));
            let bytes = write_vec(&spec(kind, shape, encoding), &params).expect("blob");
            Model::from_blob(&bytes).expect("unflipped blob loads");
            for bit in 0..bytes.len() * 8 {
                let mut b = bytes.clone();
                b[bit / 8] ^= 1 << (bit % 8);
                assert!(
                    Model::from_blob(&b).is_err(),
                    "{encoding} {kind}: bit {bit} loaded"
                );
            }
            for len in 0..bytes.len() {
                assert!(
                    Model::from_blob(&bytes[..len]).is_err(),
                    "{encoding} {kind}: {len}"
                );
            }
        }
    }
}
