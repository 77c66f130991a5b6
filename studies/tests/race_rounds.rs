//! What held a race, read from race folders as `train` writes them: each criterion's first
//! round, and the winners' test against their kept rounds.

use std::path::Path;

use host_trainer::run::race::{RaceRecord, RacerRecord};
use host_trainer::run::validation::Round;
use studies::race_rounds::read_line;

use crate::study;

/// A round at `episode` with these figures; it meets the criteria (0.9, 0.1, 0.4) when all hold.
fn round(episode: usize, success: f64, stuck: f64, error: f64) -> Round {
    let meets = success >= 0.9 && stuck <= 0.1 && error < 0.4;
    Round {
        episode,
        success,
        stuck,
        error: Some(error),
        gate: success >= 0.8 && stuck <= 0.2,
        meets,
        ..Round::default()
    }
}

/// A finished line `name` in `runs`: a race of two racers won by racer 1, whose kept round
/// settled `kept` from the centre, and a test settling `test`.
fn race_line(runs: &Path, name: &str, kept: f64, test: f64) {
    let race_dir = runs.join(name).join("nav-walls__dcp__0");
    std::fs::create_dir_all(&race_dir).expect("race folder");
    let slow = vec![round(10, 0.5, 0.3, 3.0), round(20, 0.95, 0.05, 0.7)];
    let won = vec![round(10, 0.92, 0.2, 0.9), round(20, 0.97, 0.0, kept)];
    let racer = |seed, validation: Vec<Round>| RacerRecord {
        seed,
        folder: format!("racers/nav-walls__dcp__{seed}"),
        ending: None,
        episodes: 20,
        kept: validation.last().cloned(),
        validation,
    };
    let record = RaceRecord {
        base_seed: 0,
        config_toml: "task = \"nav-walls\"\n[validation]\nevery = 10\nin_a_row = 1\n".into(),
        racers: vec![racer(0, slow), racer(9, won)],
        winner: Some(1),
        why: "racer 1 (seed 9) was the first whose validation met the criteria".into(),
    };
    std::fs::write(
        race_dir.join("race.json"),
        serde_json::to_string(&record).expect("json"),
    )
    .expect("race.json");
    std::fs::write(
        race_dir.join("eval.json"),
        format!(r#"{{"success_rate": 1.0, "mean_error": {test}, "stuck_rate": 0.0}}"#),
    )
    .expect("eval.json");
}

#[test]
fn each_criterion_first_round_and_the_winners_test_against_their_kept_round() {
    let dir = std::env::temp_dir().join(format!("race-rounds-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    race_line(&dir, "every-10-0", 0.25, 0.25);
    race_line(&dir, "every-10-1", 0.3, 0.45);

    let (racers, winner) = read_line(&dir.join("every-10-0")).expect("reads");
    assert_eq!(racers.len(), 2);
    // The slow racer met success and stuck at episode 20, never the settled error.
    assert_eq!(
        (
            racers[0].success,
            racers[0].stuck,
            racers[0].error,
            racers[0].all
        ),
        (Some(20), Some(20), None, None)
    );
    assert_eq!(racers[1].all, Some(20));
    assert_eq!((winner.kept_error, winner.test_error), (Some(0.25), 0.25));

    let runs = dir.to_string_lossy().to_string();
    let out = study(
        env!("CARGO_BIN_EXE_race-rounds"),
        &["--runs", &runs, "--lines", "every-10", "--seeds", "0-1"],
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    assert!(text.starts_with("4 racers in 2 races:"), "{text}");
    assert!(
        text.contains("settled error: first met at episode 20–20 (median 20) by 2 racers; 2 not before their race ended"),
        "{text}"
    );
    assert!(
        text.contains("for 1 of 2; the others: every-10-1 0.450 against 0.300"),
        "{text}"
    );

    // A seed whose line is missing is named, in one line.
    let out = study(
        env!("CARGO_BIN_EXE_race-rounds"),
        &["--runs", &runs, "--lines", "every-10", "--seeds", "0-2"],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.starts_with("race-rounds: ") && err.contains("every-10-2"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_backward_seed_range_is_refused() {
    let out = study(
        env!("CARGO_BIN_EXE_race-rounds"),
        &["--runs", "runs", "--lines", "every-10", "--seeds", "5-2"],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("the range 5-2 is empty"), "{err}");
}
