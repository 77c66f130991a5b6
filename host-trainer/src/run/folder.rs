//! A run's folder, `{task}__{algo}__{seed}`, and the files in it.
//!
//! Every file the trainer produces is written with `firmware_sim::files::write_atomic` (a
//! temporary sibling renamed into place), so a crash, a full disk or Ctrl-C never leaves a
//! half-written checkpoint or blob behind: a reader sees the previous complete file or the new
//! complete file. Temporaries left by a killed process are removed when the folder is opened.
//!
//! A run folder holds everything its run needs: its configuration (`config.toml`), the plant it
//! trains on (`scenario.toml`, also inside every checkpoint), and its checkpoint. Resume and
//! export read nothing outside it.

use std::fs;
use std::path::{Path, PathBuf};

use firmware_sim::files;
use policy_core::blob::LABEL_CAPACITY;

use crate::Error;

/// The configuration file of a run.
pub const CONFIG: &str = "config.toml";
/// The plant the run trains on, as resolved when it started (readable copy; the checkpoint
/// holds the same text).
pub const SCENARIO: &str = "scenario.toml";
/// Per-episode training metrics.
pub const METRICS: &str = "metrics.csv";
/// The learning-curve plot.
pub const CURVE: &str = "learning-curve.svg";
/// The resumable training state.
pub const CHECKPOINT: &str = "checkpoint.postcard";
/// The folder of every checkpoint's copy (`train --keep-checkpoints`).
pub const KEPT_CHECKPOINTS: &str = "checkpoints";

/// The name of the kept copy of the checkpoint after `episode` episodes, sorting in episode
/// order.
///
/// ```
/// assert_eq!(host_trainer::run::folder::kept_checkpoint(300), "episode-0000300.postcard");
/// ```
pub fn kept_checkpoint(episode: usize) -> String {
    format!("episode-{episode:07}.postcard")
}
/// The exported actor blob (what gets flashed).
pub const POLICY: &str = "policy.postcard";
/// The exported critic blob (for on-device compare steps).
pub const CRITIC: &str = "critic.postcard";

/// The policy blob's file name in an encoding: `policy.postcard` for f32 (what `train` writes),
/// `policy-f16.postcard` and `policy-int8.postcard` for the quantised exports.
pub fn policy_file(encoding: policy_core::Encoding) -> String {
    match encoding {
        policy_core::Encoding::F32 => POLICY.to_string(),
        other => format!("policy-{other}.postcard"),
    }
}
/// A flash slot image's file name: the policy file's stem, the slot and the format, e.g.
/// `policy.slot-b.hex` or `policy-int8.slot-a.bin`.
///
/// ```
/// use host_trainer::blob::export::ImageFormat;
/// use policy_core::{slot::SlotId, Encoding};
/// assert_eq!(
///     host_trainer::run::folder::image_file(Encoding::Int8, SlotId::A, ImageFormat::Bin),
///     "policy-int8.slot-a.bin"
/// );
/// ```
pub fn image_file(
    encoding: policy_core::Encoding,
    slot: policy_core::slot::SlotId,
    format: crate::blob::export::ImageFormat,
) -> String {
    let policy = policy_file(encoding);
    let stem = policy.trim_end_matches(".postcard");
    let slot = slot.to_string().to_lowercase();
    format!("{stem}.slot-{slot}.{format}")
}

/// The firmware-sim evaluation of the exported policy.
pub const EVAL: &str = "eval.json";

/// The run's validation rounds, one row each (a run with a `[validation]` section).
pub const VALIDATION: &str = "validation.csv";

/// The record of a race (`train --race K`): every racer's validation history and why the
/// winner won.
pub const RACE: &str = "race.json";

/// The folder of a race's racers, one run folder each.
pub const RACERS: &str = "racers";

/// Files that mark a folder as holding a run (a new run must not overwrite them).
const RUN_FILES: [&str; 5] = [CONFIG, CHECKPOINT, POLICY, METRICS, RACE];

/// The folder name of a run: `{task}__{algo}__{seed}`.
///
/// ```
/// assert_eq!(host_trainer::run::folder::run_name("nav-walls", "dcp", 3), "nav-walls__dcp__3");
/// ```
pub fn run_name(task: &str, algo: &str, seed: u64) -> String {
    format!("{task}__{algo}__{seed}")
}

