//! Experiment 1's results page, built from the run folders alone: tables 1–3 with the mean,
//! 95 % interval and per-seed values of every cell, the verdicts on claims 1–3 by the rules of
//! `docs/results/reproduction.md`, and the runs that are missing.
//!
//! A failed run counts: its success is 0 in every success column and in the verdicts, it is a
//! training failure in table 3, and the other columns, which need a finished evaluation, say how
//! many runs they average.

use std::fmt::Write as _;

use super::folder::{Finished, Outcome};
use super::grid::{
    Agent, Cell, Grid, GridRun, Walls, AGENTS, LARGE_SIGMAS, NOISE_AGENTS, REWARDS, SIZES,
};
use super::verdict::{
    differences, discordant, judge, mcnemar_side, paired_power_text, partner_extremes,
    permutation_side, permutation_text, t_side, t_text, Judged, Side, Word,
};
use crate::run::config::RewardKind;
use crate::stats::aggregate::{iqm_ci, probability_of_improvement_ci};
use crate::stats::binomial::clopper_pearson;
use crate::stats::power::{power_rate_difference, seeds_for_rate_difference};
use crate::stats::student_t::{clipped_text, Range, NON_NEGATIVE, UNIT};
use crate::stats::{student_t, ALPHA, CONFIDENCE, POWER, REPS, SEED};

/// A run whose test success is below this failed to train (table 3) [design §2].
pub const TRAINING_FAILURE: f64 = 0.5;

/// The outcomes of one cell, seed by seed.
struct CellRuns<'a> {
    runs: Vec<(u64, &'a Outcome)>,
}

impl<'a> CellRuns<'a> {
    fn of(all: &'a [(GridRun, Outcome)], cell: &Cell) -> Self {
        CellRuns {
            runs: all
                .iter()
                .filter(|(run, _)| run.cell == *cell)
                .map(|(run, o)| (run.seed, o))
                .collect(),
        }
    }

    fn finished(&self) -> impl Iterator<Item = (u64, &'a Finished)> + '_ {
        self.runs.iter().filter_map(|&(seed, o)| match o {
            Outcome::Finished(f) => Some((seed, &**f)),
            _ => None,
        })
    }

    /// Success per seed, a failed run as 0; missing runs absent.
    fn success(&self) -> Vec<(u64, f64)> {
        self.runs
            .iter()
            .filter_map(|&(seed, o)| match o {
                Outcome::Finished(f) => Some((seed, f.report.success_rate)),
                Outcome::Failed(_) => Some((seed, 0.0)),
                Outcome::Missing => None,
            })
            .collect()
    }

    fn count(&self, what: fn(&Outcome) -> bool) -> usize {
        self.runs.iter().filter(|(_, o)| what(o)).count()
    }

    fn metric(&self, get: fn(&Finished) -> f64) -> Vec<f64> {
        self.finished().map(|(_, f)| get(f)).collect()
    }
}

fn interval_text(values: &[f64], range: Range) -> String {
    clipped_text(values, 2, range)
}

/// `k of n` as a rate with its exact 95 % interval: `0.20 [0.01, 0.72]`.
fn rate_text(k: usize, n: usize) -> String {
    let (lo, hi) = clopper_pearson(k as u64, n as u64, CONFIDENCE);
    format!("{:.2} [{lo:.2}, {hi:.2}]", k as f64 / n.max(1) as f64)
}

fn per_seed(values: &[(u64, f64)]) -> String {
    values
        .iter()
        .map(|(_, v)| format!("{v:.2}"))
        .collect::<Vec<_>>()
        .join(", ")
}

const HEADER: &str = "| runs (done / failed / missing) | success | settled error | strict reach | pass within 0.25 | stuck at margin | success per seed | settled error per seed |\n";

fn metrics_row(cells: &CellRuns<'_>) -> String {
    let done = cells.count(|o| matches!(o, Outcome::Finished(_)));
    let failed = cells.count(|o| matches!(o, Outcome::Failed(_)));
    let missing = cells.count(|o| matches!(o, Outcome::Missing));
    let success: Vec<f64> = cells.success().iter().map(|s| s.1).collect();
    let errors: Vec<(u64, f64)> = cells
        .finished()
        .map(|(seed, f)| (seed, f.report.mean_error))
        .collect();
    format!(
        "| {done} / {failed} / {missing} | {} | {} | {} | {} | {} | {} | {} |",
        interval_text(&success, UNIT),
        interval_text(&cells.metric(|f| f.report.mean_error), NON_NEGATIVE),
        interval_text(&cells.metric(|f| f.report.strict_reach_rate), UNIT),
        interval_text(&cells.metric(|f| f.report.near_pass_rate), UNIT),
        interval_text(&cells.metric(|f| f.report.stuck_rate), UNIT),
        per_seed(&cells.success()),
        per_seed(&errors),
    )
}

fn reward_name(r: RewardKind) -> &'static str {
    match r {
        RewardKind::Lr => "LR",
        RewardKind::Gr => "GR",
        RewardKind::Lrgr => "LR+GR",
    }
}

