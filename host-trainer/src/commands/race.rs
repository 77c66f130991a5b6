//! `train --race K`: K seeds raced on every core, the winner exported and tested; `train
//! --resume` of a race folder continues it. The race itself is the library's
//! ([`host_trainer::run::race`]); this file builds the racers, runs them in threads and
//! reports.
//!
//! A race folder holds the winner's `policy.postcard` (and `critic.postcard`), `eval.json` of
//! the test on the test starts, `race.json` (every racer's validation history and why the
//! winner won) and `racers/`, one run folder per racer.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::Ordering;
use std::time::Instant;

use anyhow::{Context, Result};
use firmware_sim::boot::{self, PlantSizes};
use firmware_sim::outln;
use firmware_sim::plant_link::child::{ChildPlant, Timeouts};
use firmware_sim::plant_test::{evaluate_plant, PlantTestConfig};
use host_trainer::algorithms::Algo;
use host_trainer::nn::workers::Workers;
use host_trainer::run::config::TrainConfig;
use host_trainer::run::folder::{self, RunDir};
use host_trainer::run::lock::{self, FolderLock};
use host_trainer::run::metrics::EpisodeRow;
use host_trainer::run::plant::RunPlant;
use host_trainer::run::progress;
use host_trainer::run::race::{
    self, best_kept, race_one, racer_seed, Board, Ending, RaceRecord, RacerRecord,
};
use host_trainer::run::trainer::Trainer;
use host_trainer::run::validation::{Kept, Round, TEST_SEED};

use super::cores;
use super::eval::{
    evaluate, plant_report_json, plant_summary_line, print_summary_text, report_json, summary_line,
};
use super::signals::{install_ctrl_c_handler, stop_when_parent_goes, INTERRUPTED, INTERRUPTS};
use super::train::{out_folder, resume, verdict_code, TrainArgs};

/// How a racer's thread gets its trainer: a fresh run in the race's `racers/` folder, or a
/// racer's folder continued. (A trainer holds its plant, which need not move between threads:
/// each racer's is built in its own thread.)
enum Entrant {
    Fresh {
        config: Box<TrainConfig>,
        racers: PathBuf,
    },
    Resume {
        folder: PathBuf,
        episodes: Option<usize>,
    },
}

impl Entrant {
    fn start(&self, timeouts: Timeouts) -> Result<(Trainer, RunDir, FolderLock)> {
        match self {
            Entrant::Fresh { config, racers } => {
                let trainer = Trainer::new_with(TrainConfig::clone(config), timeouts)?;
                let run = RunDir::create(racers, &trainer.config.run_name())?;
                let lock = lock::acquire(run.path())?;
                Ok((trainer, run, lock))
            }
            Entrant::Resume { folder, episodes } => resume(folder, *episodes, timeouts),
        }
    }
}

/// What a racer's thread hands back: everything the report needs, none of the trainer.
struct Finished {
    ending: Ending,
    seed: u64,
    episode: usize,
    config: TrainConfig,
    plant: RunPlant,
    validation: Vec<Round>,
    kept: Option<Kept>,
}

/// A new race of `k` racers on `config` (its seed is the base seed).
pub(crate) fn race_command(
    args: &TrainArgs,
    config: TrainConfig,
    k: usize,
    timeouts: Timeouts,
) -> Result<ExitCode> {
    anyhow::ensure!(
        config.validation.is_some(),
        "--race {k} needs validation to race by: drop --no-validation (or give the config file a [validation] section)"
    );
    anyhow::ensure!(
        args.threads.is_none(),
        "--threads is for a single run: racers run one thread each (--race 1 trains one run on several threads)"
    );
    check_racers(k)?;
    let base = config.seed;
    // Every check a run makes is made once here, before any folder is created (the seed
    // changes none of them).
    let name = Trainer::new_with(config.clone(), timeouts)?
        .config
        .run_name();
    let out = out_folder(args)?;
    let race_dir = RunDir::create(&out, &name)?;
    let lock = lock::acquire(race_dir.path())?;
    let racers_out = race_dir.file(folder::RACERS);
    // Made here, once, before the racers' threads each create their run inside it.
    folder::create_output_folder(&racers_out)?;
    let mut entrants = Vec::with_capacity(k);
    let mut record = RaceRecord {
        base_seed: base,
        config_toml: config.to_toml(),
        racers: Vec::with_capacity(k),
        winner: None,
        why: "the race is running".into(),
    };
    for i in 0..k {
        let config = TrainConfig {
            seed: racer_seed(base, i),
            ..config.clone()
        };
        record.racers.push(RacerRecord {
            seed: config.seed,
            folder: format!("{}/{}", folder::RACERS, config.run_name()),
            ending: None,
            episodes: 0,
            validation: Vec::new(),
            kept: None,
        });
        entrants.push(Entrant::Fresh {
            config: Box::new(config),
            racers: racers_out.clone(),
        });
    }
    write_record(&race_dir, &record)?;
    run_race(args, (race_dir, lock), entrants, record, timeouts)
}

