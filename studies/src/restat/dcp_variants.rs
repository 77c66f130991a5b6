//! docs/results/dcp-variants.md: nine DCP variants screened on seeds 0–4, the winner confirmed
//! on seeds 5–9, and the protocol's pre-registered selection and adoption rules.

use std::fmt::Write as _;

use anyhow::{ensure, Result};
use host_trainer::reproduce::verdict::{permutation_side, t_side, Side};
use host_trainer::stats::ALPHA;

use super::per_seed::PerSeed;
use super::text::{
    count_cell, diff, floor_note, judge, mean, mean_cell, paired_cell, paired_table,
    partner_extremes, power_text, sign_flip, t_cell, table, PairedRow,
};
use super::Page;
use crate::paired::ANY;

/// The page.
pub const PAGE: Page = Page {
    name: "dcp-variants",
    tables: &[
        "experiments/dcp-variants/per-seed-screening.tsv",
        "experiments/dcp-variants/per-seed-confirmation.tsv",
    ],
    rows_on: None,
    build,
    rows_shown: super::lines_on_page,
};

const SUCCESS: &str = "test success";
const ERROR: &str = "settled error";
const PASS: &str = "pass within 0.25";
const STUCK: &str = "stuck at margin";
const TIME: &str = "training s";
/// A run failed below this test success (the protocol's "failed runs").
const FAILED_BELOW: f64 = 0.5;
/// The candidates of step 3: mean success at least this.
const ELIGIBLE: f64 = 0.85;
const WINNER: &str = "combo-2";

fn arm(t: &PerSeed, run: &str, column: &str) -> Result<Vec<f64>> {
    t.values(&[("run", run)], column)
}

fn build(tables: &[PerSeed]) -> Result<String> {
    let (screen, confirm) = (&tables[0], &tables[1]);
    let mut out = String::new();
    let _ = writeln!(
        out,
        "**Screening** (nav-walls, seeds 0–4), means over the seeds:\n"
    );
    out.push_str(&means(screen)?);
    let _ = writeln!(
        out,
        "\n**Confirmation** (fresh seeds 5–9), means over the seeds:\n"
    );
    out.push_str(&means(confirm)?);
    out.push_str(&paired_differences(confirm)?);
    out.push_str("\n**Verdicts.**\n\n");
    selection(screen, &mut out)?;
    adoption(confirm, &mut out)?;
    goal(confirm, &mut out)?;
    comparisons(confirm, &mut out)?;
    Ok(out)
}

fn means(t: &PerSeed) -> Result<String> {
    let mut rows = Vec::new();
    for run in t.distinct("run")? {
        let success = arm(t, &run, SUCCESS)?;
        let failed = success.iter().filter(|s| **s < FAILED_BELOW).count();
        rows.push(vec![
            run.clone(),
            success.len().to_string(),
            mean_cell(&success, 2),
            mean_cell(&arm(t, &run, ERROR)?, 3),
            mean_cell(&arm(t, &run, PASS)?, 2),
            mean_cell(&arm(t, &run, STUCK)?, 2),
            count_cell(failed, success.len()),
            mean_cell(&arm(t, &run, TIME)?, 0),
        ]);
    }
    Ok(table(
        &[
            "run",
            "seeds",
            SUCCESS,
            ERROR,
            PASS,
            STUCK,
            "failed runs (success < 0.5)",
            TIME,
        ],
        1,
        &rows,
    ))
}

/// The confirmation's layouts and baselines, by their labels.
const LAYOUTS: [&str; 2] = ["nav-walls", "nav-open"];
const BASELINES: [&str; 3] = ["the paper's DCP", "DDPG", "TD3"];

fn confirm_arm(t: &PerSeed, layout: &str, who: &str, column: &str) -> Result<Vec<f64>> {
    arm(t, &format!("{layout}, {who}"), column)
}

fn winner_label() -> String {
    format!("winner (`{WINNER}`)")
}