/// A table of [`metrics_row`]s, one per `(setting, cell)` of `rows`, under a header whose second
/// column is `setting`.
fn metrics_table(
    all: &[(GridRun, Outcome)],
    setting: &str,
    rows: impl IntoIterator<Item = (String, Cell)>,
) -> String {
    let mut t = format!("| agent | {setting} {HEADER}");
    t.push_str("|---|---|---|---|---|---|---|---|---|---|\n");
    for (value, cell) in rows {
        let row = metrics_row(&CellRuns::of(all, &cell));
        let _ = writeln!(t, "| {} | {value} {row}", cell.agent.name);
    }
    t
}

/// Table 1: every agent at every network size on the pinwheel.
pub fn table1(all: &[(GridRun, Outcome)]) -> String {
    let rows = AGENTS.into_iter().flat_map(|agent| {
        SIZES.into_iter().map(move |size| {
            let cell = Cell {
                size,
                ..Cell::headline(agent)
            };
            (format!("{}×{}", size.0, size.1), cell)
        })
    });
    metrics_table(all, "hidden", rows)
}

/// Table 2: every agent under the three rewards (4×48, the pinwheel).
pub fn table2(all: &[(GridRun, Outcome)]) -> String {
    let rows = AGENTS.into_iter().flat_map(|agent| {
        REWARDS.into_iter().map(move |reward| {
            let cell = Cell {
                reward,
                ..Cell::headline(agent)
            };
            (reward_name(reward).to_string(), cell)
        })
    });
    metrics_table(all, "reward", rows)
}

/// The layouts table: every agent with and without walls (4×48, GR), the cells of figures 4–7
/// and of claim 1's second half, whose open-arena rows no other table shows.
pub fn layouts_table(all: &[(GridRun, Outcome)]) -> String {
    let layouts = [(Walls::With, "pinwheel"), (Walls::Without, "open arena")];
    let rows = AGENTS.into_iter().flat_map(move |agent| {
        layouts.into_iter().map(move |(walls, layout)| {
            let cell = Cell {
                walls,
                ..Cell::headline(agent)
            };
            (layout.to_string(), cell)
        })
    });
    metrics_table(all, "layout", rows)
}

/// Training failures (success below [`TRAINING_FAILURE`], or a failed run) per seed: 1 or 0.
fn failures(all: &[(GridRun, Outcome)], cell: &Cell) -> Vec<(u64, f64)> {
    CellRuns::of(all, cell)
        .success()
        .into_iter()
        .map(|(seed, s)| (seed, f64::from(u8::from(s < TRAINING_FAILURE))))
        .collect()
}

fn noise_cell(name: &str, sigma: f32) -> Cell {
    Cell {
        sigma: Some(sigma),
        ..Cell::headline(Agent::named(name).expect("table 3's agents are agents"))
    }
}

/// Table 3: training failure rate under large exploration noise.
pub fn table3(all: &[(GridRun, Outcome)]) -> String {
    let mut t = String::from(
        "| agent | exploration σ | failed trainings | failure rate | success | success per seed |\n|---|---|---|---|---|---|\n",
    );
    for name in NOISE_AGENTS {
        for sigma in LARGE_SIGMAS {
            let cell = noise_cell(name, sigma);
            let fails = failures(all, &cell);
            let k = fails.iter().filter(|f| f.1 > 0.0).count();
            let success = CellRuns::of(all, &cell).success();
            let values: Vec<f64> = success.iter().map(|s| s.1).collect();
            let _ = writeln!(
                t,
                "| {name} | {sigma} | {k} of {} | {} | {} | {} |",
                fails.len(),
                rate_text(k, fails.len()),
                interval_text(&values, UNIT),
                per_seed(&success),
            );
        }
    }
    t
}

/// The side of 0 the 95 % t interval of `values` lies on (the pre-registered rule).
pub fn side(values: &[f64]) -> Side {
    t_side(values)
}

/// `a − b` for the seeds both have.
fn paired(a: &[(u64, f64)], b: &[(u64, f64)]) -> Vec<f64> {
    a.iter()
        .filter_map(|&(seed, x)| b.iter().find(|p| p.0 == seed).map(|p| x - p.1))
        .collect()
}

/// Success per seed of `agent` in `cell`'s other settings.
fn success_of(
    all: &[(GridRun, Outcome)],
    agent: &str,
    cell: impl Fn(Agent) -> Cell,
) -> Vec<(u64, f64)> {
    CellRuns::of(
        all,
        &cell(Agent::named(agent).expect("a claim's agents are agents")),
    )
    .success()
}

/// How many runs of `agents` in the cells `cell` makes are missing.
fn missing_runs(
    all: &[(GridRun, Outcome)],
    agents: &[&str],
    cell: impl Fn(Agent) -> Cell,
) -> usize {
    agents
        .iter()
        .map(|name| {
            let agent = Agent::named(name).expect("a claim's agents are agents");
            CellRuns::of(all, &cell(agent)).count(|o| matches!(o, Outcome::Missing))
        })
        .sum()
}

