//! The one error type of host-trainer.

use std::fmt;
use std::path::PathBuf;

/// Everything that can stop training, export or evaluation.
#[derive(Debug)]
#[non_exhaustive]
pub enum Error {
    /// A blob could not be written or read by policy-core.
    Blob(policy_core::Error),
    /// The network shape cannot be written as a blob (beyond the format's limits, or the wrong
    /// output for its kind).
    UnsupportedShape {
        /// The requested shape, e.g. "2 observations, 65x48 hidden, 2 actions".
        shape: String,
        /// Why, e.g. policy-core's limit that it breaks.
        reason: String,
    },
    /// Sizes that do not fit together (network, normaliser, bounds, batch).
    ShapeMismatch {
        /// What was being combined.
        what: &'static str,
        /// The size expected.
        expected: usize,
        /// The size found.
        found: usize,
    },
    /// A file could not be read or written.
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A configuration value (CLI flag or config file entry) is out of range or malformed.
    InvalidConfig {
        /// Which setting, e.g. "--hidden" or "agent.batch".
        what: String,
        /// What is accepted.
        expected: String,
        /// What was given.
        found: String,
    },
    /// A config file could not be parsed.
    ConfigFile {
        /// The file.
        path: PathBuf,
        /// The parser's message (one line).
        message: String,
    },
    /// A new run's folder already holds a run; it is never overwritten.
    RunExists {
        /// The run folder.
        path: PathBuf,
        /// The run file found in it.
        found: String,
    },
    /// `inspect --against`: the reference is not the f32 blob of the same model.
    NotTheReference {
        /// What differs, e.g. "the reference holds a critic and the blob an actor".
        difference: String,
    },
    /// A setting away from its default that none of the chosen algorithms reads: it would be
    /// recorded in `config.toml` and change nothing.
    UnreadSetting {
        /// The setting as `section.key`, or the flag that set it.
        key: String,
        /// Its value, or empty for a flag.
        value: String,
        /// The algorithms of the run or sweep, none of which reads it.
        algos: String,
        /// The algorithms that read it.
        readers: String,
    },
    /// A sweep's run folder holds a run of other settings than the sweep would run there.
    RunDiffers {
        /// The run folder.
        path: PathBuf,
        /// The first setting that differs, e.g. `episodes = 4 recorded, 6 in the sweep`.
        difference: String,
    },
    /// A `reproduce` folder holds another grid (experiment, seeds or budget) than the command's,
    /// or none to merge.
    GridDiffers {
        /// The `--out` folder.
        path: PathBuf,
        /// How, e.g. "it holds the grid `exp1 --seeds 5`, not `exp1 --seeds 6`".
        difference: String,
    },
    /// A finished run's result file does not read, or holds values no evaluation gives (a
    /// success rate of 7.5): the run is damaged, and training it again is the way out.
    DamagedRun {
        /// The run folder.
        path: PathBuf,
        /// What is wrong, e.g. "eval.json is cut short (EOF while parsing ...)".
        problem: String,
    },
    /// A `reproduce` folder's `grid.json` does not read as a grid record.
    GridRecord {
        /// The file.
        path: PathBuf,
        /// The parser's message (one line).
        message: String,
    },
    /// A race's folder's `race.json` does not read as a race's record.
    RaceRecord {
        /// The file.
        path: PathBuf,
        /// The parser's message (one line).
        message: String,
    },
    /// A `reproduce` part that would run runs of a part already running on the same `--out`
    /// (the same part again, or one that shares runs with it).
    PartRunning {
        /// The grid's `--out`.
        path: PathBuf,
        /// The running part and its process, and how it meets this one.
        running: String,
    },
    /// Another process writes into the folder (it holds the folder's lock).
    Locked {
        /// The run or sweep folder.
        path: PathBuf,
        /// Who holds it, e.g. "host-trainer process 4242".
        holder: String,
    },
    /// A checkpoint could not be encoded or decoded.
    Checkpoint {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// firmware-sim refused a scenario, an environment or an evaluation.
    Sim {
        /// What was being done, e.g. "scenario nav-walls".
        context: String,
        /// firmware-sim's message.
        message: String,
    },
    /// Training produced a non-finite loss or non-finite weights and was stopped.
    Diverged {
        /// The episode (1-based) during which it happened.
        episode: usize,
        /// What became non-finite, e.g. "critic loss".
        what: String,
        /// The last good checkpoint, kept on disk.
        checkpoint: Option<PathBuf>,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Blob(e) => write!(f, "blob: {e}"),
            Error::UnsupportedShape { shape, reason } => {
                write!(f, "unsupported network shape {shape}: {reason}")
            }
            Error::ShapeMismatch {
                what,
                expected,
                found,
            } => {
                write!(f, "{what}: expected size {expected}, found {found}")
            }
            Error::Io { path, source } => write!(f, "{}: {source}", path.display()),
            Error::InvalidConfig {
                what,
                expected,
                found,
            } => {
                write!(f, "{what}: expected {expected}, found {found:?}")
            }
            Error::ConfigFile { path, message } => {
                write!(f, "config file {}: {message}", path.display())
            }
            Error::RunExists { path, found } => write!(
                f,
                "{} already holds a run ({found}); continue it with --resume {}, or choose another --out or --seed",
                path.display(),
                path.display()
            ),
            Error::NotTheReference { difference } => write!(
                f,
                "{difference}: --against takes the f32 blob the quantised one was exported from (the same run's policy.postcard)"
            ),
            Error::UnreadSetting {
                key,
                value,
                algos,
                readers,
            } => {
                let value = if value.is_empty() {
                    String::new()
                } else {
                    format!(" = {value}")
                };
                write!(
                    f,
                    "{key}{value} is not used by {algos}, only by {readers}: remove it or choose one of those with --algo"
                )
            }
            Error::RunDiffers { path, difference } => write!(
                f,
                "{} holds a run of other settings than this sweep's ({difference}); sweep into another --out, or move the folder away",
                path.display()
            ),
            Error::GridDiffers { path, difference } => write!(
                f,
                "{}: {difference}; give the same experiment, --seeds and --quick as the runs there, or another --out",
                path.display()
            ),
            Error::DamagedRun { path, problem } => write!(
                f,
                "run {} is damaged: {problem}; remove that folder and run the same command again to train it anew",
                path.display()
            ),
            Error::RaceRecord { path, message } => write!(
                f,
                "{} is not a race's record ({message}); train writes it when it races seeds: restore it, or train the race anew in another folder",
                path.display()
            ),
            Error::GridRecord { path, message } => write!(
                f,
                "{} is not a grid record ({message}); it must hold experiment, seeds and quick as reproduce wrote them: restore it from the command that made the runs, or use another --out",
                path.display()
            ),
            Error::PartRunning { path, running } => write!(
                f,
                "{}: {running}; wait for it or stop it (parts that share no run go side by side)",
                path.display()
            ),
            Error::Locked { path, holder } => write!(
                f,
                "{} is in use by {holder}: one train, export or sweep writes a folder at a time; wait for it or stop it",
                path.display()
            ),
            Error::Checkpoint { path, message } => {
                write!(f, "checkpoint {}: {message}", path.display())
            }
            Error::Sim { context, message } => write!(f, "{context}: {message}"),
            Error::Diverged {
                episode,
                what,
                checkpoint,
            } => {
                write!(
                    f,
                    "training diverged in episode {episode}: {what} is not finite; "
                )?;
                match checkpoint {
                    Some(path) => write!(f, "last good checkpoint kept at {}", path.display()),
                    None => write!(f, "no checkpoint was written before it"),
                }
            }
        }
    }
}

