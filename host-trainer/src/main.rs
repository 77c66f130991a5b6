//! `host-trainer`: train DCP or DDPG on a firmware-sim plant, export the blob, evaluate it.
//!
//! ```text
//! host-trainer train [--task nav-walls] [--algo dcp|ddpg|td3|ppo|dqn] [--hidden 4x48] [--reward gr] [--episodes 3000]
//!                    [--t 16] [--sigma 0.2] [--noise gaussian|ou] [--seed 0] [--out runs] [--config FILE] [--resume RUN_DIR]
//!                    [--threads N]
//! host-trainer eval --blob FILE [--task nav-walls] [--episodes 100] [--seed 0] [--json FILE]
//! host-trainer export --run RUN_DIR [--encoding f32|f16|int8]
//!                     [--image bin|hex --slot a|b --sequence N [--address ADDR] [--slot-size BYTES]]
//! host-trainer inspect BLOB
//! host-trainer sweep --seeds 0-4 [--algo dcp,ddpg] [--jobs N] --out DIR [--config FILE] [--quiet]
//! host-trainer team [--algo dcp] [--t 16] [--players 16] [--points 20000] [--seed 0] [--out DIR]
//! host-trainer reproduce exp1|exp2 --out DIR [--seeds 5] [--jobs N] [--slice I/N | --merge] [--quick]
//! ```
//! Errors are one line on stderr and a non-zero exit.

use std::io::Read as _;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use firmware_sim::boot::{self, PlantSizes};
use firmware_sim::controller::Controller;
use firmware_sim::files;
use firmware_sim::heads::HeadsPolicy;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::{self, EvalConfig, Report};
use firmware_sim::{out, outln};
use host_trainer::algorithms::noise::Noise;
use host_trainer::algorithms::{self, Algo};
use host_trainer::blob::export::{self, ImageFormat, SlotTarget};
use host_trainer::blob::inspect;
use host_trainer::nn::hidden::Hidden;
use host_trainer::nn::workers::Workers;
use host_trainer::reproduce::{
    self,
    grid::{self, Experiment, Grid, Slice},
};
use host_trainer::run::checkpoint::Checkpoint;
use host_trainer::run::config::{RewardKind, TrainConfig};
use host_trainer::run::folder::{self, RunDir};
use host_trainer::run::lock::{self, FolderLock};
use host_trainer::run::progress;
use host_trainer::run::trainer::{self, Outcome, Trainer};
use host_trainer::sweep::plan::{self, Seeds};
use host_trainer::sweep::record::Status;
use host_trainer::sweep::{report, supervise};
use host_trainer::team::{self, config::TeamConfig, folder::TeamRun};
use policy_core::slot::SlotId;
use policy_core::Encoding;

#[derive(Debug, Parser)]
#[command(
    name = "host-trainer",
    version,
    about = "Train DCP/DDPG policies on firmware-sim plants and export postcard blobs"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

/// The exit code after Ctrl-C (128 + SIGINT), as shells report it.
const INTERRUPTED: u8 = 130;

#[derive(Debug, Subcommand)]
enum Command {
    /// Train a policy; writes OUT/{task}__{algo}__{seed}/ and evaluates the exported blob.
    Train(TrainArgs),
    /// Evaluate a policy blob in firmware-sim on test starts.
    Eval(EvalArgs),
    /// Export policy.postcard (and, for DCP and DDPG, critic.postcard) from a run's checkpoint;
    /// with --encoding f16|int8, policy-f16.postcard or policy-int8.postcard.
    Export(ExportArgs),
    /// Print what a blob holds: kind, shape, label, sizes, CRC, normaliser, bounds or table.
    Inspect(InspectArgs),
    /// Train one run per (algo, seed) as parallel processes; skips finished runs, continues
    /// unfinished ones, and writes OUT/sweep.md and OUT/sweep.json.
    Sweep(SweepArgs),
    /// Train a badminton team (experiment 2): N players of three agents each, random pairings,
    /// one point per episode; writes OUT/{scenario}__{algo}__{seed}/ and exports every player
    /// into its players/ folder.
    Team(TeamArgs),
    /// Rebuild an experiment of the paper: plan its grid of runs, run them (or one --slice of
    /// them) as sweep does, and build the results page and figures from the run folders
    /// (OUT/exp1.md or OUT/exp2.md, OUT/figures/).
    Reproduce(ReproduceArgs),
}

