//! The standard-tasks page (`docs/results/standard-tasks.md`): the grid's runs, as
//! `python3 -m margin_safe_rl.standard_tasks run` recorded them, turned into the page's tables,
//! verdicts and learning curves by the protocol fixed on the page before the runs.
//!
//! Reads `OUT/{task}/{agent}/seed{N}/result.json` (and each run's `train.jsonl` for the curves),
//! plus, where present, each task's `OUT/{task}/chip.json` (the cost of its DCP blob on the Cortex-M4F) and
//! `OUT/speed.json` (the per-step speed measurement). Every cell of the protocol appears: a cell
//! with runs missing says how many.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use anyhow::{Context, Result};
use firmware_sim::nav::reward::Reward;
use firmware_sim::nav::scenario::Scenario;
use host_trainer::run::plot::{svg, Panel, Series};
use host_trainer::stats::aggregate::{iqm_ci, probability_of_improvement_ci};
use host_trainer::stats::binomial::clopper_pearson;
use host_trainer::stats::bootstrap::{bootstrap_percentile_ci, stratified_bootstrap_ci};
use host_trainer::stats::permutation::{permutation_two_sample, PValue};
use host_trainer::stats::sensitivity::{sensitivity, Sensitivity};
use host_trainer::stats::{ALPHA, CONFIDENCE, REPS, SEED};
use serde_json::Value;

use crate::main_job::span;

/// The tasks in the protocol's order: (name, its Zoo anchor scores (agent, mean, std)).
pub const TASKS: [&str; 5] = [
    "pendulum",
    "mountain-car",
    "inverted-pendulum",
    "reacher",
    "nav-walls",
];
/// The agents in the tables' order.
pub const AGENTS: [&str; 11] = [
    "sb3-td3",
    "sb3-sac",
    "sb3-ddpg",
    "dcp",
    "dcp-paper",
    "ddpg",
    "td3",
    "dcp@zoo-net",
    "dcp-paper@zoo-net",
    "ddpg@zoo-net",
    "td3@zoo-net",
];
/// Seeds per cell.
pub const SEEDS: u64 = 5;
/// The RL Zoo's published scores (`benchmark.md` at 22e3ff2): task, agent, mean, std.
pub const ZOO_SCORES: [(&str, &str, f64, f64); 6] = [
    ("pendulum", "sb3-td3", -151.855, 90.227),
    ("pendulum", "sb3-sac", -156.995, 88.714),
    ("pendulum", "sb3-ddpg", -152.099, 94.282),
    ("mountain-car", "sb3-td3", 93.483, 0.075),
    ("mountain-car", "sb3-sac", 94.679, 1.134),
    ("mountain-car", "sb3-ddpg", 93.512, 0.048),
];
/// A margin binds in a cell when this share of its test steps is at the action bound or at the
/// position limit.
pub const BINDS: f64 = 0.10;

/// Training episodes as (env steps so far, return).
pub type Curve = Vec<(f64, f64)>;

/// One finished run.
#[derive(Clone, Debug)]
pub struct Run {
    /// Its seed.
    pub seed: u64,
    /// The run's `result.json`.
    pub result: Value,
    /// Training episodes, from `train.jsonl`.
    pub curve: Curve,
    /// The episodes `train.jsonl` holds after the training ones (the toolkit's trainer records
    /// its own test there, the blob's to the bit), each as the recorder wrote it.
    pub after: Vec<Value>,
    /// Whether the training episodes' environment clock (`env_seconds`) goes back: a plant
    /// started afresh on the record, a run continued from its checkpoint before the recorder
    /// carried its clock on.
    pub clock_restarted: bool,
}

impl Run {
    fn test(&self, key: &str) -> f64 {
        self.result["test"][key].as_f64().unwrap_or(f64::NAN)
    }
    /// The mean test return.
    pub fn mean_return(&self) -> f64 {
        self.test("mean_return")
    }
    /// Whether `train_seconds` times the run's last part alone: a toolkit run continued from
    /// its checkpoint by a grid runner that took the trainer's last `trained` line as the run's
    /// time. Such a run's record restarted its clock, and its result has no `train_parts`
    /// (which the runner writes since it adds the earlier parts' time).
    pub fn timed_last_part_alone(&self) -> bool {
        self.clock_restarted && self.result.get("train_parts").is_none()
    }
}

/// A cell: the finished runs of one task and agent, and how many failed.
#[derive(Clone, Debug, Default)]
pub struct Cell {
    /// Runs that finished.
    pub runs: Vec<Run>,
    /// Runs that failed, with their reasons.
    pub failed: Vec<(u64, String)>,
}

impl Cell {
    /// The per-run mean test returns, in seed order.
    pub fn returns(&self) -> Vec<f64> {
        self.runs.iter().map(Run::mean_return).collect()
    }
    /// Every seed finished: the cell a verdict, an anchor or a scale may use.
    fn complete(&self) -> bool {
        self.runs.len() as u64 == SEEDS
    }
    fn missing(&self) -> u64 {
        SEEDS - self.runs.len() as u64 - self.failed.len() as u64
    }
    fn share(&self, key: &str) -> f64 {
        let steps: f64 = self.runs.iter().map(|r| r.test("steps")).sum();
        let shares: f64 = self
            .runs
            .iter()
            .map(|r| r.test(key) * r.test("steps"))
            .sum();
        shares / steps
    }
}

/// The grid as recorded.
#[derive(Clone, Debug, Default)]
pub struct Grid {
    /// (task, agent) → cell.
    pub cells: BTreeMap<(String, String), Cell>,
    /// A uniformly random policy's mean test return per task (`OUT/{task}/random.json`).
    pub random: BTreeMap<String, f64>,
    /// Each task's chip figures (`OUT/{task}/chip.json`) where measured.
    pub chip: BTreeMap<String, Value>,
    /// `OUT/speed.json` where measured.
    pub speed: Option<Value>,
}

fn optional_json(path: &Path) -> Result<Option<Value>> {
    match std::fs::read_to_string(path) {
        Ok(text) => {
            Ok(Some(serde_json::from_str(&text).with_context(|| {
                format!("{}: not JSON", path.display())
            })?))
        }
        Err(_) => Ok(None),
    }
}

