//! The plant link's frames (proptest): any message of either side round-trips bit for bit, any
//! byte string and any valid frame with bytes changed go through [`plant_link_checks::check`]
//! (the `plant_link` fuzz target's properties), and a frame with any one bit flipped is
//! refused. The committed fuzz seeds are frames of this protocol version.

use std::path::Path;

use firmware_sim::plant_link::messages::{
    self, decode, encode, Agent, FromPlant, Hello, StepReply, ToPlant,
};
use proptest::prelude::*;
use tests::plant_link_checks;

/// Any f32, NaN payloads and signed zeros included.
fn value() -> impl Strategy<Value = f32> {
    prop_oneof![
        3 => any::<u32>().prop_map(f32::from_bits),
        1 => prop::sample::select(vec![0.0, -0.0, 1.0, f32::NAN, -f32::NAN, f32::INFINITY, f32::MIN_POSITIVE]),
    ]
}

fn values() -> impl Strategy<Value = Vec<f32>> {
    prop::collection::vec(value(), 0..12)
}

fn text() -> impl Strategy<Value = String> {
    prop_oneof![
        any::<String>(),
        "[a-z-]{0,12}",
        Just("é\u{0}\n".to_string())
    ]
}

fn to_plant() -> impl Strategy<Value = ToPlant> {
    prop_oneof![
        Just(ToPlant::Hello),
        any::<u64>().prop_map(|seed| ToPlant::Reset { seed }),
        values().prop_map(|action| ToPlant::Step { action }),
        Just(ToPlant::Close),
    ]
}

fn agent() -> impl Strategy<Value = Agent> {
    (text(), values(), values(), values(), values()).prop_map(|(name, ol, oh, al, ah)| Agent {
        name,
        observation_low: ol,
        observation_high: oh,
        action_low: al,
        action_high: ah,
    })
}

fn from_plant() -> impl Strategy<Value = FromPlant> {
    let step = (
        values(),
        value(),
        any::<[bool; 3]>(),
        values(),
        any::<Option<bool>>(),
    )
        .prop_map(
            |(observation, reward, [terminated, truncated, margin_touched], applied, success)| {
                FromPlant::Step(StepReply {
                    observation,
                    reward,
                    terminated,
                    truncated,
                    margin_touched,
                    applied,
                    success,
                })
            },
        );
    prop_oneof![
        (text(), prop::collection::vec(agent(), 0..3))
            .prop_map(|(name, agents)| FromPlant::Hello(Hello { name, agents })),
        values().prop_map(|observation| FromPlant::Reset { observation }),
        step,
        text().prop_map(|message| FromPlant::Error { message }),
    ]
}

/// The frames a stream of bytes holds, read as the host reads a plant's output.
fn frames(bytes: &[u8]) -> Vec<Vec<u8>> {
    let mut input = bytes;
    let mut out = Vec::new();
    while let Some(frame) = messages::read_frame(&mut input).expect("a slice reads") {
        out.extend(frame.ok());
    }
    out
}

