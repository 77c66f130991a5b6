//! `host-trainer team`: a badminton team trained, resumed, and its players exported.

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::Ordering;
use std::time::Instant;

use anyhow::Result;
use clap::Args;
use firmware_sim::outln;
use host_trainer::algorithms::{self, Algo};
use host_trainer::run::lock;
use host_trainer::run::progress;
use host_trainer::team::{self, config::TeamConfig, folder::TeamRun};

use super::signals::{install_ctrl_c_handler, stop_when_parent_goes, INTERRUPTED, INTERRUPTS};

/// Flags override the config file, which overrides the defaults (the paper's values).
#[derive(Debug, Args)]
pub(crate) struct TeamArgs {
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
    /// Output folder, created if missing (its parent must exist); the team's folder is created
    /// in it.
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

pub(crate) fn team_command(args: TeamArgs) -> Result<ExitCode> {
    let (mut team, _lock) = match &args.resume {
        Some(dir) => {
            holds_a_team(dir)?;
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
            // As train: a flag the team's algorithm does not read would be recorded in its
            // config.toml and change nothing.
            if args.t.is_some() && !algorithms::readers("dcp", "t").contains(&config.algo) {
                return Err(host_trainer::Error::UnreadSetting {
                    key: "--t".into(),
                    value: String::new(),
                    algos: config.algo.to_string(),
                    readers: algorithms::names(algorithms::readers("dcp", "t")),
                }
                .into());
            }
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

/// `--resume DIR` names a team's folder: one holding its checkpoint. The `--out` folder that
/// holds the team (the usual slip) is named with the team folder inside it, rather than as the
/// system's missing `checkpoint.postcard`.
fn holds_a_team(dir: &Path) -> Result<()> {
    use host_trainer::run::folder::CHECKPOINT;
    if !dir.is_dir() || dir.join(CHECKPOINT).is_file() {
        // A missing folder, or one with a checkpoint: resume says what is wrong with it.
        return Ok(());
    }
    let mut inside: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .flatten()
                .map(|e| e.path())
                .filter(|p| p.join(CHECKPOINT).is_file())
                .collect()
        })
        .unwrap_or_default();
    inside.sort();
    let shown: Vec<String> = inside.iter().map(|p| p.display().to_string()).collect();
    match shown.as_slice() {
        [] => anyhow::bail!(
            "--resume {}: no team checkpoint ({CHECKPOINT}) in it: not a team folder (give the folder host-trainer team wrote, SCENARIO__ALGO__SEED)",
            dir.display()
        ),
        [one] => anyhow::bail!(
            "--resume {}: no team checkpoint ({CHECKPOINT}) in it: it holds the team folder {one}; resume with --resume {one}",
            dir.display()
        ),
        many => anyhow::bail!(
            "--resume {}: no team checkpoint ({CHECKPOINT}) in it: it holds the team folders {}; give one of them",
            dir.display(),
            many.join(", ")
        ),
    }
}
