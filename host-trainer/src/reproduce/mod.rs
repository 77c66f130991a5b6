//! `host-trainer reproduce`: an experiment of the paper rebuilt by one command, on one machine
//! or as the parts of a cluster job array.
//!
//! 1. [`grid`] lists every run experiment 1's tables and figures need (cells of settings ×
//!    seeds), each once, and cuts it into disjoint slices (`--slice I/N`); [`teams`] does the
//!    same for experiment 2's badminton teams.
//! 2. [`folder`] plans a slice through `sweep`'s planner, one sweep folder per cell (finished
//!    runs skipped, stopped ones resumed, a folder of other settings refused), and reads back
//!    what became of every run from the run folders alone.
//! 3. The runs go through `sweep`'s supervisor: every run its own `train` process.
//! 4. [`page`] and [`figures`] build experiment 1's results page from the run folders, and
//!    [`badminton`] experiment 2's from the team folders: tables with intervals and per-seed
//!    values, the verdicts on the claims, the figures, and the runs that are missing. [`Part`] records what each part ran, with which commit and how long.

pub mod badminton;
pub mod figures;
pub mod folder;
pub mod grid;
pub mod page;
pub mod teams;
pub mod verdict;

use std::fmt::Write as _;
use std::fs;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::sweep::plan::PlannedRun;
use crate::Error;
use firmware_sim::files;
use grid::{Experiment, Grid, Slice};

/// The commit the running binary was built from (`git describe`-like: the short hash, with
/// `+changes` when files tracked by git differed from it), or `unknown` outside a checkout.
pub const COMMIT: &str = env!("HOST_TRAINER_COMMIT");

/// The folder of the parts' records under `--out`.
pub const PARTS: &str = "parts";
/// The name of the added seeds' part, in its record and file name.
pub const ADDED: &str = "added";
/// The folder of the figures under `--out`.
pub const FIGURES: &str = "figures";

/// What one part of a grid ran: `parts/{i}-of-{n}.json`, rewritten at the end of each
/// invocation of that part.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Part {
    /// `I/N`.
    pub slice: String,
    /// The commit of the binary that ran it ([`COMMIT`]).
    pub commit: String,
    /// Runs in the part.
    pub runs: usize,
    /// Trained to the end by this invocation.
    pub finished: usize,
    /// Already finished before it.
    pub skipped: usize,
    /// Failed.
    pub failed: usize,
    /// Wall-clock seconds of this invocation.
    pub wall_seconds: f64,
    /// Wall-clock seconds of every invocation of this part so far.
    pub total_wall_seconds: f64,
}

impl Part {
    /// The part's record file.
    pub fn path(out: &Path, slice: Slice) -> std::path::PathBuf {
        out.join(PARTS)
            .join(format!("{}-of-{}.json", slice.index, slice.count))
    }

    /// What this invocation did, as `reproduce` prints it after the part's name: `12 runs, 4
    /// trained, 8 already finished, 0 failed, 3170 s`.
    pub fn tally(&self) -> String {
        format!(
            "{} runs, {} trained, {} already finished, {} failed, {:.0} s",
            self.runs, self.finished, self.skipped, self.failed, self.wall_seconds
        )
    }

    /// The record file of the added seeds' part (`reproduce --added-seeds`).
    pub fn added_path(out: &Path) -> std::path::PathBuf {
        out.join(PARTS).join(format!("{ADDED}.json"))
    }

    /// Writes the record to `path` ([`Part::path`] or [`Part::added_path`]), adding the earlier
    /// invocations' wall time.
    pub fn write(mut self, path: std::path::PathBuf) -> Result<Part, Error> {
        let earlier: Option<Part> = fs::read_to_string(&path)
            .ok()
            .and_then(|t| serde_json::from_str(&t).ok());
        self.total_wall_seconds = self.wall_seconds + earlier.map_or(0.0, |p| p.total_wall_seconds);
        let text = serde_json::to_string_pretty(&self).unwrap_or_default() + "\n";
        files::write_atomic(&path, text.as_bytes()).map_err(|source| Error::Io { path, source })?;
        Ok(self)
    }

