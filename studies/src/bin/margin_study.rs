//! `margin-study`: the margin study's tables and decisions (docs/results/margin-study.md), from
//! its record: every run's row, each arm's count of failed seeds and mean settled error, and
//! what the protocol's rules decide from them.
//!
//! ```sh
//! cargo run --release -p studies --bin margin-study -- record runs/margin/screen \
//!     --into experiments/margin/record/screen.jsonl --binary b296d5d
//! cargo run --release -p studies --bin margin-study -- screen \
//!     experiments/margin/record/screen.jsonl
//! cargo run --release -p studies --bin margin-study -- confirm \
//!     experiments/margin/record/confirm.jsonl --winner NAME
//! ```
//!
//! - `record ROOT --into FILE --binary COMMIT` adds the finished runs of `ROOT` to the record
//!   `FILE` (one JSON object per line, committed with the page), naming the commit of the binary
//!   that made them. `ROOT` holds one folder per arm (`A0`, each candidate; in confirmation also
//!   `ddpg`, `td3`, `ppo`, `dqn`), each the `--out` of that arm's `host-trainer sweep` commands;
//!   a run is finished when its folder holds `eval.json` (firmware-sim's test protocol on the
//!   exported blob). The record, not the run folders, is the study's evidence: run folders live
//!   on one machine and can be lost; the record travels with the repository. A run already in the
//!   record must agree with it (training is deterministic), or nothing is written.
//!
//! A **failed seed** is a run with test success below 0.9 or settled error 0.5 or more.
//!
//! - `screen FILE` (protocol step 1 and 2): each arm's 26 runs are the pinwheel's seeds 0–9 and
//!   seeds 0–1 on each layout of `--layouts` (default `experiments/margin/layouts`). It prints
//!   every run's row, each arm's failed seeds by kind of layout, and the tallies. The winner is
//!   the candidate with the fewest failed seeds, fewer than `A0`'s, with a mean settled error no
//!   worse than `A0`'s; ties go to the lower mean. Before every run is in, it says which
//!   candidates can no longer win whatever the missing runs give, and names the winner once
//!   `A0`'s runs and those of every candidate still able to win are in.
//!
//! The tables give each arm's share of failed seeds with its exact (Clopper–Pearson) 95 %
//! interval, and the means of per-run quantities with their 95 % t intervals clipped to the
//! quantity's range (a rate to [0, 1], settled error to 0 and up), as `host_trainer::stats`
//! prescribes. The rules themselves were fixed before the runs and stay as written.
//! - `confirm FILE` (step 3 and 4): seeds 10–19 on the pinwheel and 10–11 on each layout of
//!   `--layouts` (default `experiments/margin/confirm-layouts`). The winner is adopted only if the
//!   95 % interval of its paired difference from `A0` (Student t over the pairs of task and seed)
//!   lies below 0 on the failed-seed indicator or on settled error; then the goal's checks for
//!   DCP's defaults after the decision (the winner if adopted, `A0` if not). Beside the rows it
//!   prints each arm's mean settled error per task, the evidence for which agent to prefer where.
//!   Beside the rule's t intervals it prints the exact tests of the same pairs: McNemar on the
//!   failed-seed indicator, the sign-flip permutation test on settled error. They decide
//!   nothing; the rule does.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, ensure, Context, Result};
use host_trainer::stats::binomial::{clopper_pearson, mcnemar_exact};
use host_trainer::stats::permutation::sign_flip_permutation;
use host_trainer::stats::student_t::{clipped_text, interval_text, mean_interval};
use host_trainer::stats::student_t::{NON_NEGATIVE, UNIT};
use host_trainer::stats::{CONFIDENCE, REPS, SEED};
use host_trainer::sweep::record::read_eval;
use serde::{Deserialize, Serialize};

/// The reference arm: DCP as adopted.
const REFERENCE: &str = "A0";
/// The baselines of the confirmation, against which the goal is checked.
const BASELINES: [&str; 4] = ["ddpg", "td3", "ppo", "dqn"];
/// The built-in task's folder name, shown as "pinwheel".
const PINWHEEL: &str = "nav-walls";
/// A seed fails below this test success rate...
const MIN_SUCCESS: f64 = 0.9;
/// ... or at this settled error or more.
const MAX_ERROR: f64 = 0.5;

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("margin-study: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<()> {
    let usage = "usage: margin-study record ROOT --into FILE --binary COMMIT\n       margin-study screen|confirm FILE [--layouts DIR] [--winner NAME]";
    let mut args = std::env::args().skip(1);
    let step = args.next().context(usage)?;
    let path = PathBuf::from(args.next().context(usage)?);
    let (mut layouts, mut winner, mut into, mut binary) = (None, None, None, None);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--layouts" => layouts = Some(args.next().context("--layouts needs a folder")?),
            "--winner" => winner = Some(args.next().context("--winner needs an arm")?),
            "--into" => into = Some(PathBuf::from(args.next().context("--into needs a file")?)),
            "--binary" => binary = Some(args.next().context("--binary needs a commit")?),
            _ => bail!("unknown argument {arg}\n{usage}"),
        }
    }
    match step.as_str() {
        "record" => {
            let into = into.context("record needs --into FILE")?;
            let binary = binary.context("record needs --binary COMMIT (the binary's commit)")?;
            let (added, known) = record(&path, &into, &binary)?;
            println!(
                "{}: {added} runs added, {known} already in the record",
                into.display()
            );
        }
        "screen" => {
            let arms = read_record(&path)?;
            let dir = layouts.unwrap_or_else(|| "experiments/margin/layouts".into());
            let plan = Plan::new(&dir, 0..10, 0..2)?;
            print!("{}", rows_table(&arms, &plan));
            print!("{}", kinds_table(&arms, &plan));
            print!("{}", screen_verdict(&arms, &plan));
        }
        "confirm" => {
            let arms = read_record(&path)?;
            let winner = winner.context("confirm needs --winner NAME")?;
            let dir = layouts.unwrap_or_else(|| "experiments/margin/confirm-layouts".into());
            let plan = Plan::new(&dir, 10..20, 10..12)?;
            print!("{}", rows_table(&arms, &plan));
            print!("{}", kinds_table(&arms, &plan));
            print!("{}", layouts_table(&arms, &plan));
            print!("{}", confirm_verdict(&arms, &plan, &winner));
        }
        _ => bail!("unknown step {step}\n{usage}"),
    }
    Ok(())
}