fn paired_differences(t: &PerSeed) -> Result<String> {
    let mut rows = Vec::new();
    for layout in LAYOUTS {
        for baseline in BASELINES {
            let d = |column: &str, decimals: usize| -> Result<String> {
                let w = confirm_arm(t, layout, &winner_label(), column)?;
                let b = confirm_arm(t, layout, baseline, column)?;
                Ok(paired_cell(&diff(&w, &b), decimals))
            };
            rows.push(vec![
                layout.to_string(),
                baseline.to_string(),
                d(ERROR, 3)?,
                d(SUCCESS, 2)?,
                d(STUCK, 2)?,
            ]);
        }
    }
    Ok(format!(
        "\nPaired per-seed differences, winner minus baseline: the mean with the bootstrap \
         interval of the five differences, and the sign-flip p (exact over 32 sign patterns). \
         \"(all 5 equal)\" where the five differences were equal (all 0: no interval and no \
         test can say more).\n\n{}",
        table(&["layout", "winner −", ERROR, SUCCESS, STUCK], 2, &rows)
    ))
}

/// Steps 2–3: the winner is the candidate with the lowest mean settled error among those with
/// mean success ≥ 0.85.
fn selection(t: &PerSeed, out: &mut String) -> Result<()> {
    let mut eligible = Vec::new();
    for run in t.distinct("run")? {
        if run.starts_with("baseline") {
            continue;
        }
        if mean(&arm(t, &run, SUCCESS)?) >= ELIGIBLE {
            eligible.push(run);
        }
    }
    let winner_at = eligible.iter().position(|r| r == WINNER);
    ensure!(winner_at.is_some(), "{WINNER} is not a candidate");
    let winner_at = winner_at.unwrap_or_default();
    let n = 5;
    let runs: Vec<f64> = eligible
        .iter()
        .map(|r| arm(t, r, ERROR))
        .collect::<Result<Vec<_>>>()?
        .concat();
    let pick = |r: &[f64]| {
        (0..eligible.len())
            .min_by(|&a, &b| mean(&r[a * n..][..n]).total_cmp(&mean(&r[b * n..][..n])))
            .unwrap_or_default()
    };
    let chosen = pick(&runs);
    ensure!(chosen == winner_at, "the rule picks {}", eligible[chosen]);
    // Each candidate's run against the winner's extremes; the winner's against the runner-up's.
    let runner_up = (0..eligible.len())
        .filter(|&a| a != winner_at)
        .min_by(|&a, &b| mean(&runs[a * n..][..n]).total_cmp(&mean(&runs[b * n..][..n])))
        .unwrap_or_default();
    let alts = partner_extremes(
        &runs,
        n,
        |a| if a == winner_at { runner_up } else { winner_at },
    );
    let pre = judge(&runs, &alts, pick);
    let w = &runs[winner_at * n..][..n];
    let r = &runs[runner_up * n..][..n];
    let d = diff(w, r);
    let exact = judge(
        &[w, r].concat(),
        &partner_extremes(&[w, r].concat(), n, |a| 1 - a),
        |v| permutation_side(&diff(&v[..n], &v[n..]), ALPHA),
    );
    let means: Vec<String> = eligible
        .iter()
        .enumerate()
        .map(|(a, name)| format!("`{name}` {:.3}", mean(&runs[a * n..][..n])))
        .collect();
    let _ = writeln!(
        out,
        "- **Steps 2–3: the winner is `{WINNER}`.** Pre-registered (the lowest mean settled \
         error among the candidates with mean success ≥ {ELIGIBLE}: {}): **`{WINNER}`**; {}, a \
         candidate's run changed to the lowest or highest of the winner's, the winner's to the \
         runner-up's. A selection rule is not a test: the same choice by an exact test asks \
         whether the winner's lead over the runner-up, `{}`, is resolved. Exact: the sign-flip \
         test of the winner's settled error minus the runner-up's, paired by seed, mean \
         {:+.3}, {}: **{}**; {}; {}. Power: {}.",
        means.join(", "),
        pre.sensitivity,
        eligible[runner_up],
        mean(&d),
        sign_flip(&d),
        if exact.word == Side::Below {
            "resolved"
        } else {
            "not resolved"
        },
        exact.sensitivity,
        floor_note(n).unwrap_or_default(),
        power_text(&d, 3).trim_start_matches("power "),
    );
    Ok(())
}

