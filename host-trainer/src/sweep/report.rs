//! Reporting a sweep: one row per run, then per (task, algo) the mean and a 95 % Student-t
//! interval over the finished seeds clipped to each column's range
//! ([`crate::stats::student_t`]), and where a sweep spans several tasks, each algo's
//! interquartile mean of success over every task with its stratified bootstrap interval
//! ([`crate::stats::aggregate`]), as Markdown and JSON.

use std::fmt::Write as _;
use std::path::Path;

use firmware_sim::files;
use serde::Serialize;

use super::record::{exit_text, RunRecord, Status};
use crate::algorithms::Algo;
use crate::stats::aggregate::iqm_ci;
use crate::stats::student_t::{self as stats, clipped_interval, MeanInterval, Range};
use crate::stats::{CONFIDENCE, REPS, SEED};
use crate::Error;

/// The summary table, in the sweep's output folder.
pub const SUMMARY_MD: &str = "sweep.md";
/// The summary as JSON.
pub const SUMMARY_JSON: &str = "sweep.json";

/// A column of the summary: header, JSON key, value of a run, decimals.
struct Column {
    header: &'static str,
    key: &'static str,
    value: fn(&RunRecord) -> Option<f64>,
    decimals: usize,
    /// The values the column can take: its interval is clipped to them.
    range: Range,
}

/// A rate in percent.
const PERCENT: Range = (0.0, 100.0);

/// Rates are shown in percent, as `train` and `eval` print them.
const COLUMNS: [Column; 6] = [
    Column {
        header: "wall s",
        key: "wall_seconds",
        value: |r| r.wall_seconds,
        decimals: 1,
        range: stats::NON_NEGATIVE,
    },
    Column {
        header: "success %",
        key: "success_pct",
        value: |r| r.eval.map(|e| 100.0 * e.success_rate),
        decimals: 1,
        range: PERCENT,
    },
    Column {
        header: "settled error",
        key: "mean_error",
        value: |r| r.eval.and_then(|e| e.mean_error),
        decimals: 3,
        range: stats::NON_NEGATIVE,
    },
    Column {
        header: "stuck at margin %",
        key: "stuck_pct",
        value: |r| r.eval.map(|e| 100.0 * e.stuck_rate),
        decimals: 1,
        range: PERCENT,
    },
    Column {
        header: "pass within 0.25 %",
        key: "near_pass_pct",
        value: |r| r.eval.and_then(|e| e.near_pass_rate).map(|v| 100.0 * v),
        decimals: 1,
        range: PERCENT,
    },
    Column {
        header: "strict reach %",
        key: "strict_reach_pct",
        value: |r| r.eval.and_then(|e| e.strict_reach_rate).map(|v| 100.0 * v),
        decimals: 1,
        range: PERCENT,
    },
];

/// The (task, algo) groups in first-seen order, each with its runs that have a result.
fn groups(records: &[RunRecord]) -> Vec<((String, Algo), Vec<&RunRecord>)> {
    let mut groups: Vec<((String, Algo), Vec<&RunRecord>)> = Vec::new();
    for r in records {
        let key = (r.task.clone(), r.algo);
        let at = match groups.iter().position(|(k, _)| *k == key) {
            Some(at) => at,
            None => {
                groups.push((key, Vec::new()));
                groups.len() - 1
            }
        };
        if r.eval.is_some() {
            groups[at].1.push(r);
        }
    }
    groups
}

fn column_values(runs: &[&RunRecord], column: &Column) -> Vec<f64> {
    runs.iter().filter_map(|r| (column.value)(r)).collect()
}

fn column_interval(runs: &[&RunRecord], column: &Column) -> Option<MeanInterval> {
    stats::mean_interval(&column_values(runs, column))
}