/// One finished run's test result.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Outcome {
    success: f64,
    error: f64,
    stuck: f64,
    near_pass: f64,
    /// Decided by [`fails`] on the run's own values when it was recorded: a row copied at the
    /// page's rounding (settled error 0.500 of a run below 0.5) keeps the decision made before
    /// the rounding.
    failed: bool,
}

/// The protocol's rule for a failed seed.
fn fails(success: f64, error: f64) -> bool {
    success < MIN_SUCCESS || error >= MAX_ERROR
}

impl Outcome {
    fn new(success: f64, error: f64, stuck: f64, near_pass: f64) -> Self {
        Self {
            success,
            error,
            stuck,
            near_pass,
            failed: fails(success, error),
        }
    }

    fn failed(&self) -> bool {
        self.failed
    }

    /// Whether two records of one run agree, up to the page's rounding (3 decimals of settled
    /// error, 2 of success, whole percent of the rates).
    fn agrees(&self, other: &Self) -> bool {
        (self.success - other.success).abs() <= 0.005 + 1e-9
            && (self.error - other.error).abs() <= 0.0005 + 1e-9
            && (self.stuck - other.stuck).abs() <= 0.005 + 1e-9
            && (self.near_pass - other.near_pass).abs() <= 0.005 + 1e-9
            && self.failed == other.failed
    }
}

/// One line of the record: a finished run, where its values come from and the binary that made
/// it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct Row {
    arm: String,
    task: String,
    seed: u64,
    success: f64,
    settled_error: f64,
    stuck: f64,
    near_pass: f64,
    failed: bool,
    binary: String,
    source: String,
}

impl Row {
    fn outcome(&self) -> Outcome {
        Outcome {
            success: self.success,
            error: self.settled_error,
            stuck: self.stuck,
            near_pass: self.near_pass,
            failed: self.failed,
        }
    }
}

/// A run's place in the grid: its task (the pinwheel or a layout's name) and seed.
type Cell = (String, u64);

/// Every arm's finished runs, by cell.
type Arms = BTreeMap<String, BTreeMap<Cell, Outcome>>;

/// The runs every arm makes: the pinwheel's seeds, then each layout's.
struct Plan {
    cells: Vec<Cell>,
}

impl Plan {
    fn new(
        layouts: &str,
        pinwheel: std::ops::Range<u64>,
        per_layout: std::ops::Range<u64>,
    ) -> Result<Self> {
        let mut names = Vec::new();
        let entries = std::fs::read_dir(layouts).with_context(|| format!("layouts {layouts}"))?;
        for entry in entries {
            let path = entry?.path();
            if path.extension().is_some_and(|e| e == "toml") {
                let text =
                    std::fs::read_to_string(&path).with_context(|| path.display().to_string())?;
                let table: toml::Table =
                    toml::from_str(&text).with_context(|| path.display().to_string())?;
                let name = table.get("name").and_then(|v| v.as_str());
                names.push(
                    name.with_context(|| format!("{}: no name", path.display()))?
                        .to_string(),
                );
            }
        }
        if names.is_empty() {
            bail!("no layout (*.toml) in {layouts}");
        }
        names.sort();
        Ok(Self::from_names(&names, pinwheel, per_layout))
    }

    fn from_names(
        layouts: &[String],
        pinwheel: std::ops::Range<u64>,
        per_layout: std::ops::Range<u64>,
    ) -> Self {
        let mut cells: Vec<Cell> = pinwheel.map(|s| (PINWHEEL.to_string(), s)).collect();
        for name in layouts {
            cells.extend(per_layout.clone().map(|s| (name.clone(), s)));
        }
        Self { cells }
    }

    /// The runs of the plan an arm has finished, in plan order.
    fn finished<'a>(&self, runs: &'a BTreeMap<Cell, Outcome>) -> Vec<&'a Outcome> {
        self.cells.iter().filter_map(|c| runs.get(c)).collect()
    }

    /// Whether an arm has finished every run of the plan.
    fn complete(&self, runs: &BTreeMap<Cell, Outcome>) -> bool {
        self.cells.iter().all(|c| runs.contains_key(c))
    }

    /// The plan's tasks, each once, in plan order.
    fn tasks(&self) -> Vec<&str> {
        let mut tasks: Vec<&str> = Vec::new();
        for cell in &self.cells {
            if !tasks.contains(&cell.0.as_str()) {
                tasks.push(&cell.0);
            }
        }
        tasks
    }

    /// The part of the plan whose tasks pass `keep`.
    fn only(&self, keep: impl Fn(&str) -> bool) -> Plan {
        let cells = self.cells.iter().filter(|c| keep(&c.0)).cloned().collect();
        Plan { cells }
    }
}

