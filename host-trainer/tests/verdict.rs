//! The gate's verdict where `eval` judges a blob: exit 0 and `gate PASS` when the scenario's (or
//! the plant test's) pass criteria hold, exit 1 and `gate FAIL (why)` when they do not, worded
//! as `firmware-sim run` words it; an error is exit 2, never a verdict.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::support::{assert_one_line_error, firmware_sim, host_trainer, s, scratch};

/// The committed policy (the paper's DCP, seed 0): it parks against the pinwheel's inner ring on
/// 47 of the 100 test starts (docs/results/dcp-vs-ddpg.md, "The committed blob") and reaches
/// the goal from every start without walls, so it fails one gate and passes the other.
fn committed_blob() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/nav-walls__dcp-paper__0.postcard")
}

fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The one summary line `eval` prints.
fn summary(out: &Output) -> String {
    let text = stdout(out);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 1, "one summary line: {text}");
    lines[0].to_string()
}

fn eval(args: &[&str]) -> Output {
    let blob = committed_blob();
    let mut all = vec!["eval", "--blob", s(&blob)];
    all.extend_from_slice(args);
    host_trainer(&all)
}

#[test]
fn eval_of_a_blob_that_fails_the_gate_exits_1_and_says_why() {
    let out = eval(&["--task", "nav-walls"]);
    let line = summary(&out);
    assert_eq!(out.status.code(), Some(1), "{line}");
    assert!(
        line.ends_with(
            "stuck at margin 47.0%  left arena 0.0%  gate FAIL (stuck-at-margin rate 0.470 is above the maximum 0.200)"
        ),
        "{line}"
    );
    // A verdict, not an error: nothing on stderr.
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn eval_of_a_blob_that_passes_the_gate_exits_0_and_says_pass() {
    let out = eval(&["--task", "nav-open"]);
    let line = summary(&out);
    assert_eq!(out.status.code(), Some(0), "{line}");
    assert!(line.contains(" on nav-open, 100 test starts: "), "{line}");
    assert!(
        line.ends_with("stuck at margin 0.0%  left arena 0.0%  gate PASS"),
        "{line}"
    );
}

/// A CI that gates on `eval` gates on what `firmware-sim run` says of the same bytes: the same
/// exit status and the same verdict, word for word.
#[test]
fn eval_and_firmware_sim_run_give_one_verdict() {
    let blob = committed_blob();
    for task in ["nav-walls", "nav-open"] {
        let judged = eval(&["--task", task, "--episodes", "30"]);
        let run = Command::new(firmware_sim())
            .args([
                "run",
                "--blob",
                s(&blob),
                "--scenario",
                task,
                "--episodes",
                "30",
            ])
            .output()
            .expect("firmware-sim runs");
        assert_eq!(judged.status.code(), run.status.code(), "{task}");
        let line = summary(&judged);
        let verdict = line
            .split("  gate ")
            .nth(1)
            .expect("the line ends with the verdict");
        let row = stdout(&run)
            .lines()
            .find(|l| l.trim_start().starts_with("pass criteria"))
            .map(|l| l.trim_start()["pass criteria".len()..].trim().to_string())
            .expect("firmware-sim's pass criteria row");
        assert_eq!(verdict, row, "{task}");
    }
}

/// `--plant-cmd`: the test for any plant judges by its own criteria (success ≥ 0.8, stuck ≤ 0.2)
/// and exits by them, as `firmware-sim run --plant-cmd` does.
#[test]
fn eval_on_a_plant_process_exits_by_the_plant_tests_verdict() {
    for (scenario, code, ending) in [
        ("nav-open", 0, "gate PASS"),
        (
            "nav-walls",
            1,
            "gate FAIL (stuck-at-margin rate 0.700 is above the maximum 0.200)",
        ),
    ] {
        let plant = format!(
            "{} serve-plant --scenario {scenario}",
            firmware_sim().display()
        );
        let out = eval(&["--plant-cmd", &plant, "--episodes", "20"]);
        let line = summary(&out);
        assert_eq!(out.status.code(), Some(code), "{line}");
        assert!(
            line.contains(&format!(" on {scenario}, 20 test starts: ")),
            "{line}"
        );
        assert!(line.ends_with(ending), "{line}");
    }
}

/// A blob that cannot be judged is an error (2), so a CI never mistakes it for a FAIL (1) of a
/// policy that ran, nor for a PASS.
#[test]
fn a_corrupt_blob_or_a_bad_argument_is_an_error_not_a_verdict() {
    let base = scratch("verdict-errors");
    let mut bytes = std::fs::read(committed_blob()).expect("the committed blob");
    let middle = bytes.len() / 2;
    bytes[middle] ^= 1;
    let corrupt = base.join("corrupt.postcard");
    std::fs::write(&corrupt, bytes).expect("write");
    let out = host_trainer(&["eval", "--blob", s(&corrupt)]);
    assert_one_line_error(
        &out,
        &["corrupt.postcard", "does not boot", "checksum mismatch"],
    );
    assert!(
        out.stdout.is_empty(),
        "no verdict for a blob that never ran"
    );
    for (args, needle) in [
        (&["--episodes", "many"][..], "--episodes"),
        (&["--task", "nowhere"][..], "nowhere"),
        (&["--plant-cmd", "/no/such/plant"][..], "/no/such/plant"),
        (
            &["--task", "nav-open", "--plant-cmd", "x"][..],
            "--plant-cmd",
        ),
    ] {
        let out = eval(args);
        assert_one_line_error(&out, &[needle]);
        assert!(out.stdout.is_empty(), "{args:?}");
    }
    std::fs::remove_dir_all(&base).expect("cleanup");
}