/// The label a run's blobs carry: its run name, with the task shortened (ending in `~`) when
/// the whole would not fit the blob header's [`LABEL_CAPACITY`] bytes. Algorithm and seed are
/// always kept whole, so no seed and no task name can make a run unexportable.
///
/// ```
/// use host_trainer::run::folder::blob_label;
/// assert_eq!(blob_label("nav-walls", "dcp", 0), "nav-walls__dcp__0");
/// let long = blob_label("my-very-long-task-file-name", "ddpg", u64::MAX);
/// assert_eq!(long, "my-~__ddpg__18446744073709551615");
/// assert!(long.len() <= policy_core::blob::LABEL_CAPACITY);
/// ```
pub fn blob_label(task: &str, algo: &str, seed: u64) -> String {
    let full = run_name(task, algo, seed);
    if full.len() <= LABEL_CAPACITY {
        return full;
    }
    let tail = run_name("", algo, seed);
    // Room for the task's first characters and the `~` that marks the cut.
    let room = LABEL_CAPACITY.saturating_sub(tail.len() + 1);
    let mut cut = room.min(task.len());
    while !task.is_char_boundary(cut) {
        cut -= 1;
    }
    let label = format!("{}~{tail}", &task[..cut]);
    // An algorithm name too long to fit even alone (none exists) keeps the first bytes.
    let mut end = label.len().min(LABEL_CAPACITY);
    while !label.is_char_boundary(end) {
        end -= 1;
    }
    label[..end].to_string()
}

/// The first file in `dir` that marks it as holding a run, if any: such a folder is continued
/// with `--resume`, never started afresh.
pub fn run_file_in(dir: &Path) -> Option<&'static str> {
    RUN_FILES.iter().copied().find(|f| dir.join(f).exists())
}

/// The folder of a run's kept checkpoints (`train --keep-checkpoints`), made if missing, after
/// [`check_kept_checkpoints`].
pub fn kept_checkpoints(run: &RunDir) -> Result<PathBuf, Error> {
    check_kept_checkpoints(run.path())?;
    let kept = run.file(KEPT_CHECKPOINTS);
    fs::create_dir_all(&kept).map_err(|source| Error::Io {
        path: kept.clone(),
        source,
    })?;
    Ok(kept)
}

/// Refuses a file named `checkpoints` in the run folder `run` by name (the system would say only
/// `File exists` at the first checkpoint); `train --resume --keep-checkpoints` checks it before
/// anything is written.
pub fn check_kept_checkpoints(run: &Path) -> Result<(), Error> {
    let kept = run.join(KEPT_CHECKPOINTS);
    if kept.exists() && !kept.is_dir() {
        return Err(io_error(
            &kept,
            std::io::ErrorKind::NotADirectory,
            "not a folder: --keep-checkpoints keeps its copies in a folder of this name; move the file away",
        ));
    }
    Ok(())
}

/// Checks that `out` can be a command's output folder (`--out`): a folder, or a name not yet
/// taken inside a folder that exists. Only that last folder is ever created
/// ([`create_output_folder`]): the README's first command names `/tmp/runs`, which a fresh
/// machine does not have, while a mistyped parent (`/tmp/rnus/exp1`) is still refused rather
/// than a tree of folders made where nobody will look. Writes nothing.
pub fn check_output_folder(out: &Path) -> Result<(), Error> {
    // One look at the file system, not `is_dir` then `exists`: the racers of one race create
    // their shared `racers/` folder from several threads, and a folder made between two looks
    // read as "exists, not a folder".
    match fs::metadata(out) {
        Ok(meta) if meta.is_dir() => return Ok(()),
        Ok(_) => {
            return Err(io_error(
                out,
                std::io::ErrorKind::NotADirectory,
                "not a folder: --out names a file (give the folder the runs go in)",
            ))
        }
        Err(_) => {}
    }
    let parent = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !parent.is_dir() {
        return Err(io_error(
            out,
            std::io::ErrorKind::NotFound,
            "output folder does not exist, nor the folder that holds it (only the last folder of --out is created)",
        ));
    }
    Ok(())
}

/// Creates the output folder `out` if it is missing, after [`check_output_folder`].
///
/// ```
/// let base = std::env::temp_dir().join(format!("output-folder-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&base).unwrap();
/// host_trainer::run::folder::create_output_folder(&base.join("runs")).unwrap();
/// assert!(base.join("runs").is_dir());
/// assert!(host_trainer::run::folder::create_output_folder(&base.join("a/b")).is_err());
/// # std::fs::remove_dir_all(&base).unwrap();
/// ```
pub fn create_output_folder(out: &Path) -> Result<(), Error> {
    check_output_folder(out)?;
    match fs::create_dir(out) {
        Ok(()) => Ok(()),
        // Another process of the same command (a second part of a grid) made it first.
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && out.is_dir() => Ok(()),
        Err(source) => Err(Error::Io {
            path: out.to_path_buf(),
            source,
        }),
    }
}

/// An existing, writable run folder.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RunDir {
    path: PathBuf,
}

