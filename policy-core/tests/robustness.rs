//! No byte string makes the loader panic, and every corruption of a real blob is rejected.
//!
//! docs/design.md §5: "no input makes policy-core panic (fuzzed); every 1- and 2-bit corruption of a
//! blob is rejected". A panic fails these tests by itself; the asserts check rejection.

use policy_core::model::Model;
use policy_core::{blob, Activation, Critic, Policy};

use crate::support::{
    blob_of, discrete_blob, nav_critic, nav_policy, tiny_policy, SplitMix64, TINY_LABEL,
};

type Actor = Policy<2, 32, 1, 2>;
type Tiny = Policy<1, 2, 0, 1>;
type Q = Critic<2, 32, 1, 2>;

fn actor_blob() -> Vec<u8> {
    blob_of(
        &nav_policy::<2, 32, 1, 2>(11, Activation::Tanh),
        "robustness",
    )
}

/// Runs every loader on `bytes`; returns whether any accepted it. Checks that failed loads
/// leave their (zero) slots untouched.
fn try_all(bytes: &[u8], actor: &mut Actor, tiny: &mut Tiny, critic: &mut Q) -> bool {
    let verified = blob::verify(bytes).is_ok();
    let runtime = Model::from_blob(bytes).is_ok();
    let a = actor.load_into(bytes).is_ok();
    let t = tiny.load_into(bytes).is_ok();
    let c = critic.load_into(bytes).is_ok();
    if !a {
        assert_eq!(*actor, Actor::ZERO);
    }
    if !t {
        assert_eq!(*tiny, Tiny::ZERO);
    }
    if !c {
        assert_eq!(*critic, Q::ZERO);
    }
    verified || runtime || a || t || c
}

/// 100,000 inputs in four families: pure noise, noise after the magic, noise after a real
/// header prefix, and real tiny blobs with a few random bytes overwritten.
#[test]
fn random_byte_strings_are_rejected_without_panic() {
    let mut rng = SplitMix64(0xF022);
    let actor = actor_blob();
    let header_len = actor.len() - 4 * 1227 - 4;
    let tiny = blob_of(&tiny_policy(), TINY_LABEL);
    let (mut a, mut t, mut c) = (Actor::ZERO, Tiny::ZERO, Q::ZERO);
    let mut bytes = Vec::with_capacity(256);
    let mut accepted_mutants = 0;
    for case in 0..100_000 {
        bytes.clear();
        let family = case % 4;
        match family {
            0 => {}
            1 => bytes.extend_from_slice(b"DCPB"),
            2 => bytes.extend_from_slice(&actor[..rng.below(header_len + 1)]),
            _ => bytes.extend_from_slice(&tiny),
        }
        if family == 3 {
            for _ in 0..1 + rng.below(4) {
                let at = rng.below(bytes.len());
                bytes[at] = rng.next() as u8;
            }
        } else {
            let extra = rng.below(if family == 0 { 80 } else { 120 });
            bytes.extend((0..extra).map(|_| rng.next() as u8));
        }
        let accepted = try_all(&bytes, &mut a, &mut t, &mut c);
        if family == 3 {
            // Overwriting a byte with its own value leaves a valid blob: that must load.
            accepted_mutants += usize::from(accepted);
            assert_eq!(
                accepted,
                bytes == tiny,
                "mutant {case} accepted: {bytes:02x?}"
            );
            t = Tiny::ZERO;
        } else {
            assert!(!accepted, "random input {case} accepted: {bytes:02x?}");
        }
    }
    assert!(accepted_mutants < 1000);
}

