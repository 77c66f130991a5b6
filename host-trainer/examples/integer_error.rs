//! How far an integer actor's actions lie from the f32 actor's it was made from, measured on a
//! trained blob (docs/blob-format.md, "The integer encoding", the measured comparison):
//!
//! ```text
//! cargo run --release -p host-trainer --example integer_error -- POLICY.postcard SCENARIO \
//!     [CALIBRATION_EPISODES] [TEST_EPISODES] [OUT.postcard]
//! ```
//!
//! It calibrates on the observations the f32 policy meets in CALIBRATION_EPISODES (20) test
//! episodes with the calibration seed, as `export --encoding integer` does, then compares the
//! two actors' actions on the observations the f32 policy meets in TEST_EPISODES (100) episodes
//! of the test protocol (seed 0: other starts), and on 10,000 observations spread over the
//! normaliser's box (the int8 encoding's figures beside them, for scale); last, it runs the
//! test protocol with each blob in the loop.

use std::process::ExitCode;

use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::{evaluate, EvalConfig};
use host_trainer::blob::export::{
    calibration_observations, encode_integer, visited_observations, CALIBRATION_EPISODES,
};
use host_trainer::blob::inspect::{action_errors, normaliser_box};

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("integer_error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [policy, scenario, rest @ ..] = args.as_slice() else {
        return Err("usage: integer_error POLICY.postcard SCENARIO [CALIBRATION_EPISODES] [TEST_EPISODES] [OUT.postcard]".into());
    };
    let number = |i: usize, default: usize| -> Result<usize, Box<dyn std::error::Error>> {
        Ok(rest
            .get(i)
            .map(|s| s.parse())
            .transpose()?
            .unwrap_or(default))
    };
    let calibration = number(0, CALIBRATION_EPISODES as usize)?;
    let test = number(1, 100)?;
    let f32 = std::fs::read(policy)?;
    let scenario =
        Scenario::builtin(scenario).ok_or(format!("no built-in scenario {scenario:?}"))?;
    let observations = calibration_observations(&f32, &scenario, calibration)?;
    let integer = encode_integer(&f32, &observations)?;
    if let Some(out) = rest.get(2) {
        std::fs::write(out, &integer)?;
    }
    let s = usize::from(policy_core::blob::verify(&f32)?.header.shape.observations);
    println!(
        "blob {policy}: f32 {} bytes, integer {} bytes, calibrated on {} observations of {calibration} episodes",
        f32.len(),
        integer.len(),
        observations.len() / s
    );
    let visited = visited_observations(&f32, &scenario, test, 0)?;
    let spread = normaliser_box(&f32, 10_000)?;
    // The int8 encoding (weights only, f32 arithmetic) beside it, for scale.
    let int8 = host_trainer::blob::export::encode(&f32, policy_core::Encoding::Int8)?;
    for (what, obs, blob) in [
        ("integer, test-protocol states", &visited, &integer),
        ("integer, normaliser box", &spread, &integer),
        ("int8, test-protocol states", &visited, &int8),
        ("int8, normaliser box", &spread, &int8),
    ] {
        let e = action_errors(blob, &f32, obs)?;
        let list = |v: &[f32]| {
            let v: Vec<String> = v.iter().map(|e| format!("{e:.5}")).collect();
            v.join(", ")
        };
        println!(
            "{what}: {} observations, |a - a_f32| per dimension: largest [{}], \
             99th percentile [{}]; mean {:.5}",
            obs.len() / s,
            list(&e.largest),
            list(&e.p99),
            e.mean
        );
    }
    let config = EvalConfig {
        episodes: test,
        ..EvalConfig::default()
    };
    for (name, bytes) in [("f32", &f32), ("integer", &integer)] {
        let r = evaluate(bytes, &scenario, &config)?;
        println!(
            "closed loop, {name}: success {:.2}, settled error {:.4}, stuck {:.2} ({test} episodes)",
            r.success_rate, r.mean_error, r.stuck_rate
        );
    }
    Ok(())
}