/// Reads `ROOT/ARM/TASK__ALGO__SEED/eval.json` for every arm.
fn read_folders(root: &Path) -> Result<Arms> {
    let mut arms = Arms::new();
    let entries = std::fs::read_dir(root).with_context(|| root.display().to_string())?;
    for arm in entries {
        let arm = arm?.path();
        if !arm.is_dir() {
            continue;
        }
        let name = arm
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .to_string();
        let mut runs = BTreeMap::new();
        for run in std::fs::read_dir(&arm)? {
            let run = run?.path();
            let eval = run.join("eval.json");
            let folder = run
                .file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .to_string();
            let mut parts = folder.rsplitn(3, "__");
            let (Some(seed), Some(_algo), Some(task)) = (parts.next(), parts.next(), parts.next())
            else {
                continue; // sweep-logs and the like
            };
            let Ok(seed) = seed.parse::<u64>() else {
                continue;
            };
            if !eval.is_file() {
                continue; // not finished
            }
            let e = read_eval(&run)?;
            // The study's runs are navigation's: their reports have the navigation columns.
            let (Some(error), Some(near)) = (e.mean_error, e.near_pass_rate) else {
                bail!("{}: not a navigation run's report", run.display());
            };
            let outcome = Outcome::new(e.success_rate, error, e.stuck_rate, near);
            if runs.insert((task.to_string(), seed), outcome).is_some() {
                bail!("{}: two runs of {task}, seed {seed}", arm.display());
            }
        }
        arms.insert(name, runs);
    }
    Ok(arms)
}

/// The record's rows, one JSON object per line; an empty or missing file holds none.
fn read_rows(file: &Path) -> Result<Vec<Row>> {
    let text = match std::fs::read_to_string(file) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(e).with_context(|| file.display().to_string()),
    };
    let mut rows = Vec::new();
    for (n, line) in text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
    {
        let row: Row = serde_json::from_str(line)
            .with_context(|| format!("{} line {}", file.display(), n + 1))?;
        // A row's decision may differ from the rule on its values only where rounding could
        // have moved a value across a threshold.
        let near = (row.settled_error - MAX_ERROR).abs() <= 0.0005 + 1e-9
            || (row.success - MIN_SUCCESS).abs() <= 0.005 + 1e-9;
        ensure!(
            row.failed == fails(row.success, row.settled_error) || near,
            "{} line {}: failed = {} contradicts success {} and settled error {}",
            file.display(),
            n + 1,
            row.failed,
            row.success,
            row.settled_error
        );
        rows.push(row);
    }
    Ok(rows)
}

/// The rows grouped by arm and cell; a run may have one row only.
fn by_arm(rows: &[Row], file: &Path) -> Result<Arms> {
    let mut arms = Arms::new();
    for row in rows {
        let runs = arms.entry(row.arm.clone()).or_default();
        let cell = (row.task.clone(), row.seed);
        ensure!(
            runs.insert(cell, row.outcome()).is_none(),
            "{}: two rows of {} on {}, seed {}",
            file.display(),
            row.arm,
            row.task,
            row.seed
        );
    }
    Ok(arms)
}

/// Every arm's runs in the record; it must hold `A0`'s arm.
fn read_record(file: &Path) -> Result<Arms> {
    let arms = by_arm(&read_rows(file)?, file)?;
    ensure!(
        arms.contains_key(REFERENCE),
        "{}: no run of {REFERENCE} (DCP as adopted)",
        file.display()
    );
    Ok(arms)
}

/// Adds the finished runs of the folders under `root` to the record `into`; returns how many were
/// added and how many were in it already. Writes a new file beside it and renames it over the old
/// one, so a record is never half written.
fn record(root: &Path, into: &Path, binary: &str) -> Result<(usize, usize)> {
    let mut rows = read_rows(into)?;
    let in_record = by_arm(&rows, into)?;
    let (mut added, mut known) = (0, 0);
    for (arm, runs) in read_folders(root)? {
        for (cell, outcome) in runs {
            match in_record.get(&arm).and_then(|runs| runs.get(&cell)) {
                Some(old) => {
                    ensure!(
                        old.agrees(&outcome),
                        "{arm} on {}, seed {}: the run folder ({outcome:?}) disagrees with the record ({old:?}); nothing written",
                        cell.0,
                        cell.1
                    );
                    known += 1;
                }
                None => {
                    rows.push(Row {
                        arm: arm.clone(),
                        task: cell.0,
                        seed: cell.1,
                        success: outcome.success,
                        settled_error: outcome.error,
                        stuck: outcome.stuck,
                        near_pass: outcome.near_pass,
                        failed: outcome.failed,
                        binary: binary.to_string(),
                        source: "eval.json".to_string(),
                    });
                    added += 1;
                }
            }
        }
    }
    rows.sort_by(|a, b| (&a.arm, &a.task, a.seed).cmp(&(&b.arm, &b.task, b.seed)));
    let mut text = String::new();
    for row in &rows {
        text += &serde_json::to_string(row)?;
        text.push('\n');
    }
    let name = into.file_name().context("--into names no file")?;
    let tmp = into.with_file_name(format!(".{}.tmp", name.to_string_lossy()));
    std::fs::write(&tmp, text).with_context(|| tmp.display().to_string())?;
    std::fs::rename(&tmp, into).with_context(|| into.display().to_string())?;
    Ok((added, known))
}

