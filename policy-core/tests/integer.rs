//! The integer encoding: an independent reader written from docs/blob-format.md ("The integer
//! forward pass") computes the runtime's bits; the float and integer entries agree; actions stay
//! finite and in bounds for any observation; the writer's and the calibration's refusals; no
//! flip, truncation or mutation of an integer blob panics.

use proptest::prelude::*;

use policy_core::blob::{self, IntegerLayer, Spec};
use policy_core::model::{Model, Scratch};
use policy_core::{Activation, Encoding, Error, ModelKind, Shape};

use crate::support::{
    calibration_observations, integer_vec, reseal, runtime_params, write_vec, SplitMix64,
};

const SHAPES: [(Shape, Activation); 4] = [
    (shape(2, 2, 16, 3), Activation::Relu),
    (shape(2, 2, 16, 2), Activation::Tanh),
    (shape(3, 1, 8, 1), Activation::Tanh),
    (shape(5, 3, 33, 2), Activation::Relu),
];

const fn shape(s: u16, a: u16, h: u16, d: u8) -> Shape {
    Shape {
        observations: s,
        actions: a,
        width: h,
        depth: d,
        choices: 0,
    }
}

/// An f32 actor of `shape` and its integer encoding, calibrated on 256 observations.
fn actor(shape: Shape, activation: Activation, seed: u64) -> (Vec<u8>, Vec<u8>) {
    let params = runtime_params(ModelKind::Actor, shape, &mut SplitMix64(seed));
    let spec = Spec {
        kind: ModelKind::Actor,
        encoding: Encoding::F32,
        shape,
        activation,
        label: "integer",
    };
    let f32 = write_vec(&spec, &params).expect("f32 actor");
    let obs = calibration_observations(shape.observations.into(), 256, 5.0, seed + 1);
    let integer = integer_vec(&f32, &obs).expect("integer actor");
    (f32, integer)
}

// ------------------------------------------------------------------------------------------
// An independent reader, from the page.

fn word(b: &[u8], at: usize) -> i32 {
    i32::from_le_bytes(b[at..at + 4].try_into().expect("4 bytes"))
}

/// `SaturatingRoundingDoublingHighMul` then `RoundingDivideByPOT`, as the page states them:
/// `2ab / 2^32` rounded to nearest with ties up (saturating `MIN · MIN`), then `/ 2^-shift`
/// rounded to nearest with ties away from zero; in i128, without the gemmlowp formulas.
fn requantise(acc: i32, multiplier: i32, shift: i32) -> i32 {
    let high = if acc == i32::MIN && multiplier == i32::MIN {
        i128::from(i32::MAX)
    } else {
        (2 * i128::from(acc) * i128::from(multiplier) + (1 << 31)).div_euclid(1 << 32)
    };
    let e = -shift;
    if e == 0 {
        return high as i32;
    }
    let half = 1i128 << (e - 1);
    let magnitude = (high.abs() + half) >> e;
    (if high < 0 { -magnitude } else { magnitude }) as i32
}

/// The unit codes of an integer actor for an observation, from the blob's bytes alone.
fn reference_unit_codes(bytes: &[u8], obs: &[f32]) -> Vec<i32> {
    let v = blob::verify(bytes).expect("verifies");
    let (h, p) = (&v.header, v.payload);
    let mut layers: Vec<IntegerLayer> = Vec::new();
    let (input, _) = blob::integer_layers(h.kind, h.shape, h.activation, |_, l| layers.push(l))
        .expect("an integer actor");
    let f = |at: usize| f32::from_bits(word(p, at) as u32);
    let mut zero = word(p, input.zero);
    let mut x: Vec<i32> = obs
        .iter()
        .enumerate()
        .map(|(i, &o)| {
            if !o.is_finite() {
                return zero;
            }
            let t = o * f(input.scales + 4 * i) + f(input.offsets + 4 * i);
            t.clamp(-128.0, 127.0).round() as i32
        })
        .collect();
    for l in &layers {
        let out_zero = word(p, l.zero);
        let relu = l.table.is_none();
        let y: Vec<i32> = (0..l.outputs)
            .map(|o| {
                let mut acc = word(p, l.bias + 4 * o) as i64;
                for (j, &xj) in x.iter().enumerate() {
                    let q = p[l.weights + j * l.outputs + o] as i8;
                    acc += i64::from(q) * i64::from(xj - zero);
                }
                let acc = i32::try_from(acc).expect("the page's bound: no overflow");
                let shift = i32::from(p[l.shifts + o] as i8);
                let r = requantise(acc, word(p, l.multipliers + 4 * o), shift) + out_zero;
                let code = r.clamp(if relu { out_zero } else { -128 }, 127);
                match l.table {
                    Some(t) => i32::from(p[t + (code + 128) as usize] as i8),
                    None => code,
                }
            })
            .collect();
        zero = if l.table.is_some() { 0 } else { out_zero };
        x = y;
    }
    x
}