#[derive(Debug, Args)]
struct ReproduceArgs {
    /// The experiment: exp1 (navigation among walls: tables 1–3, figures 4–7) or exp2
    /// (badminton teams: tables 5–7, team scores, influence of T, heat maps).
    #[arg(value_enum)]
    experiment: Experiment,
    /// Existing output folder: the grid's runs, its page and figures go there.
    #[arg(long)]
    out: PathBuf,
    /// Seeds 0..N of every cell (at least 5 unless --quick).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..=1000))]
    seeds: u64,
    /// Most runs at once [default: the number of cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    jobs: Option<u32>,
    /// Run only part I of N (from 0) of the grid, e.g. a Slurm array task's
    /// $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT; the page is built by --merge.
    #[arg(long, conflicts_with = "merge")]
    slice: Option<Slice>,
    /// A few episodes per run: a test of the machinery, not a result.
    #[arg(long)]
    quick: bool,
    /// Run nothing: build the page from the run folders of every part, and say which runs
    /// are missing (exit 1 if any).
    #[arg(long)]
    merge: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

/// Flags override the config file, which overrides the defaults (the paper's values).
#[derive(Debug, Args)]
struct TeamArgs {
    /// Team config file (TOML); see config.toml in any team folder.
    #[arg(long, conflicts_with = "resume")]
    config: Option<PathBuf>,
    /// Learning algorithm of every agent: dcp, ddpg, td3 or ppo [default: dcp].
    #[arg(long, value_enum, conflicts_with = "resume")]
    algo: Option<Algo>,
    /// DCP's proposals per state T [default: 16].
    #[arg(long, conflicts_with = "resume")]
    t: Option<usize>,
    /// Players in the team [default: 16].
    #[arg(long, conflicts_with = "resume")]
    players: Option<usize>,
    /// Points of training [default: 20000]; with --resume, a new budget.
    #[arg(long)]
    points: Option<usize>,
    /// The team's seed [default: 0].
    #[arg(long, conflicts_with = "resume")]
    seed: Option<u64>,
    /// Badminton scenario: badminton or a scenario TOML file [default: badminton].
    #[arg(long, conflicts_with = "resume")]
    scenario: Option<String>,
    /// Existing output folder; the team's folder is created in it.
    #[arg(long, required_unless_present = "resume", conflicts_with = "resume")]
    out: Option<PathBuf>,
    /// Continue the team in this folder from its checkpoint.
    #[arg(long)]
    resume: Option<PathBuf>,
    /// Stop as on Ctrl-C (checkpoint, exit 130) when standard input reaches its end: how
    /// `reproduce exp2` makes its teams stop with it, however it dies.
    #[arg(long, hide = true)]
    stop_when_stdin_closes: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
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
    /// Hidden layers DEPTHxWIDTH of every network [default: 4x48].
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
    /// Worker threads of the updates; any count trains to the same bytes [default: the cores
    /// available].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    threads: Option<u32>,
    /// Also keep a copy of every checkpoint in RUN/checkpoints/ (to study how the run
    /// learned; each holds the whole replay buffer, tens of MB).
    #[arg(long)]
    keep_checkpoints: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Stop as on Ctrl-C (checkpoint, exit 130) when standard input reaches its end. A sweep
    /// starts its runs with this and holds their standard input open, so a sweep that dies by
    /// any signal, SIGKILL included, takes its runs with it instead of leaving them training.
    #[arg(long, hide = true)]
    stop_when_stdin_closes: bool,
}

#[derive(Debug, Args)]
struct SweepArgs {
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
    /// Most runs at once [default: the number of cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    jobs: Option<u32>,
    /// Existing output folder: run folders, sweep-logs/, sweep.md and sweep.json go there.
    #[arg(long)]
    out: PathBuf,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

#[derive(Debug, Args)]
struct EvalArgs {
    /// The policy blob (policy.postcard).
    #[arg(long)]
    blob: PathBuf,
    /// The critic blob of an actor of several heads (DCP's `heads`): it chooses the head.
    #[arg(long)]
    critic: Option<PathBuf>,
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
    /// How the policy's weights are stored: f32 (policy.postcard and the critic), f16 or int8
    /// (policy-f16.postcard, policy-int8.postcard; weights only, everything else stays f32).
    #[arg(long, default_value = "f32", value_parser = parse_encoding)]
    encoding: Encoding,
    /// Also write a flash slot image of the policy (a slot record: header with --sequence, then
    /// the blob): bin (raw; the flasher is given the address) or hex (Intel HEX at the address).
    #[arg(long, value_enum, requires_all = ["slot", "sequence"])]
    image: Option<ImageFormat>,
    /// The slot the image is for: a or b (write the one the device is not running).
    #[arg(long, value_parser = parse_slot, requires = "image")]
    slot: Option<SlotId>,
    /// The record's sequence number: one more than the running slot's, which the firmware
    /// prints at boot (`SLOT A running 3`). The newer slot that verifies runs.
    #[arg(long, requires = "image")]
    sequence: Option<u32>,
    /// The slot's flash address, decimal or 0x hex [default: the example firmware's
    /// (firmware/memory.x): 0x40000 for a, 0x60000 for b].
    #[arg(long, value_parser = parse_address, requires = "image")]
    address: Option<u32>,
    /// The slot's size in bytes; a record that does not fit is refused [default: 131072, the
    /// example firmware's].
    #[arg(long, requires = "image")]
    slot_size: Option<usize>,
}

fn parse_slot(s: &str) -> Result<SlotId, String> {
    match s {
        "a" | "A" => Ok(SlotId::A),
        "b" | "B" => Ok(SlotId::B),
        _ => Err(format!("expected a or b, found {s:?}")),
    }
}

fn parse_address(s: &str) -> Result<u32, String> {
    let parsed = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(hex) => u32::from_str_radix(&hex.replace('_', ""), 16),
        None => s.parse(),
    };
    parsed.map_err(|_| format!("expected a 32-bit address such as 0x08040000, found {s:?}"))
}

#[derive(Debug, Args)]
struct InspectArgs {
    /// The blob file (policy.postcard, critic.postcard, ...).
    blob: PathBuf,
    /// An f32 blob the inspected (quantised) blob was made from: prints each layer's largest
    /// weight error against it.
    #[arg(long)]
    against: Option<PathBuf>,
}

fn parse_encoding(s: &str) -> Result<Encoding, String> {
    Encoding::ALL
        .into_iter()
        .find(|e| e.to_string() == s)
        .ok_or_else(|| format!("expected f32, f16 or int8, found {s:?}"))
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
            eprintln!("host-trainer: {} (see --help)", usage_error(&e));
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Some(Command::Train(args)) => train_command(args),
        Some(Command::Eval(args)) => eval_command(args).map(|()| ExitCode::SUCCESS),
        Some(Command::Export(args)) => export_command(args).map(|()| ExitCode::SUCCESS),
        Some(Command::Inspect(args)) => inspect_command(&args).map(|()| ExitCode::SUCCESS),
        Some(Command::Sweep(args)) => sweep_command(args),
        Some(Command::Team(args)) => team_command(args),
        Some(Command::Reproduce(args)) => reproduce_command(args),
        None => {
            eprintln!(
                "host-trainer: missing a subcommand: train, eval, export, inspect, sweep or team (see --help)"
            );
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("host-trainer: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// A command-line error as one line: clap's message up to its usage block, folded, so the
/// names of missing arguments (listed on the lines after the first) and the accepted values
/// are kept, as firmware-sim prints them.
fn usage_error(e: &clap::Error) -> String {
    let text = e.to_string();
    let head: Vec<&str> = text
        .lines()
        .take_while(|l| !l.trim().is_empty())
        .map(str::trim)
        .collect();
    let line = head.join(" ");
    let line = line.trim_start_matches("error: ");
    if line.is_empty() {
        "invalid arguments".to_string()
    } else {
        line.to_string()
    }
}

/// Ctrl-C presses so far: the first stops training after the current episode with a
/// checkpoint, the second exits at once.
static INTERRUPTS: AtomicU32 = AtomicU32::new(0);

/// When the first Ctrl-C came. A second delivery within [`SAME_PRESS`] is the same press: a
/// sweep's children get a terminal's Ctrl-C directly (they share its process group) and once
/// more from the sweep, which forwards it for the case where only the sweep got the signal.
static FIRST_PRESS: OnceLock<Instant> = OnceLock::new();
const SAME_PRESS: Duration = Duration::from_millis(500);

fn install_ctrl_c_handler() {
    set_ctrl_c_handler(|| {
        let first = *FIRST_PRESS.get_or_init(Instant::now);
        if INTERRUPTS.fetch_add(1, Ordering::SeqCst) == 0 {
            eprintln!("\nhost-trainer: stopping after this episode and writing a checkpoint (Ctrl-C again to exit at once)");
        } else if first.elapsed() >= SAME_PRESS {
            eprintln!("\nhost-trainer: interrupted; the last checkpoint is kept");
            std::process::exit(i32::from(INTERRUPTED));
        }
    });
}

/// A sweep never exits from its handler: it forwards the press to its children and waits for
/// them, so no run is left writing after the sweep has gone.
fn install_sweep_ctrl_c_handler() {
    set_ctrl_c_handler(|| {
        if INTERRUPTS.fetch_add(1, Ordering::SeqCst) == 0 {
            eprintln!("\nhost-trainer: stopping the sweep: no new run starts, running runs write a checkpoint and stop (Ctrl-C again stops them at once)");
        }
    });
}

/// Counts the end of standard input as a Ctrl-C press: the parent that holds the other end has
/// gone (the kernel closes a dead process's pipes, whatever killed it).
fn stop_when_parent_goes() {
    std::thread::spawn(|| {
        let mut buf = [0u8; 64];
        loop {
            match std::io::stdin().read(&mut buf) {
                Ok(0) | Err(_) => break,
                Ok(_) => {}
            }
        }
        if INTERRUPTS.fetch_add(1, Ordering::SeqCst) == 0 {
            eprintln!("host-trainer: the sweep that started this run has gone; stopping and writing a checkpoint");
        }
    });
}

fn set_ctrl_c_handler(handler: fn()) {
    // Without a handler (it can only fail if another one is installed) Ctrl-C still ends the
    // process, losing at most `checkpoint_every` episodes: worth a warning, not a failure.
    let installed = ctrlc::set_handler(handler);
    if let Err(e) = installed {
        eprintln!("host-trainer: warning: no Ctrl-C handler ({e}); Ctrl-C loses the episodes since the last checkpoint");
    }
}

fn train_command(args: TrainArgs) -> Result<ExitCode> {
    let quiet = args.quiet;
    let stop_when_stdin_closes = args.stop_when_stdin_closes;
    let keep_checkpoints = args.keep_checkpoints;
    let workers = workers(args.threads)?;
    let (mut trainer, run, _lock) = match &args.resume {
        Some(dir) => resume(dir, args.episodes)?,
        None => fresh(args)?,
    };
    trainer.set_workers(workers);
    trainer.keep_checkpoints = keep_checkpoints;
    install_ctrl_c_handler();
    if stop_when_stdin_closes {
        stop_when_parent_goes();
    }
    let bar = progress::bar(trainer.config.episodes as u64, "episode", quiet);
    bar.set_position(trainer.episode as u64);
    let started = Instant::now();
    let steps_before = trainer.total_steps;
    let outcome = trainer::run(&mut trainer, &run, &mut |row, t| {
        bar.set_position(row.episode as u64);
        bar.set_message(format!(
            "success(100) {:>3.0}%  {:>6.0} steps/s",
            100.0 * t.recent_success(100),
            row.steps_per_s
        ));
        if INTERRUPTS.load(Ordering::SeqCst) > 0 {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    bar.finish_and_clear();
    if let Outcome::Stopped { episode } = outcome? {
        eprintln!(
            "host-trainer: interrupted after episode {episode} of {}; checkpoint written. Continue with: host-trainer train --resume {}",
            trainer.config.episodes,
            run.path().display()
        );
        return Ok(ExitCode::from(INTERRUPTED));
    }
    let seconds = started.elapsed().as_secs_f64();
    let steps = trainer.total_steps - steps_before;
    // Every file first, then the report: a reader of standard output that goes away (which
    // ends the program) cannot cost the run its blobs or its evaluation.
    let blob = trainer.export(&run)?;
    // An actor of several heads runs with its critic choosing the head, as on the chip.
    let heads = trainer.config.algo == Algo::Dcp && trainer.config.dcp.heads > 1;
    let critic = if heads {
        Some(files::read_blob(&run.file(folder::CRITIC))?)
    } else {
        None
    };
    let report = evaluate(
        &blob,
        critic.as_deref(),
        &run.file(folder::POLICY),
        &trainer.scenario,
        trainer.config.eval_episodes,
        0,
    )?;
    run.write(folder::EVAL, report_json(&report)?.as_bytes())?;
    outln!("trained {} ({} episodes, {steps} env steps in {seconds:.1} s, {:.0} steps/s incl. updates)", run.path().display(), trainer.episode, steps as f64 / seconds.max(1e-9));
    print_summary(&report);
    outln!("wrote {}", run.path().display());
    Ok(ExitCode::SUCCESS)
}

/// The cores this process may use (1 if the system cannot say).
fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// `--threads`: the worker threads of the updates, all cores by default. A count above the
/// cores is allowed (it trains to the same bytes, only slower) and said once.
fn workers(threads: Option<u32>) -> Result<Workers> {
    let cores = cores();
    let threads = threads.map_or(cores, |n| n as usize);
    if threads > cores {
        eprintln!("host-trainer: note: --threads {threads} is more than the {cores} cores available; the run trains to the same bytes, probably slower");
    }
    Workers::new(threads).with_context(|| format!("cannot start {threads} worker threads"))
}

/// A new run: defaults, then the config file, then flags; nothing is written until the
/// configuration is valid and the trainer is built.
fn fresh(args: TrainArgs) -> Result<(Trainer, RunDir, FolderLock)> {
    let mut config = match &args.config {
        Some(path) => TrainConfig::from_file(path)?,
        None => TrainConfig::default(),
    };
    apply_flags(&mut config, &args);
    check_flags_used(config.algo, &args)?;
    config.check_read(&[config.algo])?;
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
    let lock = lock::acquire(run.path())?;
    Ok((trainer, run, lock))
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

/// A flag the run's algorithm does not read would be recorded in `config.toml` and change
/// nothing: it is refused, naming the algorithms that use it (even at its default value; a
/// config file's setting is refused only away from its default, see
/// [`TrainConfig::check_read`]).
fn check_flags_used(algo: Algo, args: &TrainArgs) -> Result<()> {
    let flags = [
        ("--t", args.t.is_some(), ("dcp", "t")),
        ("--sigma", args.sigma.is_some(), ("agent", "sigma")),
        ("--noise", args.noise.is_some(), ("agent", "noise")),
        ("--dropout", args.dropout.is_some(), ("agent", "dropout")),
    ];
    for (flag, given, (section, key)) in flags {
        let readers = algorithms::readers(section, key);
        if given && !readers.contains(&algo) {
            return Err(host_trainer::Error::UnreadSetting {
                key: flag.into(),
                value: String::new(),
                algos: algo.to_string(),
                readers: algorithms::names(readers),
            }
            .into());
        }
    }
    Ok(())
}

/// Continues a run from its folder alone. A run killed before its first checkpoint starts
/// again from its recorded config and plant (the result is the same: one seed drives it all).
fn resume(dir: &Path, episodes: Option<usize>) -> Result<(Trainer, RunDir, FolderLock)> {
    let run = RunDir::open(dir)?;
    // Held until the command ends: a second trainer, export or sweep child is refused.
    let lock = lock::acquire(run.path())?;
    let path = run.file(folder::CHECKPOINT);
    let trainer = if path.exists() {
        let trainer = Trainer::resume(Checkpoint::load(&path)?, episodes, &path)?;
        if episodes.is_some() {
            // The new budget is the run's: recorded in its checkpoint and its config.toml, so a
            // sweep sees the run's real budget and a later --resume keeps it.
            trainer.save(&run)?;
            run.write(folder::CONFIG, trainer.config.to_toml().as_bytes())?;
        }
        trainer
    } else {
        restart(&run, episodes)?
    };
    note_changed_plant(&trainer);
    Ok((trainer, run, lock))
}

fn restart(run: &RunDir, episodes: Option<usize>) -> Result<Trainer> {
    let config_path = run.file(folder::CONFIG);
    if !config_path.exists() {
        anyhow::bail!(
            "{} holds no checkpoint and no config: not a run folder, or killed before it recorded anything (start it again with train)",
            run.path().display()
        );
    }
    let mut config = TrainConfig::from_file(&config_path)?;
    if let Some(n) = episodes {
        config.episodes = n;
    }
    // The plant is recorded right after the config; a kill between the two leaves only the
    // config, and the task it names is then the plant (nothing has trained on it yet).
    let scenario_path = run.file(folder::SCENARIO);
    let scenario = if scenario_path.exists() {
        trainer::scenario_file(&scenario_path)
            .with_context(|| format!("the recorded plant of {}", run.path().display()))?
    } else {
        trainer::scenario(&config.task)?
    };
    eprintln!(
        "host-trainer: {} has no checkpoint yet (stopped before its first one); starting it again from its recorded config",
        run.path().display()
    );
    Ok(Trainer::on(config, scenario)?)
}

/// A run trains on the plant it recorded. If its scenario file has changed since, say so: the
/// run goes on with the plant it started with, which is what makes it one run.
fn note_changed_plant(trainer: &Trainer) {
    let task = &trainer.config.task;
    if Scenario::builtin(task).is_some() || !Path::new(task).exists() {
        return;
    }
    if Scenario::resolve(task).ok().as_ref() != Some(&trainer.scenario) {
        eprintln!(
            "host-trainer: note: {task} has changed (or no longer loads) since the run started; the run continues on its recorded plant ({})",
            folder::SCENARIO
        );
    }
}

/// Everything is checked (config, algorithms, output folder, every run folder) before the
/// first run starts; then the runs go, and the summary is printed and written at the end.
fn sweep_command(args: SweepArgs) -> Result<ExitCode> {
    let mut base = match &args.config {
        Some(path) => TrainConfig::from_file(path)?,
        None => TrainConfig::default(),
    };
    if let Some(task) = &args.task {
        base.task = task.clone();
    }
    // Checked before the folder is locked: a refused sweep leaves nothing behind.
    host_trainer::run::trainer::scenario(&base.task)?;
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
    // One sweep per folder: a second one would resume the first one's runs under it. (A
    // missing folder is reported by the plan.)
    let _lock = if args.out.is_dir() {
        Some(lock::acquire(&args.out)?)
    } else {
        None
    };
    let plan = plan::runs(&base, &algos, &args.seeds.0, &args.out)?;
    let jobs = match args.jobs {
        Some(n) => n as usize,
        None => cores(),
    };
    // The cores are shared out between the runs that go at once: `jobs`, or fewer if fewer
    // runs are left to run.
    let to_run = plan.iter().filter(|r| r.start != plan::Start::Skip).count();
    let threads = (cores() / jobs.min(to_run).max(1)).max(1);
    install_sweep_ctrl_c_handler();
    let runner = supervise::Runner {
        exe: std::env::current_exe().context("cannot find the host-trainer binary")?,
        jobs,
        threads,
        quiet: args.quiet,
        announce: false,
        interrupts: &INTERRUPTS,
    };
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

/// Checks everything (the grid against the folder, every run folder) before the first run; runs
/// the slice; records the part; builds the page when the whole grid ran here.
fn reproduce_command(args: ReproduceArgs) -> Result<ExitCode> {
    let grid = Grid {
        experiment: args.experiment,
        seeds: args.seeds,
        quick: args.quick,
    };
    if !grid.quick && grid.seeds < grid::MIN_SEEDS {
        anyhow::bail!(
            "--seeds {}: a grid's cells need at least {} seeds (docs/design.md §7); --quick runs fewer",
            grid.seeds,
            grid::MIN_SEEDS
        );
    }
    if args.merge {
        reproduce::folder::check(&args.out, &grid)?;
        return merge(&args.out, &grid);
    }
    let slice = args.slice.unwrap_or(Slice::WHOLE);
    if let Some(found) = reproduce::folder::recorded(&args.out)? {
        if found != grid {
            reproduce::folder::check(&args.out, &grid)?;
        }
    }
    // Every check first (nothing is written if one fails), then the grid's record and the
    // part's lock, then the plan again: another process of this part may have moved its runs
    // on before the lock was ours.
    reproduce::plan(&args.out, &grid, slice)?;
    reproduce::folder::claim(&args.out, &grid)?;
    let part_dir = reproduce::Part::path(&args.out, slice).with_extension("");
    std::fs::create_dir_all(&part_dir)
        .with_context(|| format!("cannot create {}", part_dir.display()))?;
    // One process per part: a second one would run the same runs beside the first.
    let _lock = lock::acquire(&part_dir)?;
    let plan = reproduce::plan(&args.out, &grid, slice)?;
    reproduce::folder::create_cells(&plan)?;
    let jobs = args.jobs.map_or_else(cores, |n| n as usize);
    let to_run = plan.iter().filter(|r| r.start != plan::Start::Skip).count();
    let threads = (cores() / jobs.min(to_run).max(1)).max(1);
    install_sweep_ctrl_c_handler();
    let runner = supervise::Runner {
        exe: std::env::current_exe().context("cannot find the host-trainer binary")?,
        jobs,
        threads,
        quiet: args.quiet,
        announce: true,
        interrupts: &INTERRUPTS,
    };
    let started = Instant::now();
    let records = supervise::execute(&plan, &runner)?;
    reproduce::folder::mark(&plan, &records)?;
    let count = |s: Status| records.iter().filter(|r| r.status == s).count();
    let part = reproduce::Part {
        slice: slice.to_string(),
        commit: reproduce::COMMIT.into(),
        runs: plan.len(),
        finished: count(Status::Finished),
        skipped: count(Status::Skipped),
        failed: count(Status::Failed),
        wall_seconds: started.elapsed().as_secs_f64(),
        total_wall_seconds: 0.0,
    }
    .write(&args.out, slice)?;
    if INTERRUPTS.load(Ordering::SeqCst) > 0 {
        eprintln!("host-trainer: reproduce interrupted; the stopped runs kept a checkpoint. Re-run the same command to continue (finished runs are skipped)");
        return Ok(ExitCode::from(INTERRUPTED));
    }
    outln!(
        "part {slice} of {}: {} runs, {} trained, {} already finished, {} failed, {:.0} s",
        grid.describe(),
        part.runs,
        part.finished,
        part.skipped,
        part.failed,
        part.wall_seconds
    );
    if slice != Slice::WHOLE {
        outln!(
            "when every part has run: host-trainer reproduce {} --out {} --merge",
            grid.describe(),
            args.out.display()
        );
        return Ok(if part.failed > 0 {
            ExitCode::FAILURE
        } else {
            ExitCode::SUCCESS
        });
    }
    let code = merge(&args.out, &grid)?;
    Ok(if part.failed > 0 {
        ExitCode::FAILURE
    } else {
        code
    })
}

/// Builds the page; exit 1 when runs are missing.
fn merge(out: &Path, grid: &Grid) -> Result<ExitCode> {
    let built = reproduce::build_page(out, grid)?;
    let page = out.join(reproduce::page_file(grid));
    outln!(
        "wrote {} and {}/: {} runs, {} failed, {} missing",
        page.display(),
        out.join(reproduce::FIGURES).display(),
        built.runs,
        built.failed,
        built.missing
    );
    if built.missing > 0 {
        eprintln!(
            "host-trainer: {} of {} runs are missing (listed at the end of {}); run the missing parts, then merge again",
            built.missing,
            built.runs,
            page.display()
        );
        return Ok(ExitCode::FAILURE);
    }
    Ok(ExitCode::SUCCESS)
}

fn team_command(args: TeamArgs) -> Result<ExitCode> {
    let (mut team, _lock) = match &args.resume {
        Some(dir) => {
            let team = TeamRun::resume(dir, args.points)?;
            let lock = lock::acquire(team.dir.path())?;
            (team, lock)
        }
        None => {
            let mut config = match &args.config {
                Some(path) => TeamConfig::from_file(path)?,
                None => TeamConfig::default(),
            };
            config.algo = args.algo.unwrap_or(config.algo);
            config.dcp.t = args.t.unwrap_or(config.dcp.t);
            config.players = args.players.unwrap_or(config.players);
            config.points = args.points.unwrap_or(config.points);
            config.seed = args.seed.unwrap_or(config.seed);
            config.scenario = args.scenario.clone().unwrap_or(config.scenario);
            let out = args.out.as_deref().unwrap_or(Path::new("."));
            let team = TeamRun::create(config, out)?;
            let lock = lock::acquire(team.dir.path())?;
            (team, lock)
        }
    };
    install_ctrl_c_handler();
    if args.stop_when_stdin_closes {
        stop_when_parent_goes();
    }
    let bar = progress::bar(team.config.points as u64, "point", args.quiet);
    bar.set_position(team.team.points as u64);
    let started = Instant::now();
    let before = team.team.points;
    let outcome = team.train(&mut |t| {
        bar.set_position(t.points as u64);
        if INTERRUPTS.load(Ordering::SeqCst) > 0 {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    bar.finish_and_clear();
    if let team::folder::Outcome::Stopped(points) = outcome? {
        eprintln!(
            "host-trainer: interrupted after point {points} of {}; checkpoint written. Continue with: host-trainer team --resume {}",
            team.config.points,
            team.dir.path().display()
        );
        return Ok(ExitCode::from(INTERRUPTED));
    }
    let seconds = started.elapsed().as_secs_f64();
    let players = team.export()?;
    let played = team.team.points - before;
    outln!(
        "trained {} ({played} points in {seconds:.1} s, {:.1} points/s); exported {} players into {}",
        team.dir.path().display(),
        played as f64 / seconds.max(1e-9),
        players.len(),
        team.dir.path().join(team::folder::PLAYERS).display()
    );
    Ok(ExitCode::SUCCESS)
}

fn eval_command(args: EvalArgs) -> Result<()> {
    // Everything that can be checked is checked before the evaluation runs.
    if let Some(path) = &args.json {
        files::check_output(path).with_context(|| format!("cannot write {}", path.display()))?;
    }
    let scenario = trainer::scenario(&args.task)?;
    let blob = files::read_blob(&args.blob)
        .with_context(|| format!("cannot read blob {}", args.blob.display()))?;
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
    print_summary(&report);
    if let Some(path) = &args.json {
        files::write_atomic(path, report_json(&report)?.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(())
}

fn export_command(args: ExportArgs) -> Result<()> {
    // Without a checkpoint there is no trained policy: exporting the recorded config's freshly
    // initialised networks would write an untrained policy under the run's name.
    let run = RunDir::open(&args.run)?;
    if !run.file(folder::CHECKPOINT).exists() {
        anyhow::bail!(
            "{} has no checkpoint: nothing to export (train it, or continue it with train --resume {})",
            run.path().display(),
            run.path().display()
        );
    }
    let (trainer, run, _lock) = resume(&args.run, None)?;
    let name = folder::policy_file(args.encoding);
    let f32 = trainer.policy_blob(&trainer.config.blob_label())?;
    let policy = match args.encoding {
        Encoding::F32 => f32,
        other => export::encode(&f32, other)?,
    };
    // The image is made (and refused) before anything is written.
    let image = args
        .image
        .map(|format| slot_image(&args, format, &policy))
        .transpose()?;
    if args.encoding != Encoding::F32 {
        run.write(&name, &policy)?;
        outln!(
            "wrote {} ({} bytes, {} weights; episode {})",
            run.file(&name).display(),
            policy.len(),
            args.encoding,
            trainer.episode
        );
    } else {
        trainer.export(&run)?;
        let critic_file = run.file(folder::CRITIC);
        let critic = if critic_file.is_file() {
            format!(" and {}", critic_file.display())
        } else {
            String::new()
        };
        outln!(
            "wrote {}{critic} (episode {})",
            run.file(folder::POLICY).display(),
            trainer.episode
        );
    }
    if let Some((format, id, target, bytes)) = image {
        write_slot_image(&run, args.encoding, format, id, target, &bytes)?;
    }
    Ok(())
}

/// The policy's flash slot image for `--image`, with where it goes.
fn slot_image(
    args: &ExportArgs,
    format: ImageFormat,
    policy: &[u8],
) -> Result<(ImageFormat, SlotId, SlotTarget, Vec<u8>)> {
    use policy_core::slot;
    // clap's `requires` guarantees both with --image.
    let (Some(id), Some(sequence)) = (args.slot, args.sequence) else {
        anyhow::bail!("--image needs --slot and --sequence");
    };
    let default_address = match id {
        SlotId::A => slot::EXAMPLE_SLOT_A,
        SlotId::B => slot::EXAMPLE_SLOT_B,
    };
    let target = SlotTarget {
        address: args.address.unwrap_or(default_address),
        size: args.slot_size.unwrap_or(slot::EXAMPLE_SLOT_SIZE),
        sequence,
    };
    let bytes = export::slot_image(policy, format, target)
        .with_context(|| format!("cannot make the slot {id} image"))?;
    Ok((format, id, target, bytes))
}

/// Writes the policy's flash slot image next to it and says how to flash it.
fn write_slot_image(
    run: &RunDir,
    encoding: Encoding,
    format: ImageFormat,
    id: SlotId,
    target: SlotTarget,
    bytes: &[u8],
) -> Result<()> {
    let name = folder::image_file(encoding, id, format);
    run.write(&name, bytes)?;
    let file = run.file(&name);
    let (path, address, sequence) = (file.display(), target.address, target.sequence);
    outln!("wrote {path} (slot {id} at {address:#010x}, sequence {sequence})");
    match format {
        ImageFormat::Bin => outln!(
            "flash it: probe-rs download --chip YOUR_CHIP --binary-format bin --base-address {address:#010x} {path}\n\
             under QEMU: -device loader,file={path},addr={address:#x}"
        ),
        ImageFormat::Hex => outln!(
            "flash it: probe-rs download --chip YOUR_CHIP --binary-format hex {path}\n\
             under QEMU: -device loader,file={path}"
        ),
    }
    Ok(())
}

fn inspect_command(args: &InspectArgs) -> Result<()> {
    let path = args.blob.display();
    let bytes = files::read_blob(&args.blob).with_context(|| format!("cannot read blob {path}"))?;
    let text = inspect::describe(&bytes).with_context(|| format!("{path} is not a valid blob"))?;
    out!("{text}");
    if let Some(reference) = &args.against {
        let other = reference.display();
        let f32 =
            files::read_blob(reference).with_context(|| format!("cannot read blob {other}"))?;
        let errors = inspect::describe_errors(&bytes, &f32)
            .with_context(|| format!("cannot compare {path} with {other}"))?;
        out!("{errors}");
    }
    Ok(())
}

/// firmware-sim's test protocol on the blob; a blob that does not boot is an error here.
/// Boots the blob as firmware-sim's loop does and runs its test protocol. Where the loop would run
/// a blob that does not boot in the safe state (what a chip does), a user asking to evaluate a
/// file gets an error naming `source`, before any episode runs.
/// With `critic`, the blob is an actor of several heads and the critic chooses among them.
fn evaluate(
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

fn report_json(report: &Report) -> Result<String> {
    Ok(serde_json::to_string_pretty(report)? + "\n")
}

fn print_summary(report: &Report) {
    let steps = report
        .mean_steps_to_goal
        .map_or_else(|| "-".to_string(), |s| format!("{s:.1}"));
    outln!(
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
