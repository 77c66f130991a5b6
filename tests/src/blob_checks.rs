//! What must hold for any byte string given to the blob loader and the firmware boot path.
//!
//! Shared by the coverage-guided fuzz target `fuzz/fuzz_targets/blob.rs` and the proptest in
//! `tests/tests/blob_mutations.rs`, so both harnesses check the same things. Every check
//! panics with a message that names the broken property.

use firmware_sim::boot;
use firmware_sim::controller::Controller;
use policy_core::blob::{self, Compiled, Spec, Verified};
use policy_core::model::{Model, Scratch};
use policy_core::slot::{self, SlotId};
use policy_core::{Critic, Error, ModelKind, Policy};

/// The golden 2x32 actor's shape.
pub type Actor2x32 = Policy<2, 32, 1, 2>;
/// The paper's 4x48 navigation actor.
pub type Actor4x48 = Policy<2, 48, 3, 2>;
/// The golden 2x32 critic.
pub type Critic2x32 = Critic<2, 32, 1, 2>;
/// A tiny actor: small enough that a fuzzer reaches its payload checks often.
pub type TinyActor = Policy<1, 2, 0, 1>;
/// A tiny critic, for the same reason.
pub type TinyCritic = Critic<1, 2, 0, 1>;

/// Observation components every loaded model is asked about: ordinary, huge, infinite and NaN.
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

/// The widest scratch the checks use; wider blobs must be refused with `ScratchTooSmall`.
const WIDTH: usize = 256;

/// Runs every loader on `bytes` and checks all properties.
pub fn check(bytes: &[u8]) {
    let verified = blob::verify(bytes);
    if let Ok(v) = &verified {
        check_verified(bytes, v);
    }
    let runtime = Model::from_blob(bytes);
    match (&runtime, &verified) {
        (Ok(_), Err(e)) => panic!("Model accepted a blob verify rejects ({e})"),
        (Err(e), Err(v)) => assert_eq!(e, v, "Model and verify disagree on a bad blob"),
        (Err(e), Ok(_)) => assert!(
            matches!(
                e,
                Error::NonFiniteParameter { .. } | Error::InvalidParameter { .. }
            ) || matches!(e, Error::Malformed { what } if what.contains("padding")),
            "a verified blob failed its parameter checks with {e}"
        ),
        (Ok(model), Ok(v)) => check_model(model, v),
    }
    let header = verified.map(|v| v.header);
    let runtime = runtime.ok();
    check_actor::<2, 32, 1, 2>(bytes, &header, runtime.as_ref());
    check_actor::<2, 48, 3, 2>(bytes, &header, runtime.as_ref());
    check_actor::<1, 2, 0, 1>(bytes, &header, runtime.as_ref());
    check_load(
        &mut *Box::new(Critic2x32::ZERO),
        bytes,
        &header,
        runtime.is_some(),
    );
    check_load(
        &mut *Box::new(TinyCritic::ZERO),
        bytes,
        &header,
        runtime.is_some(),
    );
    check_boot(bytes, runtime.as_ref());
    check_slots(bytes);
}

/// A good slot A: the golden 2x32 actor with sequence number 1.
fn good_slot_a() -> &'static [u8] {
    static A: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    A.get_or_init(|| {
        let blob = include_bytes!("../../policy-core/tests/golden/actor_2x32.postcard");
        slot::record(blob, 1, 1 << 16).expect("the golden actor fits a 64 KiB slot")
    })
}

/// The A/B slot rule (policy-core's `slot::choose` with the firmware's verification): with the
/// bytes as slot B beside a good slot A, something always runs, and B only if its record is
/// intact and its blob passes; with the bytes split into two slots, whatever runs passed.
fn check_slots(bytes: &[u8]) {
    fn verify(blob: &[u8]) -> Result<Model<'_>, Error> {
        Model::for_policy(blob, 2, 2, WIDTH)
    }
    let runs_verified = |slot_bytes: &[u8]| {
        let record = slot::read(slot_bytes).expect("a running slot has an intact record");
        assert!(
            verify(record.blob).is_ok(),
            "a running slot's blob verifies"
        );
    };
    match slot::choose(good_slot_a(), bytes, verify).running {
        None => panic!("a good slot A must run whatever slot B holds"),
        Some((SlotId::B, _)) => runs_verified(bytes),
        Some((SlotId::A, _)) => {}
    }
    let (x, y) = bytes.split_at(bytes.len() / 2);
    match slot::choose(x, y, verify).running {
        Some((SlotId::A, _)) => runs_verified(x),
        Some((SlotId::B, _)) => runs_verified(y),
        None => {}
    }
}

