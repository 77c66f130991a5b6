//! Golden frames of the plant link: each message below, its frame's bytes in hex, committed in
//! `tests/data/plant-link-frames.json`. This test asserts that `messages::encode` still writes
//! exactly those bytes and reads them back; the Python package's codec
//! (`python/tests/test_golden_frames.py`) asserts the same file both ways, so the two
//! implementations agree byte for byte. `UPDATE_GOLDEN=1` rewrites the file (then commit it:
//! a changed frame is a protocol change).
//!
//! Floats are described by their bits (`f32::to_bits`), so infinities, NaN and subnormals
//! travel through JSON unchanged.

use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::NavEnv;
use firmware_sim::plant_link::messages::{
    decode, encode, Agent, FromPlant, Hello, StepReply, ToPlant,
};
use firmware_sim::plant_link::serve;
use serde_json::{json, Value};

const GOLDEN: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/data/plant-link-frames.json"
);

fn bits(values: &[f32]) -> Value {
    values.iter().map(|v| v.to_bits()).collect()
}

fn describe_request(m: &ToPlant) -> Value {
    match m {
        ToPlant::Hello => json!({"Hello": {}}),
        ToPlant::Reset { seed } => json!({"Reset": {"seed": seed}}),
        ToPlant::Step { action } => json!({"Step": {"action": bits(action)}}),
        ToPlant::Close => json!({"Close": {}}),
    }
}

fn describe_reply(m: &FromPlant) -> Value {
    match m {
        FromPlant::Hello(h) => json!({"Hello": {
            "name": h.name,
            "agents": h.agents.iter().map(|a| json!({
                "name": a.name,
                "observation_low": bits(&a.observation_low),
                "observation_high": bits(&a.observation_high),
                "action_low": bits(&a.action_low),
                "action_high": bits(&a.action_high),
            })).collect::<Vec<_>>(),
        }}),
        FromPlant::Reset { observation } => json!({"Reset": {"observation": bits(observation)}}),
        FromPlant::Step(s) => json!({"Step": {
            "observation": bits(&s.observation),
            "reward": s.reward.to_bits(),
            "terminated": s.terminated,
            "truncated": s.truncated,
            "margin_touched": s.margin_touched,
            "applied": bits(&s.applied),
            "success": s.success,
        }}),
        FromPlant::Error { message } => json!({"Error": {"message": message}}),
    }
}

