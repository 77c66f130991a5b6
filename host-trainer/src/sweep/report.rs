//! Reporting a sweep: one row per run; then per (task, algo) the mean of each column over the
//! finished seeds with its 95 % percentile bootstrap interval, and the failed trainings as a
//! count of runs with its exact (Clopper–Pearson) interval; per task, each pair of algos on
//! the seeds both finished, compared by the exact sign-flip permutation test; and where a sweep
//! spans several tasks, each algo's interquartile mean of success over every task with its
//! stratified bootstrap interval. As Markdown and JSON; docs/design.md §7 says why these.
//!
//! Every resample comes from the stream seeded [`SEED`], so the same runs give the same text.

use std::fmt::Write as _;
use std::path::Path;

use firmware_sim::files;
use serde::Serialize;

use super::record::{exit_text, RunRecord, Status};
use crate::algorithms::Algo;
use crate::stats::aggregate::iqm_ci;
use crate::stats::binomial::clopper_pearson;
use crate::stats::bootstrap::{mean_ci, mean_text, Interval};
use crate::stats::permutation::{sign_flip_permutation, Draws, PValue};
use crate::stats::{CONFIDENCE, REPS, SEED};
use crate::Error;

/// The summary table, in the sweep's output folder.
pub const SUMMARY_MD: &str = "sweep.md";
/// The summary as JSON.
pub const SUMMARY_JSON: &str = "sweep.json";

/// A training has failed when its run failed or its policy succeeds on fewer than this share
/// of the test starts (docs/design.md §2's training failure).
pub const FAILED_BELOW: f64 = 0.5;

/// A column of the summary: header, JSON key, value of a run, decimals.
struct Column {
    header: &'static str,
    key: &'static str,
    value: fn(&RunRecord) -> Option<f64>,
    decimals: usize,
}

/// Rates are shown in percent, as `train` and `eval` print them.
const COLUMNS: [Column; 6] = [
    Column {
        header: "wall s",
        key: "wall_seconds",
        value: |r| r.wall_seconds,
        decimals: 1,
    },
    Column {
        header: "success %",
        key: "success_pct",
        value: |r| r.eval.map(|e| 100.0 * e.success_rate),
        decimals: 1,
    },
    Column {
        header: "settled error",
        key: "mean_error",
        value: |r| r.eval.and_then(|e| e.mean_error),
        decimals: 3,
    },
    Column {
        header: "stuck at margin %",
        key: "stuck_pct",
        value: |r| r.eval.map(|e| 100.0 * e.stuck_rate),
        decimals: 1,
    },
    Column {
        header: "pass within 0.25 %",
        key: "near_pass_pct",
        value: |r| r.eval.and_then(|e| e.near_pass_rate).map(|v| 100.0 * v),
        decimals: 1,
    },
    Column {
        header: "strict reach %",
        key: "strict_reach_pct",
        value: |r| r.eval.and_then(|e| e.strict_reach_rate).map(|v| 100.0 * v),
        decimals: 1,
    },
];

/// The columns two algos are compared on: success, settled error, stuck at margin.
const COMPARED: [usize; 3] = [1, 2, 3];

/// The (task, algo) groups in first-seen order, each with all its runs.
fn groups(records: &[RunRecord]) -> Vec<((String, Algo), Vec<&RunRecord>)> {
    let mut groups: Vec<((String, Algo), Vec<&RunRecord>)> = Vec::new();
    for r in records {
        let key = (r.task.clone(), r.algo);
        match groups.iter_mut().find(|(k, _)| *k == key) {
            Some((_, runs)) => runs.push(r),
            None => groups.push((key, vec![r])),
        }
    }
    groups
}

/// The runs with a result (finished or skipped), whose columns are averaged.
fn with_result<'a>(runs: &[&'a RunRecord]) -> Vec<&'a RunRecord> {
    runs.iter().copied().filter(|r| r.eval.is_some()).collect()
}

fn column_values(runs: &[&RunRecord], column: &Column) -> Vec<f64> {
    runs.iter().filter_map(|r| (column.value)(r)).collect()
}

