//! Any valid model written then loaded is identical, bit for bit (proptest).

use policy_core::blob::{self, Compiled};
use policy_core::{Critic, Policy};
use proptest::prelude::*;

use crate::support::{arbitrary_critic, arbitrary_policy, blob_of};

/// Write, verify the header, load into a fresh slot, compare values and re-written bytes (the
/// bytes catch what `==` on f32 misses: -0.0 versus 0.0).
fn round_trip<M: Compiled + Clone + PartialEq + core::fmt::Debug>(model: &M, label: &str, zero: M) {
    let bytes = blob_of(model, label);
    let v = blob::verify(&bytes).expect("verify");
    assert_eq!(v.header.label.as_str(), label);
    assert_eq!((v.header.kind, v.header.shape), (M::KIND, M::SHAPE));
    assert_eq!(v.header.activation, model.activation());
    let mut slot = zero;
    blob::load_into(&mut slot, &bytes).expect("load");
    assert_eq!(&slot, model);
    assert_eq!(blob_of(&slot, label), bytes);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn actors_round_trip(seed in any::<u64>(), label in "\\PC{0,8}") {
        let label: String = label.chars().take(8).collect(); // ≤ 32 bytes of UTF-8
        round_trip(&arbitrary_policy::<1, 1, 0, 1>(seed), &label, Policy::ZERO);
        round_trip(&arbitrary_policy::<2, 32, 1, 2>(seed), &label, Policy::ZERO);
        round_trip(&arbitrary_policy::<2, 48, 3, 2>(seed), &label, Policy::ZERO);
        round_trip(&arbitrary_policy::<5, 7, 2, 3>(seed), &label, Policy::ZERO);
    }

    #[test]
    fn critics_round_trip(seed in any::<u64>(), label in "[a-z0-9 _-]{0,32}") {
        round_trip(&arbitrary_critic::<2, 32, 1, 2>(seed), &label, Critic::ZERO);
        round_trip(&arbitrary_critic::<3, 4, 0, 1>(seed), &label, Critic::ZERO);
        round_trip(&arbitrary_critic::<6, 9, 2, 4>(seed), &label, Critic::ZERO);
    }
}

/// Both activations are covered whatever proptest draws (the generator picks by seed parity).
#[test]
fn both_activations_round_trip() {
    for seed in [0, 1] {
        round_trip(&arbitrary_policy::<2, 32, 1, 2>(seed), "a", Policy::ZERO);
        round_trip(&arbitrary_critic::<2, 32, 1, 2>(seed), "c", Critic::ZERO);
    }
    assert_ne!(
        arbitrary_policy::<1, 1, 0, 1>(0).trunk.activation,
        arbitrary_policy::<1, 1, 0, 1>(1).trunk.activation
    );
}

/// Same seed, same bytes: the writer has no hidden state.
#[test]
fn writing_is_deterministic() {
    let p = arbitrary_policy::<2, 48, 3, 2>(42);
    assert_eq!(blob_of(&p, "x"), blob_of(&p.clone(), "x"));
}
