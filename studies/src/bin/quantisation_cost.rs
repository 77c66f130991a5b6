//! `quantisation-cost`: what quantisation costs in the closed loop. Every given run folder's
//! `policy.postcard`, its f16 and int8 encodings ([`host_trainer::blob::export::encode`]), each
//! run through firmware-sim's test protocol (100 boundary starts, seed 0, the run's own recorded
//! plant) exactly as `host-trainer eval` runs it.
//!
//! ```text
//! cargo run --release -p studies --bin quantisation-cost -- RUN_DIR...
//! ```
//!
//! Prints one markdown row per run and encoding (success, settled error, stuck at margin, and
//! the difference from the f32 blob), then per (task, algorithm) and encoding the mean
//! difference over the runs (paired by run) with the 95 % percentile bootstrap interval of the
//! differences and their sign-flip permutation p ([`studies::paired`]), and whether every int8 run stays
//! within 0.02 of f32 success and 0.05 of its settled error.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use firmware_sim::nav::test_protocol::evaluate;
use host_trainer::blob::export::encode;
use host_trainer::run::folder;
use policy_core::Encoding;
use studies::paired::paired_text;
use studies::run_folder;

/// Success rate, settled error and stuck rate of one blob.
type Outcome = [f64; 3];

/// One run: its folder name and, per encoding, the outcome and the blob's size in bytes.
type RunResults = (String, Vec<(Encoding, Outcome, usize)>);

fn run_one(dir: &Path) -> Result<RunResults, String> {
    let name = run_folder::name(dir)?;
    let f32 = run_folder::read(dir, folder::POLICY)?;
    let scenario = run_folder::scenario(dir)?;
    let config = run_folder::test_protocol();
    let mut out = Vec::new();
    for encoding in Encoding::WEIGHTS_ONLY {
        let bytes = encode(&f32, encoding).map_err(|e| format!("{name}: {e}"))?;
        let report = evaluate(&bytes, &scenario, &config).map_err(|e| format!("{name}: {e}"))?;
        if let Some(e) = report.boot_error {
            return Err(format!("{name}: the {encoding} blob does not boot: {e}"));
        }
        let outcome = [report.success_rate, report.mean_error, report.stuck_rate];
        out.push((encoding, outcome, bytes.len()));
    }
    Ok((name, out))
}

fn main() -> ExitCode {
    let dirs: Vec<PathBuf> = std::env::args().skip(1).map(PathBuf::from).collect();
    if dirs.is_empty() {
        eprintln!("usage: quantisation-cost RUN_DIR...");
        return ExitCode::from(2);
    }
    let mut rows = Vec::new();
    for dir in &dirs {
        match run_one(dir) {
            Ok(row) => rows.push(row),
            Err(e) => {
                eprintln!("quantisation-cost: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    println!("| run | encoding | blob bytes | success | settled error | stuck at margin | Δ success | Δ settled error | Δ stuck |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|");
    // (task and algorithm, encoding) -> per-run differences from f32.
    let mut groups: BTreeMap<(String, String), Vec<Outcome>> = BTreeMap::new();
    let mut within = true;
    for (name, results) in &rows {
        let base = results[0].1;
        let group = run_folder::group(name);
        for &(encoding, o, len) in results {
            let d = [o[0] - base[0], o[1] - base[1], o[2] - base[2]];
            println!(
                "| {name} | {encoding} | {len} | {:.2} | {:.3} | {:.2} | {:+.2} | {:+.3} | {:+.2} |",
                o[0], o[1], o[2], d[0], d[1], d[2]
            );
            if encoding != Encoding::F32 {
                groups
                    .entry((group.to_string(), encoding.to_string()))
                    .or_default()
                    .push(d);
            }
            if encoding == Encoding::Int8 && (d[0].abs() > 0.02 || d[1].abs() > 0.05) {
                within = false;
            }
        }
    }
    println!();
    println!(
        "| task, algorithm | encoding | runs | Δ success | Δ settled error | Δ stuck at margin |"
    );
    println!("|---|---|---:|---:|---:|---:|");
    for ((group, encoding), diffs) in &groups {
        let cell = |k: usize| {
            let values: Vec<f64> = diffs.iter().map(|d| d[k]).collect();
            paired_text(&values, 3)
        };
        println!(
            "| {group} | {encoding} | {} | {} | {} | {} |",
            diffs.len(),
            cell(0),
            cell(1),
            cell(2)
        );
    }
    println!();
    println!(
        "int8 within 0.02 of f32 success and 0.05 of its settled error on every run: {}",
        if within { "yes" } else { "no" }
    );
    ExitCode::SUCCESS
}
