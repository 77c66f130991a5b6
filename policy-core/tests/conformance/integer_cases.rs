//! Integer actors made by hand, field by field, so that one reading of the integer forward pass
//! or of its loading checks decides each output: observations whose input code lands exactly on
//! a tie, or where an f64 or fused multiply-add input map rounds otherwise than the two f32
//! operations; accumulators on exact ties of `SaturatingRoundingDoublingHighMul` and
//! `RoundingDivideByPOT`; a ReLU layer whose output zero point is above −128, so that the fused
//! clamp matters; unit codes whose `u / 127` differs from `u · (1/127)`; and blobs broken in two
//! places, which settle the order of the checks.
//!
//! Each hand-made actor starts as a writer-made integer actor of its shape (a valid layout and
//! prefix) whose integer fields are then overwritten. Their tables are the identity
//! (`table[c + 128] = c`, −128 raised to −127) and their "transparent" layers pass codes through
//! unchanged (weight 1 on the diagonal, multiplier `2^31 − 1`, shift 0, bias 0), so a code an
//! observation selects reaches the unit code, and the action, unchanged.

use policy_core::blob::Encoding;
use policy_core::model::Model;
use policy_core::{Activation, ModelKind, Shape};

use super::generate::{accept_with, integer_at, reject, shape, Vectors};
use crate::support::SplitMix64;
use crate::support::{calibration_observations, integer_vec, reseal, runtime_params, write_vec};

/// The multiplier that makes `SaturatingRoundingDoublingHighMul(acc, m)` return `acc` for every
/// accumulator below 2^30 in magnitude (a real multiplier of `1 − 2^-31`).
const PASS: i32 = i32::MAX;
/// A real multiplier of exactly 0.5: an odd accumulator is then an exact tie.
const HALF: i32 = 1 << 30;

/// One layer's integer fields; its table, if it has one, is the identity.
struct Layer {
    zero: i32,
    multipliers: Vec<i32>,
    shifts: Vec<i8>,
    /// Column-major, as the payload stores them.
    weights: Vec<i8>,
    bias: Vec<i32>,
}

impl Layer {
    /// A layer of `n` inputs and outputs that passes every code through: `y = x − Z_in + zero`.
    fn transparent(n: usize, zero: i32) -> Layer {
        Layer {
            zero,
            multipliers: vec![PASS; n],
            shifts: vec![0; n],
            weights: (0..n * n).map(|i| i8::from(i % (n + 1) == 0)).collect(),
            bias: vec![0; n],
        }
    }
}

/// A hand-made integer actor: bounds `[-1, 1]`, input map `(scale, offset)` per observation
/// with input zero point 0, and the layers' fields.
struct Handmade {
    shape: Shape,
    activation: Activation,
    input: Vec<(f32, f32)>,
    layers: Vec<Layer>,
}

impl Handmade {
    fn bytes(&self) -> Vec<u8> {
        let kind = ModelKind::Actor;
        let params = runtime_params(kind, self.shape, &mut SplitMix64(0x1A7E));
        let spec = policy_core::blob::Spec {
            kind,
            encoding: Encoding::F32,
            shape: self.shape,
            activation: self.activation,
            label: "handmade",
        };
        let f32_blob = write_vec(&spec, &params).expect("valid");
        let s = usize::from(self.shape.observations);
        let calibration = calibration_observations(s, 64, 5.0, 0xCA1);
        let mut out = integer_vec(&f32_blob, &calibration).expect("calibrates");
        let (input, layers) = integer_at(&out);
        let put = |out: &mut Vec<u8>, at: usize, bytes: &[u8]| {
            out[at..at + bytes.len()].copy_from_slice(bytes);
        };
        // Bounds [-1, 1]: the prefix (mean, inv_std, clip, low, high) ends at the input block.
        let a = usize::from(self.shape.actions);
        let payload = input.scales - 4 * (2 * s + 1 + 2 * a);
        for i in 0..a {
            put(
                &mut out,
                payload + 4 * (2 * s + 1 + i),
                &(-1.0f32).to_le_bytes(),
            );
            put(
                &mut out,
                payload + 4 * (2 * s + 1 + a + i),
                &1.0f32.to_le_bytes(),
            );
        }
        for (i, &(scale, offset)) in self.input.iter().enumerate() {
            put(&mut out, input.scales + 4 * i, &scale.to_le_bytes());
            put(&mut out, input.offsets + 4 * i, &offset.to_le_bytes());
        }
        put(&mut out, input.zero, &0i32.to_le_bytes());
        assert_eq!(layers.len(), self.layers.len());
        for (at, layer) in layers.iter().zip(&self.layers) {
            put(&mut out, at.zero, &layer.zero.to_le_bytes());
            for (o, m) in layer.multipliers.iter().enumerate() {
                put(&mut out, at.multipliers + 4 * o, &m.to_le_bytes());
            }
            let shifts: Vec<u8> = layer.shifts.iter().map(|&s| s as u8).collect();
            put(&mut out, at.shifts, &shifts);
            let weights: Vec<u8> = layer.weights.iter().map(|&q| q as u8).collect();
            put(&mut out, at.weights, &weights);
            for (o, b) in layer.bias.iter().enumerate() {
                put(&mut out, at.bias + 4 * o, &b.to_le_bytes());
            }
            if let Some(table) = at.table {
                let identity: Vec<u8> = (0..256).map(|k| (k - 128).max(-127) as i8 as u8).collect();
                put(&mut out, table, &identity);
            }
        }
        reseal(&mut out);
        out
    }
}

