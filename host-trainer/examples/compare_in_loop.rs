//! What DCP's compare step on the device does in the closed loop: every given
//! run folder's `policy.postcard` run through firmware-sim's test protocol (100 boundary starts,
//! seed 0, the run's own recorded plant) plainly, and with its `critic.postcard` refining each
//! action (policy-core's `compare::refine_model`: T proposals with noise σ around the actor's
//! unit action, the best under the critic if its Q is higher), for T = 4 and 16 at σ = 0.2, the
//! σc every run trained with. The same computation as `firmware-sim run --blob P --critic C
//! --refine T,0.2`.
//!
//! ```text
//! cargo run --release -p host-trainer --example compare_in_loop -- RUN_DIR...
//! ```
//!
//! Prints one markdown row per run and setting (success, settled error, stuck at margin, the
//! share of ticks on which a proposal replaced the actor's action), then per (task, algorithm)
//! and setting the mean with its 95 % Student-t interval over the runs, and the mean paired
//! difference from the plain actor with its interval.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use firmware_sim::boot::{boot, PlantSizes};
use firmware_sim::controller::Controller;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::{evaluate_controller, EvalConfig};
use firmware_sim::refine::RefiningPolicy;
use host_trainer::run::folder;
use host_trainer::stats::student_t::mean_interval;

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
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .ok_or_else(|| format!("{}: not a run folder", dir.display()))?;
    let read = |file: &str| {
        std::fs::read(dir.join(file)).map_err(|e| format!("{}: {e}", dir.join(file).display()))
    };
    let (actor, critic) = (read(folder::POLICY)?, read(folder::CRITIC)?);
    let plant = String::from_utf8(read(folder::SCENARIO)?).map_err(|e| e.to_string())?;
    let scenario = Scenario::from_toml_str(&plant).map_err(|e| format!("{name}: {e}"))?;
    let sizes = PlantSizes::of(&scenario).map_err(|e| format!("{name}: {e}"))?;
    let config = EvalConfig {
        episodes: 100,
        ..EvalConfig::default()
    };
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

fn cell(values: &[f64], digits: usize) -> String {
    match mean_interval(values) {
        Some(m) => match m.half_width {
            Some(h) => format!("{:+.digits$} ± {h:.digits$}", m.mean),
            None => format!("{:+.digits$}", m.mean),
        },
        None => "-".into(),
    }
}

fn main() -> ExitCode {
    let dirs: Vec<PathBuf> = std::env::args().skip(1).map(PathBuf::from).collect();
    if dirs.is_empty() {
        eprintln!("usage: compare_in_loop RUN_DIR...");
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
                eprintln!("compare_in_loop: {e}");
                return ExitCode::FAILURE;
            }
        };
        let group = name.rsplit_once("__").map_or(name.as_str(), |(g, _)| g);
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
        let delta = |i: usize, digits: usize| {
            if *k == 0 {
                "-".to_string()
            } else {
                cell(&col(diffs, i), digits)
            }
        };
        println!(
            "| {group} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            setting_name(SETTINGS[*k]),
            outcomes.len(),
            cell(&col(outcomes, 0), 2),
            cell(&col(outcomes, 1), 3),
            cell(&col(outcomes, 2), 2),
            cell(&col(outcomes, 3), 3),
            delta(0, 2),
            delta(1, 3),
            delta(2, 2)
        );
    }
    ExitCode::SUCCESS
}