/// Continues the race in `dir` from its racers' checkpoints.
pub(crate) fn resume_race(dir: &Path, args: &TrainArgs, timeouts: Timeouts) -> Result<ExitCode> {
    let race_dir = RunDir::open(dir)?;
    let lock = lock::acquire(race_dir.path())?;
    let path = race_dir.file(folder::RACE);
    let record = RaceRecord::read(race_dir.path())?;
    anyhow::ensure!(
        !record.racers.is_empty() && record.racers.len() <= race::MAX_RACERS,
        "{} names {} racers: expected 1 to {}",
        path.display(),
        record.racers.len(),
        race::MAX_RACERS
    );
    let mut entrants = Vec::with_capacity(record.racers.len());
    for r in &record.racers {
        let folder = r
            .folder_in(race_dir.path())
            .with_context(|| format!("{}", path.display()))?;
        if args.keep_checkpoints && folder.is_dir() {
            folder::check_kept_checkpoints(&folder)?;
        }
        if folder::run_file_in(&folder).is_some() {
            entrants.push(Entrant::Resume {
                folder,
                episodes: args.episodes,
            });
            continue;
        }
        // Killed before this racer's folder held anything: it starts again from the race's
        // settings (nothing of it had trained).
        let mut config: TrainConfig = toml::from_str(&record.config_toml).with_context(|| {
            format!(
                "{}: its config_toml is not a run's settings",
                path.display()
            )
        })?;
        config.validate()?;
        config.seed = r.seed;
        if let Some(n) = args.episodes {
            config.episodes = n;
        }
        entrants.push(Entrant::Fresh {
            config: Box::new(config),
            racers: race_dir.file(folder::RACERS),
        });
    }
    run_race(args, (race_dir, lock), entrants, record, timeouts)
}

/// `--race K` within range; more racers than cores is allowed (same winner, only slower).
fn check_racers(k: usize) -> Result<()> {
    anyhow::ensure!(
        (1..=race::MAX_RACERS).contains(&k),
        "--race {k}: expected 1 to {} racers",
        race::MAX_RACERS
    );
    let cores = cores();
    if k > cores {
        eprintln!("host-trainer: note: --race {k} is more racers than the {cores} cores available; the race gives the same winner and bytes, only slower");
    }
    Ok(())
}

