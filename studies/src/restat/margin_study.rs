//! docs/results/margin-study.md: the screening (four candidates and DCP's defaults `A0`, 26 runs
//! each: the pinwheel's seeds 0–9 and two seeds of each of eight generated layouts) and the
//! confirmation (the screening's winner `uniform-share`, `A0` and four baselines, 26 fresh runs
//! each), from the two run tables the page prints, committed as per-seed files.
//!
//! Every arm ran the same 26 (layout, seed) cases in each phase, so every comparison with `A0`
//! is paired by case: under "the arm changes nothing" the two outcomes of a case are
//! exchangeable, which is what the sign-flip test needs. A failed seed is a 0/1 outcome, for
//! which the sign-flip test of the paired differences is McNemar's exact test (only the
//! discordant cases move the statistic).

use std::fmt::Write as _;

use anyhow::{ensure, Context, Result};

use super::per_seed::PerSeed;
use super::text::{count_cell, mean_cell, paired_table, sign_flip, table, PairedRow};
use super::Page;
use crate::paired::{ANY, RATE};

/// The page.
pub const PAGE: Page = Page {
    name: "margin-study",
    tables: &[
        "experiments/margin/per-seed-screen.tsv",
        "experiments/margin/per-seed-confirm.tsv",
    ],
    rows_on: None,
    build,
    rows_shown: super::lines_on_page,
};

const SUCCESS: &str = "success";
const ERROR: &str = "settled error";
const STUCK: &str = "stuck at margin";
const FAILED: &str = "failed seed";
/// Cases per arm and phase.
const CASES: usize = 26;
/// The sensitivity is searched up to this many runs at once (the other pages: three). Over 26
/// pairs the sign-flip test draws its sign patterns, and every set of three of the 52 runs
/// would redraw them about 180,000 times per comparison.
const SENSITIVITY_RUNS: usize = 1;

/// The candidates of the screening, in the page's order.
const CANDIDATES: [&str; 4] = ["uniform-share", "sigma-schedule", "uniform-sigma", "heads"];
/// The baselines of the confirmation.
const BASELINES: [&str; 4] = ["ddpg", "td3", "ppo", "dqn"];

/// A cell as a number: `46 %` as 0.46, `yes`/`no` as 1/0, else the number.
fn number(cell: &str) -> Result<f64> {
    let parsed: Result<f64, std::num::ParseFloatError> = match cell {
        "yes" => Ok(1.0),
        "no" => Ok(0.0),
        _ => match cell.strip_suffix('%') {
            Some(p) => p.trim().parse::<f64>().map(|v| v / 100.0),
            None => cell.parse::<f64>(),
        },
    };
    parsed.with_context(|| format!("{cell:?} is not a number, a share or yes/no"))
}

/// The `column` of `arm`'s 26 cases in `table`, ordered by (layout, seed) so that two arms'
/// values pair case by case.
fn arm(table: &PerSeed, arm: &str, column: &str) -> Result<Vec<f64>> {
    let (l, s, c) = (
        table.column("layout")?,
        table.column("seed")?,
        table.column(column)?,
    );
    let mut rows: Vec<(String, u64, f64)> = table
        .select(&[("arm", arm)])?
        .into_iter()
        .map(|r| Ok((r[l].clone(), r[s].parse::<u64>()?, number(&r[c])?)))
        .collect::<Result<_>>()?;
    ensure!(
        rows.len() == CASES,
        "{}: {arm} has {} runs where the page has {CASES}",
        table.path.display(),
        rows.len()
    );
    rows.sort_by(|a, b| (&a.0, a.1).cmp(&(&b.0, b.1)));
    Ok(rows.into_iter().map(|r| r.2).collect())
}

fn build(tables: &[PerSeed]) -> Result<String> {
    let (screen, confirm) = (&tables[0], &tables[1]);
    let mut out = String::new();
    means(screen, confirm, &mut out)?;
    let pair = |t: &PerSeed, first: &str, column: &str| -> Result<PairedRow> {
        let failed = column == FAILED;
        Ok(PairedRow::within(
            format!(
                "{first} − A0: {}",
                if failed {
                    "failed seed"
                } else {
                    "settled error"
                }
            ),
            &arm(t, first, column)?,
            &arm(t, "A0", column)?,
            if failed { 2 } else { 3 },
            if failed { RATE } else { ANY },
            SENSITIVITY_RUNS,
        ))
    };
    let mut screening = Vec::new();
    for c in CANDIDATES {
        screening.push(pair(screen, c, FAILED)?);
        screening.push(pair(screen, c, ERROR)?);
    }
    out.push_str(
        "\n**Screening, each candidate against `A0`, paired by case** (the 26 pairs of layout \
         and seed; sensitivity searched up to one run at once). Step 2's rule is a ranking (the fewest failed seeds, then a mean settled \
         error no worse than `A0`'s), not a test, so the t column stands for comparison only:\
         \n\n",
    );
    out.push_str(&paired_table("for comparison", &screening));
    let mut confirmation = vec![
        pair(confirm, "uniform-share", FAILED)?,
        pair(confirm, "uniform-share", ERROR)?,
    ];
    for b in BASELINES {
        confirmation.push(pair(confirm, b, FAILED)?);
        confirmation.push(pair(confirm, b, ERROR)?);
    }
    out.push_str(
        "\n**Confirmation, against `A0`, paired by case** (26 fresh pairs; sensitivity up to one run). Step 4's rule, fixed \
         before the runs, is the t column of `uniform-share`'s two rows (adopted only if both \
         intervals lie below 0): it is the pre-registered verdict. The baselines' rows decide \
         nothing (the page's \"which agent where\" reads them by layout):\n\n",
    );
    out.push_str(&paired_table(
        "pre-registered (uniform-share)",
        &confirmation,
    ));
    decisions(&screening, &confirmation, &mut out);
    Ok(out)
}

