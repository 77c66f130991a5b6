//! Builds with only some weight encodings (policy-core's cargo features `f32`, `f16`, `int8`; all
//! three by default). A test binary of its own, built with whatever features the command gives,
//! so that it runs both in the full build (`cargo test -p policy-core`) and in the one an
//! int8-only firmware links:
//!
//! ```text
//! cargo test -p policy-core --no-default-features --features int8 --test encodings
//! ```
//!
//! It checks that a blob whose encoding is not compiled in is refused with
//! `Error::EncodingNotCompiled` (never a panic, never run), and that the int8 blob gives the
//! actions the full build gives, bit for bit: `golden/actor_4x48_int8.txt` holds them, written
//! by the full build (`UPDATE_GOLDEN=1 cargo test -p policy-core --test encodings`).

use std::path::{Path, PathBuf};

use policy_core::model::{Model, Scratch};
use policy_core::{slot, Encoding, Error, Policy};

/// The golden tanh 4x48 actor, f32 weights.
static F32_BLOB: &[u8] = include_bytes!("golden/actor_4x48.postcard");
/// The same actor with int8 weights, as `blob::encode` (host-trainer `export --encoding int8`)
/// quantises it.
const INT8_BLOB: &str = "actor_4x48_int8.postcard";
/// Its actions for [`OBSERVATIONS`], as f32 bit patterns, from the full build.
#[cfg(feature = "int8")]
const INT8_ACTIONS: &str = "actor_4x48_int8.txt";
/// The same actor in the integer encoding, calibrated on [`calibration_grid`].
const INTEGER_BLOB: &str = "actor_4x48_integer.postcard";
/// Its actions for [`OBSERVATIONS`], from the full build.
#[cfg(feature = "integer")]
const INTEGER_ACTIONS: &str = "actor_4x48_integer.txt";

/// The integer golden's calibration observations: a 25 × 25 grid over the arena, [-6, 6]².
#[cfg(all(feature = "f32", feature = "integer"))]
fn calibration_grid() -> Vec<f32> {
    let step = |k: usize| -6.0 + 0.5 * k as f32;
    (0..25)
        .flat_map(|i| (0..25).flat_map(move |j| [step(i), step(j)]))
        .collect()
}

/// The arena's corners and centre, sensor faults and extremes.
const OBSERVATIONS: [[f32; 2]; 12] = [
    [0.0, 0.0],
    [-0.0, 0.0],
    [6.0, 6.0],
    [-6.0, -6.0],
    [6.0, -6.0],
    [0.25, -0.25],
    [4.0, -2.5],
    [f32::NAN, 1.0],
    [f32::INFINITY, f32::NEG_INFINITY],
    [1e30, -1e30],
    [1e-40, -3.0],
    [-5.5, 2.75],
];

fn golden(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(name)
}