/// The verdicts on claims 1–3, one paragraph each: the verdict by the rule written before the
/// runs ("pre-registered", a 95 % t interval of paired differences) and beside it the verdict
/// by exact tests ([`super::verdict`]), each with its test, p-value or interval and sensitivity, and
/// the power of the comparison.
///
/// A claim whose cells still miss runs is undecided: a rule read off part of its seeds could
/// turn once the rest are in, so the page says how many are missing instead.
pub fn verdicts(all: &[(GridRun, Outcome)]) -> String {
    let mut text = String::new();
    let walls = |a| Cell::headline(a);
    let open = |a| Cell {
        walls: Walls::Without,
        ..Cell::headline(a)
    };
    let undecided = |missing: usize| format!("**undecided ({missing} of its runs missing)**");
    text.push_str(
        "Each claim has two verdicts. **Pre-registered**: the rule fixed before the runs, a 95 % \
         Student-t interval of the paired differences off 0. **Exact**: the same comparison by an \
         exact test at two-sided α = 0.05 (the sign-flip permutation test of paired differences \
         of success; McNemar's exact test of paired pass/fail outcomes). Sensitivity: the fewest \
         of the claim's runs whose change flips the verdict, a run changed to the lowest or \
         highest value of the arm it is compared with (a pass/fail outcome: flipped), up to \
         three runs at once. Power: the normal approximation of Colas et al. (2018) at the \
         observed effect and spread.\n\n",
    );

    // Claim 1, first half: the paper's DCP against DDPG on the pinwheel, success paired by seed.
    let missing = missing_runs(all, &["dcp-paper", "ddpg"], walls);
    let adopted = paired(
        &success_of(all, "dcp", walls),
        &success_of(all, "ddpg", walls),
    );
    let head = "- **Claim 1, first half** (with walls, DCP reaches the goal more often than DDPG)";
    if missing > 0 {
        let _ = writeln!(text, "{head}: {}.", undecided(missing));
    } else {
        let runs = [arm(all, "dcp-paper", walls), arm(all, "ddpg", walls)];
        let n = runs[0].len();
        let d = differences(&runs[0], &runs[1]);
        let j = judge_paired(
            &runs,
            n,
            |i| i ^ 1,
            |r| {
                let s = t_side(&differences(&r[..n], &r[n..]));
                Word::of(s == Side::Above, s == Side::Below)
            },
            |r| {
                let s = permutation_side(&differences(&r[..n], &r[n..]), ALPHA);
                Word::of(s == Side::Above, s == Side::Below)
            },
        );
        let _ = writeln!(
            text,
            "{head}: **{}** (pre-registered). Success of the paper's DCP minus DDPG's, paired by \
             seed: {}; {}. Exact: **{}**, sign-flip test {}; {}; {}. (DCP as adopted minus \
             DDPG: {}, sign-flip test {}.)",
            j.pre.text(),
            t_text(&d),
            j.pre_sensitivity,
            j.exact.text(),
            permutation_text(&d),
            j.exact_sensitivity,
            paired_power_text(&d),
            t_text(&adopted),
            permutation_text(&adopted),
        );
    }

    // Claim 1, second half: the drop from open to walls, DDPG and DQN against DCP and PPO.
    let four = ["ddpg", "dqn", "dcp-paper", "ppo"];
    let missing = missing_runs(all, &four, walls) + missing_runs(all, &four, open);
    let head = "- **Claim 1, second half** (walls hurt DDPG and DQN more than DCP and PPO)";
    if missing > 0 {
        let _ = writeln!(text, "{head}: {}.", undecided(missing));
    } else {
        // Arms: each agent open, then with walls; the drop is open minus walls.
        let runs: Vec<Vec<f64>> = four
            .iter()
            .flat_map(|a| [arm(all, a, open), arm(all, a, walls)])
            .collect();
        let n = runs[0].len();
        let drop = |r: &[f64], agent: usize| {
            differences(
                &r[2 * agent * n..(2 * agent + 1) * n],
                &r[(2 * agent + 1) * n..(2 * agent + 2) * n],
            )
        };
        let pairs = [(0, 2), (0, 3), (1, 2), (1, 3)];
        let gaps = move |r: &[f64]| -> Vec<Vec<f64>> {
            pairs
                .iter()
                .map(|&(h, s)| differences(&drop(r, h), &drop(r, s)))
                .collect()
        };
        let j = judge_paired(
            &runs,
            n,
            |i| i ^ 1,
            |r| {
                let sides: Vec<Side> = gaps(r).iter().map(|d| t_side(d)).collect();
                Word::of(
                    sides.iter().all(|s| *s == Side::Above),
                    sides.contains(&Side::Below),
                )
            },
            |r| {
                let g = gaps(r);
                let above = g.iter().all(|d| permutation_side(d, ALPHA) == Side::Above);
                let below = g
                    .iter()
                    .any(|d| permutation_side(d, ALPHA / g.len() as f64) == Side::Below);
                Word::of(above, below)
            },
        );
        let flat = runs.concat();
        let parts: Vec<String> = pairs
            .iter()
            .zip(gaps(&flat))
            .map(|(&(h, s), d)| {
                format!(
                    "{} − {} {}, sign-flip test {}, {}",
                    four[h],
                    four[s],
                    t_text(&d),
                    permutation_text(&d),
                    paired_power_text(&d)
                )
            })
            .collect();
        let drops: Vec<String> = (0..four.len())
            .map(|a| format!("{} {}", four[a], t_text(&drop(&flat, a))))
            .collect();
        let _ = writeln!(
            text,
            "{head}: **{}** (pre-registered; {}). Exact: **{}** (all four above 0 at p < 0.05 \
             to reproduce, any below at p < 0.0125 to contradict; {}). The drop of success from \
             open arena to pinwheel, paired by seed: {}; the drops themselves: {}.",
            j.pre.text(),
            j.pre_sensitivity,
            j.exact.text(),
            j.exact_sensitivity,
            parts.join("; "),
            drops.join(", ")
        );
    }

    text.push_str(&claim2(all));
    text.push_str(&claim3(all));
    text
}

