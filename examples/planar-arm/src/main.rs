//! `planar-arm`: train a DCP policy for the two-joint arm, check its blob, or serve the arm to
//! the toolkit's tools over the plant link (README.md walks through all three).
//!
//! - `train --out DIR [--episodes N] [--seed S]`: trains in process (`Trainer::with_plant`),
//!   exports `policy.postcard`, then runs the exported blob through the test for any plant;
//! - `check --blob FILE [--episodes N] [--json FILE]`: the same test on a blob (exit 1 if it
//!   fails its criteria);
//! - `serve`: the arm on standard input and output, for `firmware-sim run --plant-cmd` and
//!   `--hil qemu-m4f`.

use std::io::{BufReader, BufWriter};
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use firmware_sim::boot::{boot, PlantSizes};
use firmware_sim::plant_link::serve::serve;
use firmware_sim::plant_test::{evaluate_plant, PlantReport, PlantTestConfig};
use host_trainer::run::config::TrainConfig;
use host_trainer::run::folder::RunDir;
use host_trainer::run::trainer::{self, Trainer};

use planar_arm::arm::Arm;

/// The plant's name: run folders, blob labels and reports carry it.
const NAME: &str = "planar-arm";

#[derive(Parser)]
#[command(about = "A two-joint arm with hard joint limits, trained and checked with the toolkit")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Train DCP on the arm, export the blob and test it.
    Train {
        /// Output folder (created if missing); the run goes to DIR/planar-arm__dcp__SEED.
        #[arg(long)]
        out: PathBuf,
        /// Training episodes (100 steps each).
        #[arg(long, default_value_t = 1000)]
        episodes: usize,
        /// The run's seed.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Test episodes after training.
        #[arg(long, default_value_t = 100)]
        eval_episodes: usize,
    },
    /// Test a blob on the arm (exit 1 if it fails the criteria).
    Check {
        /// The policy blob.
        #[arg(long)]
        blob: PathBuf,
        /// Test episodes.
        #[arg(long, default_value_t = 100)]
        episodes: usize,
        /// Also write the report as JSON here.
        #[arg(long)]
        json: Option<PathBuf>,
    },
    /// Serve the arm over standard input and output (the plant link).
    Serve,
}

fn main() -> ExitCode {
    match run(Cli::parse().command) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run(command: Command) -> Result<bool> {
    match command {
        Command::Train {
            out,
            episodes,
            seed,
            eval_episodes,
        } => train(out, episodes, seed, eval_episodes),
        Command::Check {
            blob,
            episodes,
            json,
        } => {
            let bytes =
                std::fs::read(&blob).with_context(|| format!("cannot read {}", blob.display()))?;
            let report = check(&bytes, episodes)?;
            print!("{}", report.summary());
            if let Some(path) = json {
                let text = serde_json_text(&report)?;
                std::fs::write(&path, text)
                    .with_context(|| format!("cannot write {}", path.display()))?;
            }
            Ok(report.pass.passed)
        }
        Command::Serve => {
            let mut input = BufReader::new(std::io::stdin().lock());
            let mut output = BufWriter::new(std::io::stdout().lock());
            serve(NAME, &mut Arm::new(), &mut input, &mut output)
                .context("the plant link broke")?;
            Ok(true)
        }
    }
}

fn train(out: PathBuf, episodes: usize, seed: u64, eval_episodes: usize) -> Result<bool> {
    let config = TrainConfig {
        task: NAME.into(),
        episodes,
        seed,
        eval_episodes,
        ..TrainConfig::default()
    };
    let mut trainer = Trainer::with_plant(config, Box::new(Arm::new()))?;
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let run = RunDir::create(&out, &trainer.config.run_name())?;
    let started = std::time::Instant::now();
    trainer::run(&mut trainer, &run, &mut |_, _| ControlFlow::Continue(()))?;
    let blob = trainer.export(&run)?;
    println!(
        "trained {} ({episodes} episodes, {} steps in {:.1} s)",
        run.path().display(),
        trainer.total_steps,
        started.elapsed().as_secs_f64()
    );
    let report = check(&blob, eval_episodes)?;
    print!("{}", report.summary());
    Ok(report.pass.passed)
}

/// The exported blob, booted as the chip boots it, through the test for any plant.
fn check(blob: &[u8], episodes: usize) -> Result<PlantReport> {
    let sizes = PlantSizes {
        observations: 6,
        actions: 2,
    };
    let mut policy = boot(blob, &sizes).context("the blob does not boot on the arm")?;
    let cfg = PlantTestConfig {
        episodes,
        ..PlantTestConfig::default()
    };
    Ok(evaluate_plant(&mut policy, &mut Arm::new(), NAME, &cfg)?)
}

fn serde_json_text(report: &PlantReport) -> Result<String> {
    Ok(serde_json::to_string_pretty(report)? + "\n")
}
