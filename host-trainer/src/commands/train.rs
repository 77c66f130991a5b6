//! `host-trainer train`: a new run from the defaults, a config file and flags, or a run
//! continued from its checkpoint; trained, exported and evaluated.

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use clap::Args;
use firmware_sim::boot::{self, PlantSizes};
use firmware_sim::files;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::outln;
use firmware_sim::plant_link::child::Timeouts;
use firmware_sim::plant_test::{evaluate_plant, PlantReport, PlantTestConfig};
use host_trainer::algorithms::noise::Noise;
use host_trainer::algorithms::{self, Algo};
use host_trainer::nn::hidden::Hidden;
use host_trainer::nn::workers::{Workers, MAX_THREADS};
use host_trainer::run::checkpoint::Checkpoint;
use host_trainer::run::config::{RewardKind, TrainConfig};
use host_trainer::run::folder::{self, RunDir};
use host_trainer::run::lock::{self, FolderLock};
use host_trainer::run::progress;
use host_trainer::run::trainer::{self, Outcome, Trainer};
use host_trainer::run::validation::{ValidationConfig, TEST_SEED};

use super::cores;
use super::eval::{
    evaluate, plant_report_json, plant_summary_line, print_summary_text, report_json, summary_line,
};
use super::signals::{install_ctrl_c_handler, stop_when_parent_goes, INTERRUPTED, INTERRUPTS};

/// Flags override the config file, which overrides the defaults (the paper's values).
#[derive(Debug, Args)]
pub(crate) struct TrainArgs {
    /// Built-in scenario (nav-walls, nav-open) or a scenario TOML file [default: nav-walls].
    #[arg(long)]
    task: Option<String>,
    /// A plant of your own instead of a scenario: "CMD ARGS" starts it as a child process that
    /// speaks the plant link on its standard input and output (docs/own-plant.md), e.g.
    /// "python3 -m margin_safe_rl.plant_link serve Pendulum-v1". The run is named for the
    /// plant's hello and records the command; the end-of-training test is the protocol for any
    /// plant.
    #[arg(long, conflicts_with = "task")]
    plant_cmd: Option<String>,
    /// The longest wait, in seconds, for the plant's answer to a reset or step.
    #[arg(long, default_value_t = 10.0)]
    plant_timeout: f64,
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
    pub(crate) episodes: Option<usize>,
    /// A budget in environment steps as well (as Stable-Baselines3 counts): the run ends with
    /// the episode in which its steps reach N; --episodes stays an upper bound [default: none].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    env_steps: Option<u64>,
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
    /// Output folder, created if missing (its parent must exist) [default: ./runs].
    #[arg(long)]
    out: Option<PathBuf>,
    /// Config file (TOML, or JSON if it ends in .json); see config.toml in any run folder.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Validate every N episodes (and at the end of the budget): the actor, exported as its
    /// blob, through firmware-sim's test protocol on validation starts of its own, never the
    /// test's; the best policy by validation is the one kept [default: 10].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    validate_every: Option<u64>,
    /// Validation starts per round [default: 100].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    validation_starts: Option<u64>,
    /// Train to the budget even once validation meets its criteria (the best is still kept).
    #[arg(long)]
    no_stop: bool,
    /// No validation: train to the budget and keep the last networks (what sweep and
    /// reproduce do).
    #[arg(long, conflicts_with_all = ["validate_every", "validation_starts", "no_stop"])]
    no_validation: bool,
    /// Race K seeds derived from --seed, one thread each; the first whose validation ends its
    /// run wins, the others stop (docs/training.md, "Seeds raced") [default: one racer per
    /// core; 1 without validation].
    #[arg(long, value_name = "K", value_parser = clap::value_parser!(u64).range(1..))]
    race: Option<u64>,
    /// Continue the run (or race) in this folder from its checkpoints (--episodes may raise
    /// the budget).
    #[arg(long, conflicts_with_all = ["task", "plant_cmd", "algo", "hidden", "reward", "t", "sigma", "noise", "dropout", "reward_scale", "seed", "out", "config", "env_steps", "validate_every", "validation_starts", "no_stop", "no_validation", "race"])]
    resume: Option<PathBuf>,
    /// Worker threads of the updates of a single run (--race 1), 1 to 1024; any count trains to
    /// the same bytes [default: the cores available; a racer always runs one].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_THREADS)))]
    pub(crate) threads: Option<u32>,
    /// Also keep a copy of every checkpoint in RUN/checkpoints/ (to study how the run
    /// learned; each holds the whole replay buffer, tens of MB).
    #[arg(long)]
    pub(crate) keep_checkpoints: bool,
    /// No progress bar.
    #[arg(long)]
    pub(crate) quiet: bool,
    /// Stop as on Ctrl-C (checkpoint, exit 130) when standard input reaches its end. A sweep
    /// starts its runs with this and holds their standard input open, so a sweep that dies by
    /// any signal, SIGKILL included, takes its runs with it instead of leaving them training.
    #[arg(long, hide = true)]
    pub(crate) stop_when_stdin_closes: bool,
}

