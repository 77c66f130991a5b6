//! What must hold for any byte string given to the blob loader and the firmware boot path.
//!
//! Shared by the coverage-guided fuzz target `fuzz/fuzz_targets/blob.rs` and the proptest in
//! `tests/tests/blob_mutations.rs`, so both harnesses check the same things. Every check
//! panics with a message that names the broken property.

use firmware_sim::controller::{Controller, SUPPORTED};
use firmware_sim::harness;
use policy_core::blob::{self, Model, Verified};
use policy_core::{Critic, Error, ModelKind, Policy};

/// The golden 2x32 actor's shape, one of firmware-sim's compiled shapes.
pub type Actor2x32 = Policy<2, 32, 1, 2>;
/// The paper's 4x48 navigation actor.
pub type Actor4x48 = Policy<2, 48, 3, 2>;
/// The golden 2x32 critic.
pub type Critic2x32 = Critic<2, 2, 32, 1>;
/// A 66-byte actor: small enough that a fuzzer reaches its payload checks often.
pub type TinyActor = Policy<1, 2, 0, 1>;
/// A tiny critic, for the same reason.
pub type TinyCritic = Critic<1, 1, 2, 0>;

/// Observations every loaded actor is asked about: ordinary, huge, infinite and NaN.
pub const PROBES: [f32; 8] = [
    0.0,
    -5.9,
    3.25,
    1.0e30,
    f32::MAX,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
];

/// Runs every loader on `bytes` and checks all properties.
pub fn check(bytes: &[u8]) {
    let verified = blob::verify(bytes);
    if let Ok(v) = &verified {
        check_verified(bytes, v);
    }
    let verified = verified.map(|v| v.header);
    check_actor::<2, 32, 1, 2>(bytes, &verified);
    check_actor::<2, 48, 3, 2>(bytes, &verified);
    check_actor::<1, 2, 0, 1>(bytes, &verified);
    check_load(&mut *Box::new(Critic2x32::ZERO), bytes, &verified);
    check_load(&mut *Box::new(TinyCritic::ZERO), bytes, &verified);
    check_boot(bytes, &verified);
}

/// `verify` Ok: the header is this format's, and its length fields agree with the bytes.
fn check_verified(bytes: &[u8], v: &Verified<'_>) {
    let h = &v.header;
    assert_eq!(h.magic, blob::MAGIC, "verified blob has the wrong magic");
    assert_eq!(
        h.version,
        blob::VERSION,
        "verified blob has the wrong version"
    );
    assert_eq!(
        Some(v.payload.len()),
        h.shape.payload_len(h.kind),
        "verified payload length differs from the shape's"
    );
    assert_eq!(v.payload.len(), h.payload_len as usize, "payload_len field");
    assert!(
        v.payload.len() <= blob::MAX_PAYLOAD_LEN,
        "payload above the cap"
    );
    assert!(
        h.label.len() <= blob::LABEL_CAPACITY,
        "label above its capacity"
    );
    assert!(bytes.ends_with(&policy_core::crc32(&bytes[..bytes.len() - 4]).to_le_bytes()));
}

/// A snapshot of a model's parameters as bits (NaN-safe equality).
fn bits<M: Model>(model: &M) -> Vec<u32> {
    let mut out = Vec::new();
    model.params(&mut |p| out.extend(p.iter().map(|v| v.to_bits())));
    out
}

/// Makes `slot` not `ZERO`, so that "untouched" cannot pass by accident: parameter `i` holds
/// `i + 0.5`.
fn fill_sentinel<M: Model>(slot: &mut M) {
    let mut i = 0.0f32;
    slot.params_mut(&mut |p| {
        for v in p {
            *v = i + 0.5;
            i += 1.0;
        }
    });
}

/// Loads `bytes` into a sentinel-filled `slot` and checks the outcome against `verified`.
/// Returns whether the load succeeded.
fn check_load<M: Model>(
    slot: &mut M,
    bytes: &[u8],
    verified: &Result<blob::Header, Error>,
) -> bool {
    fill_sentinel(slot);
    let before = bits(slot);
    let result = blob::load_into(slot, bytes);
    match (&result, verified) {
        (Err(e), Err(v)) => assert_eq!(e, v, "load_into and verify disagree on a bad blob"),
        (_, Err(v)) => panic!("load_into accepted a blob verify rejects ({v})"),
        (Ok(()), Ok(h)) => check_loaded(slot, bytes, h),
        (Err(e), Ok(h)) => check_refused::<M>(e, h),
    }
    if result.is_err() {
        assert_eq!(
            bits(slot),
            before,
            "a failed load changed the slot ({result:?})"
        );
    }
    result.is_ok()
}

/// A verified blob that did not load: the error is the typed one its header calls for.
fn check_refused<M: Model>(e: &Error, h: &blob::Header) {
    if h.kind != M::KIND {
        assert!(
            matches!(e, Error::WrongKind { .. }),
            "expected WrongKind, got {e}"
        );
    } else if h.shape != M::SHAPE {
        assert!(
            matches!(e, Error::ShapeMismatch { .. }),
            "expected ShapeMismatch, got {e}"
        );
    } else {
        assert!(
            matches!(
                e,
                Error::NonFiniteParameter { .. } | Error::InvalidParameter { .. }
            ),
            "a verified blob of the right kind and shape failed with {e}"
        );
    }
}