/// Flips one bit of a frame (its delimiter included) and checks that nothing in it decodes as
/// `decode` reads: the flip may split the frame in two or merge it into what follows, but no
/// part of it is ever taken for a message.
fn flipped_is_refused<M: std::fmt::Debug>(
    frame: &[u8],
    bit: usize,
    decode: fn(&mut [u8]) -> Result<M, messages::LinkError>,
) -> Result<(), TestCaseError> {
    let mut bytes = frame.to_vec();
    let bit = bit % (bytes.len() * 8);
    bytes[bit / 8] ^= 1 << (bit % 8);
    for mut piece in frames(&bytes) {
        let got = decode(&mut piece);
        prop_assert!(got.is_err(), "bit {bit} flipped, still read as {got:?}");
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn requests_round_trip_bit_for_bit(message in to_plant()) {
        let frame = encode(&message).expect("any message encodes");
        prop_assert_eq!(frame.iter().position(|&b| b == 0), Some(frame.len() - 1));
        let read = frames(&frame);
        prop_assert_eq!(read.len(), 1);
        let back: ToPlant = decode(&mut read[0].clone()).expect("its own frame decodes");
        prop_assert_eq!(encode(&back).expect("encodes again"), frame.clone());
        plant_link_checks::check(&frame);
    }

    #[test]
    fn answers_round_trip_bit_for_bit(message in from_plant()) {
        let frame = encode(&message).expect("any message encodes");
        prop_assert_eq!(frame.iter().position(|&b| b == 0), Some(frame.len() - 1));
        let read = frames(&frame);
        prop_assert_eq!(read.len(), 1);
        let back: FromPlant = decode(&mut read[0].clone()).expect("its own frame decodes");
        // Bit for bit, NaN payloads included: equal frames hold equal bits.
        prop_assert_eq!(encode(&back).expect("encodes again"), frame.clone());
        if let (FromPlant::Step(a), FromPlant::Step(b)) = (&message, &back) {
            prop_assert_eq!(a.reward.to_bits(), b.reward.to_bits());
        }
        plant_link_checks::check(&frame);
    }

    #[test]
    fn any_bytes_are_a_message_or_an_error(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        plant_link_checks::check(&bytes);
    }

    #[test]
    fn valid_frames_with_bytes_changed_are_a_message_or_an_error(
        message in from_plant(),
        request in to_plant(),
        edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>(), 0..3u8), 1..4),
    ) {
        let mut bytes = encode(&message).expect("any message encodes");
        bytes.extend(encode(&request).expect("any message encodes"));
        for (at, byte, kind) in edits {
            let i = at.index(bytes.len());
            match kind {
                0 => bytes[i] = byte,
                1 => bytes.insert(i, byte),
                _ => { bytes.remove(i); }
            }
            if bytes.is_empty() {
                break;
            }
        }
        plant_link_checks::check(&bytes);
    }

    #[test]
    fn a_request_with_one_bit_flipped_is_refused(message in to_plant(), bit in any::<usize>()) {
        flipped_is_refused::<ToPlant>(&encode(&message).expect("any message encodes"), bit, decode)?;
    }

    #[test]
    fn an_answer_with_one_bit_flipped_is_refused(message in from_plant(), bit in any::<usize>()) {
        flipped_is_refused::<FromPlant>(&encode(&message).expect("any message encodes"), bit, decode)?;
    }
}

/// Every bit of a short request, not a sample: a frame from the byte-level example of
/// docs/own-plant.md.
#[test]
fn every_single_bit_flip_of_a_reset_is_refused() {
    let frame = encode(&ToPlant::Reset { seed: 1 }).expect("encodes");
    assert_eq!(
        frame,
        [0x09, 0x01, 0x02, 0x01, 0x01, 0xc0, 0x6d, 0x60, 0xf4, 0x00]
    );
    for bit in 0..frame.len() * 8 {
        flipped_is_refused::<ToPlant>(&frame, bit, decode).expect("refused");
    }
}

/// The fuzz target's seeds are frames of this version (each decodes as one side's message), so
/// a protocol change that would leave the fuzzer starting from refused frames fails here.
#[test]
fn the_fuzz_seeds_are_current_frames() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/seeds/plant_link");
    let mut seeds = 0;
    for entry in std::fs::read_dir(&dir).expect("fuzz/seeds/plant_link") {
        let path = entry.expect("a seed").path();
        let bytes = std::fs::read(&path).expect("a seed reads");
        for mut frame in frames(&bytes) {
            let request = decode::<ToPlant>(&mut frame.clone());
            let answer = decode::<FromPlant>(&mut frame);
            assert!(
                request.is_ok() || answer.is_ok(),
                "{}: {request:?} {answer:?}",
                path.display()
            );
        }
        plant_link_checks::check(&bytes);
        seeds += 1;
    }
    assert!(seeds >= 4, "{seeds} seeds in {}", dir.display());
}