/// Runs every racer in a thread of its own, then names the winner, exports its kept policy
/// into the race's folder, tests it on the test starts and reports.
fn run_race(
    args: &TrainArgs,
    (race_dir, _lock): (RunDir, FolderLock),
    entrants: Vec<Entrant>,
    mut record: RaceRecord,
    timeouts: Timeouts,
) -> Result<ExitCode> {
    install_ctrl_c_handler();
    if args.stop_when_stdin_closes {
        stop_when_parent_goes();
    }
    // Every lane starts as running: no round is decided before each racer has restored its
    // checkpoint and reported the rounds it holds.
    let board = Board::new(vec![Vec::new(); entrants.len()]);
    let bar = progress::bar(0, "episode", args.quiet);
    bar.set_message(format!("{} racers", entrants.len()));
    let interrupted = || INTERRUPTS.load(Ordering::SeqCst) > 0;
    let tick = |_: usize, _: &EpisodeRow| bar.inc(1);
    let keep = args.keep_checkpoints;
    let started = Instant::now();
    let results: Vec<Result<Finished>> = std::thread::scope(|s| {
        let handles: Vec<_> = entrants
            .iter()
            .enumerate()
            .map(|(i, entrant)| {
                let (board, interrupted, tick, bar) = (&board, &interrupted, &tick, &bar);
                s.spawn(move || {
                    let result = race_thread(
                        i,
                        entrant,
                        board,
                        Reporting {
                            interrupted,
                            tick,
                            bar,
                        },
                        keep,
                        timeouts,
                    );
                    // However the thread ends, the others stop waiting for it.
                    board.finish(i);
                    result
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| Err(anyhow::anyhow!("the racer's thread panicked")))
            })
            .collect()
    });
    bar.finish_and_clear();
    let seconds = started.elapsed().as_secs_f64();
    let racers: Vec<Finished> = results.into_iter().collect::<Result<_>>()?;
    for (r, f) in record.racers.iter_mut().zip(&racers) {
        r.ending = Some(f.ending.clone());
        r.episodes = f.episode;
        r.validation = f.validation.clone();
        r.kept = f.kept.as_ref().map(|k| k.round.clone());
    }
    if racers.iter().any(|f| f.ending == Ending::Interrupted) {
        write_record(&race_dir, &record)?;
        eprintln!(
            "host-trainer: race interrupted; every racer's checkpoint written. Continue with: host-trainer train --resume {}",
            race_dir.path().display()
        );
        return Ok(ExitCode::from(INTERRUPTED));
    }
    let (winner, why) = winner_and_why(&racers, &board)?;
    record.winner = Some(winner);
    record.why = why.clone();
    // Every file first, then the report (as a single run does).
    let won = &racers[winner];
    let Some(kept) = &won.kept else {
        anyhow::bail!("racer {winner} won without a validated policy");
    };
    race_dir.write(folder::POLICY, &kept.policy)?;
    if let Some(critic) = &kept.critic {
        race_dir.write(folder::CRITIC, critic)?;
    }
    let (summary, passed) = test_blob(&won.config, &won.plant, kept, &race_dir, timeouts)?;
    write_record(&race_dir, &record)?;
    let seeds: Vec<String> = racers.iter().map(|r| r.seed.to_string()).collect();
    let v = won.config.validation.clone().unwrap_or_default();
    outln!(
        "raced {} seeds from seed {} ({}), one thread each, in {seconds:.1} s; validation every {} episodes on {} starts of their own (not the test's)",
        racers.len(),
        record.base_seed,
        seeds.join(", "),
        v.every,
        v.starts
    );
    for (i, r) in racers.iter().enumerate() {
        let status = match &r.ending {
            Ending::Won => "won".to_string(),
            Ending::Stopped => "stopped".to_string(),
            Ending::Finished => "used its budget".to_string(),
            Ending::Interrupted => "interrupted".to_string(),
            Ending::Failed(e) => format!("failed ({e})"),
        };
        let best = r.kept.as_ref().map_or_else(String::new, |k| {
            let error = k
                .round
                .error
                .map_or_else(String::new, |e| format!(", settled error {e:.3}"));
            format!(
                "; kept episode {}: success {:.1}%, stuck {:.1}%{error}",
                k.round.episode,
                100.0 * k.round.success,
                100.0 * k.round.stuck
            )
        });
        outln!(
            "  racer {i}  seed {:<10}  {status} at episode {}{best}",
            r.seed,
            r.episode
        );
    }
    outln!("winner: {why}");
    print_summary_text(&summary);
    outln!(
        "wrote {} (the winner's blobs; {}: every racer's validation history; {}/: their runs)",
        race_dir.path().display(),
        folder::RACE,
        folder::RACERS
    );
    Ok(verdict_code(passed))
}

/// What a racer's thread reports to: whether to stop, each episode (the progress bar's tick),
/// and the bar itself (its length grows as racers learn their budgets).
struct Reporting<'a> {
    interrupted: &'a (dyn Fn() -> bool + Sync),
    tick: &'a (dyn Fn(usize, &EpisodeRow) + Sync),
    bar: &'a indicatif::ProgressBar,
}

