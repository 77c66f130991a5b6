use std::path::PathBuf;
use std::process::{Command, Output};

use crate::util::random_blob;

const BIN: &str = env!("CARGO_BIN_EXE_firmware-sim");

/// A fresh directory for one test's files.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("firmware-sim-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}

fn run(args: &[&str]) -> Output {
    Command::new(BIN)
        .arg("run")
        .args(args)
        .output()
        .expect("spawn firmware-sim")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Bad input: exit code 2, exactly one line on stderr containing every `needle`, no panic.
fn assert_bad_input(o: &Output, needles: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    assert_eq!(err.lines().count(), 1, "one line, got: {err}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "{n:?} not in {err}");
    }
}

#[test]
fn oracle_passes_and_writes_json_and_svg() {
    let dir = scratch("oracle");
    let (json, svg) = (dir.join("report.json"), dir.join("paths.svg"));
    let o = run(&[
        "--controller",
        "oracle",
        "--episodes",
        "6",
        "--seed",
        "1",
        "--json",
        json.to_str().expect("utf8"),
        "--svg",
        svg.to_str().expect("utf8"),
    ]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{out}{}", stderr(&o));
    assert!(
        out.contains("success rate") && out.contains("PASS"),
        "{out}"
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&json).expect("json written")).expect("valid json");
    assert_eq!(report["success_rate"], 1.0);
    assert_eq!(report["episodes"].as_array().expect("episodes").len(), 6);
    let svg = std::fs::read_to_string(&svg).expect("svg written");
    assert_eq!(svg.matches("<polyline").count(), 6);
    // Atomic writes leave no temporary files behind.
    assert_eq!(std::fs::read_dir(&dir).expect("dir").count(), 2);
}

#[test]
fn straight_fails_the_pinwheel_gate() {
    let o = run(&["--controller", "straight", "--episodes", "20"]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("stuck-at-margin rate"), "{err}");
}

#[test]
fn a_blob_runs_and_a_corrupt_blob_is_reported_in_the_safe_state() {
    let dir = scratch("blob");
    let good = dir.join("good.postcard");
    let mut bytes = random_blob::<48, 3>(1, "cli");
    std::fs::write(&good, &bytes).expect("write");
    let o = run(&[
        "--blob",
        good.to_str().expect("utf8"),
        "--episodes",
        "2",
        "--scenario",
        "nav-open",
    ]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("4x48") && out.contains("boot") && out.contains("ok"),
        "{out}"
    );
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(&o));

    let last = bytes.len() - 1;
    bytes[last] ^= 1;
    let bad = dir.join("bad.postcard");
    std::fs::write(&bad, &bytes).expect("write");
    let o = run(&["--blob", bad.to_str().expect("utf8"), "--episodes", "2"]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("bad.postcard") && err.contains("checksum") && err.contains("safe state"),
        "{err}"
    );
    assert!(String::from_utf8_lossy(&o.stdout).contains("FAILED, safe state"));
}

#[test]
fn a_blob_of_a_shape_not_compiled_is_named() {
    let dir = scratch("shape");
    let path = dir.join("tiny.postcard");
    std::fs::write(
        &path,
        policy_core::Policy::<2, 16, 1, 2>::ZERO
            .to_blob("t")
            .expect("blob"),
    )
    .expect("write");
    let o = run(&["--blob", path.to_str().expect("utf8"), "--episodes", "1"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("no compiled policy type") && stderr(&o).contains("2x16"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn bad_input_is_one_line_and_exit_code_2() {
    let dir = scratch("bad");
    let open = include_str!("../scenarios/nav-open.toml");
    let write = |name: &str, text: String| {
        let p = dir.join(name);
        std::fs::write(&p, text).expect("write");
        p.to_str().expect("utf8").to_string()
    };
    let unknown = write(
        "unknown.toml",
        open.replace("[pass]", "[pass]\nmin_sucess = 1.0"),
    );
    assert_bad_input(
        &run(&["--controller", "straight", "--scenario", &unknown]),
        &["unknown.toml:", "min_sucess"],
    );
    let outside = write(
        "outside.toml",
        format!("{open}\n[[walls]]\nfrom = [0.0, 0.0]\nto = [0.0, 9.0]\n"),
    );
    assert_bad_input(
        &run(&["--controller", "straight", "--scenario", &outside]),
        &["walls[0]", "outside the arena"],
    );
    let negative = write(
        "negative.toml",
        open.replace("time_limit = 200", "time_limit = -200"),
    );
    assert_bad_input(
        &run(&["--controller", "straight", "--scenario", &negative]),
        &["negative.toml:", "time_limit = -200"],
    );
    assert_bad_input(
        &run(&["--blob", "/nonexistent/policy.postcard"]),
        &["cannot read blob", "/nonexistent/policy.postcard"],
    );
    assert_bad_input(
        &run(&["--controller", "straight", "--scenario", "nav-nowhere"]),
        &["nav-nowhere", "nav-walls"],
    );
    assert_bad_input(&run(&["--controller", "wander"]), &["wander"]);
    assert_bad_input(
        &run(&["--controller", "straight", "--faults", "melt:1"]),
        &["melt:1"],
    );
    assert_bad_input(
        &run(&["--controller", "straight", "--episodes", "0"]),
        &["episodes"],
    );
    assert_bad_input(&run(&["--episodes", "3"]), &["required", "--blob"]);
    assert_bad_input(
        &run(&[
            "--controller",
            "straight",
            "--json",
            "/nonexistent/dir/r.json",
        ]),
        &["/nonexistent/dir"],
    );
}
