//! The runtime `Model`: any shape from the blob's bytes, the same bits as the compiled types,
//! the discrete-policy kind, and a typed error for every misuse.

use policy_core::blob::{self, Spec};
use policy_core::model::{Model, Scratch};
use policy_core::{Activation, Error, ModelKind, Policy, Shape};
use proptest::prelude::*;

use crate::support::{
    blob_of, discrete_blob, nav_critic, nav_policy, runtime_blob, runtime_params, write_vec,
    SplitMix64,
};

fn golden(name: &str) -> Vec<u8> {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden/");
    std::fs::read(format!("{dir}{name}")).expect("golden blob")
}

/// Observations with the awkward cases: NaN, ±Inf, huge, subnormal, and ordinary ones.
fn observations(rng: &mut SplitMix64, n: usize) -> Vec<[f32; 2]> {
    let special = [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::MAX,
        1e-40,
        0.0,
        -0.0,
    ];
    let mut out: Vec<[f32; 2]> = special.iter().map(|&v| [v, 1.0]).collect();
    out.extend(special.iter().map(|&v| [-2.0, v]));
    while out.len() < n {
        out.push([rng.symmetric() * 6.0, rng.symmetric() * 6.0]);
    }
    out
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn runtime_actors_equal_the_compiled_ones_bit_for_bit() {
    fn check<const H: usize, const L: usize>(activation: Activation, seed: u64) {
        let compiled = nav_policy::<2, H, L, 2>(seed, activation);
        let bytes = blob_of(&compiled, "bits");
        let model = Model::from_blob(&bytes).expect("loads");
        let mut scratch = Scratch::<64>::new();
        for obs in observations(&mut SplitMix64(seed), 1000) {
            let mut a = [0.0; 2];
            model.act(&obs, &mut scratch, &mut a).expect("act");
            assert_eq!(bits(&a), bits(&compiled.act(&obs)), "{obs:?}");
        }
    }
    check::<32, 1>(Activation::Tanh, 1);
    check::<48, 3>(Activation::Tanh, 2);
    check::<48, 3>(Activation::Relu, 3);
    check::<64, 5>(Activation::Relu, 4);
    check::<40, 2>(Activation::Relu, 5); // 3x40: a width no block size divides
}

#[test]
fn runtime_critics_equal_the_compiled_ones_bit_for_bit() {
    let compiled = nav_critic::<2, 48, 3, 2>(6, Activation::Relu);
    let bytes = blob_of(&compiled, "critic");
    let model = Model::from_blob(&bytes).expect("loads");
    let mut scratch = Scratch::<48>::new();
    let mut rng = SplitMix64(7);
    for obs in observations(&mut rng.clone(), 500) {
        let u = [rng.symmetric() * 1.5, f32::NAN];
        let q = model.q(&obs, &u, &mut scratch).expect("q");
        assert_eq!(q.to_bits(), compiled.q(&obs, &u).to_bits(), "{obs:?}");
    }
}

/// Version-1 blobs still load, and hold the same parameters as their version-2 rewrites.
#[test]
fn version_1_blobs_load_and_match_version_2() {
    for name in [
        "actor_2x32.postcard",
        "actor_4x48.postcard",
        "critic_2x32.postcard",
    ] {
        let v1 = golden(&format!("v1/{name}"));
        let v2 = golden(name);
        assert_eq!(blob::verify(&v1).expect("v1").header.version, 1);
        assert_eq!(blob::verify(&v2).expect("v2").header.version, 2);
        let (m1, m2) = (
            Model::from_blob(&v1).expect("v1"),
            Model::from_blob(&v2).expect("v2"),
        );
        assert_eq!(
            bits(&m1.values().collect::<Vec<_>>()),
            bits(&m2.values().collect::<Vec<_>>())
        );
        assert_eq!(m1.header().shape, m2.header().shape);
        assert_eq!(m1.header().label, m2.header().label);
    }
    // And the compiled types read v1 too.
    Policy::<2, 48, 3, 2>::from_blob(&golden("v1/actor_4x48.postcard")).expect("compiled v1");
}

/// The v2 payload starts at a multiple of 4, whatever the label length.
#[test]
fn payload_is_four_byte_aligned() {
    for label in ["", "a", "ab", "abc", "abcd", "abcde"] {
        let bytes = blob_of(&nav_policy::<2, 32, 1, 2>(1, Activation::Tanh), label);
        let v = blob::verify(&bytes).expect("verify");
        let offset = bytes.len() - 4 - v.payload.len();
        assert_eq!(offset % 4, 0, "label {label:?}: payload at {offset}");
    }
}

#[test]
fn discrete_policy_acts_with_the_table_row_of_the_largest_q() {
    let bytes = discrete_blob(11);
    let model = Model::from_blob(&bytes).expect("loads");
    assert_eq!(model.header().kind, ModelKind::Discrete);
    let table: Vec<f32> = model.values().skip(5 + 4).take(16).collect();
    let mut scratch = Scratch::<16>::new();
    let mut seen = [false; 8];
    for obs in observations(&mut SplitMix64(12), 400) {
        let row = model.choose(&obs, &mut scratch).expect("choose");
        let mut a = [0.0; 2];
        model.act(&obs, &mut scratch, &mut a).expect("act");
        assert_eq!(bits(&a), bits(&table[2 * row..2 * row + 2]));
        assert!(a.iter().all(|v| v.abs() <= 0.25 + 1e-7));
        seen[row] = true;
    }
    assert!(
        seen.iter().filter(|&&s| s).count() >= 2,
        "a policy that always picks one row"
    );
}

#[test]
fn ties_go_to_the_lowest_index() {
    // All weights zero: every Q equals its bias; biases [0, 1, 1, 0, ...] → row 1.
    let shape = Shape {
        observations: 1,
        actions: 1,
        width: 2,
        depth: 1,
        choices: 4,
    };
    let mut p = runtime_params(ModelKind::Discrete, shape, &mut SplitMix64(1));
    let n = p.len();
    p[5..9].copy_from_slice(&[-0.25, 0.0, 0.1, 0.25]); // the table
    for v in &mut p[9..] {
        *v = 0.0;
    }
    p[n - 4..].copy_from_slice(&[0.0, 1.0, 1.0, 0.0]);
    let spec = Spec {
        kind: ModelKind::Discrete,
        encoding: policy_core::Encoding::F32,
        shape,
        activation: Activation::Relu,
        label: "",
    };
    let bytes = write_vec(&spec, &p).expect("blob");
    let model = Model::from_blob(&bytes).expect("loads");
    assert_eq!(model.choose(&[0.3], &mut Scratch::<4>::new()), Ok(1));
}

#[test]
fn bad_action_tables_are_typed_errors() {
    let shape = Shape {
        observations: 2,
        actions: 2,
        width: 16,
        depth: 2,
        choices: 8,
    };
    let good = runtime_params(ModelKind::Discrete, shape, &mut SplitMix64(3));
    let write = |p: &[f32], shape: Shape| {
        let spec = Spec {
            kind: ModelKind::Discrete,
            encoding: policy_core::Encoding::F32,
            shape,
            activation: Activation::Relu,
            label: "",
        };
        write_vec(&spec, p)
    };
    // A row outside the bounds (row 3, first component 0.3 > 0.25).
    let mut outside = good.clone();
    outside[9 + 2 * 3] = 0.3;
    let bytes = write(&outside, shape).expect("writes");
    assert!(matches!(
        Model::from_blob(&bytes),
        Err(Error::InvalidParameter { index: 3, .. })
    ));
    // A non-finite entry.
    let mut nan = good.clone();
    nan[9 + 5] = f32::NAN;
    let bytes = write(&nan, shape).expect("writes");
    assert!(matches!(
        Model::from_blob(&bytes),
        Err(Error::NonFiniteParameter { index: 14 })
    ));
    // K = 0 is refused by the writer and, in a hand-made header, by the reader.
    let none = Shape {
        choices: 0,
        ..shape
    };
    assert!(matches!(
        write(&good, none),
        Err(Error::ShapeBeyondLimits {
            what: "choices",
            ..
        })
    ));
}

#[test]
fn misuse_is_a_typed_error_never_a_panic() {
    let actor = golden("actor_4x48.postcard");
    let model = Model::from_blob(&actor).expect("loads");
    let mut small = Scratch::<32>::new();
    let mut a = [0.0; 2];
    assert_eq!(
        model.act(&[0.0, 0.0], &mut small, &mut a),
        Err(Error::ScratchTooSmall {
            needed: 48,
            found: 32
        })
    );
    let mut scratch = Scratch::<64>::new();
    assert!(matches!(
        model.act(&[0.0; 3], &mut scratch, &mut a),
        Err(Error::SizeMismatch {
            what: "observation size",
            expected: 3,
            found: 2
        })
    ));
    assert!(matches!(
        model.act(&[0.0; 2], &mut scratch, &mut [0.0; 1]),
        Err(Error::SizeMismatch {
            what: "action size",
            ..
        })
    ));
    assert!(matches!(
        model.q(&[0.0; 2], &[0.0; 2], &mut scratch),
        Err(Error::WrongKind { .. })
    ));
    assert!(matches!(
        model.choose(&[0.0; 2], &mut scratch),
        Err(Error::WrongKind { .. })
    ));
    let critic_bytes = golden("critic_2x32.postcard");
    let critic = Model::from_blob(&critic_bytes).expect("critic");
    assert!(matches!(
        critic.act(&[0.0; 2], &mut scratch, &mut a),
        Err(Error::WrongKind { .. })
    ));
}

#[test]
fn shapes_beyond_the_limits_are_refused_by_writer_and_reader() {
    let base = Shape {
        observations: 2,
        actions: 2,
        width: 8,
        depth: 1,
        choices: 0,
    };
    for (shape, what) in [
        (
            Shape {
                width: 1025,
                ..base
            },
            "width",
        ),
        (Shape { depth: 65, ..base }, "depth"),
        (
            Shape {
                observations: 1025,
                ..base
            },
            "observations",
        ),
        (
            Shape {
                actions: 257,
                ..base
            },
            "actions",
        ),
        (Shape { choices: 3, ..base }, "choices"),
    ] {
        let spec = Spec {
            kind: ModelKind::Actor,
            encoding: policy_core::Encoding::F32,
            shape,
            activation: Activation::Relu,
            label: "",
        };
        let err = blob::encoded_len(&spec).expect_err("beyond the limits");
        assert!(
            matches!(err, Error::ShapeBeyondLimits { what: w, .. } if w == what),
            "{err}"
        );
    }
}

/// A reference forward pass written plainly, in the contract's order: any shape the runtime
/// runs must give exactly these bits.
fn reference_act(
    kind: ModelKind,
    shape: Shape,
    activation: Activation,
    p: &[f32],
    obs: &[f32],
) -> Vec<f32> {
    let (s, a, h) = (
        shape.observations as usize,
        shape.actions as usize,
        shape.width as usize,
    );
    let mut z: Vec<f32> = (0..s)
        .map(|i| {
            let v = (obs[i] - p[i]) * p[s + i];
            if !obs[i].is_finite() || v.is_nan() {
                0.0
            } else {
                v.max(-p[2 * s]).min(p[2 * s])
            }
        })
        .collect();
    let mut at = 2 * s + 1 + if kind == ModelKind::Critic { 0 } else { 2 * a };
    let bounds = 2 * s + 1;
    let dense = |x: &[f32], outputs: usize, at: &mut usize| -> Vec<f32> {
        let w = &p[*at..*at + x.len() * outputs];
        let b = &p[*at + x.len() * outputs..*at + x.len() * outputs + outputs];
        *at += x.len() * outputs + outputs;
        (0..outputs)
            .map(|o| {
                let mut y = b[o];
                for (j, &xj) in x.iter().enumerate() {
                    y += w[j * outputs + o] * xj;
                }
                y
            })
            .collect()
    };
    for _ in 0..shape.depth {
        z = dense(&z, h, &mut at)
            .into_iter()
            .map(|v| match activation {
                Activation::Tanh => libm::tanhf(v),
                Activation::Relu => {
                    if v > 0.0 {
                        v
                    } else {
                        0.0
                    }
                }
            })
            .collect();
    }
    let y = dense(&z, a, &mut at);
    (0..a)
        .map(|i| {
            let t = libm::tanhf(y[i]);
            let u = if t.is_finite() {
                t.clamp(-1.0, 1.0)
            } else {
                0.0
            };
            let (lo, hi) = (p[bounds + i], p[bounds + a + i]);
            (lo + (u + 1.0) * 0.5 * (hi - lo)).max(lo).min(hi)
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Any shape within small limits: written with the runtime writer, run by the runtime,
    /// equal to the plain reference bit for bit, finite and inside the bounds.
    #[test]
    fn any_shape_runs_from_its_bytes(
        s in 1u16..7, a in 1u16..5, width in 1u16..41, depth in 1u8..5, relu: bool,
        seed: u64, x0 in -10.0f32..10.0, x1 in proptest::num::f32::ANY,
    ) {
        let shape = Shape { observations: s, actions: a, width, depth, choices: 0 };
        let activation = if relu { Activation::Relu } else { Activation::Tanh };
        let p = runtime_params(ModelKind::Actor, shape, &mut SplitMix64(seed));
        let bytes = runtime_blob(ModelKind::Actor, shape, activation, seed);
        let model = Model::from_blob(&bytes).expect("loads");
        let obs: Vec<f32> = (0..s as usize).map(|i| if i % 2 == 0 { x0 } else { x1 }).collect();
        let mut out = vec![0.0; a as usize];
        model.act(&obs, &mut Scratch::<40>::new(), &mut out).expect("act");
        let expected = reference_act(ModelKind::Actor, shape, activation, &p, &obs);
        prop_assert_eq!(bits(&out), bits(&expected));
        for (i, v) in out.iter().enumerate() {
            prop_assert!(v.is_finite() && *v >= p[2 * s as usize + 1 + i] && *v <= p[2 * s as usize + 1 + a as usize + i]);
        }
    }
}

/// The golden vectors (`tests/golden/vectors.txt`) through the slice entry points: the same bits
/// as the committed outputs, with a scratch exactly as long as the blob needs, and with a longer
/// odd-length one (the halves are `len / 2` wide; the last float is unused).
#[test]
fn slice_scratch_reproduces_the_golden_vectors() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/golden/vectors.txt"
    ))
    .expect("vectors.txt");
    let hex = |t: &str| u32::from_str_radix(t, 16).expect("hex");
    let (a2, a4, c2) = (
        golden("actor_2x32.postcard"),
        golden("actor_4x48.postcard"),
        golden("critic_2x32.postcard"),
    );
    let mut checked = 0;
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        let Some((lhs, rhs)) = line.split_once("->") else {
            continue;
        };
        let mut input = lhs.split_whitespace();
        let tag = input.next().expect("tag");
        let inputs: Vec<f32> = input.map(|t| f32::from_bits(hex(t))).collect();
        let want: Vec<u32> = rhs.split_whitespace().map(hex).collect();
        let blob = match tag {
            "act2x32" => &a2,
            "act4x48" => &a4,
            "q2x32" => &c2,
            _ => continue,
        };
        let model = Model::from_blob(blob).expect("golden blob loads");
        for len in [model.scratch_floats(), model.scratch_floats() + 7] {
            let mut scratch = vec![f32::NAN; len];
            if tag == "q2x32" {
                let q = model
                    .q_in(&inputs[..2], &inputs[2..], &mut scratch)
                    .expect("q");
                assert_eq!(vec![q.to_bits()], want, "{line} (scratch {len})");
            } else {
                let mut action = [0.0f32; 2];
                model
                    .act_in(&inputs, &mut scratch, &mut action)
                    .expect("act");
                assert_eq!(bits(&action), want, "{line} (scratch {len})");
            }
            checked += 1;
        }
    }
    assert!(checked > 100, "only {checked} vectors checked");
}

