//! The A/B slot rule on the bad inputs a flasher or a power cut can leave behind: each leads to
//! the other slot or the safe state with its reason, never a panic, and never to running a blob
//! that does not verify.

use policy_core::model::Model;
use policy_core::slot::{self, Boot, SlotId, Status};
use policy_core::{Activation, Error};

use crate::support::{blob_of, nav_critic, nav_policy, SplitMix64};

/// The example firmware's sizes and scratch width.
const OBS: usize = 2;
const ACT: usize = 2;
const W: usize = 64;
/// A slot of the test's flash (small, so that whole-slot cases stay fast).
const SLOT: usize = 8 * 1024;

fn good(seed: u64) -> Vec<u8> {
    blob_of(&nav_policy::<2, 32, 1, 2>(seed, Activation::Relu), "slot")
}

/// A slot holding `blob` with `sequence`, the rest of the slot erased (0xFF), as after a
/// flasher's sector erase and write.
fn slot_with(blob: &[u8], sequence: u32) -> Vec<u8> {
    let mut s = slot::header(sequence, blob.len())
        .expect("test value")
        .to_vec();
    s.extend_from_slice(blob);
    s.resize(SLOT, 0xFF);
    s
}

fn boot<'a>(a: &'a [u8], b: &'a [u8]) -> Boot<Model<'a>> {
    slot::choose(a, b, |blob| Model::for_policy(blob, OBS, ACT, W))
}

fn runs(boot: &Boot<Model<'_>>) -> Option<SlotId> {
    boot.running.as_ref().map(|(id, _)| *id)
}

