//! The test protocol for any plant and `run --plant-cmd`: navigation seen as any plant gives
//! navigation's own success and stuck rates (one definition), reports are reproducible, the
//! served plant equals the plant in process, and bad settings or plants are one-line errors.

use firmware_sim::boot::{boot, PlantSizes};
use firmware_sim::env::Env;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::{evaluate, EvalConfig};
use firmware_sim::nav::NavEnv;
use firmware_sim::plant_link::child::{ChildPlant, Timeouts};
use firmware_sim::plant_test::{evaluate_plant, Criteria, PlantTestConfig, StuckRule};

use crate::util::{firmware_sim, stderr, stdout, Scratch};

const BLOB: &[u8] = include_bytes!("../../models/nav-walls__dcp-paper__0.postcard");
const SIZES: PlantSizes = PlantSizes {
    observations: 2,
    actions: 2,
};

/// Navigation's stuck rule in the generic rule's units: half a step of command, and a
/// progress of 0.05 in positions is 0.2 half-ranges of a 0.25 step.
fn nav_rule() -> StuckRule {
    StuckRule {
        window: 20,
        min_command: 0.5,
        max_progress: 0.2,
    }
}

fn nav_walls() -> (Scenario, NavEnv) {
    let scenario = Scenario::builtin("nav-walls").expect("builtin");
    let mut env = NavEnv::new(&scenario).expect("plant");
    // Navigation's protocol runs every test to its time limit, as this one runs the plant's.
    env.set_goal_terminates(false);
    (scenario, env)
}

#[test]
fn navigation_as_any_plant_gives_navigations_success_and_contact_figures() {
    let (scenario, mut env) = nav_walls();
    let cfg = EvalConfig {
        episodes: 40,
        ..EvalConfig::default()
    };
    let nav = evaluate(BLOB, &scenario, &cfg).expect("nav protocol");
    let any = PlantTestConfig {
        episodes: 40,
        criteria: Criteria {
            stuck: nav_rule(),
            ..Criteria::default()
        },
        ..PlantTestConfig::default()
    };
    let mut policy = boot(BLOB, &SIZES).expect("boots");
    let report = evaluate_plant(&mut policy, &mut env, "nav-walls", &any).expect("any plant");
    assert_eq!(report.success_rate, nav.success_rate);
    assert_eq!(report.contact_fraction, nav.contact_fraction);
    assert_eq!(report.saturation_fraction, nav.saturation_fraction);
    assert_eq!(report.total_steps, nav.total_steps);
    // The position's displacement and the summed applied motion are the same vector, so the
    // one stuck rule finds the same episodes stuck.
    let stuck: Vec<bool> = report.episodes.iter().map(|e| e.stuck).collect();
    let nav_stuck: Vec<bool> = nav.episodes.iter().map(|e| e.stuck).collect();
    assert_eq!(stuck, nav_stuck);
    assert!(
        report.stuck_rate > 0.3,
        "the paper's seed-0 blob parks: {}",
        report.stuck_rate
    );
}

#[test]
fn the_served_plant_gives_the_report_of_the_plant_in_process_bit_for_bit() {
    let (_, mut env) = nav_walls();
    let cfg = PlantTestConfig {
        episodes: 12,
        ..PlantTestConfig::default()
    };
    let mut policy = boot(BLOB, &SIZES).expect("boots");
    let local = evaluate_plant(&mut policy, &mut env, "nav-walls", &cfg).expect("local");
    let command = format!(
        "{} serve-plant --scenario nav-walls",
        env!("CARGO_BIN_EXE_firmware-sim")
    );
    let mut child = ChildPlant::spawn(&command, Timeouts::default()).expect("spawn");
    let served = evaluate_plant(&mut policy, &mut child, "nav-walls", &cfg).expect("served");
    // (The served plant ends an episode when the goal is held, as training's does; the blob's
    // episodes never hold it for 10 steps at the centre, so both run to the time limit.)
    assert_eq!(served.without_timing(), local.without_timing());
    assert!(Env::failure(&child).is_none());
}

