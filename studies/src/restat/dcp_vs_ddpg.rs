//! docs/results/dcp-vs-ddpg.md: the paper's DCP against textbook DDPG, 5 seeds per layout.
//!
//! The page fixed no rule before its runs; its verdicts are read here as the later pages read
//! the same claims (a 95 % t interval of the paired differences off 0), beside the exact tests.

use std::fmt::Write as _;

use anyhow::Result;
use host_trainer::reproduce::verdict::Side;
use host_trainer::stats::binomial::mcnemar_exact;
use host_trainer::stats::ALPHA;

use super::per_seed::PerSeed;
use super::text::{
    claim, count_cell, diff, differ_text, exact_sentence, judge, mean, mean_cell, paired,
    power_text, rate_power_text, sign_flip, t_sentence, table, word_text,
};
use super::Page;
use crate::paired::{ANY, RATE};

/// The page.
pub const PAGE: Page = Page {
    name: "dcp-vs-ddpg",
    tables: &["experiments/dcp-vs-ddpg/per-seed.tsv"],
    rows_on: None,
    build,
    rows_shown: super::lines_on_page,
};

const SUCCESS: &str = "test success";
const ERROR: &str = "mean settled error";
const PASS: &str = "pass within 0.25";
const STUCK: &str = "stuck at margin";
const STRICT: &str = "strict reach";

/// A training fails below this test success (docs/design.md §2).
const FAILED_BELOW: f64 = 0.5;

/// The cells in the page's order.
const CELLS: [(&str, &str); 4] = [
    ("nav-walls", "dcp"),
    ("nav-walls", "ddpg"),
    ("nav-open", "dcp"),
    ("nav-open", "ddpg"),
];

fn arm(t: &PerSeed, task: &str, algo: &str, column: &str) -> Result<Vec<f64>> {
    t.values(&[("task", task), ("algo", algo)], column)
}

fn count(values: &[f64], pass: impl Fn(f64) -> bool) -> usize {
    values.iter().filter(|v| pass(**v)).count()
}

fn build(tables: &[PerSeed]) -> Result<String> {
    let t = &tables[0];
    let mut out = String::new();
    means(t, &mut out)?;
    verdicts(t, &mut out)?;
    Ok(out)
}

fn means(t: &PerSeed, out: &mut String) -> Result<()> {
    let columns = [(SUCCESS, 2), (ERROR, 2), (PASS, 2), (STUCK, 2), (STRICT, 2)];
    let mut rows = Vec::new();
    let mut counts = Vec::new();
    for (task, algo) in CELLS {
        let mut row = vec![task.to_string(), algo.to_string(), "5".into()];
        for (column, decimals) in columns {
            row.push(mean_cell(&arm(t, task, algo, column)?, decimals));
        }
        rows.push(row);
        let success = arm(t, task, algo, SUCCESS)?;
        let error = arm(t, task, algo, ERROR)?;
        let pass = arm(t, task, algo, PASS)?;
        let n = success.len();
        counts.push(vec![
            task.to_string(),
            algo.to_string(),
            count_cell(count(&success, |v| v < FAILED_BELOW), n),
            count_cell(count(&success, |v| v >= 0.9), n),
            count_cell(count(&error, |v| v < 0.5), n),
            count_cell(count(&pass, |v| v > 0.0), n),
        ]);
    }
    out.push_str("**Means over the 5 seeds** (95 % bootstrap intervals):\n\n");
    out.push_str(&table(
        &[
            "task",
            "algo",
            "seeds",
            SUCCESS,
            "settled error",
            PASS,
            STUCK,
            STRICT,
        ],
        2,
        &rows,
    ));
    out.push_str(
        "\n**Counts of seeds** (k of the 5 seeds, with the exact 95 % interval of the rate over \
         seeds):\n\n",
    );
    out.push_str(&table(
        &[
            "task",
            "algo",
            "failed trainings (success < 0.5)",
            "success ≥ 0.9",
            "settled error < 0.5",
            "passes within 0.25 from some start",
        ],
        2,
        &counts,
    ));
    Ok(())
}

fn verdicts(t: &PerSeed, out: &mut String) -> Result<()> {
    out.push_str(
        "\n**Verdicts.** No rule was fixed before these runs: each reading of the page is \
         restated as the later pages judge the same claims (the 95 % t interval of the paired \
         differences off 0), beside the exact test. DCP and DDPG of one seed share the seed's \
         training starts and initial draws, so runs pair by seed.\n\n",
    );
    target(t, out)?;
    let walls = |algo: &str, c: &str| arm(t, "nav-walls", algo, c);
    let p = paired(
        &walls("dcp", SUCCESS)?,
        &walls("ddpg", SUCCESS)?,
        claim(Side::Above),
    );
    let _ = writeln!(
        out,
        "- **DCP reaches the goal more often than DDPG on the pinwheel.** The page: **not \
         reproduced** (success {} against {}). By {}. {}",
        mean_cell(&walls("dcp", SUCCESS)?, 2),
        mean_cell(&walls("ddpg", SUCCESS)?, 2),
        t_sentence(&p, 2, RATE, word_text),
        exact_sentence(&p, 2, word_text)
    );
    let p = paired(
        &walls("dcp", STUCK)?,
        &walls("ddpg", STUCK)?,
        claim(Side::Below),
    );
    let _ = writeln!(
        out,
        "- **DCP gets stuck at the walls less than DDPG.** The page: **not reproduced**, DCP's \
         stuck rate is the higher one ({} against {}). By {}. {}",
        mean_cell(&walls("dcp", STUCK)?, 2),
        mean_cell(&walls("ddpg", STUCK)?, 2),
        t_sentence(&p, 2, RATE, word_text),
        exact_sentence(&p, 2, word_text)
    );
    north_gap(t, out)?;
    let open = |algo: &str| arm(t, "nav-open", algo, ERROR);
    let p = paired(&open("dcp")?, &open("ddpg")?, |s| s);
    let differ = differ_text("DCP", "DDPG");
    let _ = writeln!(
        out,
        "- **Without walls, do the two differ?** Both succeed from every start on every seed; \
         the page reports settled error DCP {} against DDPG {} and draws no verdict. By {}. {}",
        mean_cell(&open("dcp")?, 3),
        mean_cell(&open("ddpg")?, 3),
        t_sentence(&p, 3, ANY, &differ),
        exact_sentence(&p, 3, &differ)
    );
    Ok(())
}