/// A successful load: every parameter came from the payload, and writing the model back gives
/// a blob that verifies and loads to the same parameters.
fn check_loaded<M: Model>(model: &M, bytes: &[u8], h: &blob::Header) {
    assert_eq!(
        (h.kind, h.shape),
        (M::KIND, M::SHAPE),
        "loaded a blob of another shape"
    );
    assert_eq!(
        model.activation(),
        h.activation,
        "activation not taken from the header"
    );
    let payload = blob::verify(bytes).expect("verified above").payload;
    let expected: Vec<u32> = blob::payload_values(payload).map(f32::to_bits).collect();
    assert_eq!(
        bits(model),
        expected,
        "loaded parameters differ from the payload"
    );
    assert!(
        expected.iter().all(|&b| f32::from_bits(b).is_finite()),
        "loaded a non-finite value"
    );
    let rewritten = blob::to_vec(model, h.label.as_str()).expect("a loaded model writes back");
    let again = blob::verify(&rewritten).expect("a written blob verifies");
    assert_eq!(&again.header, h, "header changed in a write-back");
    assert_eq!(again.payload, payload, "payload changed in a write-back");
}

/// [`check_load`] for an actor, plus: every action is finite and inside the loaded bounds.
fn check_actor<const S: usize, const H: usize, const L: usize, const A: usize>(
    bytes: &[u8],
    verified: &Result<blob::Header, Error>,
) {
    let mut slot = Box::new(Policy::<S, H, L, A>::ZERO);
    if !check_load(&mut *slot, bytes, verified) {
        return;
    }
    for obs in probe_observations::<S>() {
        let action = slot.act(&obs);
        for (i, a) in action.iter().enumerate() {
            let (lo, hi) = (slot.bounds.low[i], slot.bounds.high[i]);
            assert!(
                a.is_finite() && lo <= *a && *a <= hi,
                "act({obs:?})[{i}] = {a} outside [{lo}, {hi}]"
            );
        }
    }
}

/// Every pair of probes (for `S <= 2`) or each probe in every component.
fn probe_observations<const S: usize>() -> Vec<[f32; S]> {
    let mut out = Vec::new();
    for (i, &p) in PROBES.iter().enumerate() {
        for &q in &PROBES[i..] {
            let mut obs = [p; S];
            if let Some(last) = obs.last_mut() {
                *last = q;
            }
            out.push(obs);
            out.push(obs.map(|x| -x));
        }
    }
    out
}

/// The firmware-sim boot path: it accepts exactly the verified 2-observation, 2-action actor
/// blobs of a compiled shape whose payload loads, and then acts like policy-core.
fn check_boot(bytes: &[u8], verified: &Result<blob::Header, Error>) {
    let booted = harness::boot(bytes);
    let Ok(h) = verified else {
        assert!(booted.is_err(), "boot accepted a blob verify rejects");
        return;
    };
    let compiled = h.kind == ModelKind::Actor && SUPPORTED.contains(&h.shape);
    let Ok(mut policy) = booted else {
        if compiled {
            // Only the payload can be at fault: the same bytes must fail a direct load.
            assert!(
                direct_policy(bytes, h).is_none(),
                "boot refused a blob policy-core loads"
            );
        }
        return;
    };
    assert!(
        compiled,
        "boot accepted a blob of a shape it does not compile: {}",
        h.shape
    );
    assert_eq!(policy.header(), h, "boot reports another header");
    let direct = direct_policy(bytes, h);
    for x in PROBES {
        for y in PROBES {
            let mut action = [f32::NAN; 2];
            policy.act(&[x, y], &mut action);
            assert!(
                action.iter().all(|a| a.is_finite()),
                "boot act({x}, {y}) = {action:?}"
            );
            if let Some(direct) = &direct {
                let expected = direct(&[x, y]);
                assert_eq!(
                    action.map(f32::to_bits),
                    expected.map(f32::to_bits),
                    "boot and policy-core differ"
                );
            }
        }
    }
}

/// policy-core's actor for the shapes compiled here, loaded directly from `bytes`.
type DirectPolicy = Box<dyn Fn(&[f32; 2]) -> [f32; 2]>;

/// [`DirectPolicy`] of a blob whose shape is compiled here.
fn direct_policy(bytes: &[u8], h: &blob::Header) -> Option<DirectPolicy> {
    if h.shape == <Actor2x32 as Model>::SHAPE {
        let p = Actor2x32::from_blob(bytes).ok()?;
        return Some(Box::new(move |obs| p.act(obs)));
    }
    if h.shape == <Actor4x48 as Model>::SHAPE {
        let mut p = Box::new(Actor4x48::ZERO);
        p.load_into(bytes).ok()?;
        return Some(Box::new(move |obs| p.act(obs)));
    }
    None
}