#[test]
fn run_plant_cmd_reports_passes_and_fails_by_the_criteria_given() {
    let dir = Scratch::new("plant-cmd", "criteria");
    let serve = format!(
        "{} serve-plant --scenario nav-walls",
        env!("CARGO_BIN_EXE_firmware-sim")
    );
    let json = dir.file("report.json");
    let blob = "../models/nav-walls__dcp-paper__0.postcard";
    let args = [
        "--plant-cmd",
        &serve,
        "--blob",
        blob,
        "--episodes",
        "10",
        "--json",
        &json,
    ];
    let out = firmware_sim("run", &args);
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(stdout(&out).contains("stuck at margin"), "{}", stdout(&out));
    assert!(
        stderr(&out).starts_with("FAIL: stuck-at-margin rate"),
        "{}",
        stderr(&out)
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("parses");
    assert_eq!(report["episodes"].as_array().map(Vec::len), Some(10));
    // Loose enough criteria pass.
    let loose = [
        &args[..6],
        &["--max-stuck", "1", "--success-return", "-1000"],
    ]
    .concat();
    let out = firmware_sim("run", &loose);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
}

/// A harness outside firmware-sim runs its policy from the protocol's starts by `test-starts`:
/// its lines are the seeds `run --plant-cmd` resets the plant with, in order.
#[test]
fn test_starts_prints_the_seeds_the_plant_test_resets_with() {
    let dir = Scratch::new("plant-cmd", "test-starts");
    let serve = format!(
        "{} serve-plant --scenario nav-walls",
        env!("CARGO_BIN_EXE_firmware-sim")
    );
    let json = dir.file("report.json");
    let blob = "../models/nav-walls__dcp-paper__0.postcard";
    let args = ["--plant-cmd", &serve, "--blob", blob, "--episodes", "7"];
    let out = firmware_sim(
        "run",
        &[&args[..], &["--seed", "5", "--json", &json]].concat(),
    );
    assert!(
        out.status.code().is_some_and(|c| c <= 1),
        "{}",
        stderr(&out)
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).expect("json")).expect("parses");
    let reset: Vec<String> = report["episodes"]
        .as_array()
        .expect("episodes")
        .iter()
        .map(|e| e["seed"].to_string())
        .collect();
    let printed = firmware_sim("test-starts", &["--episodes", "7", "--seed", "5"]);
    assert_eq!(printed.status.code(), Some(0), "{}", stderr(&printed));
    let lines: Vec<String> = stdout(&printed).lines().map(str::to_string).collect();
    assert_eq!(lines, reset);
    let zero = firmware_sim("test-starts", &["--episodes", "0"]);
    assert_eq!(zero.status.code(), Some(2), "{}", stderr(&zero));
}

#[test]
fn run_plant_cmd_refuses_bad_input_in_one_line() {
    let serve = format!(
        "{} serve-plant --scenario nav-walls",
        env!("CARGO_BIN_EXE_firmware-sim")
    );
    let blob = "../models/nav-walls__dcp-paper__0.postcard";
    let cases: [(&[&str], &str); 4] = [
        (
            &[
                "--plant-cmd",
                &serve,
                "--blob",
                blob,
                "--faults",
                "wall:1@0/0/1/1",
            ],
            "error: --faults wall:... moves navigation's walls",
        ),
        (
            &["--plant-cmd", "no-such-plant", "--blob", blob],
            "error: plant \"no-such-plant\": cannot start: no program no-such-plant on PATH",
        ),
        (
            &["--plant-cmd", &serve, "--blob", blob, "--min-success", "2"],
            "error: criteria.min_success_rate: must be in [0, 1], found 2",
        ),
        (
            &[
                "--plant-cmd",
                &serve,
                "--blob",
                blob,
                "--plant-timeout",
                "0",
            ],
            "error: --plant-timeout must be in (0, 3600] seconds, found 0",
        ),
    ];
    for (args, expected) in cases {
        let out = firmware_sim("run", args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        let err = stderr(&out);
        assert!(err.starts_with(expected), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
    }
}