/// Failed trainings among the runs that ended (finished, skipped or failed): `(failed, of)`.
fn failed_trainings(runs: &[&RunRecord]) -> (u64, u64) {
    let ended = runs.iter().filter(|r| {
        matches!(
            r.status,
            Status::Finished | Status::Skipped | Status::Failed
        )
    });
    let (mut failed, mut of) = (0, 0);
    for r in ended {
        of += 1;
        let below = r.eval.is_some_and(|e| e.success_rate < FAILED_BELOW);
        failed += u64::from(r.status == Status::Failed || below);
    }
    (failed, of)
}

/// `k of n, rate [lo, hi]` with the Clopper–Pearson interval; `–` for no runs.
fn count_text((k, n): (u64, u64)) -> String {
    if n == 0 {
        return "–".into();
    }
    let (lo, hi) = clopper_pearson(k, n, CONFIDENCE);
    format!("{k} of {n}, {:.2} [{lo:.2}, {hi:.2}]", k as f64 / n as f64)
}

/// Two algos of one task on the seeds both have a value for: per compared column, the mean
/// difference (first minus second) over those seeds and the sign-flip p.
struct Comparison<'a> {
    task: &'a str,
    first: Algo,
    second: Algo,
    /// Per compared column: the pairs, the mean difference and its p (`None` without pairs).
    columns: Vec<Option<(usize, f64, PValue)>>,
}

/// The paired differences `first − second` of `column` by seed.
fn paired(first: &[&RunRecord], second: &[&RunRecord], column: &Column) -> Vec<f64> {
    first
        .iter()
        .filter_map(|a| {
            let b = second.iter().find(|b| b.seed == a.seed)?;
            Some((column.value)(a)? - (column.value)(b)?)
        })
        .collect()
}

