//! The verdict of a run against its scenario's pass criteria, shared by every plant's report.

use serde::{Deserialize, Serialize};

/// Whether the scenario's pass criteria hold, and which failed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PassOutcome {
    /// All criteria hold and the blob booted.
    pub passed: bool,
    /// One line per failed criterion.
    pub failures: Vec<String>,
}

impl PassOutcome {
    /// The verdict as the summary tables print it: `PASS`, or `FAIL (why; why)`.
    pub fn verdict(&self) -> String {
        if self.passed {
            "PASS".to_string()
        } else {
            format!("FAIL ({})", self.failures.join("; "))
        }
    }
}

/// The summary table every test report prints: `PLANT | CONTROLLER | N tests, seed S`, one
/// `  key  value` row each, then the chip's rows and why the run stopped early, if it did.
pub(crate) fn summary_table<K: std::fmt::Display>(
    (plant, controller, seed): (&str, &str, u64),
    (episodes, stopped): (usize, Option<&crate::nav::test_protocol::Stopped>),
    rows: impl IntoIterator<Item = (K, String)>,
    chip: Option<&crate::hil::ChipReport>,
) -> String {
    let tests = match stopped {
        Some(s) => format!("{} of {episodes} tests", s.episodes_run),
        None => format!("{episodes} tests"),
    };
    let mut out = format!("{plant} | {controller} | {tests}, seed {seed}\n");
    let mut row = |k: &dyn std::fmt::Display, v: &str| out.push_str(&format!("  {k:<33} {v}\n"));
    for (k, v) in rows {
        row(&k, &v);
    }
    for (k, v) in chip.map(crate::hil::ChipReport::rows).unwrap_or_default() {
        row(&k, &v);
    }
    if let Some(s) = stopped {
        row(
            &"stopped",
            &format!("after {} episodes: {}", s.episodes_run, s.reason),
        );
    }
    out
}
