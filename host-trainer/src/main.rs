//! `host-trainer`: train DCP or DDPG on a firmware-sim plant, export the blob, evaluate it.
//!
//! ```text
//! host-trainer train [--task nav-walls] [--algo dcp] [--hidden 4x48] [--reward gr] [--episodes 3000]
//!                    [--t 16] [--sigma 0.2] [--noise gaussian|ou] [--seed 0] [--out runs] [--config FILE] [--resume RUN_DIR]
//! host-trainer eval --blob FILE [--task nav-walls] [--episodes 100] [--seed 0] [--json FILE]
//! host-trainer export --run RUN_DIR
//! ```
//! Errors are one line on stderr and a non-zero exit.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use firmware_sim::harness::{self, EvalConfig, Report};
use host_trainer::agent::Hidden;
use host_trainer::checkpoint::Checkpoint;
use host_trainer::noise::Noise;
use host_trainer::run_dir::{self, write_atomic, RunDir};
use host_trainer::train::{self, Algo, RewardKind, TrainConfig, Trainer};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

#[derive(Debug, Parser)]
#[command(
    name = "host-trainer",
    version,
    about = "Train DCP/DDPG policies on firmware-sim plants and export postcard blobs"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Train a policy; writes OUT/{task}__{algo}__{seed}/ and evaluates the exported blob.
    Train(TrainArgs),
    /// Evaluate a policy blob in firmware-sim on test starts.
    Eval(EvalArgs),
    /// Export policy.postcard and critic.postcard from a run's checkpoint.
    Export(ExportArgs),
}

/// Flags override the config file, which overrides the defaults (the paper's values).
#[derive(Debug, Args)]
struct TrainArgs {
    /// Built-in scenario (nav-walls, nav-open) or a scenario TOML file [default: nav-walls].
    #[arg(long)]
    task: Option<String>,
    /// Learning algorithm [default: dcp].
    #[arg(long, value_enum)]
    algo: Option<Algo>,
    /// Hidden layers DEPTHxWIDTH of actor and critic [default: 4x48].
    #[arg(long)]
    hidden: Option<Hidden>,
    /// Reward: gr, lr or lrgr [default: gr].
    #[arg(long, value_enum)]
    reward: Option<RewardKind>,
    /// Training episodes [default: 3000].
    #[arg(long)]
    episodes: Option<usize>,
    /// DCP proposals per state T [default: 16].
    #[arg(long = "t")]
    t: Option<usize>,
    /// Exploration noise σ in the unit action box (also DCP's σc unless set) [default: 0.2].
    #[arg(long)]
    sigma: Option<f32>,
    /// Exploration process: independent Gaussian or Ornstein-Uhlenbeck [default: gaussian].
    #[arg(long, value_enum)]
    noise: Option<Noise>,
    /// Dropout probability while training [default: see README "Dropout"].
    #[arg(long)]
    dropout: Option<f32>,
    /// Multiply rewards by this before storing them [default: see README "Reward scale"].
    #[arg(long)]
    reward_scale: Option<f32>,
    /// The run's seed [default: 0].
    #[arg(long)]
    seed: Option<u64>,
    /// Existing output folder [default: ./runs, created if missing].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Config file (TOML, or JSON if it ends in .json); see config.toml in any run folder.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Continue the run in this folder from its checkpoint (--episodes may raise the budget).
    #[arg(long, conflicts_with_all = ["task", "algo", "hidden", "reward", "t", "sigma", "noise", "dropout", "reward_scale", "seed", "out", "config"])]
    resume: Option<PathBuf>,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

#[derive(Debug, Args)]
struct EvalArgs {
    /// The policy blob (policy.postcard).
    #[arg(long)]
    blob: PathBuf,
    /// Built-in scenario or scenario file.
    #[arg(long, default_value = "nav-walls")]
    task: String,
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

#[derive(Debug, Args)]
struct ExportArgs {
    /// The run folder holding checkpoint.postcard.
    #[arg(long)]
    run: PathBuf,
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            // --help and --version.
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            let text = e.to_string();
            let first = text.lines().next().unwrap_or("invalid arguments");
            eprintln!(
                "host-trainer: {} (see --help)",
                first.trim_start_matches("error: ")
            );
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Command::Train(args) => train_command(args),
        Command::Eval(args) => eval_command(args),
        Command::Export(args) => export_command(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("host-trainer: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn train_command(args: TrainArgs) -> Result<()> {
    let quiet = args.quiet;
    let (mut trainer, run) = match &args.resume {
        Some(dir) => resume(dir, args.episodes)?,
        None => fresh(args)?,
    };
    let bar = progress_bar(
        trainer.config.episodes as u64,
        trainer.episode as u64,
        quiet,
    );
    let started = Instant::now();
    let steps_before = trainer.total_steps;
    let outcome = train::run(&mut trainer, &run, &mut |row, t| {
        bar.set_position(row.episode as u64);
        bar.set_message(format!(
            "success(100) {:>3.0}%  {:>6.0} steps/s",
            100.0 * t.recent_success(100),
            row.steps_per_s
        ));
    });
    bar.finish_and_clear();
    outcome?;
    let seconds = started.elapsed().as_secs_f64();
    let steps = trainer.total_steps - steps_before;
    println!("trained {} ({} episodes, {steps} env steps in {seconds:.1} s, {:.0} steps/s incl. updates)", run.path().display(), trainer.episode, steps as f64 / seconds.max(1e-9));
    let blob = trainer.export(&run)?;
    let report = evaluate(&blob, &trainer.config.task, trainer.config.eval_episodes, 0)?;
    print_summary(&report);
    run.write(run_dir::EVAL, report_json(&report)?.as_bytes())?;
    println!("wrote {}", run.path().display());
    Ok(())
}

/// A new run: defaults, then the config file, then flags; nothing is written until the
/// configuration is valid and the trainer is built.
fn fresh(args: TrainArgs) -> Result<(Trainer, RunDir)> {
    let mut config = match &args.config {
        Some(path) => TrainConfig::from_file(path)?,
        None => TrainConfig::default(),
    };
    apply_flags(&mut config, &args);
    let trainer = Trainer::new(config)?;
    let out = match args.out {
        Some(out) => out,
        None => {
            let out = PathBuf::from("runs");
            std::fs::create_dir_all(&out)
                .with_context(|| format!("cannot create output folder {}", out.display()))?;
            out
        }
    };
    let run = RunDir::create(&out, &trainer.config.run_name())?;
    Ok((trainer, run))
}

fn apply_flags(config: &mut TrainConfig, args: &TrainArgs) {
    if let Some(v) = &args.task {
        config.task = v.clone();
    }
    if let Some(v) = args.algo {
        config.algo = v;
    }
    if let Some(v) = args.hidden {
        config.agent.hidden = v;
    }
    if let Some(v) = args.reward {
        config.reward = v;
    }
    if let Some(v) = args.episodes {
        config.episodes = v;
    }
    if let Some(v) = args.t {
        config.dcp.t = v;
    }
    if let Some(v) = args.sigma {
        config.agent.sigma = v;
    }
    if let Some(v) = args.noise {
        config.agent.noise = v;
    }
    if let Some(v) = args.dropout {
        config.agent.dropout = v;
    }
    if let Some(v) = args.reward_scale {
        config.agent.reward_scale = v;
    }
    if let Some(v) = args.seed {
        config.seed = v;
    }
}

fn resume(dir: &Path, episodes: Option<usize>) -> Result<(Trainer, RunDir)> {
    let run = RunDir::open(dir)?;
    let path = run.file(run_dir::CHECKPOINT);
    let trainer = Trainer::resume(Checkpoint::load(&path)?, episodes, &path)?;
    Ok((trainer, run))
}

fn progress_bar(len: u64, pos: u64, quiet: bool) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::hidden());
    }
    let bar = ProgressBar::new(len);
    let style = ProgressStyle::with_template(
        "{elapsed_precise} [{bar:30}] episode {pos}/{len}  {msg}  eta {eta}",
    )
    .map(|s| s.progress_chars("=> "));
    if let Ok(style) = style {
        bar.set_style(style);
    }
    bar.set_position(pos);
    bar
}

fn eval_command(args: EvalArgs) -> Result<()> {
    let blob = std::fs::read(&args.blob)
        .with_context(|| format!("cannot read blob {}", args.blob.display()))?;
    // firmware-sim would boot a bad blob into the safe state and report it; for a user asking to
    // evaluate a file, a blob that does not load is an error.
    policy_core::blob::verify(&blob)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.blob.display()))?;
    let report = evaluate(&blob, &args.task, args.episodes, args.seed)?;
    print_summary(&report);
    if let Some(path) = &args.json {
        write_atomic(path, report_json(&report)?.as_bytes())?;
    }
    Ok(())
}