/// Per algo over several tasks: the interquartile mean of success (percent) over every
/// finished run, with its stratified bootstrap interval (runs resampled within each task).
fn across_tasks(
    records: &[RunRecord],
) -> Vec<(Algo, usize, usize, crate::stats::bootstrap::Interval)> {
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
                .filter(|((_, a), runs)| *a == algo && !runs.is_empty())
                .map(|(_, runs)| column_values(runs, &COLUMNS[1]))
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

/// The summary as a markdown table of runs, then a table of means with 95 % intervals.
pub fn markdown(records: &[RunRecord]) -> String {
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
    md.push_str("\n## Mean and 95 % confidence interval over the finished seeds\n\n");
    md.push_str(
        "Student's t, two-sided, n − 1 degrees of freedom, clipped to the column's range (a \
         rate to 0–100 %, a time or an error to 0 and up); one seed, or seeds that all gave the \
         same value, have no interval.\n\n",
    );
    let _ = writeln!(md, "| task | algo | n | {} |", headers.join(" | "));
    let _ = writeln!(md, "|---|---|---:|{}", "---:|".repeat(COLUMNS.len()));
    for ((task, algo), runs) in groups(records) {
        let cells: Vec<String> = COLUMNS
            .iter()
            .map(|c| match column_interval(&runs, c) {
                None => "-".into(),
                Some(m) => {
                    let values = column_values(&runs, c);
                    let text = stats::clipped_text(&values, c.decimals, c.range);
                    // Wall seconds exist only for runs this sweep ran, not for skipped ones.
                    let n = if m.n == runs.len() {
                        String::new()
                    } else {
                        format!(" (n={})", m.n)
                    };
                    format!("{text}{n}")
                }
            })
            .collect();
        let _ = writeln!(
            md,
            "| {task} | {algo} | {} | {} |",
            runs.len(),
            cells.join(" | ")
        );
    }
    let across = across_tasks(records);
    if !across.is_empty() {
        let _ = writeln!(
            md,
            "\n## Success across tasks\n\nThe interquartile mean of success over every finished \
             run of every task, with its 95 % stratified bootstrap interval ({REPS} resamples of \
             the runs within each task, seed {SEED}).\n\n| algo | tasks | runs | IQM of success % |\n|---|---:|---:|---:|"
        );
        for (algo, tasks, runs, i) in across {
            let _ = writeln!(
                md,
                "| {algo} | {tasks} | {runs} | {:.1} [{:.1}, {:.1}] |",
                i.estimate, i.lo, i.hi
            );
        }
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
    /// Per column key: `{ "n": .., "mean": .., "half_width": .., "lo": .., "hi": .. }`
    /// (`half_width` null for n = 1; `lo` and `hi` the interval clipped to the column's range,
    /// null without spread; a column's n is below the group's for wall seconds, which skipped
    /// runs lack).
    columns: serde_json::Map<String, serde_json::Value>,
}

/// The summary as JSON: `{"runs": [...], "groups": [...], "interval": "..."}`.
pub fn json(records: &[RunRecord]) -> String {
    let groups: Vec<GroupJson> = groups(records)
        .into_iter()
        .map(|((task, algo), runs)| {
            let columns = COLUMNS
                .iter()
                .filter_map(|c| {
                    let m = column_interval(&runs, c)?;
                    let (lo, hi) = clipped_interval(&column_values(&runs, c), c.range)
                        .map_or((None, None), |(_, lo, hi)| (Some(lo), Some(hi)));
                    let value = serde_json::json!({
                        "n": m.n, "mean": m.mean, "half_width": m.half_width, "lo": lo, "hi": hi
                    });
                    Some((c.key.to_string(), value))
                })
                .collect();
            GroupJson {
                task,
                algo,
                n: runs.len(),
                columns,
            }
        })
        .collect();
    let doc = serde_json::json!({
        "interval": "95 % two-sided Student's t over the finished seeds, df = n - 1; lo and hi clipped to the column's range (null without spread)",
        "runs": records,
        "groups": groups,
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

    fn record(seed: u64, status: Status, success: Option<f64>) -> RunRecord {
        RunRecord {
            task: "nav-walls".into(),
            algo: Algo::Dcp,
            seed,
            status,
            wall_seconds: Some(1.0),
            exit_code: Some(if status == Status::Failed { 1 } else { 0 }),
            signal: None,
            last_line: (status == Status::Failed).then(|| "host-trainer: a | b".into()),
            eval: success.map(|s| EvalSummary {
                success_rate: s,
                mean_error: Some(1.0),
                stuck_rate: 0.0,
                near_pass_rate: Some(0.0),
                strict_reach_rate: Some(0.0),
            }),
        }
    }

    #[test]
    fn the_summary_averages_finished_seeds_only() {
        let records = [
            record(0, Status::Finished, Some(0.1)),
            record(1, Status::Skipped, Some(0.2)),
            record(2, Status::Finished, Some(0.3)),
            record(3, Status::Failed, None),
        ];
        let md = markdown(&records);
        assert!(md.contains("| nav-walls | dcp | 3 | failed |"), "{md}");
        assert!(md.contains("exit 1: host-trainer: a \\| b"), "{md}");
        // success 10, 20, 30 %: mean 20, s = 10, t(0.975, 2) · 10 / √3 = 24.8.
        assert!(
            md.contains("| nav-walls | dcp | 3 | 1.0 (all 3 equal) | 20.0 [0.0, 44.8] |"),
            "{md}"
        );
        assert!(!md.contains("Success across tasks"), "{md}");
        let one = markdown(&records[..1]);
        assert!(one.contains("10.0 (1 seed)"), "{one}");
        let doc: serde_json::Value = serde_json::from_str(&json(&records)).expect("json");
        assert_eq!(doc["runs"].as_array().map(Vec::len), Some(4));
        assert_eq!(doc["groups"][0]["n"], 3);
        let half = doc["groups"][0]["columns"]["success_pct"]["half_width"].as_f64();
        assert!(half.is_some_and(|h| (h - 24.842).abs() < 1e-3), "{half:?}");
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
