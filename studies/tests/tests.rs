//! The studies' binaries run as a user runs them, from the repository root.

/// The margin study's decisions from its committed record.
mod main_job;
mod margin_study;
/// What held a race, from its folder.
mod race_rounds;
/// The results pages' sections rebuilt from their per-seed rows, and what a check refuses.
mod restat;
/// Every study's command line: a usage error is one line on stderr and a failing exit code.
mod usage;

use std::path::Path;
use std::process::{Command, Output};

/// Runs a study's binary from the repository root (where the pages' commands run).
pub fn study(binary: &str, args: &[&str]) -> Output {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the crate lives in the workspace");
    Command::new(binary)
        .args(args)
        .current_dir(root)
        .output()
        .expect("the study runs")
}