/// Claims 2 and 3 again over the grid's seeds and the added ones
/// ([`Grid::added_runs`]; docs/results/reproduction.md, "Added seeds for claims 2 and 3"):
/// both verdicts by the same rules and tests, with sensitivity and power, beside the grid's
/// own, which stay as they are. Until every added run is in, it says how many are missing and
/// judges nothing; nothing for a grid without added runs (experiment 2).
pub fn added_seeds(
    grid: &Grid,
    all: &[(GridRun, Outcome)],
    added: &[(GridRun, Outcome)],
) -> String {
    if added.is_empty() {
        return String::new();
    }
    let mut text = String::from("## Claims 2 and 3 with the added seeds\n\n");
    let missing = added
        .iter()
        .filter(|(_, o)| matches!(o, Outcome::Missing))
        .count();
    let seeds = |cell_has_sigma: bool| {
        added
            .iter()
            .filter(|(r, _)| r.cell.sigma.is_some() == cell_has_sigma)
            .map(|(r, _)| r.seed)
            .max()
            .unwrap_or(0)
    };
    let _ = writeln!(
        text,
        "Claim 2's cells with seeds 0–{} and claim 3's with seeds 0–{}: the grid's {} seeds and \
         the {} added runs (`host-trainer reproduce {} --added-seeds`), {} of them in.\n",
        seeds(false),
        seeds(true),
        grid.seeds,
        added.len(),
        grid.describe(),
        added.len() - missing,
    );
    if grid.quick {
        text.push_str("No verdict: a quick grid trains a few episodes per run.\n\n");
    } else if missing > 0 {
        let _ = writeln!(
            text,
            "No verdict until every added run is in: {missing} missing.\n"
        );
    } else {
        let combined: Vec<(GridRun, Outcome)> = all.iter().chain(added).cloned().collect();
        text.push_str(&claim2(&combined));
        text.push_str(&claim3(&combined));
        text.push('\n');
    }
    text
}

/// Claim 2's paragraph over every run of its cells in `all` (seeds paired by number).
fn claim2(all: &[(GridRun, Outcome)]) -> String {
    let mut text = String::new();
    let undecided = |missing: usize| format!("**undecided ({missing} of its runs missing)**");
    let walls = |a| Cell::headline(a);
    let lr = |a| Cell {
        reward: RewardKind::Lr,
        ..Cell::headline(a)
    };
    // Claim 2: LR against GR, the paper's DCP and DDPG.
    let missing = missing_runs(all, &["dcp-paper", "ddpg"], walls)
        + missing_runs(all, &["dcp-paper", "ddpg"], lr);
    let head = "- **Claim 2** (DCP's success is robust to the reward form; DDPG's drops with LR)";
    if missing > 0 {
        let _ = writeln!(text, "{head}: {}.", undecided(missing));
    } else {
        let runs = [
            arm(all, "dcp-paper", lr),
            arm(all, "dcp-paper", walls),
            arm(all, "ddpg", lr),
            arm(all, "ddpg", walls),
        ];
        let n = runs[0].len();
        let drops = move |r: &[f64]| {
            (
                differences(&r[..n], &r[n..2 * n]),
                differences(&r[2 * n..3 * n], &r[3 * n..]),
            )
        };
        let rule = |sd: Side, sg: Side| {
            Word::of(
                sg == Side::Below && sd != Side::Below,
                sd == Side::Below && sg != Side::Below,
            )
        };
        let j = judge_paired(
            &runs,
            n,
            |i| i ^ 1,
            |r| {
                let (d, g) = drops(r);
                rule(t_side(&d), t_side(&g))
            },
            |r| {
                let (d, g) = drops(r);
                rule(permutation_side(&d, ALPHA), permutation_side(&g, ALPHA))
            },
        );
        let (d, g) = drops(&runs.concat());
        let _ = writeln!(
            text,
            "{head}: **{}** (pre-registered; {}). Exact: **{}** ({}). Success under LR minus \
             under GR, paired by seed: the paper's DCP {}, sign-flip test {}, {}; DDPG {}, \
             sign-flip test {}, {}.",
            j.pre.text(),
            j.pre_sensitivity,
            j.exact.text(),
            j.exact_sensitivity,
            t_text(&d),
            permutation_text(&d),
            paired_power_text(&d),
            t_text(&g),
            permutation_text(&g),
            paired_power_text(&g),
        );
    }

    text
}