/// Every pair of algos within each task, in first-seen order.
fn comparisons<'a>(groups: &'a [((String, Algo), Vec<&'a RunRecord>)]) -> Vec<Comparison<'a>> {
    let mut out = Vec::new();
    for (i, ((task, first), a)) in groups.iter().enumerate() {
        for ((other_task, second), b) in &groups[i + 1..] {
            if other_task != task {
                continue;
            }
            let (a, b) = (with_result(a), with_result(b));
            let columns = COMPARED
                .iter()
                .map(|&c| {
                    let d = paired(&a, &b, &COLUMNS[c]);
                    (!d.is_empty()).then(|| {
                        let mean = d.iter().sum::<f64>() / d.len() as f64;
                        (d.len(), mean, sign_flip_permutation(&d, REPS as u64, SEED))
                    })
                })
                .collect();
            out.push(Comparison {
                task,
                first: *first,
                second: *second,
                columns,
            });
        }
    }
    out
}

/// `mean, p P (n pairs)`; `–` without pairs.
fn comparison_text(cell: Option<(usize, f64, PValue)>, decimals: usize) -> String {
    match cell {
        None => "–".into(),
        Some((n, mean, p)) => format!("{mean:+.decimals$}, p {:.3} ({n} pairs)", p.p),
    }
}

/// Per algo over several tasks: the interquartile mean of success (percent) over every
/// finished run, with its stratified bootstrap interval (runs resampled within each task).
fn across_tasks(records: &[RunRecord]) -> Vec<(Algo, usize, usize, Interval)> {
    let groups = groups(records);
    let mut algos: Vec<Algo> = Vec::new();
    for ((_, algo), _) in &groups {
        if !algos.contains(algo) {
            algos.push(*algo);
        }
    }
    algos
        .into_iter()
        .filter_map(|algo| {
            let tasks: Vec<Vec<f64>> = groups
                .iter()
                .filter(|((_, a), _)| *a == algo)
                .map(|(_, runs)| column_values(&with_result(runs), &COLUMNS[1]))
                .filter(|values| !values.is_empty())
                .collect();
            let runs = tasks.iter().map(Vec::len).sum();
            (tasks.len() > 1).then(|| {
                (
                    algo,
                    tasks.len(),
                    runs,
                    iqm_ci(&tasks, CONFIDENCE, REPS, SEED),
                )
            })
        })
        .collect()
}

/// The summary as markdown: the runs, the means with their intervals, the paired comparisons,
/// and the interquartile mean across tasks.
pub fn markdown(records: &[RunRecord]) -> String {
    let mut md = runs_table(records);
    md.push_str(&means_table(records));
    md.push_str(&comparisons_table(records));
    md.push_str(&across_tasks_table(records));
    md
}

fn runs_table(records: &[RunRecord]) -> String {
    let headers: Vec<&str> = COLUMNS.iter().map(|c| c.header).collect();
    let mut md = String::from("## Runs\n\n");
    let _ = writeln!(
        md,
        "| task | algo | seed | status | {} | note |",
        headers.join(" | ")
    );
    let _ = writeln!(
        md,
        "|---|---|---:|---|{}---|",
        "---:|".repeat(COLUMNS.len())
    );
    for r in records {
        let cells: Vec<String> = COLUMNS
            .iter()
            .map(|c| (c.value)(r).map_or("-".into(), |v| format!("{v:.*}", c.decimals)))
            .collect();
        let note = match r.status {
            Status::Failed | Status::Interrupted => format!(
                "{}: {}",
                exit_text(r),
                r.last_line.as_deref().unwrap_or("no output")
            ),
            _ => String::new(),
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} |",
            r.task,
            r.algo,
            r.seed,
            status_text(r.status),
            cells.join(" | "),
            note.replace('|', "\\|")
        );
    }
    md
}

fn means_table(records: &[RunRecord]) -> String {
    let headers: Vec<&str> = COLUMNS.iter().map(|c| c.header).collect();
    let mut md = String::from("\n## Mean and 95 % interval over the finished seeds\n\n");
    let _ = writeln!(
        md,
        "Each column: the mean over the seeds with its percentile bootstrap interval ({REPS} \
         resamples of the seeds, seed {SEED}), which stays within the values seen; seeds that \
         all gave one value say so and have no interval. Over five seeds it is narrower than a \
         t interval: it shows the seeds' spread, the tests below decide. Failed trainings (a \
         failed run, or success on fewer than {:.0} % of the test starts) are a count of the \
         runs that ended, with its exact (Clopper–Pearson) interval.\n",
        100.0 * FAILED_BELOW
    );
    let _ = writeln!(
        md,
        "| task | algo | n | {} | failed trainings |",
        headers.join(" | ")
    );
    let _ = writeln!(md, "|---|---|---:|{}---:|", "---:|".repeat(COLUMNS.len()));
    for ((task, algo), runs) in groups(records) {
        let finished = with_result(&runs);
        let cells: Vec<String> = COLUMNS
            .iter()
            .map(|c| {
                let values = column_values(&finished, c);
                // Wall seconds exist only for runs this sweep ran, not for skipped ones.
                let n = match values.len() {
                    0 => return "-".into(),
                    n if n == finished.len() => String::new(),
                    n => format!(" (n={n})"),
                };
                format!("{}{n}", mean_text(&values, c.decimals))
            })
            .collect();
        let _ = writeln!(
            md,
            "| {task} | {algo} | {} | {} | {} |",
            finished.len(),
            cells.join(" | "),
            count_text(failed_trainings(&runs))
        );
    }
    md
}

fn comparisons_table(records: &[RunRecord]) -> String {
    let groups = groups(records);
    let comparisons = comparisons(&groups);
    if comparisons.is_empty() {
        return String::new();
    }
    let mut md = String::from("\n## Algos compared on the same seeds\n\n");
    let _ = writeln!(
        md,
        "The mean difference, first algo minus second, over the seeds both finished, and the \
         two-sided sign-flip permutation p of the paired differences (exact over every sign \
         pattern up to 20 pairs, else {REPS} random patterns of seed {SEED}). With five pairs \
         no p falls below 0.0625.\n"
    );
    let headers: Vec<String> = COMPARED
        .iter()
        .map(|&c| format!("Δ {}", COLUMNS[c].header))
        .collect();
    let _ = writeln!(md, "| task | algos | {} |", headers.join(" | "));
    let _ = writeln!(md, "|---|---|{}", "---:|".repeat(COMPARED.len()));
    for c in comparisons {
        let cells: Vec<String> = c
            .columns
            .iter()
            .zip(COMPARED)
            .map(|(cell, i)| comparison_text(*cell, COLUMNS[i].decimals))
            .collect();
        let _ = writeln!(
            md,
            "| {} | {} − {} | {} |",
            c.task,
            c.first,
            c.second,
            cells.join(" | ")
        );
    }
    md
}

fn across_tasks_table(records: &[RunRecord]) -> String {
    let across = across_tasks(records);
    if across.is_empty() {
        return String::new();
    }
    let mut md = format!(
        "\n## Success across tasks\n\nThe interquartile mean of success over every finished \
         run of every task, with its 95 % stratified bootstrap interval ({REPS} resamples of \
         the runs within each task, seed {SEED}).\n\n| algo | tasks | runs | IQM of success % \
         |\n|---|---:|---:|---:|\n"
    );
    for (algo, tasks, runs, i) in across {
        let _ = writeln!(
            md,
            "| {algo} | {tasks} | {runs} | {:.1} [{:.1}, {:.1}] |",
            i.estimate, i.lo, i.hi
        );
    }
    md
}

fn status_text(status: Status) -> &'static str {
    match status {
        Status::Finished => "finished",
        Status::Skipped => "skipped",
        Status::Failed => "failed",
        Status::Interrupted => "interrupted",
        Status::Pending => "not started",
    }
}

