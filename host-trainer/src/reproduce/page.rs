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
use crate::run::config::RewardKind;
use crate::stats::student_t as stats;

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

fn interval_text(values: &[f64]) -> String {
    stats::interval_text(values, 2)
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
        interval_text(&success),
        interval_text(&cells.metric(|f| f.report.mean_error)),
        interval_text(&cells.metric(|f| f.report.strict_reach_rate)),
        interval_text(&cells.metric(|f| f.report.near_pass_rate)),
        interval_text(&cells.metric(|f| f.report.stuck_rate)),
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
                interval_text(&fails.iter().map(|f| f.1).collect::<Vec<_>>()),
                interval_text(&values),
                per_seed(&success),
            );
        }
    }
    t
}

/// Where a paired difference's 95 % interval lies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// Entirely above 0.
    Above,
    /// Entirely below 0.
    Below,
    /// Holds 0, or too few pairs for an interval.
    Spans,
}

/// The side of 0 the interval of `values` lies on.
pub fn side(values: &[f64]) -> Side {
    match stats::against(values, 0.0) {
        std::cmp::Ordering::Greater => Side::Above,
        std::cmp::Ordering::Less => Side::Below,
        std::cmp::Ordering::Equal => Side::Spans,
    }
}

/// `a − b` for the seeds both have.
fn paired(a: &[(u64, f64)], b: &[(u64, f64)]) -> Vec<f64> {
    a.iter()
        .filter_map(|&(seed, x)| b.iter().find(|p| p.0 == seed).map(|p| x - p.1))
        .collect()
}