fn frame_of<M: serde::Serialize>(m: &M) -> Vec<u8> {
    encode(m).expect("every golden message fits a frame")
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn step(observation: Vec<f32>, reward: f32, flags: [bool; 3], success: Option<bool>) -> FromPlant {
    let applied = observation.iter().map(|v| v * 0.5).collect();
    FromPlant::Step(StepReply {
        observation,
        reward,
        terminated: flags[0],
        truncated: flags[1],
        margin_touched: flags[2],
        applied,
        success,
    })
}

fn requests() -> Vec<(&'static str, ToPlant)> {
    vec![
        ("hello", ToPlant::Hello),
        ("reset, seed 0", ToPlant::Reset { seed: 0 }),
        (
            "reset, a seed of two varint bytes",
            ToPlant::Reset { seed: 300 },
        ),
        ("reset, the largest seed", ToPlant::Reset { seed: u64::MAX }),
        (
            "step, two values",
            ToPlant::Step {
                action: vec![0.25, -1.0],
            },
        ),
        ("step, no values", ToPlant::Step { action: vec![] }),
        ("close", ToPlant::Close),
    ]
}

/// An error answer whose frame ends with a run of exactly 254 non-zero bytes: where COBS
/// implementations differ (postcard closes it with a last `0x01` code, others omit it).
fn error_ending_on_a_full_run() -> FromPlant {
    (200..1200)
        .map(|n| FromPlant::Error {
            message: "m".repeat(n),
        })
        .find(|m| ends_on_a_full_run(&frame_of(m)))
        .expect("some length ends on a full run")
}

/// Walks the COBS codes: the last block is an empty one after a 0xFF block.
fn ends_on_a_full_run(frame: &[u8]) -> bool {
    let body = &frame[..frame.len() - 1];
    let (mut codes, mut at) = (Vec::new(), 0);
    while at < body.len() {
        codes.push(body[at]);
        at += usize::from(body[at]);
    }
    at == body.len() && codes.ends_with(&[0xFF, 1])
}

fn replies() -> Vec<(&'static str, FromPlant)> {
    let scenario = Scenario::builtin("nav-walls").expect("a built-in scenario");
    let nav = NavEnv::new(&scenario).expect("nav-walls builds");
    let unbounded = Hello {
        name: "Pendule-ü".into(),
        agents: vec![Agent {
            name: "agent".into(),
            observation_low: vec![-1.0, f32::NEG_INFINITY, -8.0],
            observation_high: vec![1.0, f32::INFINITY, 8.0],
            action_low: vec![-2.0],
            action_high: vec![2.0],
        }],
    };
    let long: Vec<f32> = (0..300).map(|i| i as f32 * 0.37 - 50.0).collect();
    vec![
        (
            "hello of nav-walls",
            FromPlant::Hello(serve::hello("nav-walls", &nav)),
        ),
        (
            "hello with infinite bounds and a UTF-8 name",
            FromPlant::Hello(unbounded),
        ),
        (
            "reset",
            FromPlant::Reset {
                observation: vec![1.414_125_8, -5.75],
            },
        ),
        (
            "step, success unknown",
            step(vec![0.5, -1.0], -0.25, [false, false, true], None),
        ),
        (
            "step, succeeded and terminated",
            step(vec![0.0, 0.0], 1.0, [true, false, false], Some(true)),
        ),
        (
            "step, truncated, not succeeded, NaN and a subnormal",
            step(
                vec![f32::NAN, f32::from_bits(1), f32::MAX],
                f32::MIN,
                [false, true, true],
                Some(false),
            ),
        ),
        (
            "step, 300 values (COBS blocks of 254)",
            step(long, 0.125, [false, false, false], None),
        ),
        (
            "error",
            FromPlant::Error {
                message: "an action of 3 values, expected 2".into(),
            },
        ),
        (
            "error ending on a full COBS run",
            error_ending_on_a_full_run(),
        ),
    ]
}

fn golden() -> Value {
    let mut frames = Vec::new();
    for (what, m) in requests() {
        let frame = frame_of(&m);
        frames.push(json!({"what": what, "direction": "to_plant",
            "message": describe_request(&m), "frame": hex(&frame)}));
    }
    for (what, m) in replies() {
        let frame = frame_of(&m);
        frames.push(json!({"what": what, "direction": "from_plant",
            "message": describe_reply(&m), "frame": hex(&frame)}));
    }
    json!({
        "about": "plant link frames (protocol version 1): the message, floats as f32 bits, and \
                  its frame in hex, delimiter included; written by firmware-sim's \
                  tests/plant_link_frames.rs with UPDATE_GOLDEN=1",
        "frames": frames,
    })
}

#[test]
fn frames_equal_the_committed_golden_file() {
    let fresh = golden();
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        let text = serde_json::to_string_pretty(&fresh).expect("JSON") + "\n";
        std::fs::write(GOLDEN, text).expect("write the golden file");
    }
    let committed: Value = serde_json::from_str(
        &std::fs::read_to_string(GOLDEN)
            .expect("the golden file (UPDATE_GOLDEN=1 cargo test -p firmware-sim --test integration plant_link)"),
    )
    .expect("the golden file is JSON");
    assert_eq!(
        committed, fresh,
        "the plant link's frames changed; if on purpose, raise the protocol version and run with UPDATE_GOLDEN=1"
    );
}

#[test]
fn golden_frames_decode_to_their_messages() {
    for (what, m) in requests() {
        let frame = frame_of(&m);
        let mut wire = frame[..frame.len() - 1].to_vec();
        assert_eq!(decode::<ToPlant>(&mut wire).expect(what), m, "{what}");
    }
    for (what, m) in replies() {
        let frame = frame_of(&m);
        let mut wire = frame[..frame.len() - 1].to_vec();
        let back: FromPlant = decode(&mut wire).expect(what);
        // NaN is not equal to itself: compare the descriptions, which hold bits.
        assert_eq!(describe_reply(&back), describe_reply(&m), "{what}");
    }
}

#[test]
fn one_golden_frame_ends_on_a_full_cobs_run() {
    let m = error_ending_on_a_full_run();
    assert!(ends_on_a_full_run(&frame_of(&m)));
}
