//! Valid blobs, mutated one field at a time, through every loader (proptest).
//!
//! Each case starts from a real blob (the golden 2x32 actor and critic, a tiny actor, an 8-row
//! discrete policy, all format version 2), decodes it into header fields and payload values, changes some of them, re-encodes it (with the CRC
//! fixed or left stale) and runs [`tests::blob_checks::check`], the same properties the `blob`
//! fuzz target checks.

use policy_core::blob::{self, Header, Spec};
use policy_core::{ActionBounds, Activation, ModelKind, Normalizer, Policy, Shape};
use proptest::prelude::*;
use tests::blob_checks::{self, TinyActor};

static ACTOR_2X32: &[u8] = include_bytes!("../../policy-core/tests/golden/actor_2x32.postcard");
static CRITIC_2X32: &[u8] = include_bytes!("../../policy-core/tests/golden/critic_2x32.postcard");
static ACTOR_V1: &[u8] = include_bytes!("../../policy-core/tests/golden/v1/actor_2x32.postcard");

/// A valid discrete policy: 8 moves of 0.25 at n·45°, a 1x4 Q network.
fn discrete() -> Vec<u8> {
    let shape = Shape {
        observations: 2,
        actions: 2,
        width: 4,
        depth: 1,
        choices: 8,
    };
    let mut p = vec![0.0, 0.0, 1.0, 1.0, 5.0, -0.25, -0.25, 0.25, 0.25];
    for k in 0..8 {
        let angle = k as f32 * std::f32::consts::FRAC_PI_4;
        p.extend([0.25 * angle.cos(), 0.25 * angle.sin()]);
    }
    let total = shape.param_count(ModelKind::Discrete).expect("fits");
    while p.len() < total {
        p.push(0.1 * ((p.len() % 7) as f32 - 3.0));
    }
    let spec = Spec {
        kind: ModelKind::Discrete,
        encoding: policy_core::Encoding::F32,
        shape,
        activation: Activation::Relu,
        label: "dqn",
    };
    blob::to_vec_with(&spec, &mut |sink| sink(&p)).expect("a discrete policy writes")
}

/// A valid tiny actor.
fn tiny_actor() -> Vec<u8> {
    let mut p = TinyActor::ZERO;
    p.normalizer = Normalizer::identity(5.0);
    p.bounds = ActionBounds::symmetric(0.25);
    p.input.w[(0, 0)] = 0.5;
    p.trunk.output.b[0] = 0.1;
    p.to_blob("tiny").expect("a tiny actor writes")
}

/// A blob taken apart: the fields a mutation can change.
#[derive(Clone, Debug)]
struct Parts {
    header: Header,
    values: Vec<f32>,
}

impl Parts {
    fn of(bytes: &[u8]) -> Parts {
        let v = blob::verify(bytes).expect("base blobs are valid");
        Parts {
            header: v.header.clone(),
            values: blob::payload_values(v.payload).collect(),
        }
    }

    /// Header, padding (version 2), payload and (correct) CRC.
    fn encode(&self) -> Vec<u8> {
        let mut out = postcard::to_allocvec(&self.header).expect("a header encodes");
        if self.header.version != 1 {
            out.resize(out.len().next_multiple_of(4), 0);
        }
        self.values.iter().for_each(|v| out.extend(v.to_le_bytes()));
        let crc = policy_core::crc32(&out);
        out.extend(crc.to_le_bytes());
        out
    }
}

/// One change to a blob.
#[derive(Clone, Debug)]
enum Mutation {
    Version(u16),
    Kind(u8),
    Choices(u16),
    Observations(u16),
    Actions(u16),
    Width(u16),
    Depth(u8),
    Activation(bool),
    Label(String),
    PayloadLen(u32),
    /// Sets payload value `index % len` to `value`.
    Value(usize, f32),
    /// Sets byte `index % len` of the encoded blob (the CRC is then fixed or not).
    Byte(usize, u8),
    Truncate(usize),
    Append(Vec<u8>),
}