/// Reads every run of the protocol from `out`. Tiny runs (a grid run with `--steps`, as CI
/// makes) are refused unless `tiny` is set: a page of the protocol is made from its budgets.
pub fn load(out: &Path, tiny: bool) -> Result<Grid> {
    let mut grid = Grid {
        speed: optional_json(&out.join("speed.json"))?,
        ..Grid::default()
    };
    for task in TASKS {
        if let Some(v) = optional_json(&out.join(task).join("random.json"))? {
            if let Some(x) = v["mean_return"].as_f64() {
                grid.random.insert(task.to_string(), x);
            }
        }
        if let Some(v) = optional_json(&out.join(task).join("chip.json"))? {
            grid.chip.insert(task.to_string(), v);
        }
    }
    for task in TASKS {
        for agent in AGENTS {
            let mut cell = Cell::default();
            for seed in 0..SEEDS {
                let folder = out.join(task).join(agent).join(format!("seed{seed}"));
                let path = folder.join("result.json");
                let Ok(text) = std::fs::read_to_string(&path) else {
                    continue;
                };
                let result: Value = serde_json::from_str(&text)
                    .with_context(|| format!("{}: not a run's result", path.display()))?;
                if let Some(why) = result.get("failed") {
                    cell.failed
                        .push((seed, why.as_str().unwrap_or("?").to_string()));
                    continue;
                }
                if result["steps_override"].is_number() && !tiny {
                    anyhow::bail!(
                        "{}: a tiny run (--steps), not the protocol's budget; a page is made from protocol runs only",
                        path.display()
                    );
                }
                let steps = result["env_steps"].as_f64().unwrap_or(f64::INFINITY);
                let (curve, after, clock_restarted) =
                    read_curve(&folder.join("train.jsonl"), steps)?;
                cell.runs.push(Run {
                    seed,
                    result,
                    curve,
                    after,
                    clock_restarted,
                });
            }
            grid.cells
                .insert((task.to_string(), agent.to_string()), cell);
        }
    }
    Ok(grid)
}

/// The training episodes of a run: (env steps at the episode's end, return), up to `steps`;
/// the episodes after those (the trainer's own test episodes follow in the same file); and
/// whether the training episodes' environment clock goes back somewhere.
fn read_curve(path: &Path, steps: f64) -> Result<(Curve, Vec<Value>, bool)> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut total = 0.0;
    let mut curve = Vec::new();
    let mut after = Vec::new();
    let (mut clock, mut restarted) = (f64::NEG_INFINITY, false);
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let e: Value = serde_json::from_str(line)
            .with_context(|| format!("{}: a line that is not JSON", path.display()))?;
        if total >= steps {
            after.push(e);
            continue;
        }
        total += e["steps"].as_f64().unwrap_or(0.0);
        curve.push((total, e["return"].as_f64().unwrap_or(f64::NAN)));
        if let Some(seconds) = e["env_seconds"].as_f64() {
            restarted |= seconds < clock;
            clock = seconds;
        }
    }
    Ok((curve, after, restarted))
}

/// Nav-walls' episode length and exit penalty, from the shipped scenario the Gymnasium
/// environment serves (its reward GR; the penalty is the worst step reward over 1 − γ). An
/// episode that leaves the arena earns the penalty on its last step and nothing positive before.
fn nav_limits(s: &Scenario) -> (f64, f64) {
    (
        f64::from(s.time_limit),
        f64::from(Reward::Gr.exit_penalty(s.gamma)),
    )
}

/// Nav-walls' test episodes that ended at the goal (within 0.1 of the centre for 10 steps)
/// before the plant's settled flag could rise (20 steps within 2 of it): shorter than the time
/// limit, flag down, and a return above the exit penalty, so they did not leave the arena.
/// Only the grid's pinned plant leaves them out; firmware-sim's plant has since raised the flag
/// on such an episode, so runs on it count none here.
/// Counted from the trainer's test episodes in `train.jsonl`, and only where they are the
/// run's test (as many, the same mean return); `None` otherwise.
fn ended_at_goal(run: &Run, (time_limit, exit_penalty): (f64, f64)) -> Option<usize> {
    let episodes = run.test("episodes");
    let mean_after = run
        .after
        .iter()
        .map(|e| e["return"].as_f64().unwrap_or(f64::NAN))
        .sum::<f64>()
        / run.after.len() as f64;
    if run.after.len() as f64 != episodes || (mean_after - run.mean_return()).abs() > 1e-9 {
        return None;
    }
    Some(
        run.after
            .iter()
            .filter(|e| {
                e["steps"].as_f64().unwrap_or(time_limit) < time_limit
                    && e["success"].as_bool() == Some(false)
                    && e["return"].as_f64().unwrap_or(f64::NEG_INFINITY) > exit_penalty
            })
            .count(),
    )
}

/// The line under nav-walls' table: the cells whose success column misses episodes that ended
/// at the goal, and their count with those episodes taken as settled.
fn goal_endings(grid: &Grid) -> String {
    let Some(nav) = Scenario::builtin("nav-walls") else {
        return "The shipped nav-walls scenario does not parse: episodes that ended at the goal are not counted.\n".to_string();
    };
    let limits = nav_limits(&nav);
    let mut each = Vec::new();
    let mut uncounted = Vec::new();
    for agent in AGENTS {
        let c = cell(grid, "nav-walls", agent);
        if c.runs.is_empty() {
            continue;
        }
        let counts: Option<Vec<usize>> = c.runs.iter().map(|r| ended_at_goal(r, limits)).collect();
        let Some(counts) = counts else {
            uncounted.push(agent);
            continue;
        };
        let goal: usize = counts.iter().sum();
        if goal > 0 {
            let k: f64 = c.runs.iter().map(|x| x.test("successes")).sum();
            let n: f64 = c.runs.iter().map(|x| x.test("episodes")).sum();
            each.push(format!(
                "{agent} {goal} (settled or at the goal: {:.0}/{n:.0})",
                k + goal as f64
            ));
        }
    }
    let mut line = format!(
        "Test episodes that ended at the goal (within {} of the centre for {} steps) before the plant's settled flag could rise ({} steps within {}), so the success column leaves them out: {}",
        nav.goal_radius,
        nav.goal_hold,
        nav.metrics.settle_window,
        nav.metrics.success_radius,
        if each.is_empty() { "none".to_string() } else { each.join("; ") }
    );
    if !uncounted.is_empty() {
        let _ = write!(
            line,
            "; not counted for {} (no test episodes in `train.jsonl`)",
            uncounted.join(", ")
        );
    }
    let _ = writeln!(
        line,
        ". Counted from each run's test episodes in `train.jsonl`: shorter than {:.0} steps, the flag down, and a return above the exit penalty ({:.2}).",
        limits.0, limits.1
    );
    line
}