fn read(name: &str) -> Vec<u8> {
    std::fs::read(golden(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn updating() -> bool {
    std::env::var_os("UPDATE_GOLDEN").is_some()
}

/// The int8 actor's actions, one line per observation: `obs0 obs1 -> action0 action1` in hex.
fn actions_text(model: &Model<'_>, name: &str) -> String {
    let mut scratch = Scratch::<64>::new();
    let mut out = format!(
        "# The {} {name}'s actions (Model::act), f32 bit patterns in hex:\n\
         # obs0 obs1 -> action0 action1. Written by the full build; every build must match.\n",
        model.header().encoding
    );
    for obs in OBSERVATIONS {
        let mut action = [0.0f32; 2];
        model
            .act(&obs, &mut scratch, &mut action)
            .expect("the golden actor acts");
        out += &format!(
            "{:08x} {:08x} -> {:08x} {:08x}\n",
            obs[0].to_bits(),
            obs[1].to_bits(),
            action[0].to_bits(),
            action[1].to_bits()
        );
    }
    out
}

#[test]
fn an_f32_blob_is_refused_unless_f32_is_compiled_in() {
    let refused = Error::EncodingNotCompiled {
        found: Encoding::F32,
    };
    let runtime = Model::from_blob(F32_BLOB).map(|_| ());
    let for_policy = Model::for_policy(F32_BLOB, 2, 2, 64).map(|_| ());
    let compiled = Policy::<2, 48, 3, 2>::from_blob(F32_BLOB).map(|_| ());
    if cfg!(feature = "f32") {
        assert_eq!((runtime, for_policy, compiled), (Ok(()), Ok(()), Ok(())));
    } else {
        assert_eq!(runtime, Err(refused));
        assert_eq!(for_policy, Err(refused));
        assert_eq!(compiled, Err(refused));
        let message = refused.to_string();
        assert!(
            message.contains("f32 weights") && message.contains("feature \"f32\""),
            "{message}"
        );
    }
}

#[test]
fn a_slot_holding_an_encoding_not_compiled_in_falls_back_to_the_other() {
    let record = |blob: &[u8], sequence| {
        let mut r = slot::header(sequence, blob.len())
            .expect("slot header")
            .to_vec();
        r.extend_from_slice(blob);
        r
    };
    // Slot A holds the newer record, the f32 blob; slot B the int8 one.
    let (a, b) = (record(F32_BLOB, 2), record(&read(INT8_BLOB), 1));
    let booted = slot::choose(&a, &b, |blob| Model::for_policy(blob, 2, 2, 64));
    let running = booted.running.as_ref().map(|(id, _)| *id);
    match (cfg!(feature = "f32"), cfg!(feature = "int8")) {
        (true, _) => assert_eq!(running, Some(slot::SlotId::A)),
        (false, true) => {
            assert_eq!(running, Some(slot::SlotId::B));
            assert_eq!(
                booted.a,
                slot::Status::Failed(Error::EncodingNotCompiled {
                    found: Encoding::F32
                })
            );
        }
        (false, false) => assert_eq!(running, None),
    }
}

#[cfg(feature = "int8")]
#[test]
fn the_int8_blob_gives_the_full_builds_actions_bit_for_bit() {
    let blob = read(INT8_BLOB);
    let model = Model::from_blob(&blob).expect("the int8 golden loads");
    assert_eq!(model.header().encoding, Encoding::Int8);
    let text = actions_text(&model, INT8_BLOB);
    let full_build = cfg!(all(feature = "f32", feature = "f16"));
    if updating() && full_build {
        std::fs::write(golden(INT8_ACTIONS), &text).expect("write the golden actions");
    }
    let expected = String::from_utf8(read(INT8_ACTIONS)).expect("UTF-8");
    assert_eq!(text, expected, "int8 actions differ from the full build's");
}

// The int8 golden is the f32 golden quantised by the one writer, as `blob::encode` does
// (checked where f32 is read).
#[cfg(all(feature = "f32", feature = "int8"))]
#[test]
fn the_int8_golden_is_the_f32_golden_quantised() {
    use policy_core::blob::{self, Spec};
    let v = blob::verify(F32_BLOB).expect("the f32 golden verifies");
    let params: Vec<f32> = blob::values(&v.header, v.payload).collect();
    let spec = Spec::like(&v.header, Encoding::Int8);
    let mut quantised = vec![0u8; blob::encoded_len(&spec).expect("length")];
    let n = blob::write(&spec, &mut |sink| sink(&params), &mut quantised).expect("write");
    assert_eq!(n, quantised.len());
    if updating() {
        std::fs::write(golden(INT8_BLOB), &quantised).expect("write the int8 golden");
    }
    assert_eq!(quantised, read(INT8_BLOB));
}

#[test]
fn an_integer_blob_is_refused_unless_integer_is_compiled_in() {
    let blob = read(INTEGER_BLOB);
    let loaded = Model::from_blob(&blob).map(|m| m.header().encoding);
    if cfg!(feature = "integer") {
        assert_eq!(loaded, Ok(Encoding::Integer));
    } else {
        assert_eq!(
            loaded,
            Err(Error::EncodingNotCompiled {
                found: Encoding::Integer
            })
        );
    }
}

#[cfg(feature = "integer")]
#[test]
fn the_integer_blob_gives_the_full_builds_actions_bit_for_bit() {
    let blob = read(INTEGER_BLOB);
    let model = Model::from_blob(&blob).expect("the integer golden loads");
    let text = actions_text(&model, INTEGER_BLOB);
    let full_build = cfg!(all(feature = "f32", feature = "f16", feature = "int8"));
    if updating() && full_build {
        std::fs::write(golden(INTEGER_ACTIONS), &text).expect("write the golden actions");
    }
    let expected = String::from_utf8(read(INTEGER_ACTIONS)).expect("UTF-8");
    assert_eq!(
        text, expected,
        "integer actions differ from the full build's"
    );
}

// The integer golden is the f32 golden calibrated on the grid and written by the one writer, as
// `blob::encode_integer` does (checked where f32 is read).
#[cfg(all(feature = "f32", feature = "integer"))]
#[test]
fn the_integer_golden_is_the_f32_golden_calibrated_and_quantised() {
    use policy_core::blob::{self, Spec};
    let v = blob::verify(F32_BLOB).expect("the f32 golden verifies");
    let model = Model::from_blob(F32_BLOB).expect("loads");
    let mut ranges = vec![(f32::INFINITY, f32::NEG_INFINITY); 6];
    let mut scratch = vec![0.0; model.scratch_floats()];
    blob::calibrate_into(&model, &calibration_grid(), &mut scratch, &mut ranges)
        .expect("calibrates");
    let params: Vec<f32> = blob::values(&v.header, v.payload).collect();
    let spec = Spec::like(&v.header, Encoding::Integer);
    let mut out = vec![0u8; blob::encoded_len(&spec).expect("length")];
    let n =
        blob::write_integer(&spec, &ranges, &mut |sink| sink(&params), &mut out).expect("write");
    assert_eq!(n, out.len());
    if updating() {
        std::fs::write(golden(INTEGER_BLOB), &out).expect("write the integer golden");
    }
    assert_eq!(out, read(INTEGER_BLOB));
}
