//! `firmware-sim run`: the closed-loop test of a policy blob (or a reference controller) as a
//! CI gate. Exit codes: 0 the scenario's pass criteria hold, 1 they fail (or the blob did not
//! boot), 2 bad input.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};

use firmware_sim::actuator::ActuatorModel;
use firmware_sim::controller::reference;
use firmware_sim::faults::Faults;
use firmware_sim::harness::{evaluate, evaluate_controller, EvalConfig, Report};
use firmware_sim::scenario::Scenario;
use firmware_sim::sensor::SensorModel;
use firmware_sim::svg;

#[derive(Parser, Debug)]
#[command(
    name = "firmware-sim",
    version,
    about = "Closed-loop firmware simulator for policy blobs"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Boot a blob (or a reference controller) and run the scenario's test protocol.
    Run(RunArgs),
}

#[derive(Args, Debug)]
struct RunArgs {
    /// Policy blob to boot, as it would be flashed.
    #[arg(
        long,
        conflicts_with = "controller",
        required_unless_present = "controller"
    )]
    blob: Option<PathBuf>,
    /// A reference controller instead of a blob: straight or oracle.
    #[arg(long)]
    controller: Option<String>,
    /// Built-in scenario name (nav-walls, nav-open) or a TOML file.
    #[arg(long, default_value = "nav-walls")]
    scenario: String,
    /// Number of test starts.
    #[arg(long, default_value_t = 100)]
    episodes: usize,
    /// Seed of every random stream.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Faults, comma-separated: dropout-nan:P, dropout-stale:P, stuck:D@T, wall:T@X0/Y0/X1/Y1[@I].
    #[arg(long, default_value = "")]
    faults: String,
    /// Sensor noise standard deviation.
    #[arg(long, default_value_t = 0.0)]
    noise: f32,
    /// Sensor quantisation step.
    #[arg(long, default_value_t = 0.0)]
    quantum: f32,
    /// Deliver each sensor reading one tick late.
    #[arg(long)]
    delay: bool,
    /// Largest actuator change per tick and dimension.
    #[arg(long)]
    rate_limit: Option<f32>,
    /// Write the full JSON report here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Draw walls and trajectories to this SVG file.
    #[arg(long)]
    svg: Option<PathBuf>,
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            // clap's message up to its usage block, folded into one line.
            let text = e.to_string();
            let head: Vec<&str> = text
                .lines()
                .take_while(|l| !l.trim().is_empty())
                .map(str::trim)
                .collect();
            eprintln!("{}", head.join(" "));
            return ExitCode::from(2);
        }
    };
    let Command::Run(args) = cli.command;
    match run(&args) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

/// Runs the evaluation; `Ok(passed)`.
fn run(args: &RunArgs) -> Result<bool> {
    let scenario = Scenario::resolve(&args.scenario)?;
    let cfg = EvalConfig {
        episodes: args.episodes,
        seed: args.seed,
        sensor: SensorModel {
            noise_std: args.noise,
            quantum: args.quantum,
            delay: args.delay,
        },
        actuator: ActuatorModel {
            rate_limit: args.rate_limit,
        },
        faults: args.faults.parse::<Faults>()?,
        record_trajectories: args.svg.is_some(),
    };
    let report = match (&args.blob, &args.controller) {
        (Some(path), _) => {
            let bytes = std::fs::read(path)
                .with_context(|| format!("cannot read blob {}", path.display()))?;
            evaluate(&bytes, &scenario, &cfg)?
        }
        (None, Some(name)) => {
            evaluate_controller(reference(name, &scenario)?.as_mut(), &scenario, &cfg)?
        }
        (None, None) => anyhow::bail!("give --blob FILE or --controller straight|oracle"),
    };
    print!("{}", report.summary());
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&report)?;
        write_atomic(path, text.as_bytes())?;
    }
    if let Some(path) = &args.svg {
        write_atomic(path, svg::render(&scenario, &report).as_bytes())?;
    }
    report_failures(&report, args.blob.as_deref());
    Ok(report.pass.passed)
}

fn report_failures(report: &Report, blob: Option<&Path>) {
    if let (Some(reason), Some(path)) = (&report.boot_error, blob) {
        eprintln!(
            "error: {}: {reason} (ran in the safe state: zero action)",
            path.display()
        );
    } else if !report.pass.passed {
        eprintln!("FAIL: {}", report.pass.failures.join("; "));
    }
}

/// Writes through a temporary file in the same directory and renames it over `path`, so a
/// reader never sees half a report.
fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .with_context(|| format!("{} is not a file path", path.display()))?;
    let tmp = dir.join(format!(
        ".{}.tmp{}",
        name.to_string_lossy(),
        std::process::id()
    ));
    std::fs::write(&tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path)
        .with_context(|| format!("cannot move the output to {}", path.display()))
}
