//! Helpers shared by the integration tests.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use host_trainer::algorithms::Algo;
use host_trainer::run::config::TrainConfig;

/// Runs the `host-trainer` binary to the end.
pub fn host_trainer(args: &[&str]) -> Output {
    command(args).output().expect("the binary runs")
}

/// A `host-trainer` command, to add a working folder or environment before running it.
///
/// A `train` that names no race and continues none is one run (`--race 1`): `train` races one
/// seed per core by default, and these tests are about a run's behaviour, on any machine; the
/// race has tests of its own (`race.rs`).
pub fn command(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_host-trainer"));
    c.args(args);
    let named = |flag: &str| args.contains(&flag);
    if args.first() == Some(&"train") && !named("--race") && !named("--resume") && !named("--help")
    {
        c.args(["--race", "1"]);
    }
    c
}

/// firmware-sim's binary, which `cargo test --workspace` builds beside this test's.
pub fn firmware_sim() -> PathBuf {
    let exe = std::env::current_exe().expect("test binary path");
    // target/<profile>/deps/integration-HASH -> target/<profile>/firmware-sim
    let path = exe
        .parent()
        .and_then(|deps| deps.parent())
        .map(|profile| profile.join("firmware-sim"))
        .expect("target folder");
    assert!(
        path.is_file(),
        "{} is missing: build it with `cargo build -p firmware-sim` (cargo test --workspace does)",
        path.display()
    );
    path
}

/// A fresh, empty folder for one test.
pub fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("host-trainer-it-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}

/// Asserts an error: exit 2 (1 is the gate's FAIL, never an error) and exactly one line on
/// stderr, mentioning every `needle`.
pub fn assert_one_line_error(out: &Output, needles: &[&str]) -> String {
    assert_eq!(
        out.status.code(),
        Some(2),
        "an error exits 2; stderr: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_one_line(out, needles)
}

/// Asserts a command that did not succeed printed exactly one line on stderr, mentioning every
/// `needle`, whatever its non-zero exit (`reproduce --merge` with runs missing exits 1).
pub fn assert_one_line(out: &Output, needles: &[&str]) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!out.status.success(), "must fail; stderr: {stderr}");
    assert_eq!(
        stderr.trim_end().lines().count(),
        1,
        "one line only:\n{stderr}"
    );
    assert!(stderr.starts_with("host-trainer: "), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    for n in needles {
        assert!(stderr.contains(n), "stderr should mention {n:?}: {stderr}");
    }
    stderr
}

/// Asserts a command judged a blob and ended with the gate's verdict: exit 0 and `gate PASS`,
/// or exit 1 and `gate FAIL` (the runs of a few episodes these tests train fail it).
pub fn assert_judged(out: &Output) {
    let stdout = String::from_utf8_lossy(&out.stdout);
    let verdict = match out.status.code() {
        Some(0) => "gate PASS",
        Some(1) => "gate FAIL (",
        _ => panic!(
            "expected exit 0 or 1 with a verdict, got {:?}; stderr: {}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        ),
    };
    assert!(
        stdout.contains(verdict),
        "exit {:?} but no {verdict} in: {stdout}",
        out.status.code()
    );
}

/// Asserts a command did its work, showing its stderr if not: exit 0, or, for a command that
/// judges a blob (`train`, `eval`), exit 1 with the gate's `FAIL` verdict ending its test line
/// (the few-episode runs these tests train fail the gate; an error is exit 2).
pub fn assert_ok(out: &Output) {
    let stdout = String::from_utf8_lossy(&out.stdout);
    let judged_fail = out.status.code() == Some(1)
        && stdout
            .lines()
            .any(|l| l.contains(" test starts: ") && l.contains("  gate FAIL ("));
    assert!(
        out.status.success() || judged_fail,
        "exit {:?}; stderr: {}",
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The names in a folder, sorted.
pub fn entries(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Temporary files (`.NAME.tmp-...`) anywhere in a folder.
pub fn temporaries(dir: &Path) -> Vec<String> {
    entries(dir)
        .into_iter()
        .filter(|n| n.contains(".tmp"))
        .collect()
}

/// Writes the smoke config (tiny network, tiny batch) with `episodes` episodes to `dir` and
/// returns its path.
pub fn smoke_config_file(dir: &Path, episodes: usize) -> PathBuf {
    smoke_config_file_of(dir, Algo::Dcp, episodes)
}

/// [`smoke_config_file`] for `algo` (a config holds only the settings its algorithm reads).
pub fn smoke_config_file_of(dir: &Path, algo: Algo, episodes: usize) -> PathBuf {
    let mut config = TrainConfig::smoke(algo, 3);
    config.episodes = episodes;
    let path = dir.join(format!("smoke-{algo}-{episodes}.toml"));
    std::fs::write(&path, config.to_toml()).expect("config file");
    path
}

/// Runs `train` on the smoke config with `episodes` episodes, output into `base`, plus `extra`
/// flags (which override the config).
pub fn train_smoke(base: &Path, episodes: usize, extra: &[&str]) -> Output {
    let config = smoke_config_file(base, episodes);
    let mut args = vec!["train", "--config", s(&config), "--out", s(base), "--quiet"];
    args.extend_from_slice(extra);
    host_trainer(&args)
}

/// A path as the `&str` the CLI takes.
pub fn s(path: &Path) -> &str {
    path.to_str().expect("utf-8 path")
}

/// Trains `trainer` to the end of its budget in a new run folder under `out`.
pub fn train_trainer(
    mut trainer: host_trainer::run::trainer::Trainer,
    out: &Path,
) -> (
    host_trainer::run::trainer::Trainer,
    host_trainer::run::folder::RunDir,
) {
    let run = host_trainer::run::folder::RunDir::create(out, &trainer.config.run_name())
        .expect("run dir");
    host_trainer::run::trainer::run(&mut trainer, &run, &mut |_, _| {
        std::ops::ControlFlow::Continue(())
    })
    .expect("training");
    (trainer, run)
}