/// One racer's thread: its trainer built (or restored) here, its recorded rounds reported, its
/// run raced, its kept policy exported into its own folder.
fn race_thread(
    i: usize,
    entrant: &Entrant,
    board: &Board,
    Reporting {
        interrupted,
        tick,
        bar,
    }: Reporting<'_>,
    keep_checkpoints: bool,
    timeouts: Timeouts,
) -> Result<Finished> {
    let (mut trainer, run, _lock) = entrant.start(timeouts)?;
    trainer.set_workers(Workers::new(1).context("cannot start a racer's worker thread")?);
    trainer.keep_checkpoints = keep_checkpoints;
    bar.inc_length(trainer.config.episodes as u64);
    bar.inc(trainer.episode as u64);
    let v = trainer.config.validation.clone().unwrap_or_default();
    for n in 0..trainer.validation.len() {
        let ends = v.stops_after(&trainer.validation[..=n]);
        board.report(i, trainer.validation[n].clone(), ends);
    }
    let ending = race_one(i, &mut trainer, &run, board, interrupted, tick);
    // Each racer's folder is a whole run: its kept policy exported.
    if matches!(ending, Ending::Won | Ending::Stopped | Ending::Finished) {
        trainer.export(&run)?;
    }
    Ok(Finished {
        ending,
        seed: trainer.config.seed,
        episode: trainer.episode,
        config: trainer.config.clone(),
        plant: trainer.plant.clone(),
        validation: trainer.validation.clone(),
        kept: trainer.kept.clone(),
    })
}

/// The winner's kept policy through the test on the test starts, written into `race_dir`:
/// a scenario's test protocol, or the test for any plant on the plant command started again.
fn test_blob(
    config: &TrainConfig,
    plant: &RunPlant,
    kept: &Kept,
    race_dir: &RunDir,
    timeouts: Timeouts,
) -> Result<(String, bool)> {
    let heads = config.algo == Algo::Dcp && config.dcp.heads > 1;
    let critic = kept.critic.as_deref().filter(|_| heads);
    let policy_file = race_dir.file(folder::POLICY);
    match plant {
        RunPlant::Scenario(scenario) => {
            let report = evaluate(
                &kept.policy,
                critic,
                &policy_file,
                scenario,
                config.eval_episodes,
                TEST_SEED,
            )?;
            race_dir.write(folder::EVAL, report_json(&report)?.as_bytes())?;
            Ok((summary_line(&report), report.pass.passed))
        }
        RunPlant::Process { command, .. } => {
            let mut plant = ChildPlant::spawn(command, timeouts)?;
            let sizes = PlantSizes::of_env(&plant);
            let mut policy = boot::boot(&kept.policy, &sizes)
                .with_context(|| format!("{} does not boot on its plant", policy_file.display()))?;
            let cfg = PlantTestConfig {
                episodes: config.eval_episodes,
                seed: TEST_SEED,
                ..PlantTestConfig::default()
            };
            let name = plant.hello().name.clone();
            let report = evaluate_plant(&mut policy, &mut plant, &name, &cfg)?;
            race_dir.write(folder::EVAL, plant_report_json(&report)?.as_bytes())?;
            Ok((plant_summary_line(&report), report.pass.passed))
        }
        RunPlant::Given { hello } => anyhow::bail!(
            "plant {:?} was given in process: a race runs on a scenario or a plant command",
            hello.name
        ),
    }
}

/// The winner and why: the first round at which a racer's validation ended its run (the
/// board's decision), else, every racer's budget used, the best kept policy.
fn winner_and_why(racers: &[Finished], board: &Board) -> Result<(usize, String)> {
    let name = |i: usize| format!("racer {i} (seed {})", racers[i].seed);
    if let Some((round, w)) = board.winner() {
        let r = &racers[w];
        let v = r.config.validation.clone().unwrap_or_default();
        let episode = r.validation.get(round).map_or(r.episode, |r| r.episode);
        return Ok((
            w,
            format!(
                "{} was the first whose validation {} (at episode {episode}; at one round the better figure wins, then the lower index), so every racer stopped there",
                name(w),
                v.met_the_criteria()
            ),
        ));
    }
    let kept: Vec<_> = racers
        .iter()
        .map(|r| (r.kept.as_ref().map(|k| k.round.clone()), r.ending.clone()))
        .collect();
    let Some(w) = best_kept(&kept) else {
        let reasons: Vec<String> = racers
            .iter()
            .enumerate()
            .map(|(i, r)| format!("{}: {:?}", name(i), r.ending))
            .collect();
        anyhow::bail!("every racer failed: {}", reasons.join("; "));
    };
    Ok((
        w,
        format!(
            "no racer's validation ended its run within the budget; {} kept the best policy by the rule (meeting the criteria, then the gate, then the lower settled error)",
            name(w)
        ),
    ))
}

fn write_record(race_dir: &RunDir, record: &RaceRecord) -> Result<()> {
    let text = serde_json::to_string_pretty(record)? + "\n";
    race_dir.write(folder::RACE, text.as_bytes())?;
    Ok(())
}