#[test]
fn slice_scratch_too_short_names_the_width_needed_and_found() {
    let actor = golden("actor_4x48.postcard");
    let model = Model::from_blob(&actor).expect("loads");
    assert_eq!((model.scratch_width(), model.scratch_floats()), (48, 96));
    let mut a = [0.0; 2];
    for (len, found) in [(0, 0), (1, 0), (95, 47), (94, 47)] {
        assert_eq!(
            model.act_in(&[0.0, 0.0], &mut vec![0.0; len], &mut a),
            Err(Error::ScratchTooSmall { needed: 48, found }),
            "scratch of {len} floats"
        );
    }
    assert_eq!(model.act_in(&[0.0, 0.0], &mut [0.0; 96], &mut a), Ok(()));
    let critic_bytes = golden("critic_2x32.postcard");
    let critic = Model::from_blob(&critic_bytes).expect("critic");
    let needed = critic.scratch_width();
    assert_eq!(
        critic.q_in(&[0.0; 2], &[0.0; 2], &mut vec![0.0; 2 * needed - 1]),
        Err(Error::ScratchTooSmall {
            needed,
            found: needed - 1
        })
    );
    // Kind and sizes are checked before the scratch, as in the const-generic methods.
    assert!(matches!(
        model.choose_in(&[0.0; 2], &mut []),
        Err(Error::WrongKind { .. })
    ));
    assert!(matches!(
        model.act_in(&[0.0; 3], &mut [], &mut a),
        Err(Error::SizeMismatch { .. })
    ));
}

/// A discrete policy through `choose_in` and `act_in` gives what `choose` and `act` give.
#[test]
fn slice_scratch_discrete_policy_matches_the_const_generic_path() {
    let blob = discrete_blob(11);
    let model = Model::from_blob(&blob).expect("discrete");
    let mut rng = SplitMix64(3);
    for obs in observations(&mut rng, 40) {
        let mut fixed = Scratch::<64>::new();
        let mut scratch = vec![0.0; model.scratch_floats()];
        assert_eq!(
            model.choose_in(&obs, &mut scratch),
            model.choose(&obs, &mut fixed)
        );
        let (mut a, mut b) = ([0.0f32; 2], [0.0f32; 2]);
        model.act_in(&obs, &mut scratch, &mut a).expect("act_in");
        model.act(&obs, &mut fixed, &mut b).expect("act");
        assert_eq!(bits(&a), bits(&b));
    }
}