/// `verify` Ok: the header is one this build reads, its length fields agree with the bytes, the
/// payload of a version-2 blob is 4-byte aligned, and the CRC is right.
fn check_verified(bytes: &[u8], v: &Verified<'_>) {
    let h = &v.header;
    assert_eq!(h.magic, blob::MAGIC, "verified blob has the wrong magic");
    assert!(
        blob::VERSIONS_READ.contains(&h.version),
        "verified blob has version {}",
        h.version
    );
    assert_eq!(
        Some(v.payload.len()),
        h.shape.payload_len_for(h.kind, h.encoding, h.activation),
        "verified payload length differs from the shape's and encoding's"
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
    assert!(h.shape.check(h.kind).is_ok(), "shape beyond the limits");
    if h.version >= 2 {
        let offset = bytes.len() - 4 - v.payload.len();
        assert_eq!(
            offset % 4,
            0,
            "version-{} payload at offset {offset}",
            h.version
        );
        // Canonical: the header bytes are postcard's encoding of the decoded header, so no
        // field was accepted in a longer form than the writer emits (the fuzzer's widened
        // varints must be refused).
        let canonical = postcard::to_stdvec(h).expect("a header encodes");
        assert_eq!(
            bytes.get(..canonical.len()),
            Some(&canonical[..]),
            "verified a header that is not in canonical form"
        );
        assert!(offset - canonical.len() < 4, "more than 3 bytes of padding");
    }
    assert!(bytes.ends_with(&policy_core::crc32(&bytes[..bytes.len() - 4]).to_le_bytes()));
}

/// A model the runtime accepted: its values are the payload (f32) or decode from it (f16,
/// int8), it writes back to the same header (as version 2 for f32, 3 for the quantised
/// encodings) and payload (an int8 write-back may choose other scales, so there: values within
/// one quantisation step), and every kind's output obeys its contract.
fn check_model(model: &Model<'_>, v: &Verified<'_>) {
    let values: Vec<f32> = model.values().collect();
    let encoding = model.header().encoding;
    // An integer blob's values are its f32 prefix; its layers are integers that only the
    // calibrated writer makes, so there is nothing to write back: its outputs obey the contract.
    if encoding == policy_core::Encoding::Integer {
        assert!(
            values.iter().all(|x| x.is_finite()),
            "accepted a non-finite value"
        );
        check_outputs(model);
        return;
    }
    if encoding == policy_core::Encoding::F32 {
        let expected: Vec<u32> = blob::payload_values(v.payload).map(f32::to_bits).collect();
        assert_eq!(
            values.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            expected,
            "model values differ from the payload"
        );
    }
    assert!(
        values.iter().all(|x| x.is_finite()),
        "accepted a non-finite value"
    );
    let h = model.header();
    let spec = Spec::like(h, encoding);
    let mut out = vec![0u8; blob::encoded_len(&spec).expect("an accepted shape encodes")];
    let n = blob::write(&spec, &mut |sink| sink(&values), &mut out).expect("writes back");
    let again = blob::verify(&out[..n]).expect("a written blob verifies");
    if encoding == policy_core::Encoding::Int8 {
        let step = values.iter().fold(0.0f32, |m, v| m.max(v.abs())) / 127.0;
        let reloaded = Model::from_blob(&out[..n]).expect("a written blob loads");
        for (a, b) in reloaded.values().zip(&values) {
            assert!((a - b).abs() <= step, "int8 write-back moved {b} to {a}");
        }
    } else {
        assert_eq!(again.payload, v.payload, "payload changed in a write-back");
    }
    let mut header = h.clone();
    header.version = encoding.version();
    assert_eq!(again.header, header, "header changed in a write-back");
    check_outputs(model);
}

/// Outputs on the probe observations: actions finite and in bounds (a discrete policy's: its
/// table row), and a narrow scratch refused with a typed error.
fn check_outputs(model: &Model<'_>) {
    let h = model.header();
    let (s, a) = (h.shape.observations as usize, h.shape.actions as usize);
    let needed = h.shape.scratch_width(h.kind);
    let mut scratch = Box::new(Scratch::<WIDTH>::new());
    if needed > WIDTH {
        let mut action = vec![0.0; a];
        let err = model.act(&vec![0.0; s], &mut scratch, &mut action);
        assert!(
            err.is_err() || h.kind == ModelKind::Critic,
            "a blob needing width {needed} ran in {WIDTH}"
        );
        return;
    }
    let values: Vec<f32> = model.values().collect();
    let bounds = 2 * s + 1;
    for obs in probe_observations(s) {
        match h.kind {
            ModelKind::Critic => {
                // Any value, but never a panic; the action is clamped into the unit box.
                let _ = model.q(&obs, &vec![f32::NAN; a], &mut scratch);
            }
            ModelKind::Actor | ModelKind::Discrete => {
                let mut action = vec![f32::NAN; a];
                model.act(&obs, &mut scratch, &mut action).expect("acts");
                for (i, x) in action.iter().enumerate() {
                    let (lo, hi) = (values[bounds + i], values[bounds + a + i]);
                    assert!(
                        x.is_finite() && lo <= *x && *x <= hi,
                        "act({obs:?})[{i}] = {x} outside [{lo}, {hi}]"
                    );
                }
                if h.kind == ModelKind::Discrete {
                    let row = model.choose(&obs, &mut scratch).expect("chooses");
                    let at = bounds + 2 * a + row * a;
                    let expected: Vec<u32> =
                        values[at..at + a].iter().map(|x| x.to_bits()).collect();
                    let got: Vec<u32> = action.iter().map(|x| x.to_bits()).collect();
                    assert_eq!(got, expected, "discrete act is not its chosen table row");
                }
            }
        }
    }
}

/// A snapshot of a compiled model's parameters as bits (NaN-safe equality).
fn bits<M: Compiled>(model: &M) -> Vec<u32> {
    let mut out = Vec::new();
    model.params(&mut |p| out.extend(p.iter().map(|v| v.to_bits())));
    out
}

/// Makes `slot` not `ZERO`, so that "untouched" cannot pass by accident: parameter `i` holds
/// `i + 0.5`.
fn fill_sentinel<M: Compiled>(slot: &mut M) {
    let mut i = 0.0f32;
    slot.params_mut(&mut |p| {
        for v in p {
            *v = i + 0.5;
            i += 1.0;
        }
    });
}

/// Loads `bytes` into a sentinel-filled compiled `slot`: it loads exactly when the runtime
/// accepts the blob and its kind and shape are the slot's, a failed load leaves the slot as it
/// was, and a loaded slot holds the payload. Returns whether the load succeeded.
fn check_load<M: Compiled>(
    slot: &mut M,
    bytes: &[u8],
    verified: &Result<blob::Header, Error>,
    runtime_ok: bool,
) -> bool {
    fill_sentinel(slot);
    let before = bits(slot);
    let result = blob::load_into(slot, bytes);
    let fits = verified.as_ref().is_ok_and(|h| {
        h.kind == M::KIND && h.shape == M::SHAPE && h.encoding == policy_core::Encoding::F32
    });
    assert_eq!(
        result.is_ok(),
        runtime_ok && fits,
        "compiled load disagrees with the runtime ({result:?})"
    );
    match &result {
        Ok(()) => {
            let payload = blob::verify(bytes).expect("verified above").payload;
            let expected: Vec<u32> = blob::payload_values(payload).map(f32::to_bits).collect();
            assert_eq!(
                bits(slot),
                expected,
                "loaded parameters differ from the payload"
            );
        }
        Err(_) => assert_eq!(
            bits(slot),
            before,
            "a failed load changed the slot ({result:?})"
        ),
    }
    result.is_ok()
}

/// [`check_load`] for an actor, plus: its actions equal the runtime's bit for bit.
fn check_actor<const S: usize, const H: usize, const L: usize, const A: usize>(
    bytes: &[u8],
    verified: &Result<blob::Header, Error>,
    runtime: Option<&Model<'_>>,
) {
    let mut slot = Box::new(Policy::<S, H, L, A>::ZERO);
    if !check_load(&mut *slot, bytes, verified, runtime.is_some()) {
        return;
    }
    let Some(model) = runtime else { return };
    let mut scratch = Box::new(Scratch::<WIDTH>::new());
    for obs in probe_observations(S) {
        let Ok(obs) = <[f32; S]>::try_from(obs.as_slice()) else {
            continue;
        };
        let mut action = [0.0f32; A];
        model.act(&obs, &mut scratch, &mut action).expect("acts");
        assert_eq!(
            slot.act(&obs).map(f32::to_bits),
            action.map(f32::to_bits),
            "compiled and runtime actors differ"
        );
    }
}

/// Every pair of probes in the last two components (the rest hold the first of the pair).
fn probe_observations(s: usize) -> Vec<Vec<f32>> {
    let mut out = Vec::new();
    for (i, &p) in PROBES.iter().enumerate() {
        for &q in &PROBES[i..] {
            let mut obs = vec![p; s];
            if let Some(last) = obs.last_mut() {
                *last = q;
            }
            out.push(obs.iter().map(|x| -x).collect());
            out.push(obs);
        }
    }
    out
}

/// The firmware-sim boot path on the navigation plant (2 observations, 2 actions): it boots
/// exactly the blobs the runtime accepts as a policy (actor or discrete) of those sizes, and
/// then acts like the runtime.
fn check_boot(bytes: &[u8], runtime: Option<&Model<'_>>) {
    let nav = boot::PlantSizes {
        observations: 2,
        actions: 2,
    };
    let booted = boot::boot(bytes, &nav);
    let runnable =
        runtime.filter(|m| m.header().kind != ModelKind::Critic && m.expect_sizes(2, 2).is_ok());
    let (Ok(mut policy), Some(model)) = (booted, runnable) else {
        assert_eq!(
            boot::boot(bytes, &nav).is_ok(),
            runnable.is_some(),
            "boot and the runtime disagree on whether the blob runs"
        );
        return;
    };
    let mut scratch = Box::new(Scratch::<WIDTH>::new());
    for x in PROBES {
        for y in PROBES {
            let mut action = [f32::NAN; 2];
            policy.act(&[x, y], &mut action);
            let mut expected = [f32::NAN; 2];
            if model.act(&[x, y], &mut scratch, &mut expected).is_err() {
                continue; // too wide for this scratch: boot's own width decides
            }
            assert_eq!(
                action.map(f32::to_bits),
                expected.map(f32::to_bits),
                "boot and policy-core differ"
            );
        }
    }
}