/// Flips every bit of a real actor and a real critic blob in turn. (Only the matching type is
/// tried: a flipped blob that got past `verify` would fail the other types at the kind or shape
/// check anyway, and each extra load costs a CRC of the whole blob.)
#[test]
fn every_single_bit_flip_is_rejected() {
    let actor = actor_blob();
    let critic = blob_of(&nav_critic::<2, 32, 1, 2>(12, Activation::Relu), "critic");
    let (mut a, mut c) = (Actor::ZERO, Q::ZERO);
    a.load_into(&actor).expect("unflipped actor loads");
    c.load_into(&critic).expect("unflipped critic loads");
    let (a0, c0) = (a.clone(), c.clone());
    for_each_flip(&actor, |bit, bytes| {
        assert!(
            blob::verify(bytes).is_err(),
            "actor: flip of bit {bit} verified"
        );
        assert!(
            a.load_into(bytes).is_err(),
            "actor: flip of bit {bit} loaded"
        );
    });
    for_each_flip(&critic, |bit, bytes| {
        assert!(
            c.load_into(bytes).is_err(),
            "critic: flip of bit {bit} loaded"
        );
    });
    assert_eq!((a, c), (a0, c0), "a rejected load changed its slot");
}

fn for_each_flip(blob: &[u8], mut f: impl FnMut(usize, &[u8])) {
    let mut bytes = blob.to_vec();
    for bit in 0..8 * blob.len() {
        bytes[bit / 8] ^= 1 << (bit % 8);
        f(bit, &bytes);
        bytes[bit / 8] ^= 1 << (bit % 8);
    }
}

#[test]
fn every_truncation_is_rejected() {
    let blob = actor_blob();
    let (mut a, mut t, mut c) = (Actor::ZERO, Tiny::ZERO, Q::ZERO);
    for n in 0..blob.len() {
        assert!(
            !try_all(&blob[..n], &mut a, &mut t, &mut c),
            "truncation to {n} accepted"
        );
    }
}

/// Every pair of bits of the spec's 72-byte example (165,600 pairs).
#[test]
fn every_double_bit_flip_of_the_tiny_blob_is_rejected() {
    let blob = blob_of(&tiny_policy(), TINY_LABEL);
    let bits = 8 * blob.len();
    let mut bytes = blob.clone();
    let mut slot = Tiny::ZERO;
    for i in 0..bits {
        bytes[i / 8] ^= 1 << (i % 8);
        for j in i + 1..bits {
            bytes[j / 8] ^= 1 << (j % 8);
            assert!(
                slot.load_into(&bytes).is_err(),
                "flip of bits {i} and {j} accepted"
            );
            bytes[j / 8] ^= 1 << (j % 8);
        }
        bytes[i / 8] ^= 1 << (i % 8);
    }
    assert_eq!(slot, Tiny::ZERO);
}

/// 20,000 random pairs of bits of a full-size blob (all 0.8 billion pairs would take minutes).
#[test]
fn sampled_double_bit_flips_of_a_real_blob_are_rejected() {
    let blob = actor_blob();
    let bits = 8 * blob.len();
    let mut rng = SplitMix64(0x2B17);
    let mut bytes = blob.clone();
    let mut slot = Actor::ZERO;
    for _ in 0..20_000 {
        let i = rng.below(bits);
        let j = (i + 1 + rng.below(bits - 1)) % bits;
        bytes[i / 8] ^= 1 << (i % 8);
        bytes[j / 8] ^= 1 << (j % 8);
        assert!(
            slot.load_into(&bytes).is_err(),
            "flip of bits {i} and {j} accepted"
        );
        bytes.copy_from_slice(&blob);
    }
    assert_eq!(slot, Actor::ZERO);
}

/// Every single-bit flip and every truncation of version-2 blobs of every kind (actor, critic,
/// discrete policy) is rejected by the runtime loader.
#[test]
fn every_flip_and_truncation_of_every_kind_is_rejected_by_the_runtime() {
    let blobs = [
        ("actor", actor_blob()),
        (
            "critic",
            blob_of(&nav_critic::<2, 32, 1, 2>(13, Activation::Tanh), "critic"),
        ),
        ("discrete", discrete_blob(14)),
    ];
    for (kind, bytes) in &blobs {
        assert_eq!(blob::verify(bytes).expect("v2").header.version, 2);
        Model::from_blob(bytes).expect("unflipped blob loads");
        for_each_flip(bytes, |bit, flipped| {
            assert!(
                Model::from_blob(flipped).is_err(),
                "{kind}: flip of bit {bit} loaded"
            );
        });
        for n in 0..bytes.len() {
            assert!(
                Model::from_blob(&bytes[..n]).is_err(),
                "{kind}: truncation to {n} loaded"
            );
        }
    }
}