/// Claim 3's paragraph over every run of its cells in `all` (paired by σ and seed).
fn claim3(all: &[(GridRun, Outcome)]) -> String {
    let mut text = String::new();
    let undecided = |missing: usize| format!("**undecided ({missing} of its runs missing)**");
    // Claim 3: training failures under large noise, DDPG against the paper's DCP, paired by σ
    // and seed.
    let missing: usize = LARGE_SIGMAS
        .iter()
        .map(|&sigma| {
            missing_runs(all, &["ddpg", "dcp-paper"], |a| Cell {
                sigma: Some(sigma),
                ..Cell::headline(a)
            })
        })
        .sum();
    let head = "- **Claim 3** (under large exploration noise DDPG's training fails far more often \
                than DCP's)";
    if missing > 0 {
        let _ = writeln!(text, "{head}: {}.", undecided(missing));
    } else {
        let fails_of = |agent: &str| -> Vec<f64> {
            LARGE_SIGMAS
                .iter()
                .flat_map(|&sigma| {
                    let mut f = failures(all, &noise_cell(agent, sigma));
                    f.sort_by_key(|p| p.0);
                    f.into_iter().map(|p| p.1)
                })
                .collect()
        };
        let runs = [fails_of("ddpg"), fails_of("dcp-paper")];
        let n = runs[0].len();
        let alts: Vec<Vec<f64>> = runs.concat().iter().map(|v| vec![1.0 - v]).collect();
        let j = judge(
            &runs.concat(),
            &alts,
            |r| {
                let s = t_side(&differences(&r[..n], &r[n..]));
                Word::of(s == Side::Above, s == Side::Below)
            },
            |r| {
                let s = mcnemar_side(&differences(&r[..n], &r[n..]), ALPHA);
                Word::of(s == Side::Above, s == Side::Below)
            },
        );
        let d = differences(&runs[0], &runs[1]);
        let (b, c) = discordant(&d);
        let k = |r: &[f64]| r.iter().filter(|v| **v > 0.5).count();
        let (kg, kc) = (k(&runs[0]), k(&runs[1]));
        let (pg, pc) = (kg as f64 / n as f64, kc as f64 / n as f64);
        let needed =
            seeds_for_rate_difference(pg, pc, ALPHA, POWER).map_or("–".into(), |s| s.to_string());
        let _ = writeln!(
            text,
            "{head}: **{}** (pre-registered; failed trainings of DDPG minus the paper's DCP, \
             paired by σ and seed: {n} pairs, mean {}; {}). Exact: **{}**, McNemar's exact \
             test on the {} discordant pairs ({b} where only DDPG failed, {c} where only DCP \
             did): p = {:.4}; {}. Failure rates: DDPG {kg} of {n}, {}; the paper's DCP {kc} of \
             {n}, {}. Power {:.2} at {n} runs per agent for the observed {pg:.2} against \
             {pc:.2}; {POWER} needs {needed} per agent.",
            j.pre.text(),
            student_t::interval_text(&d, 2),
            j.pre_sensitivity,
            j.exact.text(),
            b + c,
            crate::stats::binomial::mcnemar_exact(b, c),
            j.exact_sensitivity,
            rate_text(kg, n),
            rate_text(kc, n),
            power_rate_difference(pg, pc, n as u64, ALPHA),
        );
    }
    text
}

/// The success of `agent`'s runs in `cell`'s settings, by seed (a failed run as 0).
fn arm(all: &[(GridRun, Outcome)], agent: &str, cell: impl Fn(Agent) -> Cell) -> Vec<f64> {
    let mut runs = success_of(all, agent, cell);
    runs.sort_by_key(|r| r.0);
    runs.into_iter().map(|r| r.1).collect()
}

/// [`judge`] over arms of `n` runs each, a run's alternatives the extremes of its partner arm.
fn judge_paired<A: AsRef<[f64]>>(
    arms: &[A],
    n: usize,
    partner: fn(usize) -> usize,
    pre: impl Fn(&[f64]) -> Word,
    exact: impl Fn(&[f64]) -> Word,
) -> Judged {
    let runs: Vec<f64> = arms.iter().flat_map(|a| a.as_ref().to_vec()).collect();
    let alts = partner_extremes(&runs, n, partner);
    judge(&runs, &alts, pre, exact)
}

/// The success of every run of `agent`'s five network sizes (pinwheel, GR), one list per size:
/// Table 1's cells as the tasks of an aggregate.
pub fn size_tasks(all: &[(GridRun, Outcome)], agent: Agent) -> Vec<Vec<f64>> {
    SIZES
        .iter()
        .map(|&size| {
            let cell = Cell {
                size,
                ..Cell::headline(agent)
            };
            CellRuns::of(all, &cell)
                .success()
                .iter()
                .map(|s| s.1)
                .collect()
        })
        .collect()
}