/// `source()` stays `None`: every `Display` above already includes its cause, and reporting it
/// twice (once in the message, once in the chain `{:#}` prints) reads as two errors.
impl std::error::Error for Error {}

impl From<policy_core::Error> for Error {
    fn from(e: policy_core::Error) -> Self {
        Error::Blob(e)
    }
}

impl Error {
    /// An [`Error::InvalidConfig`] for setting `what`, which accepts `expected` and got `found`.
    pub(crate) fn invalid(
        what: &str,
        expected: impl Into<String>,
        found: impl fmt::Display,
    ) -> Error {
        Error::InvalidConfig {
            what: what.into(),
            expected: expected.into(),
            found: found.to_string(),
        }
    }

    /// Checks that `v` is finite and in `[lo, hi]`.
    pub(crate) fn check_range(what: &str, v: f32, lo: f32, hi: f32) -> Result<(), Error> {
        if v.is_finite() && (lo..=hi).contains(&v) {
            Ok(())
        } else {
            Err(Error::invalid(what, format!("a number in [{lo}, {hi}]"), v))
        }
    }

    /// Checks that the count `n` is in `[1, max]`.
    pub(crate) fn check_count(what: &str, n: usize, max: usize) -> Result<(), Error> {
        if (1..=max).contains(&n) {
            Ok(())
        } else {
            Err(Error::invalid(what, format!("an integer in [1, {max}]"), n))
        }
    }
}