fn means(screen: &PerSeed, confirm: &PerSeed, out: &mut String) -> Result<()> {
    let mut rows = Vec::new();
    for (phase, table, arms) in [
        ("screening", screen, [&["A0"][..], &CANDIDATES].concat()),
        (
            "confirmation",
            confirm,
            [&["A0", "uniform-share"][..], &BASELINES].concat(),
        ),
    ] {
        for a in arms {
            let failed = arm(table, a, FAILED)?;
            let k = failed.iter().filter(|f| **f > 0.5).count();
            rows.push(vec![
                phase.to_string(),
                a.to_string(),
                mean_cell(&arm(table, a, SUCCESS)?, 2),
                mean_cell(&arm(table, a, ERROR)?, 3),
                mean_cell(&arm(table, a, STUCK)?, 2),
                count_cell(k, failed.len()),
            ]);
        }
    }
    out.push_str(
        "**Means over each arm's 26 runs** (95 % bootstrap intervals, within each quantity's \
         range; the page's own tables give t intervals clipped to the range), and the failed \
         seeds as a count with its exact interval:\n\n",
    );
    out.push_str(&table(
        &["phase", "arm", SUCCESS, ERROR, STUCK, "failed seeds"],
        2,
        &rows,
    ));
    Ok(())
}

/// Steps 2 and 4 by the exact tests.
fn decisions(screening: &[PairedRow], confirmation: &[PairedRow], out: &mut String) {
    let p = |r: &PairedRow| sign_flip(&r.paired.diffs).p;
    let _ = writeln!(out, "\n**The page's decisions, by the exact tests.**\n");
    let off: Vec<String> = screening
        .iter()
        .filter(|r| p(r) < 0.05)
        .map(|r| format!("{} (p {:.4})", r.label, p(r)))
        .collect();
    let _ = writeln!(
        out,
        "- *Step 2, `uniform-share` wins the screening* (pre-registered ranking: one failed \
         seed fewer than `A0`): {}. The ranking named the candidate the confirmation tested; no \
         exact test separates it from `A0` (p {:.4} on failed seeds, {:.4} on settled error).",
        if off.is_empty() {
            "no candidate differs from `A0` by the sign-flip test on either measure".to_string()
        } else {
            format!("off 0 by the sign-flip test: {}", off.join("; "))
        },
        p(&screening[0]),
        p(&screening[1]),
    );
    let _ = writeln!(
        out,
        "- *Step 4, not adopted* (pre-registered: neither t interval of `uniform-share − A0` \
         lies below 0): exact, the same: failed seed p {:.4}, settled error p {:.4}, neither \
         below 0.05; the power column says how many pairs the observed differences would need.",
        p(&confirmation[0]),
        p(&confirmation[1]),
    );
    let baselines: Vec<String> = confirmation[2..]
        .iter()
        .map(|r| format!("{} p {:.4}", r.label, p(r)))
        .collect();
    let _ = writeln!(
        out,
        "- *The baselines against `A0`* (deciding nothing): {}.",
        baselines.join("; ")
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::restat::tests::committed;

    #[test]
    fn cells_read_as_numbers() {
        assert_eq!(number("46 %").unwrap(), 0.46);
        assert_eq!(number("yes").unwrap(), 1.0);
        assert_eq!(number("no").unwrap(), 0.0);
        assert_eq!(number("1.196").unwrap(), 1.196);
        assert!(number("maybe").is_err());
    }

    /// The page's counts, read back from the committed rows: `A0` failed 17 of its 26
    /// screening seeds and `uniform-share` 16; in the confirmation 15 and 13 (the page's text).
    #[test]
    fn the_rows_give_the_pages_counts() {
        let screen = committed("experiments/margin/per-seed-screen.tsv");
        let confirm = committed("experiments/margin/per-seed-confirm.tsv");
        let failed = |t: &PerSeed, a: &str| -> usize {
            arm(t, a, FAILED)
                .unwrap()
                .iter()
                .filter(|f| **f > 0.5)
                .count()
        };
        assert_eq!(failed(&screen, "A0"), 17);
        assert_eq!(failed(&screen, "uniform-share"), 16);
        assert_eq!(failed(&screen, "heads"), 18);
        assert_eq!(failed(&confirm, "A0"), 15);
        assert_eq!(failed(&confirm, "uniform-share"), 13);
        // Step 4's McNemar: 2 pairs where only A0 failed, none where only uniform-share did:
        // p = 2 × (1/2)² = 0.5 exactly; over 26 pairs the sign-flip test draws its patterns
        // (Monte-Carlo), so within its error.
        let d: Vec<f64> = arm(&confirm, "uniform-share", FAILED)
            .unwrap()
            .iter()
            .zip(arm(&confirm, "A0", FAILED).unwrap())
            .map(|(u, a)| u - a)
            .collect();
        assert_eq!(d.iter().filter(|x| **x < 0.0).count(), 2);
        assert_eq!(d.iter().filter(|x| **x > 0.0).count(), 0);
        assert!((sign_flip(&d).p - 0.5).abs() < 0.02, "{}", sign_flip(&d).p);
    }
}
