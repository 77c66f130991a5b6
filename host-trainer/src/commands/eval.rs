//! `host-trainer eval`: a blob (or an actor of several heads with its critic) run through
//! firmware-sim's test protocol.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Args;
use firmware_sim::boot::{self, PlantSizes};
use firmware_sim::controller::Controller;
use firmware_sim::files;
use firmware_sim::heads::HeadsPolicy;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::{self, EvalConfig, Report};
use firmware_sim::outln;
use firmware_sim::plant_link::child::ChildPlant;
use firmware_sim::plant_test::{evaluate_plant, PlantReport, PlantTestConfig};
use host_trainer::run::trainer;

#[derive(Debug, Args)]
pub(crate) struct EvalArgs {
    /// The policy blob (policy.postcard).
    #[arg(long)]
    blob: PathBuf,
    /// The critic blob of an actor of several heads (DCP's `heads`): it chooses the head.
    #[arg(long)]
    critic: Option<PathBuf>,
    /// Built-in scenario or scenario file.
    #[arg(long, default_value = "nav-walls")]
    task: String,
    /// A plant of your own instead of a scenario: "CMD ARGS" starts it as a child process that
    /// speaks the plant link (docs/own-plant.md); the test is then the protocol for any plant
    /// (`firmware-sim run --plant-cmd` has its criteria and faults).
    #[arg(long, conflicts_with_all = ["task", "critic"])]
    plant_cmd: Option<String>,
    /// The longest wait, in seconds, for the plant's answer to a reset or step.
    #[arg(long, default_value_t = 10.0)]
    plant_timeout: f64,
    /// Test starts.
    #[arg(long, default_value_t = 100)]
    episodes: usize,
    /// Seed of the test starts.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Also write the report as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
}

/// Runs the test and prints its summary; exits as `firmware-sim run` does: 0 when the gate
/// passes, 1 when it fails (errors are 2, from `main`).
pub(crate) fn eval_command(args: EvalArgs) -> Result<ExitCode> {
    // Everything that can be checked is checked before the evaluation runs.
    if let Some(path) = &args.json {
        files::check_output(path).with_context(|| format!("cannot write {}", path.display()))?;
    }
    let blob = files::read_blob(&args.blob)
        .with_context(|| format!("cannot read blob {}", args.blob.display()))?;
    if let Some(command) = &args.plant_cmd {
        return eval_on_plant(&args, command, &blob);
    }
    let scenario = trainer::scenario(&args.task)?;
    let critic = match &args.critic {
        Some(path) => Some(
            files::read_blob(path)
                .with_context(|| format!("cannot read critic {}", path.display()))?,
        ),
        None => None,
    };
    let report = evaluate(
        &blob,
        critic.as_deref(),
        &args.blob,
        &scenario,
        args.episodes,
        args.seed,
    )?;
    if let Some(path) = &args.json {
        files::write_atomic(path, report_json(&report)?.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    print_summary(&report);
    Ok(super::train::verdict_code(report.pass.passed))
}

/// `eval --plant-cmd`: the blob through the test protocol for any plant, on a plant process.
fn eval_on_plant(args: &EvalArgs, command: &str, blob: &[u8]) -> Result<ExitCode> {
    let timeouts = super::train::plant_timeouts(args.plant_timeout)?;
    let mut plant = ChildPlant::spawn(command, timeouts)?;
    let sizes = PlantSizes::of_env(&plant);
    let mut policy = boot::boot(blob, &sizes)
        .with_context(|| format!("{} does not boot on this plant", args.blob.display()))?;
    let cfg = PlantTestConfig {
        episodes: args.episodes,
        seed: args.seed,
        ..PlantTestConfig::default()
    };
    let name = plant.hello().name.clone();
    let report = evaluate_plant(&mut policy, &mut plant, &name, &cfg)?;
    if let Some(path) = &args.json {
        files::write_atomic(path, plant_report_json(&report)?.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    print_summary_text(&plant_summary_line(&report));
    Ok(super::train::verdict_code(report.pass.passed))
}

/// firmware-sim's test protocol on the blob; a blob that does not boot is an error here.
/// Boots the blob as firmware-sim's loop does and runs its test protocol. Where the loop would run
/// a blob that does not boot in the safe state (what a chip does), a user asking to evaluate a
/// file gets an error naming `source`, before any episode runs.
/// With `critic`, the blob is an actor of several heads and the critic chooses among them.
pub(crate) fn evaluate(
    blob: &[u8],
    critic: Option<&[u8]>,
    source: &Path,
    scenario: &Scenario,
    episodes: usize,
    seed: u64,
) -> Result<Report> {
    let plant = PlantSizes::of(scenario)?;
    let does_not_boot = || format!("{} does not boot", source.display());
    let mut policy: Box<dyn Controller> = match critic {
        None => Box::new(boot::boot(blob, &plant).with_context(does_not_boot)?),
        Some(critic) => {
            Box::new(HeadsPolicy::boot(blob, critic, &plant).with_context(does_not_boot)?)
        }
    };
    let config = EvalConfig {
        episodes,
        seed,
        ..EvalConfig::default()
    };
    test_protocol::evaluate_controller(policy.as_mut(), scenario, &config)
        .with_context(|| format!("evaluating the policy on {}", scenario.name))
}

pub(crate) fn report_json(report: &Report) -> Result<String> {
    Ok(serde_json::to_string_pretty(report)? + "\n")
}

pub(crate) fn print_summary(report: &Report) {
    print_summary_text(&summary_line(report));
}

/// Prints a one-line summary.
pub(crate) fn print_summary_text(line: &str) {
    outln!("{line}");
}

/// A plant test's report as `eval.json` holds it.
pub(crate) fn plant_report_json(report: &PlantReport) -> Result<String> {
    Ok(serde_json::to_string_pretty(report)? + "\n")
}

/// The one line `train` and `eval` print for a test on a plant of the user's, ending with the
/// gate's verdict as [`summary_line`] does.
pub(crate) fn plant_summary_line(report: &PlantReport) -> String {
    let verdict = report.pass.verdict();
    format!(
        "{} on {}, {} test starts: success {:.1}%  mean return {:.3}  stuck at margin {:.1}%  contact {:.1}%  gate {verdict}",
        report.controller,
        report.plant,
        report.episodes.len(),
        100.0 * report.success_rate,
        report.mean_return,
        100.0 * report.stuck_rate,
        100.0 * report.contact_fraction,
    )
}

/// The one line `train` and `eval` print for a scenario's test, ending with the gate's verdict
/// as `firmware-sim run` words it (`PASS`, or `FAIL (why; why)`), after the word `gate`: the
/// verdict is on the scenario's `[pass]` table, not on the figure printed before it.
pub(crate) fn summary_line(report: &Report) -> String {
    let verdict = report.pass.verdict();
    let steps = report
        .mean_steps_to_goal
        .map_or_else(|| "-".to_string(), |s| format!("{s:.1}"));
    format!(
        "{} on {}, {} test starts: success {:.1}%  mean settled error {:.3}  strict reach {:.1}%  pass within 0.25 {:.1}%  steps to goal {steps}  stuck at margin {:.1}%  left arena {:.1}%  gate {verdict}",
        report.controller,
        report.scenario,
        report.episodes.len(),
        100.0 * report.success_rate,
        report.mean_error,
        100.0 * report.strict_reach_rate,
        100.0 * report.near_pass_rate,
        100.0 * report.stuck_rate,
        100.0 * report.left_arena_rate,
    )
}
