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