fn observation(rng: &mut SplitMix64, s: usize) -> Vec<f32> {
    (0..s).map(|_| rng.symmetric() * 8.0).collect()
}

/// The runtime computes, bit for bit, what the reader written from the page computes; the
/// float entry's action is `scale_value(code / 127)` of those codes.
#[test]
fn the_runtime_is_the_pages_integer_forward_pass() {
    for (n, &(shape, activation)) in SHAPES.iter().enumerate() {
        let (_, bytes) = actor(shape, activation, 100 + n as u64);
        let model = Model::from_blob(&bytes).expect("loads");
        assert_eq!(model.header().version, 4);
        let mut rng = SplitMix64(7);
        let mut scratch = Scratch::<64>::new();
        for k in 0..300 {
            let mut obs = observation(&mut rng, shape.observations.into());
            if k % 37 == 0 {
                obs[0] = f32::NAN;
            }
            let want = reference_unit_codes(&bytes, &obs);
            let mut unit = vec![0.0f32; shape.actions.into()];
            model.act_unit(&obs, &mut scratch, &mut unit).expect("act");
            let got: Vec<i32> = unit.iter().map(|u| (u * 127.0).round() as i32).collect();
            assert_eq!(got, want, "{shape} {activation} at {obs:?}");
            for (u, c) in unit.iter().zip(&want) {
                assert_eq!(u.to_bits(), (*c as f32 / 127.0).to_bits());
            }
        }
    }
}

/// The integer entry (codes in, codes out, no float) gives the float entry's integers.
#[test]
fn the_integer_entry_gives_the_float_entrys_codes() {
    for (n, &(shape, activation)) in SHAPES.iter().enumerate() {
        let (_, bytes) = actor(shape, activation, 200 + n as u64);
        let model = Model::from_blob(&bytes).expect("loads");
        let (s, a) = (usize::from(shape.observations), usize::from(shape.actions));
        let mut rng = SplitMix64(9);
        for _ in 0..200 {
            let obs = observation(&mut rng, s);
            let mut codes = vec![0i8; s];
            model.observation_codes(&obs, &mut codes).expect("codes");
            let mut unit_codes = vec![0i8; a];
            model
                .act_codes_in(&codes, &mut [0i32; 128], &mut unit_codes)
                .expect("act codes");
            let mut unit = vec![0.0f32; a];
            model
                .act_unit(&obs, &mut Scratch::<64>::new(), &mut unit)
                .expect("act");
            let from_codes: Vec<f32> = unit_codes.iter().map(|&c| f32::from(c) / 127.0).collect();
            assert_eq!(unit, from_codes, "{shape} at {obs:?}");
        }
    }
}

/// The integer entry's refusals: another encoding, wrong sizes, a narrow scratch.
#[test]
fn the_integer_entry_checks_its_arguments() {
    let (f32, bytes) = actor(SHAPES[0].0, SHAPES[0].1, 300);
    let f32_model = Model::from_blob(&f32).expect("f32");
    assert_eq!(
        f32_model.act_codes_in(&[0, 0], &mut [0; 64], &mut [0, 0]),
        Err(Error::WrongEncoding {
            expected: Encoding::Integer,
            found: Encoding::F32
        })
    );
    let model = Model::from_blob(&bytes).expect("integer");
    assert!(matches!(
        model.act_codes_in(&[0, 0, 0], &mut [0; 64], &mut [0, 0]),
        Err(Error::SizeMismatch { .. })
    ));
    assert!(matches!(
        model.act_codes_in(&[0, 0], &mut [0; 64], &mut [0]),
        Err(Error::SizeMismatch { .. })
    ));
    assert_eq!(
        model.act_codes_in(&[0, 0], &mut [0; 16], &mut [0, 0]),
        Err(Error::ScratchTooSmall {
            needed: 16,
            found: 8
        })
    );
    assert!(matches!(
        model.observation_codes(&[0.0], &mut [0, 0]),
        Err(Error::SizeMismatch { .. })
    ));
}