/// The hand-made vectors: three actors with their observations, then the two-edit refusals.
pub fn vectors(v: &mut Vectors) {
    v.lines.push(String::new());
    v.lines.push(
        "# Integer actors made by hand: input ties, the f32 input map, rounding ties, the fused ReLU, u / 127."
            .into(),
    );
    let map = input_map(v);
    requantisation_ties(v);
    relu_zero_point(v);
    two_edits(v, &map);
}

/// `integer-input-map`: two lanes, each passing its input code to its unit code. Lane 0's map is
/// `t = x` (scale 1, offset 0), so an observation `k + 0.5` is an exact tie of the rounding (C's
/// `roundf`: away from zero) and an integer observation `k` gives the unit code `k`, among them
/// the codes whose `k / 127` differs from `k · (1/127)` in f32. Lane 1's map (scale 0.1, offset
/// 0.3) is inexact: its observations are ones where computing `x · scale + offset` in f64, or
/// with one fused multiply-add, rounds to another code than the two f32 operations.
fn input_map(v: &mut Vectors) -> Vec<u8> {
    let (scale, offset) = (0.1f32, 0.3f32);
    let actor = Handmade {
        shape: shape(2, 2, 2, 1, 0),
        activation: Activation::Tanh,
        input: vec![(1.0, 0.0), (scale, offset)],
        layers: vec![Layer::transparent(2, 0), Layer::transparent(2, 0)],
    };
    let bytes = actor.bytes();
    let model = Model::from_blob(&bytes).expect("loads");
    let code = |x: f32| {
        let mut c = [0i8; 2];
        model.observation_codes(&[0.0, x], &mut c).expect("codes");
        i32::from(c[1])
    };
    let round = |t: f32| t.clamp(-128.0, 127.0).round() as i32;
    let f64_code = |x: f32| round((f64::from(x) * f64::from(scale) + f64::from(offset)) as f32);
    let fma_code = |x: f32| round(x.mul_add(scale, offset));
    // Lane 1: the observations nearest each code boundary where another map disagrees.
    // Two of each sign for each map.
    let (mut by_f64, mut by_fma) = (Vec::new(), Vec::new());
    let wanted =
        |found: &[f32], x: f32| found.iter().filter(|y| (**y > 0.0) == (x > 0.0)).count() < 2;
    for k in -120..120 {
        let boundary = ((k as f32 + 0.5 - offset) / scale).to_bits();
        for d in -16i32..=16 {
            let x = f32::from_bits(boundary.wrapping_add_signed(d));
            if f64_code(x) != code(x) && wanted(&by_f64, x) {
                by_f64.push(x);
            }
            if fma_code(x) != code(x) && wanted(&by_fma, x) {
                by_fma.push(x);
            }
        }
    }
    assert!(
        by_f64.len() == 4 && by_fma.len() == 4,
        "{by_f64:?} {by_fma:?}"
    );
    // Lane 0: ties of both signs, at the ends of the code range too, then the unit codes whose
    // action differs when u = k · (1/127) (with bounds [-1, 1] the action of u ≤ -0.5 is u).
    let ties = [0.5, -0.5, 2.5, -2.5, 41.5, -41.5, 126.5, -126.5, -127.5];
    let action = |u: f32| (-1.0 + ((u + 1.0) * 0.5) * 2.0f32).clamp(-1.0, 1.0);
    let reciprocal: Vec<f32> = (-127..=127)
        .map(|k| k as f32)
        .filter(|&k| action(k / 127.0) != action(k * (1.0 / 127.0)))
        .collect();
    assert!(reciprocal.len() >= 4, "{reciprocal:?}");
    let lane1 = by_f64.iter().chain(&by_fma).copied().cycle();
    let probes: Vec<Vec<f32>> = ties
        .into_iter()
        .chain(reciprocal)
        .zip(lane1)
        .map(|(x0, x1)| vec![x0, x1])
        .collect();
    accept_with(v, "integer-input-map", bytes.clone(), &probes);
    bytes
}