fn export_command(args: ExportArgs) -> Result<()> {
    let (trainer, run) = resume(&args.run, None)?;
    trainer.export(&run)?;
    println!(
        "wrote {} and {} (episode {})",
        run.file(run_dir::POLICY).display(),
        run.file(run_dir::CRITIC).display(),
        trainer.episode
    );
    Ok(())
}

fn evaluate(blob: &[u8], task: &str, episodes: usize, seed: u64) -> Result<Report> {
    let scenario = train::scenario(task, None, None)?;
    let config = EvalConfig {
        episodes,
        seed,
        ..EvalConfig::default()
    };
    harness::evaluate(blob, &scenario, &config)
        .with_context(|| format!("evaluating the policy on {task}"))
}

fn report_json(report: &Report) -> Result<String> {
    Ok(serde_json::to_string_pretty(report)? + "\n")
}

fn print_summary(report: &Report) {
    if let Some(reason) = &report.boot_error {
        println!("boot error (safe state, zero action): {reason}");
    }
    let steps = report
        .mean_steps_to_goal
        .map_or_else(|| "-".to_string(), |s| format!("{s:.1}"));
    println!(
        "{} on {}, {} test starts: success {:.1}%  mean settled error {:.3}  strict reach {:.1}%  pass within 0.25 {:.1}%  steps to goal {steps}  stuck at margin {:.1}%  left arena {:.1}%",
        report.controller,
        report.scenario,
        report.episodes.len(),
        100.0 * report.success_rate,
        report.mean_error,
        100.0 * report.strict_reach_rate,
        100.0 * report.near_pass_rate,
        100.0 * report.stuck_rate,
        100.0 * report.left_arena_rate,
    );
}