pub(crate) fn train_command(args: TrainArgs) -> Result<ExitCode> {
    let timeouts = plant_timeouts(args.plant_timeout)?;
    if let Some(dir) = &args.resume {
        if dir.join(folder::RACE).is_file() {
            return super::race::resume_race(dir, &args, timeouts);
        }
    } else {
        let config = fresh_config(&args)?;
        let racers = match args.race {
            Some(k) => usize::try_from(k).unwrap_or(usize::MAX),
            // One racer per core; a run without validation has nothing to race by.
            None if config.validation.is_some() => cores(),
            None => 1,
        };
        if racers > 1 {
            return super::race::race_command(&args, config, racers, timeouts);
        }
    }
    let quiet = args.quiet;
    let stop_when_stdin_closes = args.stop_when_stdin_closes;
    let keep_checkpoints = args.keep_checkpoints;
    let workers = workers(args.threads)?;
    if let (true, Some(dir)) = (keep_checkpoints, &args.resume) {
        folder::check_kept_checkpoints(dir)?;
    }
    let (mut trainer, run, _lock) = match &args.resume {
        Some(dir) => resume(dir, args.episodes, timeouts)?,
        None => fresh(&args, timeouts)?,
    };
    trainer.set_workers(workers);
    trainer.keep_checkpoints = keep_checkpoints;
    install_ctrl_c_handler();
    if stop_when_stdin_closes {
        stop_when_parent_goes();
    }
    // A step budget counts in steps, the way it ends the run.
    let by_steps = trainer.config.env_steps;
    let position = |episode: usize, steps: u64| by_steps.map_or(episode as u64, |_| steps);
    let bar = match by_steps {
        Some(n) => progress::bar(n, "step", quiet),
        None => progress::bar(trainer.config.episodes as u64, "episode", quiet),
    };
    bar.set_position(position(trainer.episode, trainer.total_steps));
    let started = Instant::now();
    let steps_before = trainer.total_steps;
    let episodes_before = trainer.episode;
    let outcome = trainer::run(&mut trainer, &run, &mut |row, t| {
        bar.set_position(position(row.episode, row.total_steps));
        bar.set_message(format!(
            "success(100) {:>3.0}%  {:>6.0} steps/s{}",
            100.0 * t.recent_success(100),
            row.steps_per_s,
            validation_note(t)
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
    let (summary, passed) = test_on_test_starts(&mut trainer, &blob, &run)?;
    let rate = steps as f64 / seconds.max(1e-9);
    if episodes_before == 0 && steps_before == 0 {
        outln!("trained {} ({} episodes, {steps} env steps in {seconds:.1} s, {rate:.0} steps/s incl. updates)", run.path().display(), trainer.episode);
    } else {
        // A resumed run: the run's totals first (what its metrics and checkpoint hold), then
        // this part's, whose speed alone was measured here.
        outln!("trained {} ({} episodes, {} env steps in all; this part: {} episodes, {steps} env steps in {seconds:.1} s, {rate:.0} steps/s incl. updates)", run.path().display(), trainer.episode, trainer.total_steps, trainer.episode - episodes_before);
    }
    if let Some(line) = validation_summary(&trainer) {
        outln!("{line}");
    }
    print_summary_text(&summary);
    outln!("wrote {}", run.path().display());
    Ok(verdict_code(passed))
}

/// The exit status of a judged run, as `eval` and `firmware-sim run` give it: 0 when the
/// gate passes, 1 when it fails.
pub(crate) fn verdict_code(passed: bool) -> ExitCode {
    if passed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}

/// The last validation round, for the progress bar.
fn validation_note(t: &Trainer) -> String {
    t.validation.last().map_or_else(String::new, |r| {
        let error = r
            .error
            .map_or_else(String::new, |e| format!(" error {e:.2}"));
        format!(
            "  validation@{} success {:.0}%{error}",
            r.episode,
            100.0 * r.success
        )
    })
}

/// What validation did, in one line: the rounds, how the run ended and which policy it kept.
pub(crate) fn validation_summary(trainer: &Trainer) -> Option<String> {
    let v = trainer.config.validation.as_ref()?;
    let kept = trainer.kept.as_ref()?;
    let r = &kept.round;
    let figure = match (r.error, r.mean_return) {
        (Some(e), _) => format!(", settled error {e:.3}"),
        (None, Some(m)) => format!(", mean return {m:.3}"),
        (None, None) => String::new(),
    };
    let ended = if trainer.stopped_at_gate() {
        format!(
            "{}: stopped at episode {}",
            v.met_the_criteria(),
            trainer.episode
        )
    } else if trainer.validation.iter().any(|r| r.meets) {
        "met the criteria, not enough rounds in a row to stop".to_string()
    } else {
        "never met the criteria".to_string()
    };
    Some(format!(
        "validation: {} rounds on {} starts of their own (not the test's); {ended}; kept the policy of episode {} (success {:.1}%, stuck {:.1}%{figure})",
        trainer.validation.len(),
        v.starts,
        r.episode,
        100.0 * r.success,
        100.0 * r.stuck,
    ))
}

/// The end-of-training test of the exported `blob` on the test starts (which no choice of the
/// run has seen): writes `eval.json` into `run`, returns the summary line and whether the gate
/// passed.
pub(crate) fn test_on_test_starts(
    trainer: &mut Trainer,
    blob: &[u8],
    run: &RunDir,
) -> Result<(String, bool)> {
    // An actor of several heads runs with its critic choosing the head, as on the chip.
    let heads = trainer.config.algo == Algo::Dcp && trainer.config.dcp.heads > 1;
    let critic = if heads {
        Some(files::read_blob(&run.file(folder::CRITIC))?)
    } else {
        None
    };
    match trainer.plant.scenario().cloned() {
        Some(scenario) => {
            let report = evaluate(
                blob,
                critic.as_deref(),
                &run.file(folder::POLICY),
                &scenario,
                trainer.config.eval_episodes,
                TEST_SEED,
            )?;
            run.write(folder::EVAL, report_json(&report)?.as_bytes())?;
            Ok((summary_line(&report), report.pass.passed))
        }
        None => {
            let report = evaluate_on_plant(trainer, blob, run)?;
            run.write(folder::EVAL, plant_report_json(&report)?.as_bytes())?;
            Ok((plant_summary_line(&report), report.pass.passed))
        }
    }
}

/// The end-of-training test of a run on a plant of the user's: the exported blob, booted as the
/// chip boots it, through the test protocol for any plant on the run's own plant (its test
/// episodes seeded apart from training's).
fn evaluate_on_plant(trainer: &mut Trainer, blob: &[u8], run: &RunDir) -> Result<PlantReport> {
    let name = trainer.plant.name();
    let cfg = PlantTestConfig {
        episodes: trainer.config.eval_episodes,
        seed: TEST_SEED,
        ..PlantTestConfig::default()
    };
    let sizes = {
        let agents = trainer.plant_mut().agents();
        let agent = agents.first().context("the plant declares no agent")?;
        PlantSizes {
            observations: agent.observation_space.dim(),
            actions: agent.action_space.dim(),
        }
    };
    let mut policy = boot::boot(blob, &sizes)
        .with_context(|| format!("{}: the exported blob", run.file(folder::POLICY).display()))?;
    Ok(evaluate_plant(
        &mut policy,
        trainer.plant_mut(),
        &name,
        &cfg,
    )?)
}

/// `--plant-timeout` as the plant link's time-outs.
pub(crate) fn plant_timeouts(seconds: f64) -> Result<Timeouts> {
    anyhow::ensure!(
        seconds.is_finite() && seconds > 0.0 && seconds <= 3600.0,
        "--plant-timeout must be in (0, 3600] seconds, found {seconds}"
    );
    Ok(Timeouts {
        step: Duration::from_secs_f64(seconds),
        ..Timeouts::default()
    })
}

/// `--threads`: the worker threads of the updates, all cores by default (measured fastest for
/// one run: docs/performance.md, "Threads"). A count above the cores is allowed (it trains to
/// the same bytes, only slower) and said once.
pub(crate) fn workers(threads: Option<u32>) -> Result<Workers> {
    let cores = cores();
    let threads = threads.map_or(cores, |n| n as usize);
    if threads > cores {
        eprintln!("host-trainer: note: --threads {threads} is more than the {cores} cores available; the run trains to the same bytes, probably slower");
    }
    Workers::new(threads).with_context(|| format!("cannot start {threads} worker threads"))
}

/// A new run: defaults, then the config file, then flags; nothing is written until the
/// configuration is valid and the trainer is built.
pub(crate) fn fresh(args: &TrainArgs, timeouts: Timeouts) -> Result<(Trainer, RunDir, FolderLock)> {
    let trainer = Trainer::new_with(fresh_config(args)?, timeouts)?;
    let run = RunDir::create(&out_folder(args)?, &trainer.config.run_name())?;
    let lock = lock::acquire(run.path())?;
    Ok((trainer, run, lock))
}

/// A new run's settings: the defaults, then the config file, then flags, checked.
pub(crate) fn fresh_config(args: &TrainArgs) -> Result<TrainConfig> {
    let mut config = match &args.config {
        Some(path) => TrainConfig::from_file(path)?,
        None => TrainConfig::default(),
    };
    apply_flags(&mut config, args);
    check_validate_every(&config, args)?;
    check_flags_used(config.algo, args)?;
    config.check_read(&[config.algo])?;
    Ok(config)
}

/// `--out`, or `./runs` made if missing.
pub(crate) fn out_folder(args: &TrainArgs) -> Result<PathBuf> {
    match &args.out {
        Some(out) => Ok(out.clone()),
        None => {
            let out = PathBuf::from("runs");
            std::fs::create_dir_all(&out)
                .with_context(|| format!("cannot create output folder {}", out.display()))?;
            Ok(out)
        }
    }
}

pub(crate) fn apply_flags(config: &mut TrainConfig, args: &TrainArgs) {
    if let Some(v) = &args.task {
        config.task = v.clone();
    }
    if let Some(v) = &args.plant_cmd {
        config.plant_cmd = Some(v.clone());
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
    if let Some(v) = args.env_steps {
        config.env_steps = Some(v);
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
    if args.no_validation {
        config.validation = None;
    } else if args.validate_every.is_some() || args.validation_starts.is_some() || args.no_stop {
        let v = config
            .validation
            .get_or_insert_with(ValidationConfig::default);
        if let Some(n) = args.validate_every {
            v.every = usize::try_from(n).unwrap_or(usize::MAX);
        }
        if let Some(n) = args.validation_starts {
            v.starts = usize::try_from(n).unwrap_or(usize::MAX);
        }
        if args.no_stop {
            v.stop = false;
        }
    }
}

/// `--validate-every` above the episode budget would validate once, at the end: a user who
/// asks for rounds is told instead.
fn check_validate_every(config: &TrainConfig, args: &TrainArgs) -> Result<()> {
    if let (Some(n), Some(v)) = (args.validate_every, &config.validation) {
        anyhow::ensure!(
            v.every <= config.episodes,
            "--validate-every {n} is above the episode budget ({}): at most {} (or --no-validation)",
            config.episodes,
            config.episodes
        );
    }
    Ok(())
}

/// A flag the run's algorithm does not read would be recorded in `config.toml` and change
/// nothing: it is refused, naming the algorithms that use it (even at its default value; a
/// config file's setting is refused only away from its default, see
/// [`TrainConfig::check_read`]).
pub(crate) fn check_flags_used(algo: Algo, args: &TrainArgs) -> Result<()> {
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
pub(crate) fn resume(
    dir: &Path,
    episodes: Option<usize>,
    timeouts: Timeouts,
) -> Result<(Trainer, RunDir, FolderLock)> {
    let run = RunDir::open(dir)?;
    // Held until the command ends: a second trainer, export or sweep child is refused.
    let lock = lock::acquire(run.path())?;
    let path = run.file(folder::CHECKPOINT);
    let trainer = if path.exists() {
        let trainer = Trainer::resume_with(Checkpoint::load(&path)?, episodes, &path, timeouts)?;
        if episodes.is_some() {
            // The new budget is the run's: recorded in its checkpoint and its config.toml, so a
            // sweep sees the run's real budget and a later --resume keeps it.
            trainer.save(&run)?;
            run.write(folder::CONFIG, trainer.config.to_toml().as_bytes())?;
        }
        trainer
    } else {
        restart(&run, episodes, timeouts)?
    };
    note_changed_plant(&trainer);
    Ok((trainer, run, lock))
}

pub(crate) fn restart(
    run: &RunDir,
    episodes: Option<usize>,
    timeouts: Timeouts,
) -> Result<Trainer> {
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
    if config.plant_cmd.is_some() {
        // Nothing has trained yet: the command starts the plant afresh.
        return Ok(Trainer::new_with(config, timeouts)?);
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
pub(crate) fn note_changed_plant(trainer: &Trainer) {
    let task = &trainer.config.task;
    let Some(scenario) = trainer.plant.scenario() else {
        return; // a plant process's hello was checked when it started again
    };
    if Scenario::builtin(task).is_some() || !Path::new(task).exists() {
        return;
    }
    if Scenario::resolve(task).ok().as_ref() != Some(scenario) {
        eprintln!(
            "host-trainer: note: {task} has changed (or no longer loads) since the run started; the run continues on its recorded plant ({})",
            folder::SCENARIO
        );
    }
}