/// The target for DCP on the pinwheel: mean success ≥ 0.9 and mean settled error < 0.5.
fn target(t: &PerSeed, out: &mut String) -> Result<()> {
    let success = arm(t, "nav-walls", "dcp", SUCCESS)?;
    let error = arm(t, "nav-walls", "dcp", ERROR)?;
    let n = success.len();
    let runs: Vec<f64> = success.iter().chain(&error).copied().collect();
    let best_success = success.iter().copied().fold(f64::MIN, f64::max);
    let best_error = error.iter().copied().fold(f64::MAX, f64::min);
    let alts: Vec<Vec<f64>> = (0..2 * n)
        .map(|i| vec![if i < n { best_success } else { best_error }])
        .collect();
    let met = |r: &[f64]| mean(&r[..n]) >= 0.9 && mean(&r[n..]) < 0.5;
    let j = judge(&runs, &alts, met);
    let above: Vec<f64> = error.iter().map(|e| e - 0.5).collect();
    let _ = writeln!(
        out,
        "- **The target for DCP on the pinwheel** (mean success ≥ 0.9 and mean settled error \
         below 0.5): **{}** (success {}, settled error {}); {}, a run's success changed to the \
         arm's best ({best_success:.2}) or its settled error to the arm's best \
         ({best_error:.3}). By seeds: success ≥ 0.9 on {}, settled error below 0.5 on {}. \
         Exact: the miss is not significant either, since every seed's settled error is above \
         0.5 and the sign-flip test of settled error minus 0.5 gives {}, the smallest p five \
         seeds can give. Power: {}.",
        if j.word { "met" } else { "not met" },
        mean_cell(&success, 2),
        mean_cell(&error, 3),
        j.sensitivity,
        count_cell(count(&success, |v| v >= 0.9), n),
        count_cell(count(&error, |v| v < 0.5), n),
        sign_flip(&above),
        power_text(&above, 3).trim_start_matches("power ")
    );
    Ok(())
}

/// The north gap: seeds whose policy passes within 0.25 of the centre from some start.
fn north_gap(t: &PerSeed, out: &mut String) -> Result<()> {
    let pass = |algo: &str| -> Result<Vec<f64>> {
        Ok(arm(t, "nav-walls", algo, PASS)?
            .iter()
            .map(|v| f64::from(u8::from(*v > 0.0)))
            .collect())
    };
    let (dcp, ddpg) = (pass("dcp")?, pass("ddpg")?);
    let n = dcp.len();
    let runs: Vec<f64> = dcp.iter().chain(&ddpg).copied().collect();
    let alts: Vec<Vec<f64>> = runs.iter().map(|v| vec![1.0 - v]).collect();
    let more = |r: &[f64]| r[..n].iter().sum::<f64>() > r[n..].iter().sum::<f64>();
    let page = judge(&runs, &alts, more);
    let discordant = |r: &[f64]| {
        let d = diff(&r[..n], &r[n..]);
        let b = d.iter().filter(|v| **v > 0.5).count() as u64;
        let c = d.iter().filter(|v| **v < -0.5).count() as u64;
        (b, c)
    };
    let shown = |r: &[f64]| {
        let (b, c) = discordant(r);
        b > c && mcnemar_exact(b, c) < ALPHA
    };
    let exact = judge(&runs, &alts, shown);
    let (b, c) = discordant(&runs);
    let (k1, k2) = (count(&dcp, |v| v > 0.5), count(&ddpg, |v| v > 0.5));
    let _ = writeln!(
        out,
        "- **DCP gets through the inner ring's north gap where DDPG does not** (its policy \
         passes within 0.25 of the centre from some start): the page: **shown**, by the count \
         of seeds, DCP {} against DDPG {}; {}, a seed's outcome flipped. Exact: McNemar's test \
         on the {} discordant seeds ({b} where only DCP passes, {c} where only DDPG does), p = \
         {:.4}: **{}**; {} (five pairs give at most 5 discordant seeds, and McNemar's p falls \
         below 0.05 only from 6). Power: {}.",
        count_cell(k1, n),
        count_cell(k2, n),
        page.sensitivity,
        b + c,
        mcnemar_exact(b, c),
        if exact.word { "shown" } else { "not shown" },
        exact.sensitivity,
        rate_power_text(k1, k2, n).trim_start_matches("power "),
    );
    Ok(())
}