/// Table 1's cells as tasks: per agent, the interquartile mean of success over every run of
/// its five network sizes, and the probability that a run of it beats a run of DDPG at the
/// same size, each with a stratified bootstrap interval (runs resampled within each size).
pub fn sizes_aggregate(all: &[(GridRun, Outcome)]) -> String {
    let tasks = |agent: Agent| size_tasks(all, agent);
    let ddpg = tasks(Agent::named("ddpg").expect("ddpg is an agent"));
    let mut t = String::from(
        "| agent | runs | IQM of success [95 % stratified bootstrap] | P(a run beats DDPG's at the same size) [95 %] |\n|---|---|---|---|\n",
    );
    for agent in AGENTS {
        let own = tasks(agent);
        let runs: usize = own.iter().map(Vec::len).sum();
        if own.iter().any(Vec::is_empty) {
            let _ = writeln!(t, "| {} | {runs} | – | – |", agent.name);
            continue;
        }
        let i = iqm_ci(&own, CONFIDENCE, REPS, SEED);
        let poi = probability_of_improvement_ci(&own, &ddpg, CONFIDENCE, REPS, SEED);
        let _ = writeln!(
            t,
            "| {} | {runs} | {:.2} [{:.2}, {:.2}] | {:.2} [{:.2}, {:.2}] |",
            agent.name, i.estimate, i.lo, i.hi, poi.estimate, poi.lo, poi.hi
        );
    }
    t
}

/// The runs not finished, as `cell seed` lines.
pub fn missing(all: &[(GridRun, Outcome)]) -> Vec<String> {
    all.iter()
        .filter(|(_, o)| matches!(o, Outcome::Missing))
        .map(|(run, _)| format!("{} seed {}", run.cell.name(), run.seed))
        .collect()
}

/// Each agent's training time per run: its headline cell's runs (4×48, GR, pinwheel), and the
/// range over all its runs.
pub fn run_times(all: &[(GridRun, Outcome)]) -> String {
    let mut t = String::from(
        "| agent | runs timed | seconds per run, 4×48 pinwheel (mean [95 %]) | per seed | all its runs: min – max |\n|---|---|---|---|---|\n",
    );
    for agent in AGENTS {
        let headline = CellRuns::of(all, &Cell::headline(agent));
        let timed: Vec<(u64, f64)> = headline
            .finished()
            .filter_map(|(seed, f)| f.training_seconds.map(|s| (seed, s)))
            .collect();
        let values: Vec<f64> = timed.iter().map(|t| t.1).collect();
        let every: Vec<f64> = all
            .iter()
            .filter(|(run, _)| run.cell.agent == agent)
            .filter_map(|(_, o)| match o {
                Outcome::Finished(f) => f.training_seconds,
                _ => None,
            })
            .collect();
        let range = match (
            every.iter().copied().reduce(f64::min),
            every.iter().copied().reduce(f64::max),
        ) {
            (Some(lo), Some(hi)) => format!("{lo:.0} – {hi:.0} ({} runs)", every.len()),
            _ => "–".into(),
        };
        let per_seed = timed
            .iter()
            .map(|(_, v)| format!("{v:.0}"))
            .collect::<Vec<_>>()
            .join(", ");
        let mean = clipped_text(&values, 0, NON_NEGATIVE);
        let _ = writeln!(
            t,
            "| {} | {} | {mean} | {per_seed} | {range} |",
            agent.name,
            values.len()
        );
    }
    t
}