/// On the observations it was calibrated for, the integer actor's unit action stays within a few
/// hundredths of the f32 actor's (the measured worst case is printed by the failure).
#[test]
fn integer_actions_stay_close_to_the_f32_actions() {
    for (n, &(shape, activation)) in SHAPES.iter().enumerate() {
        let (f32, bytes) = actor(shape, activation, 400 + n as u64);
        let (a, b) = (
            Model::from_blob(&f32).expect("f32"),
            Model::from_blob(&bytes).expect("integer"),
        );
        let s = usize::from(shape.observations);
        let obs = calibration_observations(s, 256, 5.0, 401 + n as u64);
        let mut worst = 0.0f32;
        for o in obs.chunks_exact(s) {
            let mut ua = vec![0.0f32; shape.actions.into()];
            let mut ub = ua.clone();
            a.act_unit(o, &mut Scratch::<64>::new(), &mut ua)
                .expect("f32");
            b.act_unit(o, &mut Scratch::<64>::new(), &mut ub)
                .expect("integer");
            for (x, y) in ua.iter().zip(&ub) {
                worst = worst.max((x - y).abs());
            }
        }
        assert!(worst < 0.1, "{shape} {activation}: {worst}");
    }
}

fn finite() -> impl Strategy<Value = f32> {
    prop_oneof![
        -10.0f32..10.0,
        any::<f32>().prop_filter("finite", |v| v.is_finite()),
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(f32::NEG_INFINITY),
        Just(1e-45),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Any observation (NaN and infinities included) gives a finite action inside the bounds,
    /// the page's reader agrees, and any bytes in the weights keep it so.
    #[test]
    fn actions_are_finite_in_bounds_and_the_pages(
        obs in [finite(), finite()],
        seed in 0u64..50,
        relu in any::<bool>(),
        weights in proptest::collection::vec(any::<u8>(), 8),
    ) {
        let activation = if relu { Activation::Relu } else { Activation::Tanh };
        let (_, mut bytes) = actor(shape(2, 2, 16, 2), activation, seed);
        // Overwrite some weights of the first layer with arbitrary bytes: any weight is valid.
        let v = blob::verify(&bytes).expect("verifies");
        let start = bytes.len() - 4 - v.payload.len();
        let mut first = None;
        blob::integer_layers(v.header.kind, v.header.shape, v.header.activation, |l, layer| {
            if l == 0 { first = Some(layer.weights); }
        });
        let at = start + first.expect("a first layer");
        bytes[at..at + 8].copy_from_slice(&weights);
        reseal(&mut bytes);
        let model = Model::from_blob(&bytes).expect("any weight bytes load");
        let mut action = [0.0f32; 2];
        model.act(&obs, &mut Scratch::<16>::new(), &mut action).expect("act");
        for (a, (lo, hi)) in action.iter().zip(model.action_bounds()) {
            prop_assert!(a.is_finite() && lo <= *a && *a <= hi, "{a} outside [{lo}, {hi}]");
        }
        let mut unit = [0.0f32; 2];
        model.act_unit(&obs, &mut Scratch::<16>::new(), &mut unit).expect("act");
        let want = reference_unit_codes(&bytes, &obs);
        prop_assert_eq!(unit.map(|u| (u * 127.0).round() as i32).to_vec(), want);
    }
}

/// Every truncation and every single-bit flip of an integer blob is refused with an error,
/// never a panic; any byte rewritten under a fresh CRC loads or is refused, and what loads
/// acts in bounds.
#[test]
fn no_flip_truncation_or_mutation_panics() {
    let (_, bytes) = actor(shape(2, 2, 8, 2), Activation::Tanh, 500);
    for n in 0..bytes.len() {
        assert!(Model::from_blob(&bytes[..n]).is_err(), "truncated to {n}");
    }
    for bit in 0..8 * bytes.len() {
        let mut b = bytes.clone();
        b[bit / 8] ^= 1 << (bit % 8);
        assert!(Model::from_blob(&b).is_err(), "bit {bit}");
    }
    let mut rng = SplitMix64(501);
    for _ in 0..20_000 {
        let mut b = bytes.clone();
        let at = rng.below(b.len() - 4);
        b[at] = rng.next() as u8;
        reseal(&mut b);
        if let Ok(model) = Model::from_blob(&b) {
            let mut action = [0.0f32; 2];
            let obs = observation(&mut rng, 2);
            model
                .act(&obs, &mut Scratch::<16>::new(), &mut action)
                .expect("act");
            for (a, (lo, hi)) in action.iter().zip(model.action_bounds()) {
                assert!(a.is_finite() && lo <= *a && *a <= hi, "byte {at}: {a}");
            }
        }
    }
}

/// The writer refuses what it cannot quantise, each with its error.
#[test]
fn the_writer_refuses_what_it_cannot_quantise() {
    let shape = shape(2, 2, 8, 1);
    let params = runtime_params(ModelKind::Actor, shape, &mut SplitMix64(600));
    let spec = Spec {
        kind: ModelKind::Actor,
        encoding: Encoding::Integer,
        shape,
        activation: Activation::Relu,
        label: "refused",
    };
    let write = |spec: &Spec<'_>, ranges: &[(f32, f32)], params: &[f32]| {
        let mut out = vec![0u8; 4096];
        blob::write_integer(spec, ranges, &mut |sink| sink(params), &mut out)
    };
    let good = [(-3.0, 3.0), (-1.0, 2.0), (-0.5, 0.5)];
    assert!(write(&spec, &good, &params).is_ok());
    let calibration = |r: Result<usize, Error>| match r {
        Err(Error::Calibration { index, .. }) => index,
        other => panic!("expected a calibration error, got {other:?}"),
    };
    assert_eq!(calibration(write(&spec, &good[..2], &params)), 2);
    assert_eq!(
        calibration(write(
            &spec,
            &[(-3.0, 3.0), (f32::NAN, 2.0), (-0.5, 0.5)],
            &params
        )),
        1
    );
    assert_eq!(
        calibration(write(
            &spec,
            &[(-3.0, 3.0), (1.0, -1.0), (-0.5, 0.5)],
            &params
        )),
        1
    );
    // A ReLU layer never positive has nothing to quantise; so has an input always 0.
    assert_eq!(
        calibration(write(
            &spec,
            &[(-3.0, 3.0), (-2.0, -1.0), (-0.5, 0.5)],
            &params
        )),
        1
    );
    assert_eq!(
        calibration(write(
            &spec,
            &[(0.0, 0.0), (-1.0, 2.0), (-0.5, 0.5)],
            &params
        )),
        0
    );
    let mut nan = params.clone();
    nan[20] = f32::NAN;
    assert_eq!(
        write(&spec, &good, &nan),
        Err(Error::NonFiniteParameter { index: 20 })
    );
    let mut still = params.clone();
    still[2] = 0.0; // inv_std 0: an observation the integer input cannot scale
    assert!(matches!(
        write(&spec, &good, &still),
        Err(Error::InvalidParameter { index: 0, .. })
    ));
    let critic = Spec {
        kind: ModelKind::Critic,
        ..spec
    };
    assert!(matches!(
        write(&critic, &good, &params),
        Err(Error::WrongKind { .. })
    ));
    let int8 = Spec {
        encoding: Encoding::Int8,
        ..spec
    };
    assert!(matches!(
        write(&int8, &good, &params),
        Err(Error::WrongEncoding { .. })
    ));
    // The weights-only writer names the integer writer.
    assert!(matches!(
        write_vec(&spec, &params),
        Err(Error::Calibration { .. })
    ));
}

/// Calibration refuses NaN observations and bad sizes, naming the observation.
#[test]
fn calibration_refuses_nan_and_bad_sizes() {
    let (f32, _) = actor(shape(2, 2, 8, 1), Activation::Tanh, 700);
    let model = Model::from_blob(&f32).expect("f32");
    let mut ranges = vec![(f32::INFINITY, f32::NEG_INFINITY); 3];
    let mut scratch = vec![0.0; model.scratch_floats()];
    let mut run = |obs: &[f32]| blob::calibrate_into(&model, obs, &mut scratch, &mut ranges);
    let index = |r: Result<(), Error>| match r {
        Err(Error::Calibration { index, .. }) => index,
        other => panic!("expected a calibration error, got {other:?}"),
    };
    assert_eq!(index(run(&[0.0, 1.0, 2.0, f32::NAN])), 1);
    assert_eq!(index(run(&[0.0, 1.0, f32::INFINITY, 0.0])), 1);
    assert_eq!(index(run(&[0.0, 1.0, 2.0])), 3);
    assert_eq!(index(run(&[])), 0);
    assert_eq!(run(&[0.0, 1.0]), Ok(()));
}
