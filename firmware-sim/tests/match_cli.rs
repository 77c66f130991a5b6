//! `firmware-sim match`: the summary, JSON and SVG outputs, exit codes, one-line errors.

use std::path::Path;
use std::process::Output;

use firmware_sim::badminton::play::{play_match, Length, MatchReport};
use firmware_sim::badminton::reference::PlayerKind;
use firmware_sim::badminton::Config;

use crate::util::{firmware_sim, stderr, Scratch};

/// A scratch folder of this module's tests.
fn scratch(name: &str) -> Scratch {
    Scratch::new("match-cli", name)
}

fn play(args: &[&str]) -> Output {
    firmware_sim("match", args)
}

fn assert_bad_input(o: &Output, needle: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    assert_eq!(err.lines().count(), 1, "one line, got: {err}");
    assert!(
        !err.contains("panicked") && err.contains(needle),
        "{needle:?}: {err}"
    );
}

#[test]
fn a_match_prints_the_score_and_writes_json_and_svg_equal_to_the_library() {
    let dir = scratch("ok");
    let (json, svg) = (dir.file("match.json"), dir.file("rally.svg"));
    let args = [
        "--p0", "scripted", "--p1", "random", "--games", "1", "--seed", "4", "--json", &json,
        "--svg", &svg,
    ];
    let o = play(&args);
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{out}{}", stderr(&o));
    for needle in [
        "p0 scripted vs p1 random",
        "by opponent's out",
        "by opponent's net",
        "by opponent's missed catch",
        "lets (rally cap)",
        "catch success",
        "serve error",
        "PASS",
    ] {
        assert!(out.contains(needle), "{needle:?} in {out}");
    }
    let written: MatchReport =
        serde_json::from_slice(&std::fs::read(&json).expect("json")).expect("a report");
    let kinds = [PlayerKind::Scripted, PlayerKind::Random];
    let library = play_match(
        &Config::builtin(),
        &kinds,
        Length::Games(1),
        4,
        false,
        |_| {},
    )
    .expect("lib");
    assert_eq!(written, library);
    let drawing = std::fs::read_to_string(&svg).expect("svg");
    assert!(drawing.contains("from above") && drawing.contains("from the side"));
    assert_eq!(dir.names(), ["match.json", "rally.svg"]);
}

#[test]
fn failed_pass_criteria_exit_1() {
    let dir = scratch("fail");
    let strict = dir.file("strict.toml");
    let text = Config::BUILTIN.replace("max_serve_error_rate = 0.08", "max_serve_error_rate = 0.0");
    std::fs::write(&strict, text).expect("scenario");
    let o = play(&[
        "--p0",
        "scripted",
        "--p1",
        "scripted",
        "--scenario",
        &strict,
        "--seed",
        "1",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).starts_with("FAIL: p0 scripted: serve error rate"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn bad_arguments_are_one_line_exit_2_and_leave_no_file() {
    let dir = scratch("bad");
    let json = dir.file("out.json");
    assert_bad_input(
        &play(&["--p0", "smash", "--p1", "random"]),
        "expected scripted or random",
    );
    assert_bad_input(&play(&["--p0", "random"]), "--p1");
    for (games, needle) in [
        ("0", "games"),
        ("1001", "games"),
        ("-3", "'-3'"),
        ("x", "games"),
    ] {
        let o = play(&[
            "--p0", "random", "--p1", "random", "--games", games, "--json", &json,
        ]);
        assert_bad_input(&o, needle);
    }
    let o = play(&[
        "--p0", "random", "--p1", "random", "--json", &json, "--svg", &json,
    ]);
    assert_bad_input(&o, "same file");
    // Regression: `--json same.out --svg ./same.out` exited 0 and left only the SVG.
    let dotted = dir.file("./out.json");
    let o = play(&[
        "--p0", "random", "--p1", "random", "--json", &json, "--svg", &dotted,
    ]);
    assert_bad_input(&o, "same file");
    let folder = dir.0.join("folder");
    std::fs::create_dir(&folder).expect("folder");
    let o = play(&[
        "--p0",
        "random",
        "--p1",
        "random",
        "--json",
        folder.to_str().expect("utf-8"),
    ]);
    assert_bad_input(&o, "cannot write");
    let broken = dir.file("broken.toml");
    std::fs::write(&broken, Config::BUILTIN.replace("dt = 0.001", "dt = nan")).expect("file");
    let o = play(&[
        "--p0",
        "random",
        "--p1",
        "random",
        "--scenario",
        &broken,
        "--json",
        &json,
    ]);
    assert_bad_input(
        &o,
        "broken.toml:17: shuttle.dt: must be in [0.0001, 0.01], found NaN",
    );
    let o = play(&[
        "--p0",
        "random",
        "--p1",
        "random",
        "--scenario",
        "nowhere.toml",
    ]);
    assert_bad_input(&o, "nowhere.toml");
    assert_eq!(dir.names(), ["broken.toml", "folder"]);
    assert!(Path::new(&folder)
        .read_dir()
        .expect("folder")
        .next()
        .is_none());
}