/// The page's tables and verdicts (the caller adds the header, figures and missing runs).
pub fn body(grid: &Grid, all: &[(GridRun, Outcome)]) -> String {
    let mut page = String::new();
    let _ = writeln!(
        page,
        "## Table 1: network sizes (pinwheel, GR)\n\nThe mean over seeds 0–{} and its 95 % \
         Student-t interval, clipped to the quantity's range (a rate to [0, 1], an error to \
         [0, ∞)); \"all 5 equal\" where every seed gave the same value, which leaves no spread \
         to build an interval from. Success counts a failed run as 0.\n\n{}",
        grid.seeds.saturating_sub(1),
        table1(all)
    );
    let _ = writeln!(
        page,
        "## Table 2: reward forms (pinwheel, 4×48)\n\n{}",
        table2(all)
    );
    let _ = writeln!(
        page,
        "## Table 3: training failure under large exploration noise (pinwheel, 4×48, GR)\n\nA \
         failed training: success on fewer than half the test starts (or a run that failed). The \
         failure rate is a count of runs, shown with its exact (Clopper–Pearson) 95 % \
         interval.\n\n{}",
        table3(all)
    );
    let _ = writeln!(
        page,
        "## Across network sizes (table 1's cells as tasks)\n\nThe interquartile mean of success \
         over the runs of an agent's five sizes, and the probability that a run of it beats a \
         run of DDPG at the same size (averaged over sizes, a tie counting half), each with a \
         95 % stratified bootstrap interval ({REPS} resamples of the runs within each size, \
         seed {SEED}), as rliable computes them. Figure 8 draws the whole distribution behind \
         them: for each threshold τ, the share of an agent's runs (each size weighing the \
         same) whose success is above τ, with its band from the same resamples.\n\n{}",
        sizes_aggregate(all)
    );
    let _ = writeln!(
        page,
        "## With and without walls (4×48, GR: the runs of figures 4–7 and of claim 1)\n\n{}",
        layouts_table(all)
    );
    let _ = writeln!(
        page,
        "## Run time per agent\n\nSeconds of training per run, from each run's `metrics.csv` \
         (episodes only; evaluation and checkpoints left out), on the machines and loads of the \
         parts above.\n\n{}",
        run_times(all)
    );
    let _ = writeln!(page, "## Claims 1–3\n");
    if grid.quick {
        let _ = writeln!(
            page,
            "No verdict: a quick grid trains a few episodes per run, a test of the machinery, \
             not a result.\n"
        );
    } else {
        page.push_str(&verdicts(all));
        page.push('\n');
    }
    page
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reproduce::folder::Finished;
    use crate::reproduce::grid::Experiment;
    use firmware_sim::nav::reference::reference;
    use firmware_sim::nav::scenario::Scenario;
    use firmware_sim::nav::test_protocol::{evaluate_controller, EvalConfig};

    /// The five-seed grid.
    const GRID: Grid = Grid {
        experiment: Experiment::Exp1,
        seeds: 5,
        quick: false,
    };

    /// A five-seed grid whose every run finished with success `success(cell, seed)`.
    fn grid_with(success: impl Fn(&Cell, u64) -> f64) -> Vec<(GridRun, Outcome)> {
        finished(GRID.runs(), success)
    }

    /// `runs`, every one finished with success `success(cell, seed)`.
    fn finished(
        runs: Vec<GridRun>,
        success: impl Fn(&Cell, u64) -> f64,
    ) -> Vec<(GridRun, Outcome)> {
        let s = Scenario::builtin("nav-walls").expect("built in");
        let mut oracle = reference("oracle", &s).expect("the oracle");
        let cfg = EvalConfig {
            episodes: 2,
            ..EvalConfig::default()
        };
        let report = evaluate_controller(oracle.as_mut(), &s, &cfg).expect("runs");
        runs.into_iter()
            .map(|run| {
                let mut report = report.clone();
                report.success_rate = success(&run.cell, run.seed);
                let finished = Finished {
                    dir: "unused".into(),
                    training_seconds: Some(100.0 + run.seed as f64),
                    config: run.cell.config(false),
                    report,
                };
                (run, Outcome::Finished(Box::new(finished)))
            })
            .collect()
    }

    fn verdict_of<'a>(text: &'a str, claim: &str) -> &'a str {
        let line = text
            .lines()
            .find(|l| l.contains(claim))
            .expect("the claim's line");
        let from = line.find("): **").expect("a verdict") + 5;
        &line[from..from + line[from..].find("**").expect("bold")]
    }

    /// Each claim's verdict in `text` is the one expected.
    fn assert_verdicts(text: &str, expected: &[(&str, &str)]) {
        for (claim, verdict) in expected {
            assert_eq!(verdict_of(text, claim), *verdict, "{claim}: {text}");
        }
    }

    /// The paper's story: DCP ahead with walls, DDPG hurt by walls, by LR and by noise.
    fn paper_story() -> Vec<(GridRun, Outcome)> {
        let jitter = |seed: u64| 0.01 * seed as f64;
        grid_with(|cell, seed| {
            let agent = cell.agent.name;
            match (cell.walls, cell.reward, cell.sigma) {
                (Walls::Without, _, _) => 1.0,
                (_, _, Some(_)) if agent == "ddpg" => 0.1,
                (_, RewardKind::Lr, _) if agent == "ddpg" => 0.2 + jitter(seed),
                _ if agent == "ddpg" || agent == "dqn" => 0.5 + jitter(seed),
                _ => 0.9 + jitter(seed),
            }
        })
    }

    #[test]
    fn the_added_seeds_judge_claims_2_and_3_again_once_all_are_in() {
        // DDPG fails to train on seeds 0, 1, 5 and 6 at both σ, the paper's DCP never: four
        // discordant pairs of the grid's ten (McNemar p = 0.125), eight of the twenty with the
        // added seeds (p = 0.0078).
        let story = |cell: &Cell, seed: u64| match (cell.agent.name, cell.sigma) {
            ("ddpg", Some(_)) if [0, 1, 5, 6].contains(&seed) => 0.1,
            _ => 0.9 + 0.01 * seed as f64,
        };
        let all = grid_with(story);
        let added = finished(GRID.added_runs(), story);
        assert_eq!(exact_of(&verdicts(&all), "Claim 3"), "not reproduced");
        let text = added_seeds(&GRID, &all, &added);
        assert!(
            text.starts_with("## Claims 2 and 3 with the added seeds"),
            "{text}"
        );
        assert!(text.contains("36 added runs"), "{text}");
        assert_eq!(exact_of(&text, "Claim 3"), "reproduced", "{text}");
        assert!(text.contains("20 pairs"), "{text}");
        assert!(text.contains("over 9 seeds"), "{text}");
        // One added run missing: no verdict, and the count.
        let mut partial = added;
        partial[3].1 = Outcome::Missing;
        let text = added_seeds(&GRID, &all, &partial);
        assert!(
            text.contains("No verdict until every added run is in: 1 missing."),
            "{text}"
        );
        assert!(!text.contains("Claim 3"), "{text}");
        // Experiment 2 has none: no section.
        let exp2 = Grid {
            experiment: Experiment::Exp2,
            ..GRID
        };
        assert_eq!(added_seeds(&exp2, &all, &[]), "");
    }

    #[test]
    fn the_claims_follow_their_rules() {
        let jitter = |seed: u64| 0.01 * seed as f64;
        let story = paper_story();
        let text = verdicts(&story);
        assert_verdicts(
            &text,
            &[
                ("Claim 1, first half", "reproduced"),
                ("Claim 1, second half", "reproduced"),
                ("Claim 2", "reproduced"),
                ("Claim 3", "reproduced"),
            ],
        );
        // The other way round, and a tie.
        let reversed = grid_with(|cell, seed| {
            let agent = cell.agent.name;
            match (cell.walls, cell.sigma) {
                (Walls::Without, _) => 1.0,
                (_, Some(_)) if agent == "dcp-paper" => 0.1,
                _ if agent == "dcp-paper" || agent == "ppo" => 0.3 + jitter(seed),
                (_, Some(_)) => 0.9,
                _ => 0.8 + jitter(seed % 2),
            }
        });
        let text = verdicts(&reversed);
        assert_verdicts(
            &text,
            &[
                ("Claim 1, first half", "contradicted"),
                ("Claim 1, second half", "contradicted"),
                ("Claim 2", "not reproduced"),
                ("Claim 3", "contradicted"),
            ],
        );
    }

    /// The verdict by exact tests on a claim's line.
    fn exact_of<'a>(text: &'a str, claim: &str) -> &'a str {
        let line = text
            .lines()
            .find(|l| l.contains(claim))
            .expect("the claim's line");
        let from = line.find("Exact: **").expect("an exact verdict") + 9;
        &line[from..from + line[from..].find("**").expect("bold")]
    }

    #[test]
    fn exact_verdicts_stand_beside_the_pre_registered_ones() {
        // The paper's story: the t rule reproduces every claim; five pairs cannot reach
        // p < 0.05 by a sign-flip test, but ten pass/fail pairs all one way can by McNemar's.
        let story = paper_story();
        let text = verdicts(&story);
        for claim in ["Claim 1, first half", "Claim 1, second half", "Claim 2"] {
            assert_eq!(verdict_of(&text, claim), "reproduced", "{text}");
            assert_eq!(exact_of(&text, claim), "not reproduced", "{text}");
        }
        assert_eq!(exact_of(&text, "Claim 3"), "reproduced", "{text}");
        assert!(
            text.contains("p = 0.0020"),
            "McNemar on 10 pairs one way: {text}"
        );
        assert!(text.contains("p = 0.0625 (exact over 32)"), "{text}");
        assert!(
            text.contains("no change of up to 3 of the 10 runs flips it"),
            "{text}"
        );
    }

    #[test]
    fn a_claim_with_missing_runs_is_undecided() {
        // The paper's story on every cell but one DDPG seed under large noise and LR.
        let mut story = grid_with(|cell, _| {
            if cell.agent.name == "ddpg" && cell.walls == Walls::With {
                0.1
            } else {
                0.9
            }
        });
        for (run, outcome) in &mut story {
            let noisy = run.cell.sigma == Some(LARGE_SIGMAS[0]);
            if run.cell.agent.name == "ddpg"
                && run.seed == 3
                && (noisy || run.cell.reward == RewardKind::Lr)
            {
                *outcome = Outcome::Missing;
            }
        }
        let text = verdicts(&story);
        assert_verdicts(
            &text,
            &[
                ("Claim 1, first half", "reproduced"),
                ("Claim 2", "undecided (1 of its runs missing)"),
                ("Claim 3", "undecided (1 of its runs missing)"),
            ],
        );
    }

    #[test]
    fn run_times_come_per_agent_from_the_headline_cell() {
        let all = grid_with(|_, _| 1.0);
        let table = run_times(&all);
        // training_seconds is 100 + seed for every run of the made-up grid.
        assert!(
            table.contains("| dcp | 5 | 102 [100, 104] | 100, 101, 102, 103, 104 | 100 – 104 ("),
            "{table}"
        );
        assert_eq!(table.lines().count(), 2 + AGENTS.len());
    }

    #[test]
    fn the_layouts_table_has_both_layouts_of_every_agent() {
        let all = grid_with(|cell, seed| match cell.walls {
            Walls::With => 0.5 + 0.1 * seed as f64,
            Walls::Without => 1.0,
        });
        let table = layouts_table(&all);
        assert_eq!(table.lines().count(), 2 + 2 * AGENTS.len());
        assert!(
            table.contains("| ddpg | pinwheel | 5 / 0 / 0 | 0.70 [0.50, 0.90] |"),
            "{table}"
        );
        assert!(
            table.contains("| ddpg | open arena | 5 / 0 / 0 | 1.00 (all 5 equal) |"),
            "{table}"
        );
    }

    #[test]
    fn the_side_of_an_interval() {
        assert_eq!(side(&[0.5, 0.6, 0.7]), Side::Above);
        assert_eq!(side(&[-0.5, -0.6, -0.7]), Side::Below);
        assert_eq!(side(&[-0.5, 0.6, 0.1]), Side::Spans);
        assert_eq!(side(&[0.5]), Side::Spans); // one pair has no interval
        assert_eq!(side(&[]), Side::Spans);
    }

    #[test]
    fn pairs_are_by_seed() {
        let a = [(0, 1.0), (1, 0.5), (3, 0.2)];
        let b = [(1, 0.25), (0, 0.5), (2, 9.0)];
        assert_eq!(paired(&a, &b), [0.5, 0.25]);
    }
}
