//! A trained run's folder as the closed-loop studies read it: its name, its files, its plant,
//! the group (task and algorithm) its name puts it in, and the test protocol they run its blobs
//! through.

use std::path::Path;

use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::EvalConfig;
use host_trainer::run::folder;

/// The folder's name (`nav-walls__dcp__0`), or an error naming the path.
///
/// ```
/// use std::path::Path;
/// assert_eq!(studies::run_folder::name(Path::new("runs/nav-walls__dcp__0")).unwrap(), "nav-walls__dcp__0");
/// assert!(studies::run_folder::name(Path::new("/")).is_err());
/// ```
pub fn name(dir: &Path) -> Result<String, String> {
    dir.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .ok_or_else(|| format!("{}: not a run folder", dir.display()))
}

/// The bytes of `file` in the folder, or an error naming the file.
///
/// ```
/// use std::path::Path;
/// let e = studies::run_folder::read(Path::new("no-such-run"), "policy.postcard").unwrap_err();
/// assert!(e.starts_with("no-such-run/policy.postcard: "));
/// ```
pub fn read(dir: &Path, file: &str) -> Result<Vec<u8>, String> {
    std::fs::read(dir.join(file)).map_err(|e| format!("{}: {e}", dir.join(file).display()))
}

/// The plant the run trained on, as its folder recorded it.
///
/// ```
/// use std::path::Path;
/// assert!(studies::run_folder::scenario(Path::new("no-such-run")).is_err());
/// ```
pub fn scenario(dir: &Path) -> Result<Scenario, String> {
    let name = name(dir)?;
    let plant = String::from_utf8(read(dir, folder::SCENARIO)?).map_err(|e| e.to_string())?;
    Scenario::from_toml_str(&plant).map_err(|e| format!("{name}: {e}"))
}

/// The group of a run: its name without the seed (`nav-walls__dcp`), or the whole name where
/// it has no `__`.
///
/// ```
/// assert_eq!(studies::run_folder::group("nav-walls__dcp__3"), "nav-walls__dcp");
/// assert_eq!(studies::run_folder::group("mine"), "mine");
/// ```
pub fn group(name: &str) -> &str {
    name.rsplit_once("__").map_or(name, |(g, _)| g)
}

/// firmware-sim's test protocol as `host-trainer eval` runs it: 100 boundary starts, seed 0.
///
/// ```
/// let config = studies::run_folder::test_protocol();
/// assert_eq!((config.episodes, config.seed), (100, 0));
/// ```
pub fn test_protocol() -> EvalConfig {
    EvalConfig {
        episodes: 100,
        ..EvalConfig::default()
    }
}