/// Values that break a loader if any will: non-finite, huge, tiny, signed zeros.
fn special_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(f32::NEG_INFINITY),
        Just(f32::MAX),
        Just(f32::MIN),
        Just(-0.0),
        Just(f32::MIN_POSITIVE / 2.0),
        Just(1.0e30),
        -10.0f32..10.0,
        any::<u32>().prop_map(f32::from_bits),
    ]
}

/// Sizes near the real ones, at the edges of their types, and anything.
fn size_u16() -> impl Strategy<Value = u16> {
    prop_oneof![0u16..4, 30u16..66, Just(u16::MAX), any::<u16>()]
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let header = prop_oneof![
        prop_oneof![Just(0u16), Just(1), Just(3), Just(u16::MAX), any::<u16>()]
            .prop_map(Mutation::Version),
        (0u8..3).prop_map(Mutation::Kind),
        size_u16().prop_map(Mutation::Choices),
        size_u16().prop_map(Mutation::Observations),
        size_u16().prop_map(Mutation::Actions),
        size_u16().prop_map(Mutation::Width),
        prop_oneof![0u8..8, Just(u8::MAX)].prop_map(Mutation::Depth),
        any::<bool>().prop_map(Mutation::Activation),
        "\\PC{0,10}".prop_map(Mutation::Label),
        prop_oneof![0u32..70_000, Just(u32::MAX), any::<u32>()].prop_map(Mutation::PayloadLen),
    ];
    let bytes = prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Mutation::Byte(i, b)),
        any::<usize>().prop_map(Mutation::Truncate),
        prop::collection::vec(any::<u8>(), 1..8).prop_map(Mutation::Append),
    ];
    prop_oneof![
        3 => header,
        3 => (any::<usize>(), special_f32()).prop_map(|(i, v)| Mutation::Value(i, v)),
        2 => bytes,
    ]
}

/// Applies the field mutations to `parts`, encodes, then applies the byte-level ones; the CRC is
/// recomputed over the result when `fix_crc` (so that the checks after the CRC are reached).
fn mutate(mut parts: Parts, mutations: &[Mutation], fix_crc: bool) -> Vec<u8> {
    let h = &mut parts.header;
    for m in mutations {
        match m {
            Mutation::Version(v) => h.version = *v,
            Mutation::Kind(k) => {
                h.kind = [ModelKind::Actor, ModelKind::Critic, ModelKind::Discrete][*k as usize % 3]
            }
            Mutation::Choices(n) => h.shape.choices = *n,
            Mutation::Observations(n) => h.shape.observations = *n,
            Mutation::Actions(n) => h.shape.actions = *n,
            Mutation::Width(n) => h.shape.width = *n,
            Mutation::Depth(n) => h.shape.depth = *n,
            Mutation::Activation(relu) => {
                h.activation = [Activation::Tanh, Activation::Relu][*relu as usize]
            }
            Mutation::Label(s) => h.label = label(s),
            Mutation::PayloadLen(n) => h.payload_len = *n,
            Mutation::Value(i, v) if !parts.values.is_empty() => {
                let n = parts.values.len();
                parts.values[i % n] = *v;
            }
            _ => {}
        }
    }
    let mut bytes = parts.encode();
    for m in mutations {
        match m {
            // A truncation to nothing leaves no byte to overwrite (this harness once divided
            // by the empty length here).
            Mutation::Byte(i, b) if !bytes.is_empty() => {
                let n = bytes.len();
                bytes[i % n] = *b;
            }
            Mutation::Truncate(n) => bytes.truncate(n % (bytes.len() + 1)),
            Mutation::Append(extra) => bytes.extend(extra),
            _ => {}
        }
    }
    if fix_crc && bytes.len() >= 4 {
        let body = bytes.len() - 4;
        let crc = policy_core::crc32(&bytes[..body]);
        bytes[body..].copy_from_slice(&crc.to_le_bytes());
    }
    bytes
}

/// The longest prefix of `s` that fits the label's 32 bytes.
fn label(s: &str) -> heapless::String<{ blob::LABEL_CAPACITY }> {
    let mut out = heapless::String::new();
    s.chars()
        .take_while(|c| out.push(*c).is_ok())
        .for_each(drop);
    out
}