/// "Ahead", "tied" or "behind" by the protocol's rule, with what it rests on.
#[derive(Clone, Debug)]
pub struct Verdict {
    /// The word.
    pub word: &'static str,
    /// The difference of the means (first minus second).
    pub difference: f64,
    /// Its percentile bootstrap interval (each group resampled on its own).
    pub interval: (f64, f64),
    /// The exact permutation test.
    pub p: PValue,
    /// The fewest runs that flip the word.
    pub sensitivity: Sensitivity,
}

fn word(a: &[f64], b: &[f64]) -> &'static str {
    word_of(
        permutation_two_sample(a, b, REPS as u64, SEED).p,
        mean(a) - mean(b),
    )
}

/// The rule's word for a test's p and the difference of the means.
fn word_of(p: f64, d: f64) -> &'static str {
    match (p < ALPHA, d > 0.0) {
        (true, true) => "ahead",
        (true, false) => "behind",
        _ => "tied",
    }
}

/// The protocol's rule for `a` against `b` (per-run mean test returns); `None` unless both
/// cells are complete.
pub fn verdict(a: &[f64], b: &[f64]) -> Option<Verdict> {
    if a.len() as u64 != SEEDS || b.len() as u64 != SEEDS {
        return None;
    }
    let p = permutation_two_sample(a, b, REPS as u64, SEED);
    let interval = stratified_bootstrap_ci(
        &[a.to_vec(), b.to_vec()],
        |s| mean(&s[0]) - mean(&s[1]),
        CONFIDENCE,
        REPS,
        SEED,
    );
    // A change: a run of either group taking the other group's lowest or highest value.
    let joined: Vec<f64> = a.iter().chain(b).copied().collect();
    let n = a.len();
    let (a_lo, a_hi) = span(a)?;
    let (b_lo, b_hi) = span(b)?;
    let flip = sensitivity(
        &joined,
        |i, _| {
            if i < n {
                vec![b_lo, b_hi]
            } else {
                vec![a_lo, a_hi]
            }
        },
        |v| word(&v[..n], &v[n..]),
        3,
    );
    Some(Verdict {
        word: word_of(p.p, mean(a) - mean(b)),
        difference: mean(a) - mean(b),
        interval: (interval.lo, interval.hi),
        p,
        sensitivity: flip,
    })
}

fn mean(xs: &[f64]) -> f64 {
    xs.iter().sum::<f64>() / xs.len() as f64
}

fn cell<'g>(grid: &'g Grid, task: &str, agent: &str) -> &'g Cell {
    static EMPTY: std::sync::OnceLock<Cell> = std::sync::OnceLock::new();
    grid.cells
        .get(&(task.to_string(), agent.to_string()))
        .unwrap_or_else(|| EMPTY.get_or_init(Cell::default))
}