fn task_label(task: &str) -> &str {
    if task == PINWHEEL {
        "pinwheel"
    } else {
        task
    }
}

/// The kind of a task: the pinwheel, or a generated layout's kind (`rings-3-seed11`: `rings`).
fn task_kind(task: &str) -> &str {
    if task == PINWHEEL {
        "pinwheel"
    } else {
        task.split('-').next().unwrap_or(task)
    }
}

/// Each arm's failed seeds among its finished runs by kind of layout, the kinds in plan order:
/// where an arm fails, which the tallies' totals do not say. A reading aid, not a rule.
fn kinds_table(arms: &Arms, plan: &Plan) -> String {
    let mut kinds: Vec<&str> = Vec::new();
    for kind in plan.tasks().into_iter().map(task_kind) {
        if !kinds.contains(&kind) {
            kinds.push(kind);
        }
    }
    let mut out = format!(
        "\nFailed seeds of the finished runs, by kind of layout:\n\n| arm | {} |\n|---|{}\n",
        kinds.join(" | "),
        "---:|".repeat(kinds.len())
    );
    let of_kind: Vec<Plan> = kinds
        .iter()
        .map(|kind| plan.only(|task| task_kind(task) == *kind))
        .collect();
    for (arm, runs) in arms {
        out += &format!("| {arm} |");
        for part in &of_kind {
            let t = tally(runs, part);
            out += &format!(" {} of {} |", t.failed, t.finished);
        }
        out += "\n";
    }
    out
}

/// Each arm's mean settled error on each task of the plan, with its failed seeds, and the arm of
/// the lowest mean: which agent to prefer on which layout. A reading aid, not a rule.
fn layouts_table(arms: &Arms, plan: &Plan) -> String {
    let names: Vec<&str> = arms.keys().map(String::as_str).collect();
    let mut out = format!(
        "\nMean settled error of the finished runs on each task (failed seeds / finished runs),\n\
         and the arm of the lowest mean once every arm has finished every run there:\n\n\
         | task | {} | lowest |\n|---|{}---|\n",
        names.join(" | "),
        "---:|".repeat(names.len())
    );
    for task in plan.tasks() {
        let part = plan.only(|t| t == task);
        out += &format!("| {} |", task_label(task));
        // A comparison needs every arm's runs: until then the last column stays empty.
        let mut lowest: Option<(&str, f64)> = None;
        let mut complete = true;
        for (arm, runs) in arms {
            let t = tally(runs, &part);
            complete &= part.complete(runs);
            match mean_interval(&t.errors) {
                Some(m) => {
                    out += &format!(" {:.3} ({}/{}) |", m.mean, t.failed, t.finished);
                    if lowest.is_none_or(|(_, e)| m.mean < e) {
                        lowest = Some((arm, m.mean));
                    }
                }
                None => out += " – |",
            }
        }
        let lowest = lowest.filter(|_| complete).map_or("–", |(arm, _)| arm);
        out += &format!(" {lowest} |\n");
    }
    out
}

/// Every finished run of the plan, one row each, cell by cell and arm by arm.
fn rows_table(arms: &Arms, plan: &Plan) -> String {
    let mut out = String::from(
        "| arm | layout | seed | success | settled error | stuck at margin | pass within 0.25 | failed seed |\n\
         |---|---|---:|---:|---:|---:|---:|---|\n",
    );
    for cell in &plan.cells {
        for (arm, runs) in arms {
            if let Some(o) = runs.get(cell) {
                out += &format!(
                    "| {arm} | {} | {} | {:.2} | {:.3} | {:.0} % | {:.0} % | {} |\n",
                    task_label(&cell.0),
                    cell.1,
                    o.success,
                    o.error,
                    100.0 * o.stuck,
                    100.0 * o.near_pass,
                    if o.failed() { "yes" } else { "no" }
                );
            }
        }
    }
    out
}

/// One arm's runs of the plan.
struct Tally {
    finished: usize,
    failed: usize,
    errors: Vec<f64>,
}

fn tally(runs: &BTreeMap<Cell, Outcome>, plan: &Plan) -> Tally {
    let done = plan.finished(runs);
    Tally {
        finished: done.len(),
        failed: done.iter().filter(|o| o.failed()).count(),
        errors: done.iter().map(|o| o.error).collect(),
    }
}

