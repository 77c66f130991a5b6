//! A run's folder, `{task}__{algo}__{seed}`, and atomic file writes into it.
//!
//! Every file the trainer produces is written to a temporary sibling and renamed into place, so a
//! crash, a full disk or Ctrl-C never leaves a half-written checkpoint or blob behind: a reader
//! sees either the previous complete file or the new complete file.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::Error;

/// The configuration file of a run.
pub const CONFIG: &str = "config.toml";
/// Per-episode training metrics.
pub const METRICS: &str = "metrics.csv";
/// The learning-curve plot.
pub const CURVE: &str = "learning-curve.svg";
/// The resumable training state.
pub const CHECKPOINT: &str = "checkpoint.postcard";
/// The exported actor blob (what gets flashed).
pub const POLICY: &str = "policy.postcard";
/// The exported critic blob (for on-device compare steps).
pub const CRITIC: &str = "critic.postcard";
/// The firmware-sim evaluation of the exported policy.
pub const EVAL: &str = "eval.json";

/// The folder name of a run: `{task}__{algo}__{seed}`.
///
/// ```
/// assert_eq!(host_trainer::run_dir::run_name("nav-walls", "dcp", 3), "nav-walls__dcp__3");
/// ```
pub fn run_name(task: &str, algo: &str, seed: u64) -> String {
    format!("{task}__{algo}__{seed}")
}

/// An existing, writable run folder.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RunDir {
    path: PathBuf,
}

impl RunDir {
    /// Creates (or reuses) `out/name`. `out` itself must already exist: a mistyped output folder
    /// is an error, not something to create silently.
    ///
    /// ```
    /// let out = std::env::temp_dir().join(format!("run-dir-doc-{}", std::process::id()));
    /// std::fs::create_dir_all(&out).unwrap();
    /// let run = host_trainer::run_dir::RunDir::create(&out, "nav-open__dcp__0").unwrap();
    /// assert!(run.path().is_dir());
    /// # std::fs::remove_dir_all(&out).unwrap();
    /// ```
    pub fn create(out: &Path, name: &str) -> Result<RunDir, Error> {
        if !out.is_dir() {
            return Err(Error::Io {
                path: out.to_path_buf(),
                source: std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    "output folder does not exist (create it first)",
                ),
            });
        }
        let path = out.join(name);
        fs::create_dir_all(&path).map_err(|source| Error::Io {
            path: path.clone(),
            source,
        })?;
        probe_writable(&path)?;
        Ok(RunDir { path })
    }

    /// Opens an existing run folder (for `--resume` and `export`).
    pub fn open(path: &Path) -> Result<RunDir, Error> {
        if !path.is_dir() {
            return Err(Error::Io {
                path: path.to_path_buf(),
                source: std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    "run folder does not exist",
                ),
            });
        }
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
        write_atomic(&self.file(name), bytes)
    }
}

/// Fails early, with the folder in the message, if files cannot be created in `dir`: better
/// than discovering it after an hour of training.
fn probe_writable(dir: &Path) -> Result<(), Error> {
    let probe = dir.join(format!(".write-probe-{}", std::process::id()));
    fs::write(&probe, b"").map_err(|source| Error::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    fs::remove_file(&probe).map_err(|source| Error::Io {
        path: probe,
        source,
    })
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so the
/// file is never seen half-written. On any failure the temporary file is removed.
///
/// ```
/// let path = std::env::temp_dir().join(format!("atomic-doc-{}.txt", std::process::id()));
/// host_trainer::run_dir::write_atomic(&path, b"hello").unwrap();
/// assert_eq!(std::fs::read(&path).unwrap(), b"hello");
/// # std::fs::remove_file(&path).unwrap();
/// ```
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    let tmp = temp_sibling(path);
    let result = write_and_sync(&tmp, bytes).and_then(|()| fs::rename(&tmp, path));
    result.map_err(|source| {
        // Best effort: the temporary file may not even exist if creating it failed.
        let _ = fs::remove_file(&tmp);
        Error::Io {
            path: path.to_path_buf(),
            source,
        }
    })
}

fn temp_sibling(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp-{}", std::process::id()))
}

fn write_and_sync(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut file = fs::File::create(path)?;
    file.write_all(bytes)?;
    file.sync_all()
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
    fn atomic_write_replaces_and_leaves_no_temp_file() {
        let dir = scratch("replace");
        let path = dir.join("a.bin");
        write_atomic(&path, b"one").expect("first write");
        write_atomic(&path, b"two").expect("second write");
        assert_eq!(fs::read(&path).expect("read"), b"two");
        let names: Vec<_> = fs::read_dir(&dir)
            .expect("list")
            .map(|e| e.expect("entry").file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("a.bin")]);
        fs::remove_dir_all(&dir).expect("cleanup");
    }

    #[test]
    fn missing_output_folder_is_an_error_and_creates_nothing() {
        let dir = scratch("missing");
        let out = dir.join("no-such-folder");
        let err = RunDir::create(&out, "x__y__0").expect_err("must fail");
        assert!(err.to_string().contains("does not exist"), "{err}");
        assert!(!out.exists());
        fs::remove_dir_all(&dir).expect("cleanup");
    }

    #[test]
    fn failed_write_keeps_the_old_file() {
        let dir = scratch("failed");
        let path = dir.join("keep.bin");
        write_atomic(&path, b"old").expect("write");
        // Writing into a folder that does not exist fails before anything is renamed.
        let bad = dir.join("missing").join("keep.bin");
        assert!(write_atomic(&bad, b"new").is_err());
        assert_eq!(fs::read(&path).expect("read"), b"old");
        fs::remove_dir_all(&dir).expect("cleanup");
    }
}