fn fmt_values(xs: &[f64]) -> String {
    xs.iter()
        .map(|x| format!("{x:.1}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The page's results section (markdown) and the learning-curve figures (file name, SVG).
pub fn render(grid: &Grid, commit: &str, figures: &str) -> (String, Vec<(String, String)>) {
    let mut md = String::new();
    let mut svgs = Vec::new();
    let done: usize = grid.cells.values().map(|c| c.runs.len()).sum();
    let failed: usize = grid.cells.values().map(|c| c.failed.len()).sum();
    let total = TASKS.len() * AGENTS.len() * SEEDS as usize;
    let _ = writeln!(
        md,
        "Measured at commit {commit}: {done} of the protocol's {total} runs done, {failed} failed, {} not yet run.\n",
        total - done - failed
    );
    md.push_str(&progress(grid));
    for task in TASKS {
        let _ = writeln!(md, "### {task}\n");
        let any = AGENTS.iter().any(|a| !cell(grid, task, a).runs.is_empty());
        if !any {
            let _ = writeln!(md, "Not yet run.\n");
            continue;
        }
        let _ = writeln!(md, "| agent | runs | mean test return [95 % bootstrap] | per seed | success [Clopper–Pearson] | at bound | at the limit (steps; episodes) | s per 1k steps (wall, as run) |");
        let _ = writeln!(md, "|---|---|---|---|---|---|---|---|");
        for agent in AGENTS {
            let c = cell(grid, task, agent);
            if c.runs.is_empty() {
                let _ = writeln!(
                    md,
                    "| {agent} | 0 done, {} failed, {} to run | | | | | | |",
                    c.failed.len(),
                    c.missing()
                );
                continue;
            }
            let r = c.returns();
            let ci = bootstrap_percentile_ci(&r, mean, CONFIDENCE, REPS, SEED);
            let k: f64 = c.runs.iter().map(|x| x.test("successes")).sum();
            let n: f64 = c.runs.iter().map(|x| x.test("episodes")).sum();
            let (lo, hi) = clopper_pearson(k as u64, n as u64, CONFIDENCE);
            let contact_eps: f64 = c.runs.iter().map(|x| x.test("contact_episodes")).sum();
            // A run timed by its last part alone says nothing of a run's time: left out, counted.
            let part_timed = c.runs.iter().filter(|x| x.timed_last_part_alone()).count();
            let per_k: Vec<f64> = c
                .runs
                .iter()
                .filter(|x| !x.timed_last_part_alone())
                .map(|x| {
                    1000.0 * x.result["train_seconds"].as_f64().unwrap_or(f64::NAN)
                        / x.result["env_steps"].as_f64().unwrap_or(f64::NAN)
                })
                .collect();
            // A run on more than one trainer thread (`run --threads N`) is the same computation
            // in less wall time: the column says how many of the cell's runs had more cores.
            let threads = |x: &Run| x.result["trainer_threads"].as_u64().unwrap_or(1);
            let multi: Vec<u64> = c.runs.iter().map(threads).filter(|&t| t > 1).collect();
            let mut notes = Vec::new();
            if let Some(most) = multi.iter().max() {
                notes.push(format!(
                    "{} of {} on up to {most} threads",
                    multi.len(),
                    c.runs.len()
                ));
            }
            if part_timed > 0 {
                notes.push(format!(
                    "{part_timed} of {} left out, timed by their last part",
                    c.runs.len()
                ));
            }
            let mut wall = if per_k.is_empty() {
                "–".to_string()
            } else {
                format!("{:.2}", mean(&per_k))
            };
            if !notes.is_empty() {
                wall = format!("{wall} ({})", notes.join("; "));
            }
            let runs = if c.complete() {
                format!("{}", c.runs.len())
            } else {
                format!(
                    "{} ({} failed, {} to run)",
                    c.runs.len(),
                    c.failed.len(),
                    c.missing()
                )
            };
            // One run has no spread to resample: its value alone, said so.
            let interval = if r.len() < 2 {
                format!("{:.1} (1 run)", ci.estimate)
            } else {
                format!("{:.1} [{:.1}, {:.1}]", ci.estimate, ci.lo, ci.hi)
            };
            let _ = writeln!(
                md,
                "| {agent} | {runs} | {interval} | {} | {:.0}/{:.0} = {:.2} [{lo:.2}, {hi:.2}] | {:.1} % | {:.1} %; {:.0}/{:.0} | {wall} |",
                fmt_values(&r),
                k,
                n,
                k / n,
                100.0 * c.share("at_bound_share"),
                100.0 * c.share("contact_share"),
                contact_eps,
                n,
            );
        }
        let _ = writeln!(
            md,
            "\nThe last column is each run's training wall time as it ran, on a machine shared with other work: not a speed comparison (that is [Speed](#speed)). A run continued from its checkpoint by the grid runner before it added the earlier parts' time (its `result.json` has no `train_parts`) is timed by its last part alone: such a run is left out of the column, and counted beside it."
        );
        if task == "nav-walls" {
            let _ = write!(md, "\n{}", goal_endings(grid));
        }
        let _ = writeln!(md);
        for (agent, score, std) in ZOO_SCORES
            .iter()
            .filter(|z| z.0 == task)
            .map(|z| (z.1, z.2, z.3))
        {
            let c = cell(grid, task, agent);
            if c.runs.is_empty() {
                continue;
            }
            let m = mean(&c.returns());
            // The protocol compares the cell's mean of five runs: a part of the cell is shown,
            // not judged.
            let judged = if c.complete() {
                if (m - score).abs() <= std {
                    "holds"
                } else {
                    "does not hold"
                }
            } else {
                "not judged until the cell is complete"
            };
            let _ = writeln!(
                md,
                "- Anchor, {agent}: measured {m:.1} over {} of {SEEDS} runs against the Zoo's {score} ± {std}: {judged}.",
                c.runs.len(),
            );
        }
        // Claim 1's comparison in each network row, then the protocol's secondary ones in each
        // row: the paper's DCP against DDPG, and DCP against SB3's TD3 and DDPG (at 2×400 the
        // toolkit's network holds every unit of the Zoo's [400, 300]).
        for (a, b) in [
            ("dcp", "ddpg"),
            ("dcp@zoo-net", "ddpg@zoo-net"),
            ("dcp-paper", "ddpg"),
            ("dcp-paper@zoo-net", "ddpg@zoo-net"),
            ("dcp", "sb3-td3"),
            ("dcp", "sb3-ddpg"),
            ("dcp@zoo-net", "sb3-td3"),
            ("dcp@zoo-net", "sb3-ddpg"),
        ] {
            match verdict(
                &cell(grid, task, a).returns(),
                &cell(grid, task, b).returns(),
            ) {
                Some(v) => {
                    let _ = writeln!(
                        md,
                        "- {a} against {b}: **{}**: difference {:.1} [{:.1}, {:.1}], {}; {}.",
                        v.word, v.difference, v.interval.0, v.interval.1, v.p, v.sensitivity
                    );
                }
                None => {
                    let _ = writeln!(md, "- {a} against {b}: not judged (a cell is incomplete).");
                }
            }
        }
        let _ = writeln!(md);
        let name = format!("curves-{task}.svg");
        let _ = writeln!(
            md,
            "![Training return against environment steps, {task}]({figures}/{name})\n"
        );
        svgs.push((name, curves(grid, task)));
    }
    md.push_str(&claim_one(grid));
    md.push_str(&chip(grid));
    md.push_str(&speed(grid));
    (md, svgs)
}

/// The palette of the curves, one colour per agent in [`AGENTS`] order.
const COLORS: [&str; 11] = [
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#bcbd22", "#17becf", "#000000",
];

/// Each agent's training return against env steps, averaged over its runs in 20 bins of the
/// budget (a bin's value: the mean return of the episodes that ended in it).
/// Which cells are done: runs finished (and failed) of each cell's five, an agent a row, so a
/// reader sees at a glance what the grid still lacks.
fn progress(grid: &Grid) -> String {
    let mut md = format!(
        "Runs finished per cell, of {SEEDS} seeds (a failed run is named beside them):\n\n| agent | {} |\n|---|{}\n",
        TASKS.join(" | "),
        "---|".repeat(TASKS.len())
    );
    for agent in AGENTS {
        let _ = write!(md, "| {agent} |");
        for task in TASKS {
            let c = cell(grid, task, agent);
            let _ = write!(md, " {}/{SEEDS}", c.runs.len());
            if !c.failed.is_empty() {
                let _ = write!(md, " ({} failed)", c.failed.len());
            }
            md.push_str(" |");
        }
        md.push('\n');
    }
    md.push('\n');
    md
}

fn curves(grid: &Grid, task: &str) -> String {
    let mut series = Vec::new();
    for (agent, color) in AGENTS.iter().zip(COLORS) {
        let c = cell(grid, task, agent);
        let budget = c
            .runs
            .iter()
            .filter_map(|r| r.result["budget"].as_f64())
            .fold(0.0, f64::max);
        if c.runs.is_empty() || budget <= 0.0 {
            continue;
        }
        let bins = 20usize;
        let mut sums = vec![(0.0, 0usize); bins];
        for (steps, ret) in c.runs.iter().flat_map(|r| r.curve.iter()) {
            let i = ((steps / budget * bins as f64).ceil() as usize).clamp(1, bins) - 1;
            sums[i].0 += ret;
            sums[i].1 += 1;
        }
        let points = sums
            .iter()
            .enumerate()
            .filter(|(_, s)| s.1 > 0)
            .map(|(i, s)| ((i + 1) as f64 * budget / bins as f64, s.0 / s.1 as f64))
            .collect();
        series.push(Series {
            name: format!("{agent} ({} runs)", c.runs.len()),
            color,
            opacity: 1.0,
            points,
        });
    }
    svg(
        &format!("{task}: training episode return, mean over seeds"),
        "environment steps",
        &[Panel {
            y_label: "return".into(),
            series,
            y_range: None,
        }],
    )
}

/// Claim 1 on one network row: the tasks where a margin binds in DDPG's test episodes, DCP's
/// verdict on each with the fewest runs that flip it, and the rule's word.
fn claim_one_row(grid: &Grid, row: &str, dcp: &str, ddpg: &str, md: &mut String) {
    // Whether a margin binds is DDPG's cell's alone, so it is known as soon as that cell is
    // complete; the verdict there waits for DCP's cell too. A task whose margin does not bind
    // is outside the rule, so its DCP cell is not waited for.
    let mut binding = Vec::new();
    let mut unknown = Vec::new();
    let mut waiting = Vec::new();
    for task in TASKS {
        let (d, g) = (cell(grid, task, dcp), cell(grid, task, ddpg));
        if !g.complete() {
            unknown.push(task);
        }
        if g.complete() && g.share("at_bound_share").max(g.share("contact_share")) > BINDS {
            binding.push(task);
            if !d.complete() {
                waiting.push(task);
            }
        }
    }
    let verdicts: Vec<(&str, Verdict)> = binding
        .iter()
        .filter(|t| !waiting.contains(t))
        .filter_map(|t| {
            verdict(
                &cell(grid, t, dcp).returns(),
                &cell(grid, t, ddpg).returns(),
            )
            .map(|v| (*t, v))
        })
        .collect();
    let ahead = verdicts.iter().filter(|v| v.1.word == "ahead").count();
    let behind = verdicts.iter().filter(|v| v.1.word == "behind").count();
    let mut pending = Vec::new();
    if !unknown.is_empty() {
        pending.push(format!(
            "whether a margin binds is not yet known on {} (DDPG's cell incomplete)",
            unknown.join(", ")
        ));
    }
    if !waiting.is_empty() {
        pending.push(format!(
            "DCP's cell is incomplete on {}, where one binds",
            waiting.join(", ")
        ));
    }
    let judged = pending.is_empty();
    let waiting = if waiting.is_empty() {
        String::new()
    } else {
        format!(
            "; not yet on {} (DCP's cell incomplete)",
            waiting.join(", ")
        )
    };
    let _ = writeln!(
        md,
        "**The {row} row.** Tasks where a margin binds in DDPG's test episodes (over {:.0} % of steps at the action bound or the limit), of those whose DDPG cell is complete: {}. DCP against DDPG there: ahead on {ahead}, behind on {behind}, tied on {}{waiting}.",
        100.0 * BINDS,
        if binding.is_empty() { "none yet".to_string() } else { binding.join(", ") },
        verdicts.len() - ahead - behind
    );
    let word = if !judged {
        format!("not yet judged: {}", pending.join("; "))
    } else if binding.is_empty() {
        "not judged: no margin binds".to_string()
    } else if 2 * ahead > verdicts.len() && behind == 0 {
        "reproduced".to_string()
    } else {
        "not reproduced".to_string()
    };
    // What the word rests on: each binding task's verdict and how many runs flip it (a task's
    // flip can flip the row's word).
    let rests_on = if judged && !verdicts.is_empty() {
        let each: Vec<String> = verdicts
            .iter()
            .map(|(t, v)| format!("{t}: {}, {}, {}", v.word, v.p, v.sensitivity))
            .collect();
        format!(" It rests on {}.", each.join("; "))
    } else {
        String::new()
    };
    let _ = writeln!(
        md,
        "\n**Verdict on claim 1, {row} row (the protocol's rule): {word}.**{rests_on}\n"
    );
}

/// Claim 1 on standard tasks, by the protocol's rule for each network row, and the aggregate
/// across tasks.
fn claim_one(grid: &Grid) -> String {
    let mut md = String::from("### Claim 1 on standard tasks\n\n");
    for (row, dcp, ddpg) in [
        ("4×48", "dcp", "ddpg"),
        ("2×400", "dcp@zoo-net", "ddpg@zoo-net"),
    ] {
        claim_one_row(grid, row, dcp, ddpg, &mut md);
    }
    // Across the tasks whose cells are complete: IQM of normalised returns and P(DCP > DDPG).
    let mut dcp_tasks = Vec::new();
    let mut ddpg_tasks = Vec::new();
    let mut used = Vec::new();
    for task in TASKS {
        let anchor = cell(grid, task, "sb3-td3");
        let random = grid.random.get(task).copied();
        let (d, g) = (cell(grid, task, "dcp"), cell(grid, task, "ddpg"));
        if ![d, g, anchor].iter().all(|c| c.complete()) {
            continue;
        }
        let (d, g) = (d.returns(), g.returns());
        let Some(random) = random else { continue };
        let top = mean(&anchor.returns());
        let scale = |x: f64| (x - random) / (top - random);
        dcp_tasks.push(d.iter().map(|&x| scale(x)).collect::<Vec<_>>());
        ddpg_tasks.push(g.iter().map(|&x| scale(x)).collect::<Vec<_>>());
        used.push(task);
    }
    if used.is_empty() {
        let _ = writeln!(md, "Across tasks: not yet computed (no task has complete DCP, DDPG and SB3 TD3 cells with a random-policy baseline).\n");
        return md;
    }
    let iqm_d = iqm_ci(&dcp_tasks, CONFIDENCE, REPS, SEED);
    let iqm_g = iqm_ci(&ddpg_tasks, CONFIDENCE, REPS, SEED);
    let poi = probability_of_improvement_ci(&dcp_tasks, &ddpg_tasks, CONFIDENCE, REPS, SEED);
    let _ = writeln!(
        md,
        "Across {} ({} task{}; returns normalised so that a uniformly random policy is 0 and SB3 TD3's cell mean is 1): IQM of DCP {:.3} [{:.3}, {:.3}], of DDPG {:.3} [{:.3}, {:.3}] (stratified bootstrap); probability that a DCP run beats a DDPG run {:.2} [{:.2}, {:.2}].\n",
        used.join(", "),
        used.len(),
        if used.len() == 1 { "" } else { "s" },
        iqm_d.estimate,
        iqm_d.lo,
        iqm_d.hi,
        iqm_g.estimate,
        iqm_g.lo,
        iqm_g.hi,
        poi.estimate,
        poi.lo,
        poi.hi
    );
    md
}

/// Each task's DCP blob (seed 0, 4×48): its size, the trainer's test return against the blob's
/// through firmware-sim (equal, or the page says not), and its cost on the M4F where measured.
fn chip(grid: &Grid) -> String {
    let mut md = String::from("### The chip\n\n");
    md.push_str("| task | blob bytes | trainer's test return | the blob's, in firmware-sim | equal | `act` on the M4F (QEMU) |\n|---|---|---|---|---|---|\n");
    for task in TASKS {
        let Some(run) = cell(grid, task, "dcp").runs.iter().find(|r| r.seed == 0) else {
            let _ = writeln!(md, "| {task} | not yet run | | | | |");
            continue;
        };
        let blob = &run.result["blob"];
        let (t, b) = (
            blob["trainer_mean_return"].as_f64(),
            blob["blob_mean_return"].as_f64(),
        );
        let act = grid
            .chip
            .get(task)
            .and_then(|c| c["act"].as_str().map(str::to_string))
            .unwrap_or_else(|| "not measured".into());
        let _ = writeln!(
            md,
            "| {task} | {} | {} | {} | {} | {act} |",
            blob["bytes"],
            t.map_or("?".into(), |x| format!("{x:.3}")),
            b.map_or("?".into(), |x| format!("{x:.3}")),
            if t.is_some() && t == b {
                "yes"
            } else {
                "**no**"
            },
        );
    }
    md.push('\n');
    md
}

/// The per-step speed measurement (`OUT/speed.json`), as recorded.
fn speed(grid: &Grid) -> String {
    let mut md = String::from("### Speed\n\n");
    match &grid.speed {
        None => md.push_str("Not yet measured.\n\n"),
        Some(v) => {
            let _ = writeln!(
                md,
                "{} (CPU: {}), the toolkit's TD3 against SB3's TD3, per environment step (processor time, the steadier figure on a shared machine; wall time beside it):\n\n| toolkit | SB3 | toolkit ms | SB3 ms | SB3 ÷ toolkit | wall: SB3 ÷ toolkit | toolkit time in the Python environment |\n|---|---|---|---|---|---|---|",
                v["what"].as_str().unwrap_or(""),
                v["cpu"].as_str().unwrap_or("?"),
            );
            for row in v["rows"].as_array().into_iter().flatten() {
                let f = |key: &str| row[key].as_f64().unwrap_or(f64::NAN);
                let _ = writeln!(
                    md,
                    "| {} | {} | {:.3} | {:.3} | {:.1} | {:.1} | {:.1} % |",
                    row["toolkit"].as_str().unwrap_or("?"),
                    row["sb3"].as_str().unwrap_or("?"),
                    1e3 * f("toolkit_cpu_seconds_per_step"),
                    1e3 * f("sb3_cpu_seconds_per_step"),
                    f("cpu_ratio"),
                    f("ratio"),
                    100.0 * f("python_share"),
                );
            }
            md.push_str("\nThe Python environment's share is the time inside its `reset` and `step`; the plant link's own cost (framing and the pipe) is apart: [performance.md](../performance.md#the-plant-link).\n\n");
        }
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A run folder as the grid runner writes it: `result.json` and `train.jsonl`.
    fn write_run(out: &Path, task: &str, agent: &str, seed: u64, ret: f64, override_steps: bool) {
        let folder = out.join(task).join(agent).join(format!("seed{seed}"));
        std::fs::create_dir_all(&folder).expect("scratch folder");
        let result = serde_json::json!({
            "task": task, "agent": agent, "seed": seed,
            "steps_override": if override_steps { Some(400) } else { None },
            "env_steps": 400, "train_seconds": 2.0, "budget": 400,
            "blob": {"bytes": 29264, "trainer_mean_return": ret, "blob_mean_return": ret},
            "test": {"episodes": 100, "mean_return": ret, "successes": 10, "steps": 20000,
                     "at_bound_share": 0.5, "contact_share": 0.0, "contact_episodes": 0},
        });
        std::fs::write(folder.join("result.json"), result.to_string()).expect("result");
        let lines = "{\"steps\": 200, \"return\": -900.0}\n{\"steps\": 200, \"return\": -400.0}\n{\"steps\": 200, \"return\": -1.0}\n";
        std::fs::write(folder.join("train.jsonl"), lines).expect("curve");
    }

    /// Changes one field of a written run's `result.json`.
    fn patch_run(out: &Path, task: &str, agent: &str, seed: u64, key: &str, value: Value) {
        let path = out
            .join(task)
            .join(agent)
            .join(format!("seed{seed}"))
            .join("result.json");
        let mut result: Value =
            serde_json::from_str(&std::fs::read_to_string(&path).expect("result")).expect("json");
        match key.split_once('.') {
            Some((outer, inner)) => result[outer][inner] = value,
            None => result[key] = value,
        }
        std::fs::write(&path, result.to_string()).expect("result");
    }

    fn scratch(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("studies-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    #[test]
    fn a_run_timed_by_its_last_part_alone_is_left_out_of_the_time_column() {
        let out = scratch("parts");
        for seed in 0..SEEDS {
            write_run(&out, "reacher", "dcp", seed, -5.0, false);
        }
        // Seeds 3 and 4 were continued from a checkpoint: the plant started afresh, its clock
        // at 0 again. Seed 3's runner timed the last part alone (0.2 s, no `train_parts`);
        // seed 4's added the earlier part (2 s in all, `train_parts` 2).
        let restarted = "{\"steps\": 200, \"return\": -9.0, \"env_seconds\": 0.5}\n{\"steps\": 200, \"return\": -5.0, \"env_seconds\": 0.1}\n";
        for seed in [3, 4] {
            let folder = out.join(format!("reacher/dcp/seed{seed}"));
            std::fs::write(folder.join("train.jsonl"), restarted).expect("curve");
        }
        patch_run(&out, "reacher", "dcp", 3, "train_seconds", 0.2.into());
        patch_run(&out, "reacher", "dcp", 4, "train_parts", 2.into());
        let grid = load(&out, false).expect("loads");
        let runs = &cell(&grid, "reacher", "dcp").runs;
        let part_timed: Vec<bool> = runs.iter().map(Run::timed_last_part_alone).collect();
        assert_eq!(part_timed, [false, false, false, true, false]);
        let (md, _) = render(&grid, "abc1234", "standard-tasks");
        // 2 s for 400 steps on every run counted: 5 s per 1,000 steps, not 4.1 with seed 3's.
        assert!(
            md.contains("| 5.00 (1 of 5 left out, timed by their last part) |"),
            "{md}"
        );
        let _ = std::fs::remove_dir_all(&out);
    }

    #[test]
    fn a_page_judges_complete_cells_and_lists_the_rest() {
        let out = scratch("page");
        for seed in 0..SEEDS {
            write_run(&out, "pendulum", "dcp", seed, -150.0 - seed as f64, false);
            write_run(&out, "pendulum", "ddpg", seed, -400.0 - seed as f64, false);
        }
        // DDPG's seed 4 trained on two threads: the wall-time column says so.
        patch_run(&out, "pendulum", "ddpg", 4, "trainer_threads", 2.into());
        let failed = out.join("pendulum/td3/seed2");
        std::fs::create_dir_all(&failed).expect("scratch folder");
        std::fs::write(failed.join("result.json"), r#"{"failed": "diverged"}"#).expect("result");
        let grid = load(&out, false).expect("loads");
        // The trainer's test episodes after the budget are not training episodes.
        let run = &cell(&grid, "pendulum", "dcp").runs[0];
        assert_eq!(run.curve, vec![(200.0, -900.0), (400.0, -400.0)]);
        let (md, figures) = render(&grid, "abc1234", "standard-tasks");
        assert!(
            md.contains(
                "commit abc1234: 10 of the protocol's 275 runs done, 1 failed, 264 not yet run"
            ),
            "{md}"
        );
        // Five against five, every DCP run above every DDPG run: the exact test's smallest p.
        assert!(
            md.contains("dcp against ddpg: **ahead**: difference 250.0"),
            "{md}"
        );
        assert!(md.contains("p = 0.0079 (exact over 252)"), "{md}");
        assert!(
            md.contains("dcp@zoo-net against ddpg@zoo-net: not judged"),
            "{md}"
        );
        // The secondary comparisons are named in both network rows, judged or not.
        for pair in [
            "dcp-paper against ddpg: not judged",
            "dcp-paper@zoo-net against ddpg@zoo-net: not judged",
            "dcp against sb3-td3: not judged",
            "dcp against sb3-ddpg: not judged",
            "dcp@zoo-net against sb3-td3: not judged",
            "dcp@zoo-net against sb3-ddpg: not judged",
        ] {
            assert!(md.contains(pair), "{pair} missing: {md}");
        }
        assert!(
            md.contains("| sb3-td3 | 0 done, 0 failed, 5 to run |"),
            "{md}"
        );
        assert!(md.contains("### mountain-car\n\nNot yet run."), "{md}");
        // The cells at a glance: pendulum's DCP and DDPG done, every other cell empty.
        assert!(
            md.contains("| agent | pendulum | mountain-car | inverted-pendulum | reacher | nav-walls |\n|---|---|---|---|---|---|\n| sb3-td3 | 0/5 | 0/5 | 0/5 | 0/5 | 0/5 |"),
            "{md}"
        );
        assert!(md.contains("| dcp | 5/5 | 0/5 | 0/5 | 0/5 | 0/5 |"), "{md}");
        assert!(
            md.contains("| ddpg | 5/5 | 0/5 | 0/5 | 0/5 | 0/5 |"),
            "{md}"
        );
        assert!(
            md.contains("| td3 | 0/5 (1 failed) | 0/5 | 0/5 | 0/5 | 0/5 |"),
            "{md}"
        );
        assert!(md.contains("| 5.00 |"), "{md}");
        assert!(md.contains("| 5.00 (1 of 5 on up to 2 threads) |"), "{md}");
        // The margin binds (50 % of steps at the bound), DCP ahead on the only judged task,
        // but the other tasks' cells are not complete yet.
        assert!(
            md.contains("**Verdict on claim 1, 4×48 row (the protocol's rule): not yet judged"),
            "{md}"
        );
        assert!(
            md.contains("| pendulum | 29264 | -150.000 | -150.000 | yes |"),
            "{md}"
        );
        assert_eq!(figures.len(), 1);
        assert!(figures[0].1.starts_with("<svg"));
        std::fs::remove_dir_all(&out).expect("clean up");
    }

    #[test]
    fn claim_one_is_judged_per_network_row_with_what_flips_it() {
        let out = scratch("claim");
        for task in TASKS {
            for seed in 0..SEEDS {
                write_run(&out, task, "dcp", seed, -150.0 - seed as f64, false);
                write_run(&out, task, "ddpg", seed, -400.0 - seed as f64, false);
            }
        }
        let (md, _) = render(
            &load(&out, false).expect("loads"),
            "abc1234",
            "standard-tasks",
        );
        assert!(
            md.contains("**Verdict on claim 1, 4×48 row (the protocol's rule): reproduced.** It rests on pendulum: ahead, p = 0.0079 (exact over 252), 2 runs flip it (45 sets of 2 of the 10 can); mountain-car: ahead"),
            "{md}"
        );
        assert!(md.contains("; nav-walls: ahead, p = 0.0079"), "{md}");
        assert!(
            md.contains("**Verdict on claim 1, 2×400 row (the protocol's rule): not yet judged: whether a margin binds is not yet known on pendulum, mountain-car, inverted-pendulum, reacher, nav-walls (DDPG's cell incomplete).**"),
            "{md}"
        );
        // DDPG's cell alone tells whether the margin binds; DCP's is awaited for the verdict.
        for seed in 0..SEEDS {
            write_run(&out, "nav-walls", "ddpg@zoo-net", seed, -60.0, false);
        }
        let (md, _) = render(
            &load(&out, false).expect("loads"),
            "abc1234",
            "standard-tasks",
        );
        assert!(
            md.contains("**The 2×400 row.** Tasks where a margin binds in DDPG's test episodes (over 10 % of steps at the action bound or the limit), of those whose DDPG cell is complete: nav-walls. DCP against DDPG there: ahead on 0, behind on 0, tied on 0; not yet on nav-walls (DCP's cell incomplete)."),
            "{md}"
        );
        assert!(
            md.contains("(the protocol's rule): not yet judged: whether a margin binds is not yet known on pendulum, mountain-car, inverted-pendulum, reacher (DDPG's cell incomplete); DCP's cell is incomplete on nav-walls, where one binds.**"),
            "{md}"
        );
        // Where DDPG's margin does not bind the task is outside the rule, so its DCP cell is
        // not waited for: nav-walls alone decides the row.
        for task in ["pendulum", "mountain-car", "inverted-pendulum", "reacher"] {
            for seed in 0..SEEDS {
                write_run(&out, task, "ddpg@zoo-net", seed, -60.0, false);
                patch_run(
                    &out,
                    task,
                    "ddpg@zoo-net",
                    seed,
                    "test.at_bound_share",
                    0.0.into(),
                );
            }
        }
        for seed in 0..SEEDS {
            write_run(&out, "nav-walls", "dcp@zoo-net", seed, -10.0, false);
        }
        let (md, _) = render(
            &load(&out, false).expect("loads"),
            "abc1234",
            "standard-tasks",
        );
        assert!(
            md.contains("**Verdict on claim 1, 2×400 row (the protocol's rule): reproduced.** It rests on nav-walls: ahead, p = 0.0079"),
            "{md}"
        );
        std::fs::remove_dir_all(&out).expect("clean up");
    }

    #[test]
    fn nav_walls_episodes_that_end_at_the_goal_are_counted_apart() {
        let out = scratch("goal");
        // Three test episodes after the two training ones: one ends at the goal in 40 steps with
        // the flag down, one leaves the arena in 3 (the exit penalty), one runs to the limit and
        // settles.
        write_run(&out, "nav-walls", "dcp", 0, -185.0 / 3.0, false);
        patch_run(&out, "nav-walls", "dcp", 0, "test.episodes", 3.into());
        patch_run(&out, "nav-walls", "dcp", 0, "test.successes", 1.into());
        let lines = [
            r#"{"steps": 200, "return": -900.0, "success": false}"#,
            r#"{"steps": 200, "return": -400.0, "success": false}"#,
            r#"{"steps": 40, "return": -10.0, "success": false}"#,
            r#"{"steps": 3, "return": -145.0, "success": false}"#,
            r#"{"steps": 200, "return": -30.0, "success": true}"#,
        ];
        std::fs::write(
            out.join("nav-walls/dcp/seed0/train.jsonl"),
            lines.join("\n") + "\n",
        )
        .expect("curve");
        // A run whose record holds no test episodes is named, not guessed at.
        write_run(&out, "nav-walls", "ddpg", 0, -60.0, false);
        let (md, _) = render(
            &load(&out, false).expect("loads"),
            "abc1234",
            "standard-tasks",
        );
        assert!(
            md.contains("so the success column leaves them out: dcp 1 (settled or at the goal: 2/3); not counted for ddpg (no test episodes in `train.jsonl`)."),
            "{md}"
        );
        std::fs::remove_dir_all(&out).expect("clean up");
    }

    #[test]
    fn the_anchor_and_the_normalised_returns_wait_for_sb3_td3s_whole_cell() {
        let out = scratch("anchor");
        for task in ["pendulum", "mountain-car"] {
            for seed in 0..SEEDS {
                write_run(&out, task, "dcp", seed, -150.0, false);
                write_run(&out, task, "ddpg", seed, -160.0, false);
            }
            std::fs::write(
                out.join(task).join("random.json"),
                r#"{"mean_return": -1000.0}"#,
            )
            .expect("random");
        }
        // Pendulum's SB3 TD3 cell is whole, mountain-car's has one run of five.
        for seed in 0..SEEDS {
            write_run(&out, "pendulum", "sb3-td3", seed, -150.0, false);
        }
        write_run(&out, "mountain-car", "sb3-td3", 0, 93.4, false);
        let (md, _) = render(
            &load(&out, false).expect("loads"),
            "abc1234",
            "standard-tasks",
        );
        assert!(
            md.contains("- Anchor, sb3-td3: measured -150.0 over 5 of 5 runs against the Zoo's -151.855 ± 90.227: holds."),
            "{md}"
        );
        assert!(
            md.contains("- Anchor, sb3-td3: measured 93.4 over 1 of 5 runs against the Zoo's 93.483 ± 0.075: not judged until the cell is complete."),
            "{md}"
        );
        // Mountain-car's one run is no cell mean to scale by: only pendulum is normalised.
        assert!(md.contains("Across pendulum (1 task;"), "{md}");
        std::fs::remove_dir_all(&out).expect("clean up");
    }

    #[test]
    fn a_tiny_run_is_refused_by_the_page() {
        let out = scratch("tiny");
        write_run(&out, "pendulum", "dcp", 0, -150.0, true);
        let err = load(&out, false).expect_err("tiny runs are not the protocol's");
        assert_eq!(load(&out, true).expect("asked for").cells.len(), 55);
        assert!(err.to_string().contains("a tiny run (--steps)"), "{err}");
        std::fs::remove_dir_all(&out).expect("clean up");
    }
}
