use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use firmware_sim::nav::reference::reference;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::svg;
use firmware_sim::nav::test_protocol::{evaluate_controller, EvalConfig};

use policy_core::{Activation, ModelKind, Shape};

use crate::util::{random_blob, runtime_blob};

const BIN: &str = env!("CARGO_BIN_EXE_firmware-sim");

/// A fresh directory for one test's files, removed when the test ends (pass or fail).
fn scratch(name: &str) -> ScratchDir {
    let dir = std::env::temp_dir().join(format!("firmware-sim-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    ScratchDir(dir)
}

/// See [`scratch`].
struct ScratchDir(PathBuf);

impl std::ops::Deref for ScratchDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for ScratchDir {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
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

/// No table of compiled shapes: a shape no build compiled (2x16, 3x40) boots and runs; a blob that
/// does not fit the plant's sizes is named in one line and the loop runs in the safe state.
#[test]
fn any_shape_runs_and_a_wrong_size_is_named() {
    let dir = scratch("shape");
    for (name, shape) in [("tiny.postcard", (2, 16)), ("odd.postcard", (3, 40))] {
        let path = dir.join(name);
        let s = Shape {
            observations: 2,
            actions: 2,
            width: shape.1,
            depth: shape.0,
            choices: 0,
        };
        std::fs::write(
            &path,
            runtime_blob(ModelKind::Actor, s, Activation::Tanh, 5, "t"),
        )
        .expect("write");
        let o = run(&["--blob", path.to_str().expect("utf8"), "--episodes", "1"]);
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(out.contains(&format!("{}x{}", shape.0, shape.1)), "{out}");
        assert!(!stderr(&o).contains("safe state"), "{}", stderr(&o));
    }
    let path = dir.join("six.postcard");
    let s = Shape {
        observations: 6,
        actions: 2,
        width: 8,
        depth: 1,
        choices: 0,
    };
    std::fs::write(
        &path,
        runtime_blob(ModelKind::Actor, s, Activation::Relu, 5, "six"),
    )
    .expect("write");
    let o = run(&["--blob", path.to_str().expect("utf8"), "--episodes", "1"]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains("observation size: the plant needs 2, found 6") && err.contains("safe state"),
        "{err}"
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

/// The names in a folder, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// The JSON report without its wall-clock part.
fn json_without_timing(bytes: &[u8]) -> serde_json::Value {
    let mut v: serde_json::Value = serde_json::from_slice(bytes).expect("valid json");
    v["timing"] = serde_json::Value::Null;
    v
}

/// Regression: `--episodes 18446744073709551615` panicked with `capacity
/// overflow` (exit 101) and `--episodes 1000000000000` aborted on a 152 TB allocation.
#[test]
fn an_episode_count_beyond_the_maximum_is_one_line_and_exit_2() {
    for n in ["18446744073709551615", "1000000000000", "1000001"] {
        let o = run(&["--controller", "straight", "--episodes", n]);
        assert_bad_input(&o, &["episodes", "1..=1000000", n]);
        assert!(o.stdout.is_empty(), "no work was done");
    }
}

/// Regression: `time_limit = 4294967295` validated and then grew
/// memory until it aborted; a wall end with extra values was accepted and the extras ignored.
#[test]
fn a_huge_time_limit_and_a_wall_end_of_four_values_are_refused() {
    let dir = scratch("scenario-limits");
    let open = include_str!("../scenarios/nav-open.toml");
    let huge = dir.join("huge.toml");
    std::fs::write(
        &huge,
        open.replace("time_limit = 200", "time_limit = 4294967295"),
    )
    .expect("write");
    assert_bad_input(
        &run(&["--controller", "straight", "--scenario", path(&huge)]),
        &["time_limit", "1..=100000", "4294967295"],
    );
    let junk = dir.join("junk.toml");
    let wall = r#"walls = [{ from = [-2.0, 1.0, 77.0], to = [2.0, 1.0, "junk", true] }]"#;
    std::fs::write(&junk, format!("{wall}\n{open}")).expect("write");
    assert_bad_input(
        &run(&["--controller", "straight", "--scenario", path(&junk)]),
        &["junk.toml:1:", "walls[0].from", "two numbers", "77.0"],
    );
}

/// Regression: two walls and two dropouts exited 0 with only the last of
/// each applied.
#[test]
fn a_fault_kind_given_twice_is_one_line_and_exit_2() {
    let faults = "wall:0@-2/1/2/1,wall:0@-2/-1/2/-1,dropout-nan:1,dropout-stale:0";
    assert_bad_input(
        &run(&["--controller", "straight", "--faults", faults]),
        &["given twice", "wall:0@-2/1/2/1", "wall:0@-2/-1/2/-1"],
    );
    assert_bad_input(
        &run(&[
            "--controller",
            "straight",
            "--faults",
            "dropout-nan:1,dropout-stale:0",
        ]),
        &["given twice", "dropout-nan:1", "dropout-stale:0"],
    );
}

/// Regression: `--json DIR` failed but left `.DIR.tmpNNNN` behind.
#[test]
fn a_folder_as_output_fails_and_leaves_nothing_behind() {
    let dir = scratch("json-dir");
    let out = dir.join("out");
    std::fs::create_dir(&out).expect("folder");
    for flag in ["--json", "--svg"] {
        assert_bad_input(
            &run(&[
                "--controller",
                "straight",
                "--episodes",
                "2",
                flag,
                path(&out),
            ]),
            &["cannot write", "is a folder"],
        );
        assert_eq!(names(&dir), ["out"]);
        assert!(names(&out).is_empty());
    }
}

/// Regression: output paths were checked only after the work; a bad
/// `--json` path lost a 6 s run's report and the `--svg` file was never written.
#[test]
fn output_paths_are_checked_before_any_work() {
    let dir = scratch("outputs-first");
    let svg = dir.join("ok.svg");
    let o = run(&[
        "--controller",
        "straight",
        "--episodes",
        "20000",
        "--json",
        "/nonexistent/r.json",
        "--svg",
        path(&svg),
    ]);
    assert_bad_input(
        &o,
        &["cannot write /nonexistent/r.json", "folder does not exist"],
    );
    assert!(o.stdout.is_empty(), "no episode ran");
    assert!(names(&dir).is_empty(), "{:?}", names(&dir));
    let same = dir.join("both");
    assert_bad_input(
        &run(&[
            "--controller",
            "straight",
            "--json",
            path(&same),
            "--svg",
            path(&same),
        ]),
        &["name the same file"],
    );
}

/// Regression: `--json s.out --svg ./s.out` exited 0 and left only one of the two reports.
#[test]
fn two_spellings_of_one_output_file_are_refused_before_any_work() {
    let dir = scratch("two-spellings");
    let plain = dir.join("s.out");
    let dotted = dir.join(".").join("s.out");
    let o = run(&[
        "--controller",
        "straight",
        "--episodes",
        "2",
        "--json",
        path(&plain),
        "--svg",
        path(&dotted),
    ]);
    assert_bad_input(&o, &["name the same file"]);
    assert!(o.stdout.is_empty(), "no episode ran");
    assert!(names(&dir).is_empty(), "{:?}", names(&dir));
}

/// Regression: `run --scenario badminton.toml` said "unknown field `court`" without saying
/// that badminton is played with `match`.
#[test]
fn a_badminton_scenario_given_to_run_points_to_match() {
    let file = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/badminton.toml");
    for scenario in [file, "badminton"] {
        assert_bad_input(
            &run(&["--controller", "straight", "--scenario", scenario]),
            &["badminton scenario", "firmware-sim match"],
        );
    }
}

/// Regression: `--noise=-3.4e38` printed a 39-digit decimal, `--noise=1e39` said "must be
/// >= 0, found inf", and a fault number that did not read gave no hint of what was expected.
#[test]
fn sensor_and_fault_numbers_are_named_compactly() {
    let cases: [(&str, &[&str]); 6] = [
        ("--noise=-3.4e38", &["sensor.noise_std", "found -3.4e38"]),
        ("--noise=1e39", &["must be finite and >= 0, found inf"]),
        ("--quantum=-1e30", &["sensor.quantum", "found -1e30"]),
        (
            "--rate-limit=-1e30",
            &["actuator.rate_limit", "found -1e30"],
        ),
        ("--faults=dropout-nan:1e30", &["in [0, 1], found 1e30"]),
        (
            "--faults=stuck:0.5@3",
            &["\"0.5\"", "expected an action dimension D"],
        ),
    ];
    for (arg, needles) in cases {
        let out = run(&["--controller", "straight", "--episodes", "1", arg]);
        assert_bad_input(&out, needles);
        assert!(stderr(&out).len() < 200, "{arg}: {}", stderr(&out));
    }
}

/// Regression: `--scratch-width` with `--blob` was accepted and silently ignored.
#[test]
fn scratch_width_without_slots_is_refused() {
    let golden = concat!(env!("CARGO_MANIFEST_DIR"), "/../policy-core/tests/golden/");
    let actor = format!("{golden}actor_2x32.postcard");
    assert_bad_input(
        &run(&["--blob", &actor, "--scratch-width", "8"]),
        &["--scratch-width applies to slot boots only"],
    );
}

/// Regression: no subcommand printed the description and exited 2 without
/// saying what was missing.
#[test]
fn a_missing_subcommand_is_named() {
    let o = Command::new(BIN).output().expect("spawn firmware-sim");
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).starts_with(
            "firmware-sim: missing a subcommand: run, match, scenario, teams, heatmap, serve-plant, test-starts"
        ),
        "{}",
        stderr(&o)
    );
}

/// `firmware-sim scenario` without its subcommand listed the binary's commands (run, match,
/// …) instead of its own: the message names the command that lacks one and its choices.
#[test]
fn a_missing_scenario_subcommand_lists_the_scenario_commands() {
    let o = Command::new(BIN)
        .arg("scenario")
        .output()
        .expect("spawn firmware-sim");
    assert_bad_input(&o, &[]);
    assert_eq!(
        stderr(&o),
        "firmware-sim scenario: missing a subcommand: generate (see firmware-sim scenario --help)\n"
    );
}

/// Regression: a huge file passed as a blob was read whole.
#[test]
fn a_file_too_large_for_a_blob_is_refused_unread() {
    let dir = scratch("huge-blob");
    let blob = dir.join("huge.postcard");
    let f = std::fs::File::create(&blob).expect("create");
    f.set_len(1 << 30).expect("sparse 1 GiB");
    assert_bad_input(
        &run(&["--blob", path(&blob)]),
        &["cannot read blob", "huge.postcard", "larger than any blob"],
    );
}

/// Regression: the CLI held every record in memory. Streamed, its JSON
/// report must still be the library's report key for key (and, timing aside, byte for byte
/// the pretty-printed one), and its SVG the library's plot.
#[test]
fn streamed_json_and_svg_equal_the_library_report() {
    let dir = scratch("streamed");
    let (json, svg) = (dir.join("r.json"), dir.join("p.svg"));
    let faults = "dropout-stale:0.1,wall:60@-2/-2/2/-2";
    let o = run(&[
        "--controller",
        "straight",
        "--episodes",
        "9",
        "--seed",
        "4",
        "--noise",
        "0.02",
        "--faults",
        faults,
        "--json",
        path(&json),
        "--svg",
        path(&svg),
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let s = Scenario::builtin("nav-walls").expect("builtin");
    let mut cfg = EvalConfig {
        episodes: 9,
        seed: 4,
        faults: faults.parse().expect("faults"),
        record_trajectories: true,
        ..EvalConfig::default()
    };
    cfg.sensor.noise_std = 0.02;
    let mut c = reference("straight", &s).expect("straight");
    let report = evaluate_controller(c.as_mut(), &s, &cfg).expect("eval");
    let written = std::fs::read(&json).expect("json written");
    let expected = serde_json::to_vec_pretty(&report).expect("json");
    assert_eq!(
        json_without_timing(&written),
        json_without_timing(&expected)
    );
    // (Timing is wall-clock, and serde_json's float parsing is not an exact round trip without
    // its `float_roundtrip` feature, so the comparison above leaves timing out.)
    assert_eq!(
        std::fs::read_to_string(&svg).expect("svg written"),
        svg::render_with_faults(&s, &report, cfg.faults.wall)
    );
    assert_eq!(names(&dir), ["p.svg", "r.json"]);
}

/// The trajectory SVG had no legend, axes or text (its orange paths were explained only in the
/// source), and a wall that `--faults wall:...` added or moved was not drawn, so paths stopped
/// in mid-air.
#[test]
fn the_trajectory_svg_has_a_legend_axes_and_the_walls_faults_add() {
    let dir = scratch("svg-legend");
    let plot = |faults: &str, name: &str| {
        let svg = dir.join(name);
        let o = run(&[
            "--controller",
            "straight",
            "--episodes",
            "4",
            "--faults",
            faults,
            "--svg",
            path(&svg),
        ]);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        std::fs::read_to_string(&svg).expect("svg")
    };
    let added = plot("wall:20@-2/0/2/0", "added.svg");
    for text in [
        "nav-walls — straight</text>",
        "settled: within 2 of the goal at the end",
        "stuck at a wall (margin)",
        "neither: wandered, looped or left the arena",
        "success radius 2",
        "wall from --faults, from tick 20",
        ">-3</text>",
        ">3</text>",
        "x, y in arena units",
    ] {
        assert!(added.contains(text), "{text}");
    }
    // The added wall from (-2, 0) to (2, 0), in pixels, over the 13 walls of the scenario.
    assert_eq!(added.matches(r#"class="wall""#).count(), 13);
    let drawn = r##"class="wall fault" stroke="#1f5fbf" stroke-width="4" stroke-linecap="round" x1="204.00" y1="270.00" x2="364.00" y2="270.00""##;
    assert!(added.contains(drawn), "{added}");
    let moved = plot("wall:20@-1/-3/1/-3@8", "moved.svg");
    assert_eq!(moved.matches(r#"class="wall""#).count(), 12);
    assert_eq!(moved.matches(r#"class="wall moved""#).count(), 1);
    assert_eq!(moved.matches(r#"class="wall fault""#).count(), 1);
    assert!(moved.contains("wall from --faults, from tick 20: wall 8 moved here"));
    assert!(moved.contains("that wall before tick 20"));
}

fn path(p: &Path) -> &str {
    p.to_str().expect("utf8")
}

/// `--slot-a/--slot-b` boot the newer slot that verifies, as the firmware does, and say which;
/// a corrupt newer slot falls back; no runnable slot is the safe state with both reasons (exit
/// 1); an Intel HEX image or a slot with --blob is bad input.
#[test]
fn slot_images_boot_like_the_firmware() {
    use policy_core::slot;
    let dir = scratch("slots");
    let blob = random_blob::<32, 1>(3, "slot");
    let write = |name: &str, bytes: &[u8]| {
        let path = dir.join(name);
        std::fs::write(&path, bytes).expect("write slot image");
        path.to_str().expect("utf8").to_string()
    };
    let a = write(
        "a.bin",
        &slot::record(&blob, 1, 1 << 17).expect("test value"),
    );
    let b_good = slot::record(&blob, 2, 1 << 17).expect("test value");
    let b = write("b.bin", &b_good);
    let mut flipped = b_good.clone();
    flipped[100] ^= 0x01;
    let b_bad = write("b-bad.bin", &flipped);
    let erased = write("erased.bin", &[0xFF; 4096]);
    let hex = write(
        "b.hex",
        slot::intel_hex(&b_good, 0x60000)
            .expect("test value")
            .as_bytes(),
    );

    let o = run(&["--slot-a", &a, "--slot-b", &b, "--episodes", "2"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("slot A: standby (sequence 1"), "{out}");
    assert!(
        out.contains("slot B: running (sequence 2)\nslot B runs"),
        "{out}"
    );
    assert!(out.contains("blob \"slot\""), "{out}");

    let o = run(&["--slot-a", &a, "--slot-b", &b_bad, "--episodes", "2"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("slot B: failed: checksum mismatch"), "{out}");
    assert!(out.contains("slot A runs"), "{out}");

    let o = run(&["--slot-a", &erased, "--slot-b", &b_bad, "--episodes", "2"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("empty slot")
            && err.contains("checksum mismatch")
            && err.contains("safe state"),
        "{err}"
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("no slot runs: safe state"), "{out}");

    // Only slot B given: slot A is empty.
    let o = run(&["--slot-b", &b, "--episodes", "2"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("slot A: failed: empty slot"));

    assert_bad_input(&run(&["--slot-a", &hex]), &["Intel HEX", ".bin"]);
    assert_bad_input(&run(&["--slot-a", &a, "--blob", &a]), &["--blob"]);
    // Regression: a slot image given as --blob said only "found [68, 67, 80, 83]".
    assert_bad_input(
        &run(&["--blob", &a, "--episodes", "2"]),
        &["flash slot image", "--slot-a"],
    );
    assert_bad_input(
        &run(&["--slot-a", &a, "--scratch-width", "0"]),
        &["scratch width"],
    );
}

/// `--critic FILE --refine T,SIGMA` runs DCP's compare step before each action and reports how
/// often a proposal won; T = 0 changes nothing; a critic of the wrong kind or size, a missing
/// --critic or a malformed T,SIGMA is bad input.
#[test]
fn the_compare_step_runs_in_the_loop() {
    let dir = scratch("refine");
    let golden = concat!(env!("CARGO_MANIFEST_DIR"), "/../policy-core/tests/golden/");
    let actor = format!("{golden}actor_2x32.postcard");
    let critic = format!("{golden}critic_2x32.postcard");
    let plain = run(&["--blob", &actor, "--episodes", "3"]);
    let same = run(&[
        "--blob",
        &actor,
        "--critic",
        &critic,
        "--refine",
        "0,0.2",
        "--episodes",
        "3",
    ]);
    let text = |o: &Output| String::from_utf8_lossy(&o.stdout).into_owned();
    let metrics = |t: &str| -> String {
        t.lines()
            .filter(|l| l.contains("settled error") || l.contains("stuck at margin"))
            .collect()
    };
    assert_eq!(
        metrics(&text(&plain)),
        metrics(&text(&same)),
        "T = 0 is the actor itself"
    );
    assert!(text(&same).contains("replaced the actor's action on 0 of 600 ticks"));
    let refined = run(&[
        "--blob",
        &actor,
        "--critic",
        &critic,
        "--refine",
        "16,0.2",
        "--episodes",
        "3",
    ]);
    assert!(
        text(&refined).contains("compare T 16"),
        "{}",
        text(&refined)
    );
    assert!(text(&refined).contains("replaced the actor's action on"));

    assert_bad_input(
        &run(&["--blob", &actor, "--refine", "4,0.2"]),
        &["--critic"],
    );
    assert_bad_input(
        &run(&["--blob", &actor, "--critic", &critic, "--refine", "4"]),
        &["T,SIGMA"],
    );
    // Regression: `--refine 16,nan` was accepted with a blob that does not boot (and from slots).
    for bad in ["16,nan", "16,0", "16,-1", "5000,0.2"] {
        assert_bad_input(
            &run(&["--blob", &critic, "--critic", &critic, "--refine", bad]),
            &["SIGMA finite"],
        );
    }
    // Regression: from slots the compare step was skipped without a word, running the plain
    // actor.
    assert_bad_input(
        &run(&[
            "--slot-a", &actor, "--critic", &critic, "--refine", "16,0.2",
        ]),
        &["--critic", "--slot-a"],
    );
    let wrong_kind = run(&["--blob", &actor, "--critic", &actor, "--refine", "4,0.2"]);
    assert_eq!(wrong_kind.status.code(), Some(2), "{}", stderr(&wrong_kind));
    assert!(
        stderr(&wrong_kind).contains("wrong model kind"),
        "{}",
        stderr(&wrong_kind)
    );
    drop(dir);
}

/// `--critic FILE --heads` runs an actor of several heads with the critic choosing one each
/// tick; an actor of one head is its plain self; a critic that cannot judge the heads boots the
/// safe state, with the reason; --heads without --critic, or with --refine, is bad input.
#[test]
fn an_actor_of_heads_runs_with_its_critic_choosing() {
    let golden = concat!(env!("CARGO_MANIFEST_DIR"), "/../policy-core/tests/golden/");
    let actor = format!("{golden}actor_2x32.postcard");
    let critic = format!("{golden}critic_2x32.postcard");
    let text = |o: &Output| String::from_utf8_lossy(&o.stdout).into_owned();
    let metrics = |t: &str| -> String {
        t.lines()
            .filter(|l| l.contains("settled error") || l.contains("stuck at margin"))
            .collect()
    };
    let plain = run(&["--blob", &actor, "--episodes", "3"]);
    let one = run(&[
        "--blob",
        &actor,
        "--critic",
        &critic,
        "--heads",
        "--episodes",
        "3",
    ]);
    assert_eq!(metrics(&text(&plain)), metrics(&text(&one)), "one head");
    assert!(
        text(&one).contains("ticks on which each head was chosen: 600"),
        "{}",
        text(&one)
    );
    let misfit = run(&[
        "--blob",
        &actor,
        "--critic",
        &actor,
        "--heads",
        "--episodes",
        "1",
    ]);
    assert_eq!(misfit.status.code(), Some(1), "{}", stderr(&misfit));
    let all = text(&misfit) + &stderr(&misfit);
    assert!(all.contains("wrong model kind"), "{all}");
    assert!(all.contains("safe-state"), "{all}");
    assert_bad_input(&run(&["--blob", &actor, "--heads"]), &["--critic"]);
    assert_bad_input(
        &run(&[
            "--blob", &actor, "--critic", &critic, "--heads", "--refine", "4,0.2",
        ]),
        &["--heads", "--refine"],
    );
    assert_bad_input(&run(&["--blob", &actor, "--critic", &critic]), &["--heads"]);
}

#[test]
fn scenario_generate_writes_the_same_solvable_file_for_a_seed_and_refuses_bad_input() {
    let dir = scratch("generate");
    let generate = |out: &Path, extra: &[&str]| {
        Command::new(BIN)
            .args(["scenario", "generate", "--kind", "maze", "--level", "2"])
            .args(["--seed", "3", "--out"])
            .arg(out)
            .args(extra)
            .output()
            .expect("spawn firmware-sim")
    };
    let (a, b, picture) = (dir.join("a.toml"), dir.join("b.toml"), dir.join("a.svg"));
    let o = generate(&a, &["--svg", picture.to_str().expect("utf-8")]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("maze-2-seed3"));
    assert!(generate(&b, &[]).status.success());
    let text = std::fs::read(&a).expect("written");
    assert_eq!(
        text,
        std::fs::read(&b).expect("written"),
        "same seed, same bytes"
    );
    assert!(std::fs::read_to_string(&picture)
        .expect("drawn")
        .starts_with("<svg"));
    // The file is a scenario the oracle passes.
    let o = run(&[
        "--controller",
        "oracle",
        "--scenario",
        a.to_str().expect("utf-8"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));

    let before = names(&dir);
    let bad = Command::new(BIN)
        .args([
            "scenario", "generate", "--kind", "maze", "--level", "9", "--out",
        ])
        .arg(dir.join("c.toml"))
        .output()
        .expect("spawn");
    assert_bad_input(&bad, &["level", "1, 2, 3 or 4"]);
    let missing = dir.join("no-such-folder").join("d.toml");
    assert_bad_input(&generate(&missing, &[]), &["folder does not exist"]);
    let spiral = Command::new(BIN)
        .args(["scenario", "generate", "--kind", "spiral", "--out"])
        .arg(dir.join("e.toml"))
        .output()
        .expect("spawn");
    assert_bad_input(&spiral, &["spiral"]);
    assert_eq!(names(&dir), before, "a refused command wrote nothing");
}

#[test]
fn a_reader_that_goes_away_ends_the_run_quietly() {
    // `firmware-sim run ... | head -1`: the pipe closes before the summary is written.
    let mut child = Command::new(BIN)
        .args(["run", "--controller", "oracle", "--episodes", "20"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn");
    drop(child.stdout.take()); // the reader goes away
    let o = child.wait_with_output().expect("wait");
    assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
    assert_eq!(o.status.code(), Some(141), "{}", stderr(&o));
}

/// `scenario generate --out A --svg B` once replaced A before B failed (B on a full disk, here
/// `/dev/full`): both are written before either is put in place, so a failed picture leaves the
/// old scenario file as it was and no temporary beside it.
#[test]
fn scenario_generate_writes_both_files_or_neither() {
    let dir = scratch("generate-both");
    let a = dir.join("a.toml");
    std::fs::write(&a, "# the old scenario\n").expect("old file");
    let o = Command::new(BIN)
        .args(["scenario", "generate", "--kind", "rings", "--out"])
        .arg(&a)
        .args(["--svg", "/dev/full"])
        .output()
        .expect("spawn firmware-sim");
    assert_bad_input(&o, &["/dev/full"]);
    assert_eq!(
        std::fs::read_to_string(&a).expect("kept"),
        "# the old scenario\n"
    );
    assert_eq!(names(&dir), ["a.toml"], "no temporary left");
}

/// `firmware-sim run --slot-a A --slot-b B 2>&1 | head -4` exited 101: the reader had gone when
/// the closing `error:` line went to standard error, and `eprintln!` panicked. Standard error's
/// reader gone ends the run with 141, as standard output's does.
#[test]
fn a_reader_of_standard_error_that_goes_away_ends_the_run_with_141() {
    let dir = scratch("stderr-closed");
    let (a, b) = (dir.join("a.bin"), dir.join("b.bin"));
    std::fs::write(&a, [0x48_u8; 300]).expect("slot a");
    std::fs::write(&b, [0x48_u8; 300]).expect("slot b");
    let mut child = Command::new(BIN)
        .args(["run", "--slot-a"])
        .arg(&a)
        .arg("--slot-b")
        .arg(&b)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn");
    drop(child.stderr.take()); // the reader goes away before the closing line
    let status = child.wait().expect("wait");
    assert_eq!(status.code(), Some(141));
}

/// `--json /dev/stdout` with standard output a pipe was refused as "a symbolic link whose
/// target cannot be reached" (the link goes through /proc/self/fd to a pipe, which has no
/// path); it is written through, as a FIFO is.
#[test]
fn json_to_dev_stdout_in_a_pipe_is_written_through() {
    let o = run(&[
        "--controller",
        "oracle",
        "--episodes",
        "2",
        "--json",
        "/dev/stdout",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    let json = &text[text.find("\n{").expect("the report") + 1..];
    let report: serde_json::Value = serde_json::from_str(json).expect("the JSON report");
    assert_eq!(report["episodes"].as_array().map(Vec::len), Some(2));
}