/// A bad slot: its name, its bytes, and the test its error must pass.
type BadSlot = (&'static str, Vec<u8>, fn(&Error) -> bool);

/// Every kind of bad slot B a device can meet (random bytes, a cut transfer, a record that
/// overflows, a critic, another plant's blob, a too-wide model, a flipped bit, an erased or
/// blank slot), with the error it must give.
fn bad_slots() -> Vec<BadSlot> {
    let mut rng = SplitMix64(0x5107);
    let random: Vec<u8> = (0..SLOT).map(|_| rng.next() as u8).collect();
    let newer = slot_with(&good(2), 2);
    // A transfer cut at half the record: the rest of the slot is still erased.
    let mut truncated = newer[..newer.len() / 2].to_vec();
    truncated.resize(SLOT, 0xFF);
    let critic = blob_of(&nav_critic::<2, 32, 1, 2>(3, Activation::Relu), "critic");
    let six = blob_of(
        &nav_policy::<6, 32, 1, 2>(4, Activation::Relu),
        "other plant",
    );
    let wide = blob_of(&nav_policy::<2, 72, 0, 2>(5, Activation::Relu), "too wide");
    let mut flipped = newer.clone();
    flipped[slot::HEADER_LEN + 100] ^= 0x10;
    vec![
        ("random bytes", random, |e| {
            matches!(e, Error::SlotMagic { .. })
        }),
        ("truncated record", truncated, |e| {
            matches!(e, Error::ChecksumMismatch { .. })
        }),
        (
            "record longer than the slot",
            newer[..slot::HEADER_LEN + good(2).len() - 1].to_vec(),
            |e| matches!(e, Error::SlotOverflow { .. }),
        ),
        ("critic blob", slot_with(&critic, 2), |e| {
            matches!(e, Error::WrongKind { .. })
        }),
        ("blob of another plant", slot_with(&six, 2), |e| {
            matches!(e, Error::SizeMismatch { .. })
        }),
        ("blob too wide for the scratch", slot_with(&wide, 2), |e| {
            matches!(e, Error::ScratchTooSmall { .. })
        }),
        ("one flipped byte", flipped, |e| {
            matches!(e, Error::ChecksumMismatch { .. })
        }),
        ("erased", vec![0xFF; SLOT], |e| *e == Error::SlotEmpty),
        ("blank", vec![0; SLOT], |e| *e == Error::SlotEmpty),
    ]
}

#[test]
fn each_bad_newer_slot_falls_back_to_the_older_with_its_reason() {
    let a = slot_with(&good(1), 1);
    for (name, b, is_reason) in bad_slots() {
        let boot = boot(&a, &b);
        assert_eq!(runs(&boot), Some(SlotId::A), "{name}");
        assert_eq!(boot.a, Status::Running { sequence: 1 }, "{name}");
        match boot.b {
            Status::Failed(e) => assert!(is_reason(&e), "{name}: {e}"),
            other => panic!("{name}: slot B is {other}"),
        }
    }
}

#[test]
fn bad_slots_on_both_sides_give_the_safe_state_with_both_reasons() {
    let slots = bad_slots();
    for (name_a, a, is_a) in &slots {
        for (name_b, b, is_b) in &slots {
            let boot = boot(a, b);
            assert!(boot.running.is_none(), "{name_a} / {name_b}");
            assert!(matches!(boot.a, Status::Failed(e) if is_a(&e)), "{name_a}");
            assert!(matches!(boot.b, Status::Failed(e) if is_b(&e)), "{name_b}");
        }
    }
}

#[test]
fn a_wrapped_sequence_number_is_newer_than_the_maximum() {
    let (old, new) = (good(1), good(2));
    let (max, zero) = (slot_with(&old, u32::MAX), slot_with(&new, 0));
    let boot_wrapped = boot(&max, &zero);
    assert_eq!(runs(&boot_wrapped), Some(SlotId::B));
    assert_eq!(boot_wrapped.a, Status::Standby { sequence: u32::MAX });
    // And the other way round: 0 in A after u32::MAX in B.
    let (zero, max) = (slot_with(&new, 0), slot_with(&old, u32::MAX));
    let boot_other = boot(&zero, &max);
    assert_eq!(runs(&boot_other), Some(SlotId::A));
}

#[test]
fn the_running_blob_is_the_newer_slots_own_bytes() {
    let (old, new) = (good(1), good(2));
    let (a, b) = (slot_with(&old, 6), slot_with(&new, 7));
    let boot = boot(&a, &b);
    let (id, model) = boot.running.expect("B runs");
    assert_eq!(id, SlotId::B);
    let newer = Model::from_blob(&new).expect("test value");
    let (mut s1, mut s2) = (
        policy_core::model::Scratch::<W>::new(),
        policy_core::model::Scratch::<W>::new(),
    );
    let (mut x, mut y) = ([0.0; 2], [0.0; 2]);
    model
        .act(&[1.0, -2.0], &mut s1, &mut x)
        .expect("test value");
    newer
        .act(&[1.0, -2.0], &mut s2, &mut y)
        .expect("test value");
    assert_eq!(x.map(f32::to_bits), y.map(f32::to_bits));
}

/// Every single-bit corruption of the newer slot's record (header and blob) makes it fall back:
/// a damaged sequence number can never promote a slot, and a damaged blob never runs.
#[test]
fn every_bit_flip_of_the_newer_record_falls_back_to_the_older() {
    let a = slot_with(&good(1), 1);
    let b = slot_with(&good(2), 2);
    let record_len = slot::HEADER_LEN + good(2).len();
    let mut damaged = b.clone();
    for byte in 0..record_len {
        for bit in 0..8 {
            damaged[byte] ^= 1 << bit;
            let boot = boot(&a, &damaged);
            assert_eq!(runs(&boot), Some(SlotId::A), "byte {byte} bit {bit}");
            damaged[byte] ^= 1 << bit;
        }
    }
}

/// Arbitrary bytes in both slots, and mutated records: the rule never panics, and whatever it
/// runs passed the firmware's verification.
#[test]
fn arbitrary_slot_contents_never_panic_and_never_run_an_unverified_blob() {
    let mut rng = SplitMix64(0xAB51);
    let base = [slot_with(&good(1), 1), slot_with(&good(2), 2)];
    for case in 0..4_000 {
        let mut slots = base.clone();
        for s in &mut slots {
            match case % 4 {
                0 => s.iter_mut().for_each(|b| *b = rng.next() as u8),
                1 => {
                    let n = rng.below(SLOT);
                    s.truncate(n);
                }
                _ => {
                    for _ in 0..1 + rng.below(4) {
                        let i = rng.below(slot::HEADER_LEN + 64);
                        s[i] = rng.next() as u8;
                    }
                }
            }
        }
        let boot = boot(&slots[0], &slots[1]);
        if let Some((id, _)) = &boot.running {
            let s = &slots[usize::from(*id == SlotId::B)];
            let record = slot::read(s).expect("a running slot has a valid record");
            assert!(Model::for_policy(record.blob, OBS, ACT, W).is_ok());
        }
    }
}

/// A firmware that takes its sizes from the blob (the example firmware: buffers of 8
/// observations and 8 actions) boots a policy for another plant, here 3 observations and 1
/// action, and runs it at the blob's sizes; a blob beyond its buffers falls back with the
/// reason, as a critic does.
#[test]
fn a_firmware_sized_by_the_blob_boots_any_plant_within_its_maxima() {
    use crate::support::runtime_blob;
    use policy_core::model::Scratch;
    use policy_core::{ModelKind, Shape};
    let shape = |observations, actions| Shape {
        observations,
        actions,
        width: 16,
        depth: 2,
        choices: 0,
    };
    let cart = runtime_blob(ModelKind::Actor, shape(3, 1), Activation::Tanh, 5);
    let wide = runtime_blob(ModelKind::Actor, shape(9, 1), Activation::Tanh, 6);
    let critic = runtime_blob(ModelKind::Critic, shape(3, 1), Activation::Tanh, 7);
    fn within(blob: &[u8]) -> Result<Model<'_>, Error> {
        Model::for_policy_within(blob, 8, 8, W)
    }
    let (a, b) = (slot_with(&cart, 1), slot_with(&wide, 2));
    let boot = slot::choose(&a, &b, within);
    let Some((SlotId::A, model)) = boot.running else {
        panic!("slot A must run: {boot:?}")
    };
    assert_eq!(
        boot.b.to_string(),
        "failed: observation size 9 beyond the firmware's maximum of 8"
    );
    let shape = model.header().shape;
    assert_eq!((shape.observations, shape.actions), (3, 1));
    let mut action = [f32::NAN; 1];
    model
        .act(
            &[0.5, f32::NAN, -4.0],
            &mut Scratch::<W>::new(),
            &mut action,
        )
        .expect("the blob's sizes run");
    assert!(action[0].is_finite() && action[0].abs() <= 0.25);
    // The same blob in a firmware of fixed sizes is refused, as before.
    assert!(matches!(
        Model::for_policy(&cart, OBS, ACT, W),
        Err(Error::SizeMismatch { .. })
    ));
    assert!(matches!(within(&critic), Err(Error::WrongKind { .. })));
}
