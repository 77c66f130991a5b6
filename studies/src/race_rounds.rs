//! What holds a race: when each racer's validation first met each of the criteria, and whether
//! the winner's test held what its kept round showed. Read from finished races' folders
//! (`race.json`, `eval.json`); the main job's page quotes it to choose and check its stop rules
//! (docs/results/main-job.md, "Second amendment").
//!
//! A racer's rounds are judged by the criteria its race trained with (`race.json`'s settings),
//! each criterion alone, so the summary says which one a race waited for.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use host_trainer::run::config::TrainConfig;
use host_trainer::run::folder;
use host_trainer::run::race::RaceRecord;
use host_trainer::run::validation::Round;
use host_trainer::sweep::record::read_eval;

use crate::main_job::{median, span};

/// Where a test's settled error counts as the kept round's: the settled error is where the
/// policy comes to rest, much the same from every start, and the main job's winners' two means
/// differ either by 10⁻⁹ to 5·10⁻⁵ (one resting point) or by 0.008 and more.
pub const SAME_ERROR: f64 = 1e-4;

/// One racer's first rounds meeting each criterion (`None`: not before its race ended).
#[derive(Clone, Debug, PartialEq)]
pub struct Racer {
    /// The episode of its first round with success at least the minimum.
    pub success: Option<usize>,
    /// ... with stuck at most the maximum.
    pub stuck: Option<usize>,
    /// ... with a mean settled error below the maximum.
    pub error: Option<usize>,
    /// ... meeting every criterion (the gate included).
    pub all: Option<usize>,
}

/// A race's winner: the kept round's validation settled error against the test's.
#[derive(Clone, Debug, PartialEq)]
pub struct Winner {
    /// The line it won.
    pub line: String,
    /// The mean settled error of the round its policy came from.
    pub kept_error: Option<f64>,
    /// The mean settled error on the test starts.
    pub test_error: f64,
}

/// The criteria a round is judged by, from the race's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Criteria {
    /// Least success rate.
    pub min_success: f64,
    /// Largest stuck rate.
    pub max_stuck: f64,
    /// Largest mean settled error (strictly below).
    pub max_error: f64,
}

/// The first round of `rounds` that `holds`.
fn first(rounds: &[Round], holds: impl Fn(&Round) -> bool) -> Option<usize> {
    rounds.iter().find(|r| holds(r)).map(|r| r.episode)
}

/// One racer's first rounds under `c`.
///
/// ```
/// use host_trainer::run::validation::Round;
/// use studies::race_rounds::{racer, Criteria};
/// let c = Criteria { min_success: 0.9, max_stuck: 0.1, max_error: 0.4 };
/// let round = |episode, success, error, meets| Round {
///     episode, success, error: Some(error), meets, ..Round::default()
/// };
/// let rounds = [round(10, 0.5, 3.0, false), round(20, 0.95, 0.6, false), round(30, 0.92, 0.3, true)];
/// let r = racer(&rounds, c);
/// assert_eq!((r.success, r.stuck, r.error, r.all), (Some(20), Some(10), Some(30), Some(30)));
/// ```
pub fn racer(rounds: &[Round], c: Criteria) -> Racer {
    Racer {
        success: first(rounds, |r| r.success >= c.min_success),
        stuck: first(rounds, |r| r.stuck <= c.max_stuck),
        error: first(rounds, |r| r.error.is_some_and(|e| e < c.max_error)),
        all: first(rounds, |r| r.meets),
    }
}

/// The racers and the winner of the finished race in the line folder `dir` (the queue's
/// `OUT/NAME`, holding one race folder).
pub fn read_line(dir: &Path) -> Result<(Vec<Racer>, Winner)> {
    let name = dir
        .file_name()
        .map_or_else(|| dir.display().to_string(), |n| n.to_string_lossy().into());
    let race_dir = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| p.join(folder::RACE).is_file())
        .with_context(|| format!("{name}: no race folder (a folder with race.json)"))?;
    let race = RaceRecord::read(&race_dir).with_context(|| format!("{name}: the race"))?;
    let test_error = read_eval(&race_dir)
        .with_context(|| format!("{name}: the test"))?
        .mean_error
        .with_context(|| format!("{name}: the test has no settled error (not a navigation run)"))?;
    // Named for errors; not `.json`, which would select JSON for the TOML text.
    let config = TrainConfig::parse(&race.config_toml, &race_dir.join("race.json (config_toml)"))
        .with_context(|| format!("{name}: the race's settings"))?;
    let v = config
        .validation
        .with_context(|| format!("{name}: the race trained without validation"))?;
    let c = Criteria {
        min_success: v.min_success,
        max_stuck: v.max_stuck,
        max_error: v.max_error,
    };
    let won = race
        .winner_record()
        .with_context(|| format!("{name}: the race has no winner (not finished?)"))?;
    let racers = race
        .racers
        .iter()
        .map(|r| racer(&r.validation, c))
        .collect();
    let winner = Winner {
        line: name.clone(),
        kept_error: won.kept_error(),
        test_error,
    };
    Ok((racers, winner))
}

/// The summary the page quotes: per criterion, the range and median of the first episodes that
/// met it and how many racers never did; then the winners' test settled error against their
/// kept rounds'.
pub fn summary(racers: &[Racer], winners: &[Winner]) -> String {
    let mut out = String::new();
    let lines = winners.len();
    let _ = writeln!(out, "{} racers in {lines} races:", racers.len());
    type Pick = fn(&Racer) -> Option<usize>;
    let criteria: [(&str, Pick); 4] = [
        ("success", |r| r.success),
        ("stuck", |r| r.stuck),
        ("settled error", |r| r.error),
        ("all the criteria", |r| r.all),
    ];
    for (what, pick) in criteria {
        let at: Vec<f64> = racers.iter().filter_map(pick).map(|e| e as f64).collect();
        let never = racers.len() - at.len();
        let _ = match (median(&at), span(&at)) {
            (Some(m), Some((lo, hi))) => writeln!(
                out,
                "  {what}: first met at episode {lo:.0}–{hi:.0} (median {m:.0}) by {} racers; {never} not before their race ended",
                at.len(),
            ),
            _ => writeln!(out, "  {what}: met by no racer before its race ended"),
        };
    }
    let mut differ: Vec<String> = Vec::new();
    let mut same = 0;
    for w in winners {
        match w.kept_error {
            Some(k) if (w.test_error - k).abs() < SAME_ERROR => same += 1,
            Some(k) => differ.push(format!("{} {:.3} against {k:.3}", w.line, w.test_error)),
            None => differ.push(format!("{} (no kept round's error)", w.line)),
        }
    }
    let _ = writeln!(
        out,
        "winners: the test's mean settled error equals the kept round's (within {SAME_ERROR:e}) for {same} of {lines}{}",
        if differ.is_empty() {
            String::new()
        } else {
            format!("; the others: {}", differ.join(", "))
        }
    );
    out
}
