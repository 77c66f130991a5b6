//! `integer-cost`: what the integer encoding costs in the closed loop
//! (docs/results/integer-cost.md). Every given run folder's f32 `policy.postcard` and its
//! integer encoding, calibrated exactly as `host-trainer export --encoding integer` calibrates
//! it, each run through firmware-sim's test protocol (100 boundary starts, seed 0, the run's
//! own recorded plant) clean and with the faults of the HIL checks.
//!
//! ```text
//! cargo run --release -p studies --bin integer-cost -- RUN_DIR...
//! ```
//!
//! Prints one markdown row per run and condition (both encodings' success, settled error and
//! stuck rate, and the differences integer − f32), then per (task, algorithm) and condition
//! the mean paired difference with its bootstrap interval and sign-flip p
//! ([`studies::paired`]), the starts whose pass/fail the encoding changed, and the protocol's
//! verdict for success and for settled error.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use firmware_sim::nav::faults::Faults;
use firmware_sim::nav::test_protocol::{evaluate, EvalConfig};
use host_trainer::blob::export::{calibration_observations, encode_integer, CALIBRATION_EPISODES};
use host_trainer::run::folder;
use host_trainer::stats::bootstrap::mean_ci;
use host_trainer::stats::permutation::sign_flip_permutation;
use host_trainer::stats::power::power_paired;
use host_trainer::stats::sensitivity::sensitivity;
use host_trainer::stats::{REPS, SEED};
use studies::paired::paired_text;
use studies::run_folder;

/// The faults of the "faults" condition: the HIL checks' set (docs/firmware-sim.md).
const FAULTS: &str = "dropout-nan:0.05,stuck:0@50";

/// The two conditions, in the order the tables print them.
const CONDITIONS: [&str; 2] = ["clean", "faults"];

/// One blob's outcome under one condition: success rate, settled error, stuck rate, and each
/// start's pass/fail (for the starts the encoding changed).
struct Outcome {
    measures: [f64; 3],
    passed: Vec<bool>,
}

/// One run under one condition: the f32 blob's and the integer blob's outcomes.
struct Pair {
    run: String,
    condition: &'static str,
    f32: Outcome,
    integer: Outcome,
}

fn outcome(
    blob: &[u8],
    name: &str,
    which: &str,
    scenario: &firmware_sim::nav::scenario::Scenario,
    config: &EvalConfig,
) -> Result<Outcome, String> {
    let report = evaluate(blob, scenario, config).map_err(|e| format!("{name}: {e}"))?;
    if let Some(e) = report.boot_error {
        return Err(format!("{name}: the {which} blob does not boot: {e}"));
    }
    Ok(Outcome {
        measures: [report.success_rate, report.mean_error, report.stuck_rate],
        passed: report.episodes.iter().map(|e| e.success).collect(),
    })
}

fn run_one(dir: &Path) -> Result<Vec<Pair>, String> {
    let name = run_folder::name(dir)?;
    let f32 = run_folder::read(dir, folder::POLICY)?;
    let scenario = run_folder::scenario(dir)?;
    // What `export --encoding integer` does: calibrate on the f32 policy's own visited states.
    let observations = calibration_observations(&f32, &scenario, CALIBRATION_EPISODES as usize)
        .map_err(|e| format!("{name}: calibration: {e}"))?;
    let integer = encode_integer(&f32, &observations)
        .map_err(|e| format!("{name}: integer export failed: {e}"))?;
    let faults: Faults = FAULTS.parse().map_err(|e| format!("{FAULTS}: {e}"))?;
    let mut pairs = Vec::new();
    for condition in CONDITIONS {
        let mut config = run_folder::test_protocol();
        if condition == "faults" {
            config.faults = faults.clone();
        }
        pairs.push(Pair {
            run: name.clone(),
            condition,
            f32: outcome(&f32, &name, "f32", &scenario, &config)?,
            integer: outcome(&integer, &name, "integer", &scenario, &config)?,
        });
    }
    Ok(pairs)
}

/// The protocol's verdict on one measure's paired differences: `better_up` says whether a
/// larger value is better (success) or worse (settled error). Holds where the 95 % bootstrap
/// interval of the mean difference contains 0 or lies on the better side; costs where it lies
/// on the worse side and the sign-flip p < 0.05; unclear otherwise.
fn verdict(diffs: &[f64], better_up: bool) -> &'static str {
    let Some(ci) = mean_ci(diffs) else {
        return "no runs";
    };
    let worse = if better_up { ci.hi < 0.0 } else { ci.lo > 0.0 };
    if !worse {
        "holds"
    } else if sign_flip_permutation(diffs, REPS as u64, SEED).p < 0.05 {
        "costs"
    } else {
        "unclear"
    }
}