fn difference_text(values: &[f64]) -> String {
    format!("{} over {} seeds", interval_text(values), values.len())
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

/// The verdicts on claims 1–3, one paragraph each, by the rules written before the runs.
///
/// A claim whose cells still miss runs is undecided: a rule read off part of its seeds could
/// turn once the rest are in, so the page says how many are missing instead.
pub fn verdicts(all: &[(GridRun, Outcome)]) -> String {
    let word = |missing: usize, reproduced: bool, contradicted: bool| {
        if missing > 0 {
            format!("undecided ({missing} of its runs missing)")
        } else if contradicted {
            "contradicted".into()
        } else if reproduced {
            "reproduced".into()
        } else {
            "not reproduced".into()
        }
    };
    let mut text = String::new();
    let walls = |a| Cell::headline(a);
    let open = |a| Cell {
        walls: Walls::Without,
        ..Cell::headline(a)
    };

    // Claim 1, first half: the paper's DCP against DDPG on the pinwheel, success paired by seed.
    let d = paired(
        &success_of(all, "dcp-paper", walls),
        &success_of(all, "ddpg", walls),
    );
    let s = side(&d);
    let adopted = paired(
        &success_of(all, "dcp", walls),
        &success_of(all, "ddpg", walls),
    );
    let _ = writeln!(
        text,
        "- **Claim 1, first half** (with walls, DCP reaches the goal more often than DDPG): \
         **{}**. Success of the paper's DCP minus DDPG's, paired by seed: {}. (DCP as adopted \
         minus DDPG: {}.)",
        word(
            missing_runs(all, &["dcp-paper", "ddpg"], walls),
            s == Side::Above,
            s == Side::Below
        ),
        difference_text(&d),
        difference_text(&adopted)
    );

    // Claim 1, second half: the drop from open to walls, DDPG and DQN against DCP and PPO.
    let per_seed_drop = |agent: &str| -> Vec<(u64, f64)> {
        let o = success_of(all, agent, open);
        let w = success_of(all, agent, walls);
        o.iter()
            .filter_map(|&(seed, x)| w.iter().find(|p| p.0 == seed).map(|p| (seed, x - p.1)))
            .collect()
    };
    let mut sides = Vec::new();
    let mut parts = Vec::new();
    for hurt in ["ddpg", "dqn"] {
        for spared in ["dcp-paper", "ppo"] {
            let diff = paired(&per_seed_drop(hurt), &per_seed_drop(spared));
            sides.push(side(&diff));
            parts.push(format!("{hurt} − {spared} {}", difference_text(&diff)));
        }
    }
    let _ = writeln!(
        text,
        "- **Claim 1, second half** (walls hurt DDPG and DQN more than DCP and PPO): **{}**. \
         The drop of success from open arena to pinwheel, paired by seed: {}; the drops \
         themselves: {}.",
        word(
            missing_runs(all, &["dcp-paper", "ddpg", "ppo", "dqn"], walls)
                + missing_runs(all, &["dcp-paper", "ddpg", "ppo", "dqn"], open),
            sides.iter().all(|s| *s == Side::Above),
            sides.contains(&Side::Below)
        ),
        parts.join("; "),
        ["dcp-paper", "ddpg", "ppo", "dqn"]
            .map(|a| {
                let drop: Vec<f64> = per_seed_drop(a).iter().map(|d| d.1).collect();
                format!("{a} {}", difference_text(&drop))
            })
            .join(", ")
    );

    // Claim 2: LR against GR, DDPG and the paper's DCP.
    let lr = |a| Cell {
        reward: RewardKind::Lr,
        ..Cell::headline(a)
    };
    let lr_minus_gr =
        |agent: &str| paired(&success_of(all, agent, lr), &success_of(all, agent, walls));
    let (dcp2, ddpg2) = (lr_minus_gr("dcp-paper"), lr_minus_gr("ddpg"));
    let (sd, sg) = (side(&dcp2), side(&ddpg2));
    let _ = writeln!(
        text,
        "- **Claim 2** (DCP's success is robust to the reward form; DDPG's drops with LR): \
         **{}**. Success under LR minus under GR, paired by seed: the paper's DCP {}, DDPG {}.",
        word(
            missing_runs(all, &["dcp-paper", "ddpg"], walls)
                + missing_runs(all, &["dcp-paper", "ddpg"], lr),
            sg == Side::Below && sd != Side::Below,
            sd == Side::Below && sg != Side::Below
        ),
        difference_text(&dcp2),
        difference_text(&ddpg2)
    );

    // Claim 3: training failures under large noise, DDPG minus the paper's DCP, paired by σ and seed.
    let mut diff = Vec::new();
    for sigma in LARGE_SIGMAS {
        let (g, c) = (
            failures(all, &noise_cell("ddpg", sigma)),
            failures(all, &noise_cell("dcp-paper", sigma)),
        );
        diff.extend(paired(&g, &c));
    }
    let s = side(&diff);
    let missing: usize = LARGE_SIGMAS
        .iter()
        .map(|&sigma| {
            missing_runs(all, &["ddpg", "dcp-paper"], |a| Cell {
                sigma: Some(sigma),
                ..Cell::headline(a)
            })
        })
        .sum();
    let _ = writeln!(
        text,
        "- **Claim 3** (under large exploration noise DDPG's training fails far more often than \
         DCP's): **{}**. Failed trainings of DDPG minus the paper's DCP, paired by σ and seed: {} \
         pairs, mean {}.",
        word(missing, s == Side::Above, s == Side::Below),
        diff.len(),
        interval_text(&diff)
    );
    text
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
        "| agent | runs timed | seconds per run, 4×48 pinwheel (mean ± 95 %) | per seed | all its runs: min – max |\n|---|---|---|---|---|\n",
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
        let mean = stats::interval_text(&values, 0);
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
        "## Table 1: network sizes (pinwheel, GR)\n\nMean ± 95 % interval (Student t) over seeds \
         0–{}; success counts a failed run as 0.\n\n{}",
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
         failed training: success on fewer than half the test starts (or a run that failed).\n\n{}",
        table3(all)
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

    /// A five-seed grid whose every run finished with success `success(cell, seed)`.
    fn grid_with(success: impl Fn(&Cell, u64) -> f64) -> Vec<(GridRun, Outcome)> {
        let s = Scenario::builtin("nav-walls").expect("built in");
        let mut oracle = reference("oracle", &s).expect("the oracle");
        let cfg = EvalConfig {
            episodes: 2,
            ..EvalConfig::default()
        };
        let report = evaluate_controller(oracle.as_mut(), &s, &cfg).expect("runs");
        let grid = Grid {
            experiment: Experiment::Exp1,
            seeds: 5,
            quick: false,
        };
        grid.runs()
            .into_iter()
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

    #[test]
    fn the_claims_follow_their_rules() {
        let jitter = |seed: u64| 0.01 * seed as f64;
        // The paper's story: DCP ahead with walls, DDPG hurt by walls, by LR and by noise.
        let story = grid_with(|cell, seed| {
            let agent = cell.agent.name;
            match (cell.walls, cell.reward, cell.sigma) {
                (Walls::Without, _, _) => 1.0,
                (_, _, Some(_)) if agent == "ddpg" => 0.1,
                (_, RewardKind::Lr, _) if agent == "ddpg" => 0.2 + jitter(seed),
                _ if agent == "ddpg" || agent == "dqn" => 0.5 + jitter(seed),
                _ => 0.9 + jitter(seed),
            }
        });
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
            table.contains("| dcp | 5 | 102 ± 2 | 100, 101, 102, 103, 104 | 100 – 104 ("),
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
            table.contains("| ddpg | pinwheel | 5 / 0 / 0 | 0.70 ± 0.20 |"),
            "{table}"
        );
        assert!(
            table.contains("| ddpg | open arena | 5 / 0 / 0 | 1.00 ± 0.00 |"),
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