/// One (task, algo) group's means and intervals in `sweep.json`.
#[derive(Debug, Serialize)]
struct GroupJson {
    task: String,
    algo: Algo,
    /// Runs with a result (finished or skipped).
    n: usize,
    /// Per column key: `{ "n": .., "mean": .., "lo": .., "hi": .. }`, the percentile
    /// bootstrap interval (`lo` and `hi` null for one value or values all equal; a column's n
    /// is below the group's for wall seconds, which skipped runs lack).
    columns: serde_json::Map<String, serde_json::Value>,
    /// `{ "failed": .., "of": .., "lo": .., "hi": .. }`: failed trainings among the runs that
    /// ended, with the Clopper–Pearson interval of their rate.
    failed_trainings: serde_json::Value,
}

fn group_json(task: String, algo: Algo, runs: &[&RunRecord]) -> GroupJson {
    let finished = with_result(runs);
    let columns = COLUMNS
        .iter()
        .filter_map(|c| {
            let values = column_values(&finished, c);
            let ci = mean_ci(&values)?;
            let spread = values.iter().any(|v| *v != values[0]);
            let (lo, hi) = if spread {
                (Some(ci.lo), Some(ci.hi))
            } else {
                (None, None)
            };
            let value = serde_json::json!({
                "n": values.len(), "mean": ci.estimate, "lo": lo, "hi": hi
            });
            Some((c.key.to_string(), value))
        })
        .collect();
    let (failed, of) = failed_trainings(runs);
    let (lo, hi) = clopper_pearson(failed, of, CONFIDENCE);
    GroupJson {
        task,
        algo,
        n: finished.len(),
        columns,
        failed_trainings: serde_json::json!({"failed": failed, "of": of, "lo": lo, "hi": hi}),
    }
}

fn comparison_json(c: &Comparison<'_>) -> serde_json::Value {
    let columns: serde_json::Map<String, serde_json::Value> = c
        .columns
        .iter()
        .zip(COMPARED)
        .filter_map(|(cell, i)| {
            let (pairs, mean, p) = (*cell)?;
            let exact = match p.draws {
                Draws::Exact(_) => true,
                Draws::MonteCarlo { .. } => false,
            };
            let value = serde_json::json!({
                "pairs": pairs, "mean_difference": mean, "p": p.p, "exact": exact
            });
            Some((COLUMNS[i].key.to_string(), value))
        })
        .collect();
    serde_json::json!({
        "task": c.task, "first": c.first, "second": c.second, "columns": columns
    })
}

/// The summary as JSON: `{"interval": "...", "runs": [...], "groups": [...], "comparisons":
/// [...]}`.
pub fn json(records: &[RunRecord]) -> String {
    let grouped = groups(records);
    let groups: Vec<GroupJson> = grouped
        .iter()
        .map(|((task, algo), runs)| group_json(task.clone(), *algo, runs))
        .collect();
    let comparisons: Vec<serde_json::Value> =
        comparisons(&grouped).iter().map(comparison_json).collect();
    let doc = serde_json::json!({
        "interval": format!("95 % percentile bootstrap of the mean over the finished seeds ({REPS} resamples, seed {SEED}); failed trainings: Clopper-Pearson; comparisons: two-sided sign-flip permutation p of the differences paired by seed"),
        "runs": records,
        "groups": groups,
        "comparisons": comparisons,
    });
    serde_json::to_string_pretty(&doc).unwrap_or_default() + "\n"
}

