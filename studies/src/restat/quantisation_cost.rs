//! docs/results/quantisation-cost.md: 20 runs' f32 blobs re-encoded in f16 and int8, each
//! encoding's closed-loop change from f32 by run, and the protocol's per-seed aim.

use std::fmt::Write as _;

use anyhow::{ensure, Result};

use super::per_seed::PerSeed;
use super::text::{count_cell, judge, paired_cell, paired_table, table, PairedRow};
use super::Page;
use crate::paired::{ANY, RATE};

/// The page.
pub const PAGE: Page = Page {
    name: "quantisation-cost",
    tables: &["experiments/quantisation-cost/per-seed.tsv"],
    rows_on: None,
    build,
    rows_shown: super::lines_on_page,
};

/// The cells in the page's order (each run folder's name is `{cell}__{seed}`).
const CELLS: [&str; 4] = [
    "nav-open__dcp",
    "nav-open__ddpg",
    "nav-walls__dcp",
    "nav-walls__ddpg",
];
const ENCODINGS: [&str; 2] = ["f16", "int8"];
/// (value column, its difference column, digits, the range of a difference).
const QUANTITIES: [(&str, &str, usize, (f64, f64)); 3] = [
    ("success", "Δ success", 2, RATE),
    ("settled error", "Δ settled error", 3, ANY),
    ("stuck at margin", "Δ stuck", 2, RATE),
];
/// The aim: int8 within this of the f32 success on every seed...
const AIM_SUCCESS: f64 = 0.02;
/// ... and within this of its settled error.
const AIM_ERROR: f64 = 0.05;

/// The runs of `cell` with `encoding`, in the file's order, as (run, row).
fn rows<'a>(t: &'a PerSeed, cell: &str, encoding: &str) -> Result<Vec<&'a Vec<String>>> {
    let (run, enc) = (t.column("run")?, t.column("encoding")?);
    let prefix = format!("{cell}__");
    let rows: Vec<&Vec<String>> = t
        .rows
        .iter()
        .filter(|r| r[run].starts_with(&prefix) && r[enc] == encoding)
        .collect();
    ensure!(
        rows.len() == 5,
        "{cell} {encoding}: {} runs, not 5",
        rows.len()
    );
    Ok(rows)
}

fn column(t: &PerSeed, cell: &str, encoding: &str, name: &str) -> Result<Vec<f64>> {
    let c = t.column(name)?;
    rows(t, cell, encoding)?
        .iter()
        .map(|r| Ok(r[c].parse::<f64>()?))
        .collect()
}

fn build(tables: &[PerSeed]) -> Result<String> {
    let t = &tables[0];
    let mut out = String::new();
    let mut cells = Vec::new();
    let mut rows = Vec::new();
    for cell in CELLS {
        for encoding in ENCODINGS {
            let mut row = vec![cell.to_string(), encoding.to_string(), "5".into()];
            for (value, delta, decimals, range) in QUANTITIES {
                let d = column(t, cell, encoding, delta)?;
                row.push(paired_cell(&d, decimals));
                // The arms as the differences have them: f32, and f32 plus the difference
                // (the page's differences were taken before rounding).
                let base = column(t, cell, "f32", value)?;
                let other: Vec<f64> = base.iter().zip(&d).map(|(b, d)| b + d).collect();
                rows.push(PairedRow::new(
                    format!("{cell}, {encoding} − f32, {value}"),
                    &other,
                    &base,
                    decimals,
                    range,
                ));
            }
            cells.push(row);
        }
    }
    out.push_str(
        "**Mean change from the f32 blob**, by run (each encoding's value minus the same run's \
         f32 value): the mean over the 5 runs with the bootstrap interval of the differences, \
         and the sign-flip p (exact over 32 sign patterns); \"(all 5 equal)\" where every run \
         changed by the same amount (mostly not at all).\n\n",
    );
    out.push_str(&table(
        &[
            "task, algorithm",
            "encoding",
            "runs",
            "Δ success",
            "Δ settled error",
            "Δ stuck at margin",
        ],
        2,
        &cells,
    ));
    out.push_str("\n**Verdicts.**\n\n");
    aim(t, &mut out)?;
    readings(&rows, &mut out);
    Ok(out)
}

