//! `compare-in-loop`: what DCP's compare step on the device does in the closed loop. Every
//! given run folder's `policy.postcard` run through firmware-sim's test protocol (100 boundary
//! starts, seed 0, the run's own recorded plant) plainly, and with its `critic.postcard`
//! refining each action (policy-core's `compare::refine_model`: T proposals with noise σ around
//! the actor's unit action, the best under the critic if its Q is higher), for T = 4 and 16 at
//! σ = 0.2, the σc every run trained with. The same computation as `firmware-sim run --blob P
//! --critic C --refine T,0.2`.
//!
//! ```text
//! cargo run --release -p studies --bin compare-in-loop -- RUN_DIR...
//! ```
//!
//! Prints one markdown row per run and setting (success, settled error, stuck at margin, the
//! share of ticks on which a proposal replaced the actor's action), then per (task, algorithm)
//! and setting the mean over the runs with its 95 % percentile bootstrap interval, and the mean
//! paired difference from the plain actor with the bootstrap interval of the differences and
//! their sign-flip permutation p ([`studies::paired`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use firmware_sim::boot::{boot, PlantSizes};
use firmware_sim::controller::Controller;
use firmware_sim::nav::test_protocol::evaluate_controller;
use firmware_sim::refine::RefiningPolicy;
use host_trainer::run::folder;
use host_trainer::stats::bootstrap::mean_text;
use studies::paired::paired_text;
use studies::run_folder;

/// The settings compared: None is the plain actor, Some(T) the compare step with T proposals.
const SETTINGS: [Option<usize>; 3] = [None, Some(4), Some(16)];
/// σ of the proposals: the σc every compared run trained with (the default exploration σ).
const SIGMA: f32 = 0.2;

/// Success rate, settled error, stuck rate and the share of ticks a proposal won.
type Outcome = [f64; 4];

fn setting_name(s: Option<usize>) -> String {
    s.map_or("actor".into(), |t| format!("T = {t}"))
}

fn run_one(dir: &Path) -> Result<(String, Vec<Outcome>), String> {
    let name = run_folder::name(dir)?;
    let actor = run_folder::read(dir, folder::POLICY)?;
    let critic = run_folder::read(dir, folder::CRITIC)?;
    let scenario = run_folder::scenario(dir)?;
    let sizes = PlantSizes::of(&scenario).map_err(|e| format!("{name}: {e}"))?;
    let config = run_folder::test_protocol();
    let mut out = Vec::new();
    for setting in SETTINGS {
        let mut policy = boot(&actor, &sizes).map_err(|e| format!("{name}: {e}"))?;
        let mut refining;
        let counts;
        let controller: &mut dyn Controller = match setting {
            None => {
                counts = None;
                &mut policy
            }
            Some(t) => {
                refining =
                    RefiningPolicy::new(policy.model().clone(), &critic, t, SIGMA, config.seed)
                        .map_err(|e| format!("{name}: {e}"))?;
                counts = Some(refining.counts());
                &mut refining
            }
        };
        let report = evaluate_controller(controller, &scenario, &config)
            .map_err(|e| format!("{name}: {e}"))?;
        let won = counts.map_or(0.0, |c| {
            let (ticks, replaced) = c.get();
            replaced as f64 / ticks.max(1) as f64
        });
        out.push([
            report.success_rate,
            report.mean_error,
            report.stuck_rate,
            won,
        ]);
    }
    Ok((name, out))
}

/// The digits of each column of an outcome.
const DIGITS: [usize; 4] = [2, 3, 2, 3];

fn main() -> ExitCode {
    let dirs: Vec<PathBuf> = std::env::args().skip(1).map(PathBuf::from).collect();
    if dirs.is_empty() {
        eprintln!("usage: compare-in-loop RUN_DIR...");
        return ExitCode::from(2);
    }
    println!("| run | setting | success | settled error | stuck at margin | proposal won |");
    println!("|---|---|---:|---:|---:|---:|");
    // (task and algorithm, setting) -> per-run outcomes and differences from the plain actor.
    let mut groups: BTreeMap<(String, usize), (Vec<Outcome>, Vec<Outcome>)> = BTreeMap::new();
    for dir in &dirs {
        let (name, results) = match run_one(dir) {
            Ok(r) => r,
            Err(e) => {
                eprintln!("compare-in-loop: {e}");
                return ExitCode::FAILURE;
            }
        };
        let group = run_folder::group(&name);
        let base = results[0];
        for (k, (setting, o)) in SETTINGS.iter().zip(&results).enumerate() {
            println!(
                "| {name} | {} | {:.2} | {:.3} | {:.2} | {:.3} |",
                setting_name(*setting),
                o[0],
                o[1],
                o[2],
                o[3]
            );
            let d = [o[0] - base[0], o[1] - base[1], o[2] - base[2], o[3]];
            let entry = groups.entry((group.to_string(), k)).or_default();
            entry.0.push(*o);
            entry.1.push(d);
        }
    }
    println!();
    println!("| task, algorithm | setting | runs | success | settled error | stuck at margin | proposal won | Δ success | Δ settled error | Δ stuck |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for ((group, k), (outcomes, diffs)) in &groups {
        let col = |v: &[Outcome], i: usize| v.iter().map(|o| o[i]).collect::<Vec<f64>>();
        let mean = |i: usize| mean_text(&col(outcomes, i), DIGITS[i]);
        let delta = |i: usize| {
            if *k == 0 {
                "-".to_string()
            } else {
                paired_text(&col(diffs, i), DIGITS[i])
            }
        };
        println!(
            "| {group} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            setting_name(SETTINGS[*k]),
            outcomes.len(),
            mean(0),
            mean(1),
            mean(2),
            mean(3),
            delta(0),
            delta(1),
            delta(2)
        );
    }
    ExitCode::SUCCESS
}