    /// Every part's record in `out`, by slice count, then index.
    pub fn all(out: &Path) -> Vec<Part> {
        let paths: Vec<_> = fs::read_dir(out.join(PARTS))
            .into_iter()
            .flatten()
            .flatten()
            .map(|e| e.path())
            .filter(|p| p.extension().is_some_and(|e| e == "json"))
            .collect();
        let mut parts: Vec<Part> = paths
            .iter()
            .filter_map(|p| fs::read_to_string(p).ok())
            .filter_map(|t| serde_json::from_str(&t).ok())
            .collect();
        let key = |p: &Part| {
            p.slice
                .parse::<Slice>()
                .map_or((u64::MAX, u64::MAX), |s| (s.count, s.index))
        };
        parts.sort_by_key(key);
        parts
    }
}

/// The page's file under `--out`, e.g. `exp1.md`.
pub fn page_file(grid: &Grid) -> String {
    format!("{}.md", grid.experiment)
}

/// What building the page found.
#[derive(Debug)]
pub struct Built {
    /// Runs of the grid.
    pub runs: usize,
    /// Runs not finished (and not failed): the page lists them.
    pub missing: usize,
    /// Runs that failed (they count in the tables).
    pub failed: usize,
}

/// Plans a slice of the grid (writes nothing).
pub fn plan(out: &Path, grid: &Grid, slice: Slice) -> Result<Vec<PlannedRun>, Error> {
    match grid.experiment {
        Experiment::Exp1 => folder::plan(out, grid, slice),
        Experiment::Exp2 => teams::plan(out, grid, slice),
    }
}

/// Builds the page and its figures from the run folders of `out` alone.
pub fn build_page(out: &Path, grid: &Grid) -> Result<Built, Error> {
    let (title, runs, failed, body, missing) = match grid.experiment {
        Experiment::Exp1 => {
            let outcomes = folder::outcomes(out, grid)?;
            let names = figures::write_all(&out.join(FIGURES), &outcomes)?;
            let failed = outcomes
                .iter()
                .filter(|(_, o)| matches!(o, folder::Outcome::Failed(_)))
                .count();
            let added = folder::outcomes_of(out, grid, grid.added_runs())?;
            let mut body = page::body(grid, &outcomes);
            body.push_str(&page::added_seeds(grid, &outcomes, &added));
            body.push_str("## Figures\n\n");
            for name in names {
                let _ = writeln!(body, "![{name}]({FIGURES}/{name})\n");
            }
            let title = "Experiment 1 rebuilt: blind navigation among walls";
            (
                title,
                outcomes.len(),
                failed,
                body,
                page::missing(&outcomes),
            )
        }
        Experiment::Exp2 => {
            let (body, missing, failed) = badminton::body(out, grid, &out.join(FIGURES))?;
            let title = "Experiment 2 rebuilt: badminton teams";
            (title, teams::runs(grid).len(), failed, body, missing)
        }
    };
    let mut text = format!(
        "# {title}\n\n\
         Built by `host-trainer reproduce {} --out DIR` (commit {COMMIT}) from the run folders \
         in DIR: {runs} runs, {} finished, {failed} failed, {} missing. The parts that trained \
         them:\n\n",
        grid.describe(),
        runs - missing.len() - failed,
        missing.len(),
    );
    text.push_str("| part | commit | runs | trained | already finished | failed | wall time (all invocations) |\n|---|---|---|---|---|---|---|\n");
    for part in Part::all(out) {
        let _ = writeln!(
            text,
            "| {} | {} | {} | {} | {} | {} | {:.0} s |",
            part.slice,
            part.commit,
            part.runs,
            part.finished,
            part.skipped,
            part.failed,
            part.total_wall_seconds
        );
    }
    text.push('\n');
    text.push_str(&body);
    let _ = writeln!(text, "## Missing runs\n");
    if missing.is_empty() {
        text.push_str("None.\n");
    } else {
        for line in &missing {
            let _ = writeln!(text, "- {line}");
        }
    }
    let path = out.join(page_file(grid));
    files::write_atomic(&path, text.as_bytes()).map_err(|source| Error::Io { path, source })?;
    Ok(Built {
        runs,
        missing: missing.len(),
        failed,
    })
}