/// `integer-requantisation-ties`: input maps `t = x`, then a hidden layer whose lane 0 has the
/// multiplier 0.5 and shift 0 (an odd accumulator is an exact tie of
/// `SaturatingRoundingDoublingHighMul`, ties toward +∞) and whose lane 1 has the pass-through
/// multiplier and shift −1 (an odd accumulator is an exact tie of `RoundingDivideByPOT`, ties
/// away from zero); identity tables, and a transparent output layer.
fn requantisation_ties(v: &mut Vectors) {
    let hidden = Layer {
        multipliers: vec![HALF, PASS],
        shifts: vec![0, -1],
        ..Layer::transparent(2, 0)
    };
    let actor = Handmade {
        shape: shape(2, 2, 2, 1, 0),
        activation: Activation::Tanh,
        input: vec![(1.0, 0.0), (1.0, 0.0)],
        layers: vec![hidden, Layer::transparent(2, 0)],
    };
    let probes: Vec<Vec<f32>> = [
        [1.0, -1.0],
        [-1.0, 1.0],
        [3.0, -3.0],
        [-3.0, 3.0],
        [-5.0, -7.0],
        [77.0, -77.0],
        [-101.0, 101.0],
        [127.0, -127.0],
        [-127.0, 127.0],
        [2.0, -2.0],
    ]
    .map(Vec::from)
    .into();
    accept_with(v, "integer-requantisation-ties", actor.bytes(), &probes);
}

/// `integer-relu-zero-point`: a ReLU actor whose hidden layer's output zero point is −50 (the
/// writer cuts ReLU ranges at 0, so its own are −128): the fused clamp `[Z_out, 127]` is then
/// all that makes the unit code `max(code, 0)`; without it negative codes pass, with a bound of
/// 0 instead of `Z_out` codes below 50 are lost.
fn relu_zero_point(v: &mut Vectors) {
    let actor = Handmade {
        shape: shape(1, 1, 1, 1, 0),
        activation: Activation::Relu,
        input: vec![(1.0, 0.0)],
        layers: vec![Layer::transparent(1, -50), Layer::transparent(1, 0)],
    };
    let probes: Vec<Vec<f32>> = [-3.0, -60.0, -100.0, -128.0, 10.0, 30.0, 49.0, 60.0, 127.0]
        .map(|x| vec![x])
        .into();
    accept_with(v, "integer-relu-zero-point", actor.bytes(), &probes);
}

/// Blobs broken in two places: the check the loader runs first decides the error (and its
/// index), which settles the order in which a reader must run checks 14.2–14.10.
fn two_edits(v: &mut Vectors, map: &[u8]) {
    let (input, layers) = integer_at(map);
    let edit = |edits: &[(usize, &[u8])]| {
        let mut out = map.to_vec();
        for &(at, bytes) in edits {
            out[at..at + bytes.len()].copy_from_slice(bytes);
        }
        reseal(&mut out);
        out
    };
    let word = |v: i32| v.to_le_bytes();
    let (l0, l1) = (&layers[0], &layers[1]);
    let table = l1.table.expect("the output layer has a table");
    let cases: [(&str, Vec<u8>, &str); 9] = [
        // 14.1's index counts values: high[1] is the ninth f32 of a 2×2 actor's prefix.
        (
            "integer-high-1-nan",
            edit(&[(input.scales - 4, &f32::NAN.to_le_bytes())]),
            "NonFiniteParameter index=8",
        ),
        (
            "integer-two-edits-scale-1-offset-0",
            edit(&[
                (input.scales + 4, &0.0f32.to_le_bytes()),
                (input.offsets, &f32::INFINITY.to_le_bytes()),
            ]),
            "InvalidParameter index=1",
        ),
        (
            "integer-two-edits-multiplier-1-shift-0",
            edit(&[(l0.multipliers + 4, &word(HALF - 1)), (l0.shifts, &[1])]),
            "InvalidParameter index=1",
        ),
        (
            "integer-two-edits-shift-1-bias-0",
            edit(&[(l0.shifts + 1, &[1]), (l0.bias, &word((1 << 30) + 1))]),
            "InvalidParameter index=1",
        ),
        (
            "integer-two-edits-shift-padding-bias-0",
            edit(&[(l0.shift_padding, &[1]), (l0.bias, &word((1 << 30) + 1))]),
            "Malformed",
        ),
        (
            "integer-two-edits-zero-multiplier-0",
            edit(&[(l1.zero, &word(200)), (l1.multipliers, &word(0))]),
            "InvalidParameter index=1",
        ),
        // Layer 0 is checked to its end before layer 1 begins.
        (
            "integer-two-edits-hidden-bias-0-output-zero",
            edit(&[(l0.bias, &word(i32::MIN)), (l1.zero, &word(-200))]),
            "InvalidParameter index=0",
        ),
        // 14.10 runs to k = 255 inclusive: the last entry is the only defect.
        (
            "integer-table-255-below-254",
            edit(&[(table + 255, &[125])]),
            "InvalidParameter index=255",
        ),
        (
            "integer-table-255-minus-128",
            edit(&[(table + 255, &[0x80])]),
            "InvalidParameter index=255",
        ),
    ];
    for (name, bytes, expected) in cases {
        reject(v, name, bytes, expected);
    }
}