/// Writes `sweep.md` and `sweep.json` atomically into `out`.
pub fn write_summary(out: &Path, records: &[RunRecord]) -> Result<(), Error> {
    for (name, text) in [
        (SUMMARY_MD, markdown(records)),
        (SUMMARY_JSON, json(records)),
    ] {
        let path = out.join(name);
        files::write_atomic(&path, text.as_bytes()).map_err(|source| Error::Io { path, source })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::record::EvalSummary;

    fn run(algo: Algo, seed: u64, status: Status, eval: Option<(f64, f64)>) -> RunRecord {
        RunRecord {
            task: "nav-walls".into(),
            algo,
            seed,
            status,
            wall_seconds: Some(1.0),
            exit_code: Some(if status == Status::Failed { 1 } else { 0 }),
            signal: None,
            last_line: (status == Status::Failed).then(|| "host-trainer: a | b".into()),
            eval: eval.map(|(success, error)| EvalSummary {
                success_rate: success,
                mean_error: Some(error),
                stuck_rate: 0.0,
                near_pass_rate: Some(0.0),
                strict_reach_rate: Some(0.0),
            }),
        }
    }

    fn record(seed: u64, status: Status, success: Option<f64>) -> RunRecord {
        run(Algo::Dcp, seed, status, success.map(|s| (s, 1.0)))
    }

    fn row<'a>(md: &'a str, start: &str) -> &'a str {
        md.lines()
            .find(|l| l.starts_with(start))
            .unwrap_or_else(|| panic!("no row {start}:\n{md}"))
    }

    #[test]
    fn the_summary_averages_finished_seeds_only() {
        let records = [
            record(0, Status::Finished, Some(0.1)),
            record(1, Status::Skipped, Some(0.6)),
            record(2, Status::Finished, Some(0.9)),
            record(3, Status::Failed, None),
        ];
        let md = markdown(&records);
        assert!(md.contains("| nav-walls | dcp | 3 | failed |"), "{md}");
        assert!(md.contains("exit 1: host-trainer: a \\| b"), "{md}");
        // Success 10, 60, 90 %: the bootstrap distribution of the mean of three values puts
        // 1/27 = 3.7 % (more than 2.5 %) on each extreme resample, so the interval is the
        // values' range. Failed trainings: seed 0 (10 % success) and seed 3 (a failed run) of
        // the 4 that ended; scipy.stats.binomtest(2, 4).proportion_ci(method="exact") is
        // [0.0676, 0.9324].
        let mean = row(&md, "| nav-walls | dcp | 3 | 1.0 (all 3 equal) |");
        assert!(mean.contains("| 53.3 [10.0, 90.0] |"), "{mean}");
        assert!(mean.ends_with("| 2 of 4, 0.50 [0.07, 0.93] |"), "{mean}");
        assert!(!md.contains("Success across tasks"), "{md}");
        assert!(!md.contains("compared on the same seeds"), "{md}");
        let one = markdown(&records[..1]);
        assert!(one.contains("10.0 (1 seed)"), "{one}");
        let doc: serde_json::Value = serde_json::from_str(&json(&records)).expect("json");
        assert_eq!(doc["runs"].as_array().map(Vec::len), Some(4));
        let group = &doc["groups"][0];
        assert_eq!(group["n"], 3);
        assert_eq!(group["columns"]["success_pct"]["lo"].as_f64(), Some(10.0));
        assert_eq!(group["columns"]["success_pct"]["hi"].as_f64(), Some(90.0));
        assert!(group["columns"]["wall_seconds"]["lo"].is_null(), "{group}");
        assert_eq!(group["failed_trainings"]["failed"], 2);
        let lo = group["failed_trainings"]["lo"].as_f64().expect("lo");
        assert!((lo - 0.067_585_986_488_542_98).abs() < 1e-10, "{lo}");
    }

    #[test]
    fn five_seeds_get_the_bootstrap_interval_of_the_mean() {
        let records: Vec<RunRecord> = [0.1, 0.6, 0.7, 0.9, 1.0]
            .iter()
            .zip(0..)
            .map(|(&s, seed)| record(seed, Status::Finished, Some(s)))
            .collect();
        let doc: serde_json::Value = serde_json::from_str(&json(&records)).expect("json");
        let success = &doc["groups"][0]["columns"]["success_pct"];
        // The exact bootstrap distribution (all 5^5 resamples, numpy's quantiles) of the mean
        // of 10, 60, 70, 90, 100 has its 2.5 % and 97.5 % points at 36 and 90; the means lie
        // on a grid of 2, and 10,000 resamples land within a step of them.
        let (lo, hi) = (success["lo"].as_f64(), success["hi"].as_f64());
        assert!(lo.is_some_and(|lo| (lo - 36.0).abs() <= 2.0), "{success}");
        assert!(hi.is_some_and(|hi| (hi - 90.0).abs() <= 2.0), "{success}");
        // The same runs give the same text.
        assert_eq!(markdown(&records), markdown(&records));
    }

    #[test]
    fn two_algos_on_the_same_seeds_get_the_sign_flip_test() {
        let mut records: Vec<RunRecord> = [(0.10, 1.3), (0.20, 0.9), (0.30, 1.4), (0.4, 1.2)]
            .iter()
            .zip(0..)
            .map(|(&e, seed)| run(Algo::Dcp, seed, Status::Finished, Some(e)))
            .collect();
        records.extend(
            [(0.05, 1.0), (0.25, 1.0), (0.20, 1.0)]
                .iter()
                .zip(0..)
                .map(|(&e, seed)| run(Algo::Ddpg, seed, Status::Finished, Some(e))),
        );
        let md = markdown(&records);
        // Success differences 5, −5, 10 (seed 3 has no DDPG run): of the 8 sign patterns,
        // |sum| ≥ 10 for 6 (±(5 − 5 + 10), ±(5 + 5 + 10), ±(−5 + 5 + 10)): p = 0.75.
        let compared = row(&md, "| nav-walls | dcp − ddpg |");
        assert!(
            compared.contains("| +3.3, p 0.750 (3 pairs) |"),
            "{compared}"
        );
        // Settled error differences 0.3, −0.1, 0.4: ±(0.3 − 0.1 + 0.4), ±(0.3 + 0.1 + 0.4) of 8.
        assert!(
            compared.contains("| +0.200, p 0.500 (3 pairs) |"),
            "{compared}"
        );

        // Five pairs against scipy.stats.permutation_test(permutation_type="samples",
        // n_resamples=inf) on the differences 0.3, −0.1, 0.4, 0.2, 0.5: p = 0.125.
        let errors = [(1.3, 1.0), (0.9, 1.0), (1.4, 1.0), (1.2, 1.0), (1.5, 1.0)];
        let records: Vec<RunRecord> = errors
            .iter()
            .zip(0..)
            .flat_map(|(&(a, b), seed)| {
                [
                    run(Algo::Dcp, seed, Status::Finished, Some((1.0, a))),
                    run(Algo::Ddpg, seed, Status::Finished, Some((1.0, b))),
                ]
            })
            .collect();
        let doc: serde_json::Value = serde_json::from_str(&json(&records)).expect("json");
        let error = &doc["comparisons"][0]["columns"]["mean_error"];
        assert_eq!(error["p"].as_f64(), Some(0.125), "{error}");
        assert_eq!(error["pairs"], 5);
        assert_eq!(error["exact"], true);
    }

    #[test]
    fn several_tasks_get_an_interquartile_mean() {
        let mut records: Vec<RunRecord> = (0..4)
            .map(|seed| record(seed, Status::Finished, Some(0.1 * (seed + 1) as f64)))
            .collect();
        records.extend((0..4).map(|seed| RunRecord {
            task: "nav-open".into(),
            ..record(seed, Status::Finished, Some(0.9))
        }));
        let md = markdown(&records);
        // Success 10, 20, 30, 40 and 90 × 4: the middle four of eight are 30, 40, 90, 90.
        assert!(md.contains("| dcp | 2 | 8 | 62.5 ["), "{md}");
    }
}