/// The protocol's aim: int8 within 0.02 of the f32 success and within 0.05 of its settled
/// error on every seed.
fn aim(t: &PerSeed, out: &mut String) -> Result<()> {
    let mut success = Vec::new();
    let mut error = Vec::new();
    for cell in CELLS {
        success.extend(column(t, cell, "int8", "Δ success")?);
        error.extend(column(t, cell, "int8", "Δ settled error")?);
    }
    // Each run as the larger of its two differences in units of its tolerance: within the aim
    // at 1 or less.
    let runs: Vec<f64> = success
        .iter()
        .zip(&error)
        .map(|(s, e)| (s.abs() / AIM_SUCCESS).max(e.abs() / AIM_ERROR))
        .collect();
    let n = runs.len();
    let met = |r: &[f64]| r.iter().all(|v| *v <= 1.0);
    // A change of a run: its int8 blob coming out as its f32 blob (no difference).
    let alts = vec![vec![0.0]; n];
    let j = judge(&runs, &alts, met);
    let k = runs.iter().filter(|v| **v <= 1.0).count();
    let _ = writeln!(
        out,
        "- **The aim: int8 within {AIM_SUCCESS} of the f32 success and within {AIM_ERROR} of its \
         settled error on every seed.** Pre-registered: **{}**; {}, a run's int8 differences \
         set to 0. A rule on every run is read off the runs, not tested: what it says of other \
         seeds is the rate of runs within both tolerances, {} (exact 95 % interval over the \
         {n} runs), and it has no power figure (it compares nothing with anything).",
        if j.word { "met" } else { "missed" },
        j.sensitivity,
        count_cell(k, n),
    );
    Ok(())
}

/// The page's reading "no mean difference is distinguishable from 0 (every interval contains
/// it)", by t interval and by sign-flip test, comparison by comparison.
fn readings(rows: &[PairedRow], out: &mut String) {
    let fewest = rows
        .iter()
        .filter_map(|r| r.paired.t.sensitivity.runs)
        .min();
    let at_fewest = rows
        .iter()
        .filter(|r| r.paired.t.sensitivity.runs == fewest)
        .count();
    let t_held = rows
        .iter()
        .filter(|r| r.paired.t.word == host_trainer::reproduce::verdict::Side::Spans)
        .count();
    let exact_held = rows
        .iter()
        .filter(|r| r.paired.exact.word == host_trainer::reproduce::verdict::Side::Spans)
        .count();
    let smallest = rows
        .iter()
        .map(|r| super::text::sign_flip(&r.paired.diffs).p)
        .fold(1.0f64, f64::min);
    let _ = writeln!(
        out,
        "- **No mean difference is distinguishable from 0.** The page's reading (every 95 % t \
         interval of the paired differences holds 0; the protocol named the interval, not this \
         reading): **{}** ({t_held} of the {} comparisons hold 0); the fewest runs that flip it: \
         {} (in {at_fewest} of the comparisons), a run of the encoding changed to the lowest \
         or highest f32 value of its cell. Exact: **{}** ({exact_held} of {} without p < 0.05; \
         the smallest p is {smallest:.4}): {}, so five runs per cell can show no change of any \
         size; the per-cell power is in the table below.\n",
        if t_held == rows.len() {
            "holds"
        } else {
            "does not hold"
        },
        rows.len(),
        fewest.map_or("none up to 3".into(), |k| k.to_string()),
        if exact_held == rows.len() {
            "the same"
        } else {
            "differs"
        },
        rows.len(),
        super::text::floor_note(5).unwrap_or_default(),
    );
    let _ = writeln!(
        out,
        "<details><summary>Every comparison ({})</summary>\n\n{}\n</details>",
        rows.len(),
        paired_table("the page", rows)
    );
}
