//! `host-trainer sweep`: one `train` process per (algo, seed), planned, supervised and
//! summarised by the library's `sweep` module.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::Ordering;

use anyhow::{Context, Result};
use clap::Args;
use firmware_sim::out;
use host_trainer::algorithms::Algo;
use host_trainer::run::config::TrainConfig;
use host_trainer::run::trainer::Trainer;
use host_trainer::run::{folder, lock};
use host_trainer::sweep::plan::{self, Seeds};
use host_trainer::sweep::record::Status;
use host_trainer::sweep::{report, supervise};

use super::cores;
use super::signals::{install_sweep_ctrl_c_handler, INTERRUPTED, INTERRUPTS};

#[derive(Debug, Args)]
pub(crate) struct SweepArgs {
    /// Train config file for every run (TOML, or JSON if it ends in .json) [default: defaults].
    #[arg(long)]
    config: Option<PathBuf>,
    /// Seeds: 0-4, 3, 0,2,5 or combinations like 0-2,7.
    #[arg(long)]
    seeds: Seeds,
    /// Algorithms, repeated or comma-separated [default: the config's].
    #[arg(long, value_enum, value_delimiter = ',')]
    algo: Vec<Algo>,
    /// Built-in scenario (nav-walls, nav-open) or a scenario TOML file, for every run
    /// [default: the config's].
    #[arg(long)]
    task: Option<String>,
    /// A plant of your own for every run instead of a scenario: "CMD ARGS" starts it as a
    /// child process speaking the plant link (docs/own-plant.md); each run starts its own.
    #[arg(long, conflicts_with = "task")]
    plant_cmd: Option<String>,
    /// Training episodes of every run, over the config's budget (recorded in each run's
    /// config.toml) [default: the config's].
    #[arg(long)]
    episodes: Option<usize>,
    /// Most runs at once [default: the number of cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    jobs: Option<u32>,
    /// Output folder, created if missing (its parent must exist): run folders, sweep-logs/,
    /// sweep.md and sweep.json go there.
    #[arg(long)]
    out: PathBuf,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

/// Everything is checked (config, algorithms, output folder, every run folder) before the
/// first run starts; then the runs go, and the summary is printed and written at the end.
pub(crate) fn sweep_command(args: SweepArgs) -> Result<ExitCode> {
    let mut base = match &args.config {
        Some(path) => TrainConfig::from_file(path)?,
        // A sweep's protocol is its fixed budget and its runs' last networks: no validation.
        None => TrainConfig {
            validation: None,
            ..TrainConfig::default()
        },
    };
    if let Some(task) = &args.task {
        base.task = task.clone();
    }
    if let Some(episodes) = args.episodes {
        base.episodes = episodes;
    }
    if let Some(command) = &args.plant_cmd {
        base.plant_cmd = Some(command.clone());
    }
    // Checked before the folder is locked: a refused sweep leaves nothing behind. A plant
    // process is started once to name the runs for its hello (as `train` names them).
    match &base.plant_cmd {
        Some(_) => base.task = Trainer::new(base.clone())?.config.task.clone(),
        None => drop(host_trainer::run::trainer::scenario(&base.task)?),
    }
    let mut algos = Vec::new();
    for algo in if args.algo.is_empty() {
        vec![base.algo]
    } else {
        args.algo
    } {
        if !algos.contains(&algo) {
            algos.push(algo);
        }
    }
    // One sweep per folder: a second one would resume the first one's runs under it. A
    // missing folder is made once the plan is checked (a refused sweep leaves nothing), then
    // locked, and planned again in case another sweep got there between the two.
    let _lock = if args.out.is_dir() {
        lock::acquire(&args.out)?
    } else {
        plan::runs(&base, &algos, &args.seeds.0, &args.out)?;
        folder::create_output_folder(&args.out)?;
        lock::acquire(&args.out)?
    };
    let plan = plan::runs(&base, &algos, &args.seeds.0, &args.out)?;
    let runner = runner(&plan, args.jobs, args.quiet, false)?;
    let records = supervise::execute(&plan, &runner)?;
    if INTERRUPTS.load(Ordering::SeqCst) > 0 {
        eprintln!("host-trainer: sweep interrupted; the stopped runs kept a checkpoint. Re-run the same sweep command to continue (finished runs are skipped)");
        return Ok(ExitCode::from(INTERRUPTED));
    }
    report::write_summary(&args.out, &records)?;
    out!("{}", report::markdown(&records));
    let failed = records
        .iter()
        .filter(|r| r.status == Status::Failed)
        .count();
    if failed > 0 {
        eprintln!(
            "host-trainer: {failed} of {} runs failed; see {} and the logs in {}",
            records.len(),
            args.out.join(report::SUMMARY_MD).display(),
            args.out.join(supervise::LOGS).display()
        );
        return Ok(ExitCode::FAILURE);
    }
    Ok(ExitCode::SUCCESS)
}

/// The supervisor's settings for `plan`, with the sweep's Ctrl-C handler installed: `jobs` runs
/// at once (default: the core count), and the cores shared out between the runs that go at
/// once (`jobs`, or fewer if fewer runs are left to run; at least one thread each).
pub(crate) fn runner(
    plan: &[plan::PlannedRun],
    jobs: Option<u32>,
    quiet: bool,
    announce: bool,
) -> Result<supervise::Runner<'static>> {
    let jobs = jobs.map_or_else(cores, |n| n as usize);
    let to_run = plan.iter().filter(|r| r.start != plan::Start::Skip).count();
    let threads = (cores() / jobs.min(to_run).max(1)).max(1);
    install_sweep_ctrl_c_handler();
    Ok(supervise::Runner {
        exe: std::env::current_exe().context("cannot find the host-trainer binary")?,
        jobs,
        threads,
        quiet,
        announce,
        interrupts: &INTERRUPTS,
    })
}