/// The verdict with its sensitivity (a run's difference set to 0, as if the encoding changed
/// nothing on it, or to the lowest or highest difference seen; up to two runs at once: each
/// try reruns the bootstrap) and the power the paired comparison had at the observed mean and
/// spread.
fn verdict_text(diffs: &[f64], better_up: bool) -> String {
    let (lo, hi) = diffs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &d| {
            (l.min(d), h.max(d))
        });
    let alternatives = |_: usize, v: f64| -> Vec<f64> {
        let mut a: Vec<f64> = [0.0, lo, hi].into_iter().filter(|&x| x != v).collect();
        a.dedup();
        a
    };
    let s = sensitivity(diffs, alternatives, |v| verdict(v, better_up), 2);
    let n = diffs.len();
    let mean = diffs.iter().sum::<f64>() / n as f64;
    let sd = (diffs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (n.max(2) - 1) as f64).sqrt();
    let power = if sd > 0.0 && mean != 0.0 {
        format!("power {:.2}", power_paired(mean, sd, n as u64, 0.05))
    } else {
        "power –, no spread".into()
    };
    format!("**{}** ({s}; {power})", verdict(diffs, better_up))
}

fn main() -> ExitCode {
    let dirs: Vec<PathBuf> = std::env::args().skip(1).map(PathBuf::from).collect();
    if dirs.is_empty() {
        eprintln!("usage: integer-cost RUN_DIR...");
        return ExitCode::from(2);
    }
    let mut pairs = Vec::new();
    for dir in &dirs {
        match run_one(dir) {
            Ok(mut p) => pairs.append(&mut p),
            Err(e) => {
                eprintln!("integer-cost: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    println!("| run | condition | success f32 → integer | settled error f32 → integer | stuck f32 → integer | Δ success | Δ settled error | Δ stuck |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|");
    // (task and algorithm, condition) -> the runs' pairs.
    let mut groups: BTreeMap<(String, usize), Vec<&Pair>> = BTreeMap::new();
    for p in &pairs {
        let (a, b) = (p.f32.measures, p.integer.measures);
        println!(
            "| {} | {} | {:.2} → {:.2} | {:.3} → {:.3} | {:.2} → {:.2} | {:+.2} | {:+.3} | {:+.2} |",
            p.run,
            p.condition,
            a[0],
            b[0],
            a[1],
            b[1],
            a[2],
            b[2],
            b[0] - a[0],
            b[1] - a[1],
            b[2] - a[2]
        );
        let c = CONDITIONS
            .iter()
            .position(|&c| c == p.condition)
            .unwrap_or(0);
        groups
            .entry((run_folder::group(&p.run).to_string(), c))
            .or_default()
            .push(p);
    }
    println!();
    println!("| task, algorithm | condition | runs | Δ success | Δ settled error | Δ stuck at margin | starts lost / gained | success | settled error |");
    println!("|---|---|---:|---:|---:|---:|---:|---|---|");
    for ((group, c), runs) in &groups {
        let diffs = |k: usize| -> Vec<f64> {
            runs.iter()
                .map(|p| p.integer.measures[k] - p.f32.measures[k])
                .collect()
        };
        let (mut lost, mut gained) = (0, 0);
        for p in runs {
            for (f, i) in p.f32.passed.iter().zip(&p.integer.passed) {
                lost += usize::from(*f && !*i);
                gained += usize::from(!*f && *i);
            }
        }
        println!(
            "| {group} | {} | {} | {} | {} | {} | {lost} / {gained} | {} | {} |",
            CONDITIONS[*c],
            runs.len(),
            paired_text(&diffs(0), 3),
            paired_text(&diffs(1), 3),
            paired_text(&diffs(2), 3),
            verdict_text(&diffs(0), true),
            verdict_text(&diffs(1), false),
        );
    }
    ExitCode::SUCCESS
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rule_reads_the_interval_then_the_exact_test() {
        // The encoding changed nothing: holds.
        assert_eq!(verdict(&[0.0; 20], true), "holds");
        // 20 runs that all lose 0.01 to 0.05 of success: interval below 0, exact p = 2/2^20.
        let lose: Vec<f64> = (0..20).map(|i| -0.01 - 0.002 * f64::from(i)).collect();
        assert_eq!(verdict(&lose, true), "costs");
        // The same for a settled error, where higher is worse.
        let higher: Vec<f64> = lose.iter().map(|d| -d).collect();
        assert_eq!(verdict(&higher, false), "costs");
        assert_eq!(verdict(&lose, false), "holds");
        // Five runs all worse: the interval lies below 0, but no sign-flip test of 5 pairs
        // reaches p < 0.05 (2 of 32 patterns = 0.0625).
        assert_eq!(verdict(&[-0.1, -0.2, -0.1, -0.3, -0.2], true), "unclear");
        assert_eq!(verdict(&[], true), "no runs");
    }

    #[test]
    fn the_verdict_names_its_sensitivity_and_power() {
        let text = verdict_text(&[-0.1, -0.2, -0.1, -0.3, -0.2], true);
        // Two runs set to 0 leave the interval below 0 (a resample of only zeros is 1 in 100).
        assert_eq!(
            text,
            "**unclear** (no change of up to 2 of the 5 runs flips it; power 1.00)"
        );
        let none = verdict_text(&[0.0; 4], true);
        assert_eq!(
            none,
            "**holds** (no change of up to 2 of the 4 runs flips it; power –, no spread)"
        );
    }
}