/// Step 2: each arm's tally, and the winner (or who can no longer win) by the rule.
fn screen_verdict(arms: &Arms, plan: &Plan) -> String {
    let want = plan.cells.len();
    let mut out = String::from(
        "\n| arm | runs | failed seeds (share, 95 % exact) | settled error (mean, 95 % t) |\n|---|---:|---:|---:|\n",
    );
    let tallies: BTreeMap<&str, Tally> = arms
        .iter()
        .map(|(a, r)| (a.as_str(), tally(r, plan)))
        .collect();
    for (arm, t) in &tallies {
        out += &format!(
            "| {arm} | {} of {want} | {} | {} |\n",
            t.finished,
            failed_text(t.failed, t.finished),
            clipped_text(&t.errors, 3, NON_NEGATIVE)
        );
    }
    out += "\n";
    let reference = &tallies[REFERENCE];
    // The most failed seeds A0 can end with: its failures so far and every missing run.
    let reference_most = reference.failed + (want - reference.finished);
    let candidates: Vec<(&str, &Tally)> = tallies
        .iter()
        .filter(|(a, _)| **a != REFERENCE)
        .map(|(a, t)| (*a, t))
        .collect();
    let mut out_of_it = Vec::new();
    for (arm, t) in &candidates {
        if t.failed >= reference_most {
            out += &format!(
                "{arm} cannot win: {} failed seeds, and {REFERENCE} ends with at most {reference_most}.\n",
                t.failed
            );
            out_of_it.push(*arm);
        }
    }
    // A candidate that cannot win changes nothing by its missing runs: the winner is named once
    // A0's runs and those of every candidate still able to win are in.
    if tallies
        .iter()
        .any(|(a, t)| t.finished < want && !out_of_it.contains(a))
    {
        out += "Incomplete: no winner is named before A0's runs and those of every candidate that can still win are in.\n";
        return out;
    }
    let mean = |t: &Tally| mean_interval(&t.errors).map_or(f64::INFINITY, |m| m.mean);
    let mut eligible: Vec<&(&str, &Tally)> = candidates
        .iter()
        .filter(|(_, t)| t.failed < reference.failed && mean(t) <= mean(reference))
        .collect();
    eligible.sort_by(|a, b| {
        (a.1.failed, mean(a.1))
            .partial_cmp(&(b.1.failed, mean(b.1)))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    match eligible.first() {
        Some((arm, t)) => {
            out += &format!(
                "Winner: {arm} ({} failed seeds against {REFERENCE}'s {}; mean settled error {:.3} against {:.3}).\n",
                t.failed,
                reference.failed,
                mean(t),
                mean(reference)
            )
        }
        None => {
            out += &format!(
                "No winner: no candidate has fewer failed seeds than {REFERENCE} ({}) with a mean settled error no worse ({:.3}).\n",
                reference.failed,
                mean(reference)
            )
        }
    }
    out
}

/// `k (share [lo, hi])`: `k` failed seeds of `n` finished runs with the exact 95 % interval of
/// the share; `0` alone for no finished run.
fn failed_text(k: usize, n: usize) -> String {
    if n == 0 {
        return k.to_string();
    }
    let (lo, hi) = clopper_pearson(k as u64, n as u64, CONFIDENCE);
    format!("{k} ({:.2} [{lo:.2}, {hi:.2}])", k as f64 / n as f64)
}

/// The exact tests of the pairs the rule reads, beside it: McNemar's on the failed-seed
/// indicator (the pairs where one arm alone failed), the sign-flip permutation test on the
/// settled errors' differences `error`.
fn exact_tests(arms: &Arms, plan: &Plan, winner: &str, error: &[f64]) -> String {
    let (a, r) = (&arms[winner], &arms[REFERENCE]);
    let (mut only_winner, mut only_reference) = (0u64, 0u64);
    for c in &plan.cells {
        if let (Some(w), Some(o)) = (a.get(c), r.get(c)) {
            only_winner += u64::from(w.failed() && !o.failed());
            only_reference += u64::from(o.failed() && !w.failed());
        }
    }
    format!(
        "Exact tests of the same pairs (beside the rule, deciding nothing): failed seed, McNemar p = {:.4} ({only_winner} pairs only {winner} failed, {only_reference} only {REFERENCE}); settled error, sign-flip permutation {}.\n",
        mcnemar_exact(only_winner, only_reference),
        sign_flip_permutation(error, REPS as u64, SEED)
    )
}

/// The paired differences `arm − reference` over the cells both finished.
fn paired(arms: &Arms, plan: &Plan, arm: &str, value: fn(&Outcome) -> f64) -> Vec<f64> {
    let (a, r) = (&arms[arm], &arms[REFERENCE]);
    plan.cells
        .iter()
        .filter_map(|c| Some(value(a.get(c)?) - value(r.get(c)?)))
        .collect()
}

/// Steps 3 and 4: each agent's means, the winner's paired differences from A0 and the goal.
fn confirm_verdict(arms: &Arms, plan: &Plan, winner: &str) -> String {
    let want = plan.cells.len();
    let mut out = String::from(
        "\n| agent | runs | failed seeds (share, 95 % exact) | success | settled error | stuck at margin |\n|---|---:|---:|---:|---:|---:|\n",
    );
    for (arm, runs) in arms {
        let done = plan.finished(runs);
        let of = |f: fn(&Outcome) -> f64| done.iter().map(|o| f(o)).collect::<Vec<_>>();
        out += &format!(
            "| {arm} | {} of {want} | {} | {} | {} | {} |\n",
            done.len(),
            failed_text(done.iter().filter(|o| o.failed()).count(), done.len()),
            clipped_text(&of(|o| o.success), 3, UNIT),
            clipped_text(&of(|o| o.error), 3, NON_NEGATIVE),
            clipped_text(&of(|o| o.stuck), 3, UNIT),
        );
    }
    // The confirmation runs the winner after A0's first runs: until its first run is in, the
    // table shows the others' progress, and the name is checked against the screening's.
    if !arms.contains_key(winner) {
        out += &format!(
            "\nIncomplete: no run of {winner} in the record yet (the winner is the name `screen` gives).\n"
        );
        return out;
    }
    if !arms.contains_key(REFERENCE) {
        out += &format!("\nIncomplete: no run of {REFERENCE} in the record yet.\n");
        return out;
    }
    let failed = paired(arms, plan, winner, |o| f64::from(u8::from(o.failed())));
    let error = paired(arms, plan, winner, |o| o.error);
    out += &format!(
        "\nPaired {winner} − {REFERENCE} over {} pairs: failed seed {}, settled error {}.\n",
        failed.len(),
        interval_text(&failed, 3),
        interval_text(&error, 3)
    );
    out += &exact_tests(arms, plan, winner, &error);
    if failed.len() < want || tally(&arms[winner], plan).finished < want {
        out += "Incomplete: adoption is decided over all the pairs.\n";
        return out;
    }
    let below_zero = |d: &[f64]| {
        mean_interval(d)
            .and_then(|m| m.half_width.map(|h| m.mean + h < 0.0))
            .unwrap_or(false)
    };
    let adopted = below_zero(&failed) || below_zero(&error);
    out += &if adopted {
        format!("Adopted: {winner}'s paired interval lies below 0.\n")
    } else {
        "Not adopted: neither paired interval lies below 0; DCP's defaults stay.\n".to_string()
    };
    // The goal is about DCP's defaults after the decision: every pinwheel seed passes; no worse
    // than the best baseline on each layout; stuck less often than DDPG.
    let default = if adopted { winner } else { REFERENCE };
    out += &format!("The goal, for DCP's defaults after the decision ({default}):\n");
    let runs = &arms[default];
    let pinwheel_fails: Vec<u64> = plan
        .cells
        .iter()
        .filter(|c| c.0 == PINWHEEL && runs[*c].failed())
        .map(|c| c.1)
        .collect();
    out += &format!(
        "Goal, pinwheel: {}.\n",
        if pinwheel_fails.is_empty() {
            "every seed reaches success ≥ 0.9 and settled error < 0.5".to_string()
        } else {
            format!("seeds {pinwheel_fails:?} fail")
        }
    );
    // A comparison with the baselines waits for all their runs of the part it reads.
    let finished = |arm: &str, part: &Plan| arms.get(arm).is_some_and(|r| part.complete(r));
    let mean_of = |arm: &str, part: &Plan, value: fn(&Outcome) -> f64| {
        let v: Vec<f64> = part.finished(&arms[arm]).into_iter().map(value).collect();
        mean_interval(&v).map_or(f64::NAN, |m| m.mean)
    };
    for layout in plan.tasks().into_iter().filter(|t| *t != PINWHEEL) {
        let part = plan.only(|t| t == layout);
        if !BASELINES.iter().all(|b| finished(b, &part)) {
            out += &format!("Goal, {layout}: not every baseline run is in.\n");
            continue;
        }
        let own = mean_of(default, &part, |o| o.error);
        let (best, theirs) = BASELINES
            .iter()
            .map(|b| (*b, mean_of(b, &part, |o| o.error)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("four baselines");
        out += &format!(
            "Goal, {layout}: settled error {own:.3} against the best baseline's ({best}) {theirs:.3}: {}.\n",
            if own <= theirs { "no worse" } else { "worse" }
        );
    }
    out += &if finished("ddpg", plan) {
        let (own, theirs) = (
            mean_of(default, plan, |o| o.stuck),
            mean_of("ddpg", plan, |o| o.stuck),
        );
        format!(
            "Goal, stuck at the margin: {own:.3} against DDPG's {theirs:.3}: {}.\n",
            if own < theirs { "below" } else { "not below" }
        )
    } else {
        "Goal, stuck at the margin: not every DDPG run is in.\n".to_string()
    };
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn outcome(error: f64) -> Outcome {
        Outcome::new(1.0, error, 0.0, 1.0)
    }

    /// Two cells; each arm's settled errors in plan order (`None`: not finished).
    fn arms(plan: &Plan, errors: &[(&str, &[Option<f64>])]) -> Arms {
        errors
            .iter()
            .map(|(arm, e)| {
                let runs = plan
                    .cells
                    .iter()
                    .zip(e.iter())
                    .filter_map(|(c, e)| Some((c.clone(), outcome((*e)?))))
                    .collect();
                (arm.to_string(), runs)
            })
            .collect()
    }

    fn plan() -> Plan {
        Plan::from_names(&["maze-1".to_string()], 0..2, 0..2)
    }

    #[test]
    fn failed_seeds_are_counted_by_kind_of_layout() {
        let names = ["maze-1-seed11".to_string(), "rings-1-seed11".to_string()];
        let plan = Plan::from_names(&names, 0..2, 0..2);
        let a = arms(
            &plan,
            &[(
                "A0",
                &[Some(0.6), Some(0.1), Some(0.7), Some(0.8), Some(0.1), None],
            )],
        );
        let t = kinds_table(&a, &plan);
        assert!(t.contains("| arm | pinwheel | maze | rings |"), "{t}");
        assert!(t.contains("| A0 | 1 of 2 | 2 of 2 | 0 of 1 |"), "{t}");
    }

    #[test]
    fn the_lowest_mean_per_task_waits_for_every_arm() {
        let plan = plan();
        let a = arms(
            &plan,
            &[
                ("A0", &[Some(0.9), Some(0.1), Some(0.7), Some(0.3)]),
                ("dqn", &[Some(0.2), Some(0.2), Some(0.2), None]),
            ],
        );
        let t = layouts_table(&a, &plan);
        assert!(t.contains("| task | A0 | dqn | lowest |"), "{t}");
        assert!(
            t.contains("| pinwheel | 0.500 (1/2) | 0.200 (0/2) | dqn |"),
            "{t}"
        );
        assert!(
            t.contains("| maze-1 | 0.500 (1/2) | 0.200 (0/1) | – |"),
            "{t}"
        );
    }

    #[test]
    fn a_seed_fails_on_success_or_error() {
        assert!(outcome(0.5).failed());
        assert!(!outcome(0.499).failed());
        assert!(Outcome::new(0.89, 0.1, 0.0, 1.0).failed());
    }

    #[test]
    fn the_winner_has_fewest_failed_seeds_then_lowest_mean() {
        let plan = plan();
        let a = arms(
            &plan,
            &[
                ("A0", &[Some(0.9), Some(0.9), Some(0.1), Some(0.1)]),
                ("x", &[Some(0.6), Some(0.1), Some(0.1), Some(0.1)]),
                ("y", &[Some(0.7), Some(0.05), Some(0.05), Some(0.05)]),
                ("z", &[Some(0.7), Some(0.7), Some(0.0), Some(0.0)]),
            ],
        );
        let v = screen_verdict(&a, &plan);
        assert!(v.contains("Winner: y"), "{v}");
        assert!(v.contains("z cannot win"), "{v}");
    }

    #[test]
    fn no_winner_without_fewer_failures_or_with_a_worse_mean() {
        let plan = plan();
        let a = arms(
            &plan,
            &[
                ("A0", &[Some(0.6), Some(0.1), Some(0.1), Some(0.1)]),
                ("x", &[Some(0.6), Some(0.0), Some(0.0), Some(0.0)]),
                ("y", &[Some(0.45), Some(0.45), Some(0.45), Some(0.45)]),
            ],
        );
        let v = screen_verdict(&a, &plan);
        assert!(v.contains("No winner"), "{v}");
    }

    #[test]
    fn an_incomplete_screening_names_only_who_cannot_win() {
        let plan = plan();
        let a = arms(
            &plan,
            &[
                ("A0", &[Some(0.6), None, None, None]),
                ("x", &[Some(0.6), Some(0.6), Some(0.6), Some(0.6)]),
                ("y", &[Some(0.6), Some(0.6), Some(0.6), None]),
            ],
        );
        let v = screen_verdict(&a, &plan);
        assert!(
            v.contains("x cannot win: 4 failed seeds, and A0 ends with at most 4"),
            "{v}"
        );
        assert!(!v.contains("y cannot win"), "{v}");
        assert!(v.contains("Incomplete") && !v.contains("Winner"), "{v}");
    }

    #[test]
    fn the_missing_runs_of_a_candidate_that_cannot_win_do_not_hold_the_winner_back() {
        let plan = plan();
        let a = arms(
            &plan,
            &[
                ("A0", &[Some(0.6), Some(0.6), Some(0.1), Some(0.1)]),
                ("x", &[Some(0.6), Some(0.6), None, None]),
                ("y", &[Some(0.6), Some(0.1), Some(0.1), Some(0.1)]),
            ],
        );
        let v = screen_verdict(&a, &plan);
        assert!(v.contains("x cannot win") && v.contains("Winner: y"), "{v}");
        let b = arms(
            &plan,
            &[
                ("A0", &[Some(0.6), Some(0.6), Some(0.1), None]),
                ("x", &[Some(0.6), Some(0.6), Some(0.6), None]),
                ("y", &[Some(0.6), Some(0.1), Some(0.1), Some(0.1)]),
            ],
        );
        let v = screen_verdict(&b, &plan);
        assert!(
            v.contains("x cannot win") && v.contains("Incomplete"),
            "{v}"
        );
    }

    #[test]
    fn adoption_needs_a_paired_interval_below_zero() {
        let plan = plan();
        let a = arms(
            &plan,
            &[
                ("A0", &[Some(0.9), Some(0.8), Some(0.7), Some(0.9)]),
                ("w", &[Some(0.1), Some(0.2), Some(0.1), Some(0.15)]),
                ("ddpg", &[Some(1.0), Some(1.0), Some(1.0), Some(1.0)]),
                ("td3", &[Some(1.0), Some(1.0), Some(0.2), Some(0.2)]),
                ("ppo", &[Some(1.0), Some(1.0), Some(0.5), Some(0.5)]),
                ("dqn", &[Some(1.0), Some(1.0), Some(0.1), None]),
            ],
        );
        let v = confirm_verdict(&a, &plan, "w");
        assert!(v.contains("Adopted: w"), "{v}");
        // DQN has not finished maze-1: no comparison yet, whatever the others give.
        assert!(
            v.contains("Goal, maze-1: not every baseline run is in"),
            "{v}"
        );
        assert!(
            v.contains("Goal, stuck at the margin: 0.000 against DDPG's 0.000: not below"),
            "{v}"
        );
        let mut a = a;
        a.get_mut("dqn")
            .expect("dqn")
            .insert(plan.cells[3].clone(), outcome(0.2));
        let v = confirm_verdict(&a, &plan, "w");
        assert!(
            v.contains("Goal, maze-1: settled error 0.125 against the best baseline's (dqn) 0.150: no worse"),
            "{v}"
        );
        let b = arms(
            &plan,
            &[
                ("A0", &[Some(0.9), Some(0.1), Some(0.7), Some(0.1)]),
                ("w", &[Some(0.1), Some(0.9), Some(0.1), Some(0.6)]),
                ("ddpg", &[Some(1.0), Some(1.0), Some(1.0), Some(1.0)]),
                ("td3", &[Some(1.0), Some(1.0), Some(1.0), Some(1.0)]),
                ("ppo", &[Some(1.0), Some(1.0), Some(1.0), Some(1.0)]),
                ("dqn", &[Some(1.0), Some(1.0), Some(1.0), Some(1.0)]),
            ],
        );
        let v = confirm_verdict(&b, &plan, "w");
        assert!(v.contains("Not adopted"), "{v}");
        // Not adopted: the goal judges the defaults that stay.
        assert!(v.contains("after the decision (A0)"), "{v}");
        assert!(v.contains("Goal, pinwheel: seeds [0] fail"), "{v}");
        assert!(
            v.contains("Goal, maze-1: settled error 0.400 against the best baseline's (ddpg) 1.000: no worse"),
            "{v}"
        );
        let c = arms(
            &plan,
            &[
                ("A0", &[Some(0.9); 4]),
                ("w", &[Some(0.1), None, None, None]),
            ],
        );
        let v = confirm_verdict(&c, &plan, "w");
        assert!(v.contains("Incomplete"), "{v}");
        let d = arms(&plan, &[("A0", &[Some(0.9), Some(0.1), None, None])]);
        let v = confirm_verdict(&d, &plan, "w");
        assert!(v.contains("| A0 | 2 of 4 |"), "{v}");
        assert!(v.contains("Incomplete: no run of w"), "{v}");
        // A record of the winner alone is incomplete too, not a panic.
        let e = arms(&plan, &[("w", &[Some(0.1), None, None, None])]);
        let v = confirm_verdict(&e, &plan, "w");
        assert!(v.contains("Incomplete: no run of A0"), "{v}");
    }

    /// A scratch folder of its own per test, in the system's temporary folder.
    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("margin-study-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("scratch folder");
        dir
    }

    fn write_run(root: &Path, arm: &str, task: &str, seed: u64, error: f64) {
        let run = root.join(arm).join(format!("{task}__dcp__{seed}"));
        std::fs::create_dir_all(&run).expect("run folder");
        let eval = format!(
            r#"{{"success_rate": 1.0, "mean_error": {error}, "stuck_rate": 0.0, "near_pass_rate": 1.0, "strict_reach_rate": 1.0}}"#
        );
        std::fs::write(run.join("eval.json"), eval).expect("eval.json");
    }

    #[test]
    fn the_record_keeps_every_run_once_and_refuses_a_disagreeing_one() {
        let dir = scratch("record");
        let (root, file) = (dir.join("runs"), dir.join("screen.jsonl"));
        write_run(&root, "A0", PINWHEEL, 0, 0.9);
        write_run(&root, "x", "maze-1", 1, 0.1);
        std::fs::create_dir_all(root.join("x/sweep-logs")).expect("logs");
        assert_eq!(record(&root, &file, "abc1234").expect("first"), (2, 0));
        assert_eq!(record(&root, &file, "abc1234").expect("again"), (0, 2));
        let arms = read_record(&file).expect("record");
        assert!(arms["A0"][&(PINWHEEL.to_string(), 0)].failed());
        assert!(!arms["x"][&("maze-1".to_string(), 1)].failed());

        // A rerun that trains other bytes is an error, and the record stays as it was.
        let before = std::fs::read(&file).expect("record bytes");
        write_run(&root, "x", "maze-1", 1, 0.7);
        let e = record(&root, &file, "abc1234").expect_err("disagrees");
        assert!(e.to_string().contains("disagrees with the record"), "{e}");
        assert_eq!(std::fs::read(&file).expect("record bytes"), before);
        std::fs::remove_dir_all(&dir).expect("clean up");
    }

    #[test]
    fn a_record_row_whose_decision_contradicts_its_values_is_refused() {
        let dir = scratch("contradiction");
        let file = dir.join("screen.jsonl");
        let row = |error: f64, failed: bool| Row {
            arm: REFERENCE.to_string(),
            task: PINWHEEL.to_string(),
            seed: 0,
            success: 1.0,
            settled_error: error,
            stuck: 0.0,
            near_pass: 1.0,
            failed,
            binary: "abc1234".to_string(),
            source: "results page".to_string(),
        };
        // 0.500 at the page's rounding may be a run below 0.5: its decision stands.
        let rounded = serde_json::to_string(&row(0.5, false)).expect("json");
        std::fs::write(&file, format!("{rounded}\n")).expect("write");
        assert!(
            !read_record(&file).expect("rounded")[REFERENCE][&(PINWHEEL.to_string(), 0)].failed()
        );
        let wrong = serde_json::to_string(&row(0.9, false)).expect("json");
        std::fs::write(&file, format!("{wrong}\n")).expect("write");
        let e = read_record(&file).expect_err("contradiction");
        assert!(
            e.to_string().contains("line 1: failed = false contradicts"),
            "{e}"
        );
        std::fs::write(&file, format!("{rounded}\n{rounded}\n")).expect("write");
        let e = read_record(&file).expect_err("twice");
        assert!(e.to_string().contains("two rows of A0"), "{e}");
        std::fs::write(&file, format!("{rounded}\n{{\"arm\": \"A0\"\n")).expect("write");
        let e = read_record(&file).expect_err("malformed");
        assert!(format!("{e:#}").contains("screen.jsonl line 2"), "{e:#}");
        std::fs::remove_dir_all(&dir).expect("clean up");
    }
}