/// Step 5: adopted if on seeds 5–9 on the pinwheel the winner's mean settled error is below
/// the paper's DCP's and DDPG's, and the 95 % t interval of its paired difference from the
/// paper's DCP lies below 0.
fn adoption(t: &PerSeed, out: &mut String) -> Result<()> {
    let walls = |who: &str| confirm_arm(t, "nav-walls", who, ERROR);
    let (w, dcp, ddpg) = (
        walls(&winner_label())?,
        walls("the paper's DCP")?,
        walls("DDPG")?,
    );
    let n = w.len();
    let runs = [w.clone(), dcp.clone(), ddpg.clone()].concat();
    // The winner's runs against the paper's DCP's extremes; the baselines' against the winner's.
    let alts = partner_extremes(&runs, n, |a| if a == 0 { 1 } else { 0 });
    let means_below = move |r: &[f64]| {
        let m = mean(&r[..n]);
        m < mean(&r[n..2 * n]) && m < mean(&r[2 * n..])
    };
    let pre = judge(&runs, &alts, |r| {
        means_below(r) && t_side(&diff(&r[..n], &r[n..2 * n])) == Side::Below
    });
    let exact = judge(&runs, &alts, |r| {
        means_below(r) && permutation_side(&diff(&r[..n], &r[n..2 * n]), ALPHA) == Side::Below
    });
    let d = diff(&w, &dcp);
    let word = |adopted: bool| if adopted { "adopted" } else { "not adopted" };
    let _ = writeln!(
        out,
        "- **Step 5: adoption.** Pre-registered (on the pinwheel, seeds 5–9, the winner's mean \
         settled error below the paper's DCP's and DDPG's, {:.3} against {:.3} and {:.3}, and \
         the 95 % t interval of its paired difference from the paper's DCP below 0, {}): \
         **{}**; {}, a winner's run changed to the lowest or highest of the paper's DCP's, a \
         baseline's run to the winner's. Exact (the same means, and the sign-flip test of the \
         paired differences below 0 at p < 0.05): **{}**: all five differences are negative, \
         {}, and {}; {}. Power: {}. The adoption stands by the protocol; by the exact test it \
         needed a sixth pair of seeds.",
        mean(&w),
        mean(&dcp),
        mean(&ddpg),
        t_cell(&d, 3, ANY),
        word(pre.word),
        pre.sensitivity,
        word(exact.word),
        sign_flip(&d),
        floor_note(n).unwrap_or_default(),
        exact.sensitivity,
        power_text(&d, 3).trim_start_matches("power "),
    );
    Ok(())
}