impl RunDir {
    /// Creates `out/name` for a new run, and `out` itself if it is missing but its parent
    /// exists ([`create_output_folder`]: a mistyped parent is an error, not a tree to create
    /// silently). A folder that already holds a run is refused, so a finished run is never
    /// overwritten; continue it with `--resume`.
    ///
    /// ```
    /// let out = std::env::temp_dir().join(format!("run-dir-doc-{}", std::process::id()));
    /// std::fs::create_dir_all(&out).unwrap();
    /// let run = host_trainer::run::folder::RunDir::create(&out, "nav-open__dcp__0").unwrap();
    /// assert!(run.path().is_dir());
    /// # std::fs::remove_dir_all(&out).unwrap();
    /// ```
    pub fn create(out: &Path, name: &str) -> Result<RunDir, Error> {
        check_output_folder(out)?;
        let path = out.join(name);
        if let Some(found) = run_file_in(&path) {
            return Err(Error::RunExists {
                path,
                found: found.to_string(),
            });
        }
        create_output_folder(out)?;
        fs::create_dir_all(&path).map_err(|source| Error::Io {
            path: path.clone(),
            source,
        })?;
        probe_writable(&path)?;
        Ok(RunDir { path })
    }

    /// Opens an existing run folder (for `--resume` and `export`) and removes temporary files
    /// that a killed process left in it.
    pub fn open(path: &Path) -> Result<RunDir, Error> {
        if !path.is_dir() {
            return Err(io_error(
                path,
                std::io::ErrorKind::NotFound,
                "run folder does not exist",
            ));
        }
        files::remove_stale_temps(path, None).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Ok(RunDir {
            path: path.to_path_buf(),
        })
    }

    /// The folder.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The path of a file in the folder.
    pub fn file(&self, name: &str) -> PathBuf {
        self.path.join(name)
    }

    /// Writes a file of the run atomically.
    pub fn write(&self, name: &str, bytes: &[u8]) -> Result<(), Error> {
        let path = self.file(name);
        files::write_atomic(&path, bytes).map_err(|source| Error::Io { path, source })
    }
}

fn io_error(path: &Path, kind: std::io::ErrorKind, message: &'static str) -> Error {
    Error::Io {
        path: path.to_path_buf(),
        source: std::io::Error::new(kind, message),
    }
}

/// Fails early, with the folder in the message, if files cannot be created in `dir`: better
/// than discovering it after an hour of training.
fn probe_writable(dir: &Path) -> Result<(), Error> {
    files::check_output(&dir.join(CHECKPOINT)).map_err(|source| Error::Io {
        path: dir.to_path_buf(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("run-dir-{tag}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).expect("scratch dir");
        dir
    }

    #[test]
    fn runs_created_at_once_from_several_threads_in_a_missing_folder_all_succeed() {
        // A race's racers create their runs in one `racers/` folder from their own threads;
        // whichever makes the folder, none may read it as "not a folder".
        let dir = scratch("threads");
        for round in 0..200 {
            let out = dir.join(format!("racers-{round}"));
            let start = std::sync::Barrier::new(8);
            let made: Vec<Result<RunDir, Error>> = std::thread::scope(|s| {
                let handles: Vec<_> = (0..8)
                    .map(|i| {
                        let (out, start) = (&out, &start);
                        s.spawn(move || {
                            start.wait();
                            RunDir::create(out, &format!("x__y__{i}"))
                        })
                    })
                    .collect();
                handles
                    .into_iter()
                    .map(|h| h.join().expect("thread"))
                    .collect()
            });
            for (i, r) in made.iter().enumerate() {
                assert!(r.is_ok(), "round {round}, run {i}: {:?}", r.as_ref().err());
            }
        }
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn output_folder_missing_with_its_parent_is_an_error_and_creates_nothing() {
        let dir = scratch("missing");
        let out = dir.join("no-such-folder").join("deeper");
        let err = RunDir::create(&out, "x__y__0").expect_err("must fail");
        assert!(err.to_string().contains("does not exist"), "{err}");
        assert!(!dir.join("no-such-folder").exists());
        fs::remove_dir_all(&dir).expect("cleanup");
    }

    /// Regression: `train --out DIR` over a finished run silently
    /// overwrote its checkpoint and metrics.
    #[test]
    fn a_folder_holding_a_run_is_not_reused() {
        let dir = scratch("exists");
        let run = RunDir::create(&dir, "x__y__0").expect("first");
        run.write(CHECKPOINT, b"state").expect("write");
        let err = RunDir::create(&dir, "x__y__0").expect_err("must refuse");
        assert!(err.to_string().contains("--resume"), "{err}");
        assert_eq!(fs::read(run.file(CHECKPOINT)).expect("kept"), b"state");
        fs::remove_dir_all(&dir).expect("cleanup");
    }

    /// Regression: a long task name or a large seed made the label longer
    /// than the blob format allows, and the run could never be exported.
    #[test]
    fn labels_always_fit_the_blob_header() {
        for task in [
            "",
            "t",
            "nav-walls",
            "a-task-file-name-of-forty-characters-xx",
            "äöü-éèê-ñ",
        ] {
            for algo in ["dcp", "ddpg"] {
                for seed in [0, 7, 123_456_789, u64::MAX] {
                    let label = blob_label(task, algo, seed);
                    assert!(label.len() <= LABEL_CAPACITY, "{label}");
                    assert!(label.ends_with(&format!("__{algo}__{seed}")), "{label}");
                }
            }
        }
    }
}
