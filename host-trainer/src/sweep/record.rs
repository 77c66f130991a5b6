//! What became of a sweep's run: one row of the summary, with the run's evaluation.

use std::fs;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::algorithms::Algo;
use crate::run::folder;
use crate::Error;

/// The columns of a finished run's `eval.json` (firmware-sim's report) that the summary shows.
/// A run on a plant of the user's (`--plant-cmd`) has the test for any plant's report, which
/// knows no distance to a goal: its navigation columns are absent.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EvalSummary {
    /// Fraction of successful test starts (navigation: settled within 2 of the centre).
    pub success_rate: f64,
    /// Mean settled distance from the centre (navigation).
    #[serde(default)]
    pub mean_error: Option<f64>,
    /// Fraction flagged stuck at a margin.
    pub stuck_rate: f64,
    /// Fraction that came within 0.25 of the centre (navigation).
    #[serde(default)]
    pub near_pass_rate: Option<f64>,
    /// Fraction that held within 0.1 of the centre for 10 steps (navigation).
    #[serde(default)]
    pub strict_reach_rate: Option<f64>,
}

/// The summary columns of `DIR/eval.json`, the report of a finished run.
pub fn read_eval(dir: &Path) -> Result<EvalSummary, Error> {
    read_report(dir)
}

/// A finished run's `DIR/eval.json` as `T` (the summary's columns, or firmware-sim's whole
/// report), once its summary's values are checked: a file cut short or edited (a success rate
/// of 7.5) is a damaged run, named with the way out (train it again), never figures in a table.
pub fn read_report<T: serde::de::DeserializeOwned>(dir: &Path) -> Result<T, Error> {
    let path = dir.join(folder::EVAL);
    let damaged = |problem: String| Error::DamagedRun {
        path: dir.to_path_buf(),
        problem,
    };
    let text = fs::read_to_string(&path).map_err(|source| Error::Io {
        path: path.clone(),
        source,
    })?;
    let summary: EvalSummary = serde_json::from_str(&text).map_err(|e| {
        damaged(format!(
            "its {} is not a firmware-sim report ({e})",
            folder::EVAL
        ))
    })?;
    summary
        .check()
        .map_err(|e| damaged(format!("its {} holds {e}", folder::EVAL)))?;
    serde_json::from_str(&text).map_err(|e| {
        damaged(format!(
            "its {} is not a firmware-sim report ({e})",
            folder::EVAL
        ))
    })
}

impl EvalSummary {
    /// Every rate in [0, 1] and the mean error finite and not negative, as an evaluation gives
    /// them; the first value that is not, as `key = value`.
    fn check(&self) -> Result<(), String> {
        let rates = [
            ("success_rate", Some(self.success_rate)),
            ("stuck_rate", Some(self.stuck_rate)),
            ("near_pass_rate", self.near_pass_rate),
            ("strict_reach_rate", self.strict_reach_rate),
        ];
        for (key, value) in rates {
            if let Some(v) = value.filter(|v| !(0.0..=1.0).contains(v)) {
                return Err(format!("{key} = {v}, outside [0, 1]"));
            }
        }
        match self.mean_error {
            Some(v) if !(v.is_finite() && v >= 0.0) => {
                Err(format!("mean_error = {v}, not a distance"))
            }
            _ => Ok(()),
        }
    }
}

/// How a run of the sweep ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// Trained (or continued) to the end by this sweep.
    Finished,
    /// Already finished before this sweep; untouched.
    Skipped,
    /// Its process failed; the row says how.
    Failed,
    /// Stopped by Ctrl-C at a checkpoint; the next sweep continues it.
    Interrupted,
    /// Not started because the sweep was interrupted first.
    Pending,
}

/// One row of the summary.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// The task as the folder names it.
    pub task: String,
    /// The algorithm.
    pub algo: Algo,
    /// The seed.
    pub seed: u64,
    /// How it ended.
    pub status: Status,
    /// Wall-clock seconds of this sweep's process for it (none when skipped).
    pub wall_seconds: Option<f64>,
    /// The child's exit code (none if killed by a signal or not run).
    pub exit_code: Option<i32>,
    /// The signal that killed the child, if one did.
    pub signal: Option<i32>,
    /// The last line the child printed (its error, for a failed run).
    pub last_line: Option<String>,
    /// The run's evaluation (finished and skipped runs).
    pub eval: Option<EvalSummary>,
}

pub(super) fn exit_text(record: &RunRecord) -> String {
    match (record.exit_code, record.signal) {
        (Some(code), _) => format!("exit {code}"),
        (None, Some(signal)) => format!("signal {signal}"),
        (None, None) => "not run".into(),
    }
}