/// The study's goal (not a rule of the protocol): success ≥ 0.9, settled error below 0.5 and a
/// stuck rate below DDPG's, on the pinwheel over seeds 5–9, as means.
fn goal(t: &PerSeed, out: &mut String) -> Result<()> {
    let w = |c: &str| confirm_arm(t, "nav-walls", &winner_label(), c);
    let ddpg = |c: &str| confirm_arm(t, "nav-walls", "DDPG", c);
    let (success, error, stuck) = (w(SUCCESS)?, w(ERROR)?, w(STUCK)?);
    let ddpg_stuck = ddpg(STUCK)?;
    let n = success.len();
    let runs = [
        success.clone(),
        error.clone(),
        stuck.clone(),
        ddpg_stuck.clone(),
    ]
    .concat();
    // The winner's runs against DDPG's extremes of the same quantity; DDPG's against the
    // winner's.
    let ddpg_arms = [
        ddpg(SUCCESS)?,
        ddpg(ERROR)?,
        ddpg_stuck.clone(),
        stuck.clone(),
    ];
    let alts: Vec<Vec<f64>> = (0..runs.len())
        .map(|i| {
            let other = &ddpg_arms[i / n];
            let lo = other.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = other.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            vec![lo, hi]
        })
        .collect();
    let met = move |r: &[f64]| {
        mean(&r[..n]) >= 0.9
            && mean(&r[n..2 * n]) < 0.5
            && mean(&r[2 * n..3 * n]) < mean(&r[3 * n..])
    };
    let pre = judge(&runs, &alts, met);
    let d = diff(&stuck, &ddpg_stuck);
    let shown = |r: &[f64]| {
        met(r) && permutation_side(&diff(&r[2 * n..3 * n], &r[3 * n..]), ALPHA) == Side::Below
    };
    let exact = judge(&runs, &alts, shown);
    let count = |v: &[f64], f: fn(f64) -> bool| v.iter().filter(|x| f(**x)).count();
    let _ = writeln!(
        out,
        "- **The study's goal** (set for the study, not a rule of the protocol: on the pinwheel \
         over seeds 5–9, mean success ≥ 0.9, mean settled error below 0.5 and a stuck rate \
         below DDPG's): the page: **met** (success {}, settled error {}, stuck {} against \
         DDPG's {}); by the means, **{}**; {}, a winner's run changed to DDPG's lowest or \
         highest of the same quantity. By seeds: success ≥ 0.9 on {}, settled error below 0.5 on {}, \
         stuck below DDPG's seed on {}. Exact (the stuck rate below DDPG's by the sign-flip \
         test of the paired differences, mean {:+.2}, {}): **{}**; {}. Power of the stuck \
         comparison: {}.",
        mean_cell(&success, 2),
        mean_cell(&error, 3),
        mean_cell(&stuck, 2),
        mean_cell(&ddpg_stuck, 2),
        if pre.word { "met" } else { "not met" },
        pre.sensitivity,
        count_cell(count(&success, |v| v >= 0.9), n),
        count_cell(count(&error, |v| v < 0.5), n),
        count_cell(d.iter().filter(|v| **v < 0.0).count(), n),
        mean(&d),
        sign_flip(&d),
        if exact.word {
            "met"
        } else {
            "not shown: the stuck rate's lead over DDPG is not resolved"
        },
        exact.sensitivity,
        power_text(&d, 2).trim_start_matches("power "),
    );
    Ok(())
}

/// The page's readings of the winner against each baseline (settled error, seeds 5–9).
fn comparisons(t: &PerSeed, out: &mut String) -> Result<()> {
    let mut rows = Vec::new();
    for layout in LAYOUTS {
        for baseline in BASELINES {
            let w = confirm_arm(t, layout, &winner_label(), ERROR)?;
            let b = confirm_arm(t, layout, baseline, ERROR)?;
            rows.push(PairedRow::new(
                format!("{layout}: winner − {baseline}"),
                &w,
                &b,
                3,
                ANY,
            ));
        }
    }
    let _ = writeln!(
        out,
        "- **The winner against each baseline** (settled error, seeds 5–9). The page reads the \
         95 % t interval of the paired differences (nearer than the paper's DCP and DDPG on \
         both layouts and than TD3 on the pinwheel; against TD3 without walls \"not resolved by \
         five seeds\"); the exact test resolves none of the six, since {}.\n",
        floor_note(5).unwrap_or_default()
    );
    out.push_str(&paired_table("the page", &rows));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use host_trainer::stats::student_t::mean_interval;

    #[test]
    fn the_adoption_rule_gives_the_interval_the_page_published() {
        // Step 5 as the page decided it: "−1.359 ± 0.351 (interval [−1.71, −1.01])".
        let t = crate::restat::tests::committed(PAGE.tables[1]);
        let walls = |who: &str| confirm_arm(&t, "nav-walls", who, ERROR).expect("an arm");
        let d = diff(&walls(&winner_label()), &walls("the paper's DCP"));
        let m = mean_interval(&d).expect("five");
        assert!((m.mean + 1.359).abs() < 5e-4, "{}", m.mean);
        assert!((m.half_width.expect("spread") - 0.351).abs() < 5e-4);
        assert_eq!(t_side(&d), Side::Below);
        // All five below 0: the sign-flip test's smallest p, 2/32, not below 0.05.
        assert_eq!(sign_flip(&d).p, 0.0625);
        assert_eq!(permutation_side(&d, ALPHA), Side::Spans);
    }
}