fn base() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        Just(ACTOR_2X32.to_vec()),
        Just(CRITIC_2X32.to_vec()),
        Just(tiny_actor()),
        Just(discrete()),
    ]
}

/// One of [`quantised_bases`].
fn quantised_base() -> impl Strategy<Value = Vec<u8>> {
    prop::sample::select(quantised_bases())
}

/// The f32 bases in f16 and in int8 (format version 3), and the actors in the integer encoding
/// (format version 4), calibrated on observations over the normaliser's range.
fn quantised_bases() -> Vec<Vec<u8>> {
    let encode = |bytes: &[u8], encoding| blob::encode(bytes, encoding).expect("a base encodes");
    let mut all = Vec::new();
    for base in [
        ACTOR_2X32.to_vec(),
        CRITIC_2X32.to_vec(),
        tiny_actor(),
        discrete(),
    ] {
        for encoding in [policy_core::Encoding::F16, policy_core::Encoding::Int8] {
            all.push(encode(&base, encoding));
        }
    }
    for base in [ACTOR_2X32.to_vec(), tiny_actor()] {
        let s = usize::from(
            blob::verify(&base)
                .expect("a base")
                .header
                .shape
                .observations,
        );
        let observations: Vec<f32> = (0..64 * s).map(|i| (i % 13) as f32 - 6.0).collect();
        all.push(blob::encode_integer(&base, &observations).expect("an actor base encodes"));
    }
    all
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(384))]

    /// Quantised blobs with bytes overwritten anywhere (header, scales, weights, padding, biases),
    /// the CRC usually fixed so the parameter checks are reached: every loader keeps its
    /// properties.
    #[test]
    fn mutated_quantised_blobs_keep_the_loader_properties(
        base in quantised_base(),
        edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..4),
        fix_crc in prop::bool::weighted(0.8),
    ) {
        let mut bytes = base;
        let body = bytes.len() - 4;
        for (at, value) in edits {
            bytes[at.index(body)] = value;
        }
        if fix_crc {
            let crc = policy_core::crc32(&bytes[..body]);
            bytes[body..].copy_from_slice(&crc.to_le_bytes());
        }
        blob_checks::check(&bytes);
    }

    #[test]
    fn mutated_blobs_keep_the_loader_properties(
        base in base(),
        mutations in prop::collection::vec(mutation(), 0..4),
        fix_crc in prop::bool::weighted(0.8),
    ) {
        blob_checks::check(&mutate(Parts::of(&base), &mutations, fix_crc));
    }

    /// Payload values only, CRC fixed: every case reaches the parameter checks, and a blob whose
    /// values are all finite with a valid prefix must load (checked inside `check`, which also
    /// asserts that loaded actions stay inside the loaded bounds).
    #[test]
    fn mutated_payload_values_load_or_give_a_typed_error(
        base in base(),
        values in prop::collection::vec((any::<usize>(), special_f32()), 1..6),
    ) {
        let mutations: Vec<_> = values.into_iter().map(|(i, v)| Mutation::Value(i, v)).collect();
        blob_checks::check(&mutate(Parts::of(&base), &mutations, true));
    }
}

/// The bases are what the properties are about: each loads into its compiled shape.
#[test]
fn unmutated_bases_load() {
    assert!(Policy::<2, 32, 1, 2>::from_blob(ACTOR_2X32).is_ok());
    assert!(TinyActor::from_blob(&tiny_actor()).is_ok());
    assert_eq!(mutate(Parts::of(CRITIC_2X32), &[], false), CRITIC_2X32);
    assert_eq!(mutate(Parts::of(&discrete()), &[], false), discrete());
    blob_checks::check(ACTOR_2X32);
    blob_checks::check(&discrete());
    // Quantised bases load in the runtime (and only there), and their truncations are refused.
    for mut quantised in quantised_bases() {
        blob_checks::check(&quantised);
        assert!(policy_core::model::Model::from_blob(&quantised).is_ok());
        quantised.truncate(quantised.len() - 1);
        blob_checks::check(&quantised);
    }
    // Version 1 still loads, through every loader.
    assert_eq!(blob::verify(ACTOR_V1).expect("v1").header.version, 1);
    blob_checks::check(ACTOR_V1);
}
