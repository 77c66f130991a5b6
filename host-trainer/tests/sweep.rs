//! `host-trainer sweep`: parallel runs, their summary, and re-running a sweep after a kill, a
//! failure or Ctrl-C. Every run is the smoke config (a few episodes, five test starts).

use std::path::{Path, PathBuf};
use std::process::{Child, Output, Stdio};
use std::time::{Duration, Instant, SystemTime};

use host_trainer::run::checkpoint::Checkpoint;
use host_trainer::run::folder;
use host_trainer::sweep::{report, supervise};

use crate::support::{
    assert_ok, assert_one_line_error, command, entries, s, scratch, smoke_config_file,
};

/// Runs `sweep --config CONFIG --out OUT --quiet` plus `extra`, with `env` set.
fn run_sweep(config: &Path, out: &Path, extra: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = command(&["sweep", "--config", s(config), "--out", s(out), "--quiet"]);
    c.args(extra);
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("the sweep runs")
}

/// Runs `train` alone on the same config and seed, into `out`; returns the run folder.
fn train_alone(config: &Path, out: &Path, seed: u64) -> PathBuf {
    std::fs::create_dir_all(out).expect("dir");
    let seed = seed.to_string();
    let args = [
        "train",
        "--config",
        s(config),
        "--seed",
        &seed,
        "--out",
        s(out),
    ];
    assert_ok(&command(&args).arg("--quiet").output().expect("runs"));
    out.join(format!("nav-walls__dcp__{seed}"))
}

fn assert_same_blobs(a: &Path, b: &Path) {
    for file in [folder::POLICY, folder::CRITIC] {
        let (x, y) = (std::fs::read(a.join(file)), std::fs::read(b.join(file)));
        assert_eq!(x.expect("blob a"), y.expect("blob b"), "{file} differs");
    }
}

/// The run rows of sweep.json, as (seed, status).
fn statuses(out: &Path) -> Vec<(u64, String)> {
    let text = std::fs::read_to_string(out.join(report::SUMMARY_JSON)).expect("sweep.json");
    let doc: serde_json::Value = serde_json::from_str(&text).expect("json");
    let runs = doc["runs"].as_array().expect("runs");
    runs.iter()
        .map(|r| {
            let seed = r["seed"].as_u64().expect("seed");
            (seed, r["status"].as_str().expect("status").to_string())
        })
        .collect()
}

fn status_pairs(pairs: &[(u64, &str)]) -> Vec<(u64, String)> {
    pairs.iter().map(|&(k, v)| (k, v.to_string())).collect()
}

fn modified(path: &Path) -> SystemTime {
    std::fs::metadata(path)
        .and_then(|m| m.modified())
        .expect("mtime")
}

#[test]
fn two_seeds_in_parallel_finish_summarise_and_match_train_alone() {
    let base = scratch("sweep-two");
    let config = smoke_config_file(&base, 3);
    let out = base.join("out");
    std::fs::create_dir_all(&out).expect("dir");
    let result = run_sweep(&config, &out, &["--seeds", "0-1", "--jobs", "2"], &[]);
    assert_ok(&result);
    let stdout = String::from_utf8_lossy(&result.stdout);
    let md = std::fs::read_to_string(out.join(report::SUMMARY_MD)).expect("sweep.md");
    assert_eq!(stdout, md, "the summary printed is the one written");
    for seed in [0, 1] {
        assert!(
            md.contains(&format!("| nav-walls | dcp | {seed} | finished |")),
            "{md}"
        );
    }
    // The mean row of the two seeds, with an interval (two values, one degree of freedom).
    let mean_row = md
        .lines()
        .find(|l| l.starts_with("| nav-walls | dcp | 2 |"))
        .unwrap_or_else(|| panic!("no mean row:\n{md}"));
    assert!(
        mean_row.contains(" [") && !mean_row.contains("(1 seed)"),
        "{mean_row}"
    );
    assert_eq!(
        statuses(&out),
        status_pairs(&[(0, "finished"), (1, "finished")])
    );
    // Three episodes teach nothing: each `train` child judged its blob, found it failing the gate
    // and exited 1, which is a finished run (its eval.json written), not a failed one.
    let text = std::fs::read_to_string(out.join(report::SUMMARY_JSON)).expect("sweep.json");
    let doc: serde_json::Value = serde_json::from_str(&text).expect("json");
    for run in doc["runs"].as_array().expect("runs") {
        assert_eq!(run["exit_code"], 1, "{run}");
    }
    // Two runs at once share the cores: each child got half of them (at least one thread).
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let log = out.join("sweep-logs").join("nav-walls__dcp__0.log");
    let log = std::fs::read_to_string(log).expect("log");
    let threads = format!("--threads {} ", (cores / 2).max(1));
    assert!(log.contains(&threads), "{threads}in {log}");
    // Determinism across process parallelism: each blob is the one `train` makes alone.
    for seed in [0, 1] {
        let alone = train_alone(&config, &base.join("alone"), seed);
        assert_same_blobs(&alone, &out.join(format!("nav-walls__dcp__{seed}")));
    }
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// A child killed mid-run (SIGKILL at a fixed episode, the crash test's switch) is recorded
/// as failed with its signal; the next sweep skips the finished run untouched and continues
/// the killed one from its checkpoint to the blob `train` makes alone.
#[test]
fn a_killed_run_is_recorded_failed_and_the_next_sweep_continues_it() {
    let base = scratch("sweep-killed-run");
    let config = smoke_config_file(&base, 5);
    let out = base.join("out");
    std::fs::create_dir_all(&out).expect("dir");
    assert_ok(&run_sweep(&config, &out, &["--seeds", "0"], &[]));
    let finished = out.join("nav-walls__dcp__0");
    let (policy, eval) = (finished.join(folder::POLICY), finished.join(folder::EVAL));
    let before = (modified(&policy), std::fs::read(&eval).expect("eval"));

    let killed = run_sweep(
        &config,
        &out,
        &["--seeds", "0-1"],
        &[("HOST_TRAINER_CRASH_AT", "episode:3")],
    );
    assert_eq!(killed.status.code(), Some(1));
    assert_eq!(
        statuses(&out),
        status_pairs(&[(0, "skipped"), (1, "failed")])
    );
    let md = std::fs::read_to_string(out.join(report::SUMMARY_MD)).expect("sweep.md");
    assert!(
        md.contains("| 1 | failed |") && md.contains("signal 9"),
        "{md}"
    );

    let again = run_sweep(&config, &out, &["--seeds", "0-1"], &[]);
    assert_ok(&again);
    assert_eq!(
        statuses(&out),
        status_pairs(&[(0, "skipped"), (1, "finished")])
    );
    let after = (modified(&policy), std::fs::read(&eval).expect("eval"));
    assert_eq!(before, after, "a skipped run is not touched");
    let log = out.join(supervise::LOGS).join("nav-walls__dcp__1.log");
    let log = std::fs::read_to_string(log).expect("log");
    assert!(
        log.contains("train --resume"),
        "continued, not restarted:\n{log}"
    );
    let alone = train_alone(&config, &base.join("alone"), 1);
    assert_same_blobs(&alone, &out.join("nav-walls__dcp__1"));
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// Kills its process group (the sweep and its children) with SIGKILL when dropped, so a failed
/// test leaves no training behind.
struct Group(Option<Child>);

impl Group {
    fn spawn(mut c: std::process::Command) -> Group {
        use std::os::unix::process::CommandExt;
        let child = c
            .process_group(0)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn");
        Group(Some(child))
    }
    fn pid(&self) -> String {
        self.0.as_ref().map_or(0, Child::id).to_string()
    }
    fn kill(&mut self, signal: &str) {
        let group = format!("-{}", self.pid());
        let sent = std::process::Command::new("kill")
            .args([signal, "--", &group])
            .status()
            .expect("kill");
        assert!(sent.success());
    }
    fn wait(&mut self) -> Output {
        let child = self.0.take().expect("running");
        child.wait_with_output().expect("wait")
    }
}

impl Drop for Group {
    fn drop(&mut self) {
        if self.0.is_some() {
            self.kill("-KILL");
            let _ = self.wait();
        }
    }
}

fn wait_for(what: &str, done: impl Fn() -> bool) {
    let started = Instant::now();
    while !done() {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "{what} never happened"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// The whole sweep (parent and children) killed with SIGKILL once one run has finished: the
/// same command again skips the finished run and completes the other.
#[test]
fn a_killed_sweep_is_continued_by_the_same_command() {
    let base = scratch("sweep-killed");
    let config = smoke_config_file(&base, 6);
    let out = base.join("out");
    std::fs::create_dir_all(&out).expect("dir");
    let args = ["--seeds", "0-1", "--jobs", "1"];
    let mut sweep = Group::spawn({
        let mut c = command(&["sweep", "--config", s(&config), "--out", s(&out), "--quiet"]);
        c.args(args);
        c
    });
    let (first, second) = (out.join("nav-walls__dcp__0"), out.join("nav-walls__dcp__1"));
    wait_for("the first run's end", || first.join(folder::EVAL).exists());
    sweep.kill("-KILL");
    let killed = sweep.wait();
    assert!(!killed.status.success());
    let before = std::fs::read(first.join(folder::POLICY)).expect("policy");
    let mtime = modified(&first.join(folder::POLICY));
    // The second run started within one poll of the first's end and trains for a while; should
    // a slow machine have let it finish before the kill, it is skipped too.
    let second_done = second.join(folder::EVAL).exists();

    let again = run_sweep(&config, &out, &args, &[]);
    assert_ok(&again);
    let second_status = if second_done { "skipped" } else { "finished" };
    assert_eq!(
        statuses(&out),
        status_pairs(&[(0, "skipped"), (1, second_status)])
    );
    assert_eq!(
        std::fs::read(first.join(folder::POLICY)).expect("policy"),
        before
    );
    assert_eq!(modified(&first.join(folder::POLICY)), mtime);
    let alone = train_alone(&config, &base.join("alone"), 1);
    assert_same_blobs(&alone, &second);
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// A run whose process fails is a failed row with its exit code and error line, the others
/// finish, and the sweep exits 1 after writing the summary. Here the failure is a corrupt
/// checkpoint in an unfinished run folder, found only when the child loads it.
#[test]
fn a_failed_run_is_recorded_and_the_others_finish() {
    let base = scratch("sweep-failed");
    let config = smoke_config_file(&base, 3);
    let out = base.join("out");
    let broken = train_alone(&config, &out, 1);
    std::fs::remove_file(broken.join(folder::EVAL)).expect("unfinish it");
    let checkpoint = broken.join(folder::CHECKPOINT);
    let mut bytes = std::fs::read(&checkpoint).expect("checkpoint");
    let middle = bytes.len() / 2;
    bytes[middle] ^= 0x10;
    std::fs::write(&checkpoint, bytes).expect("corrupt it");

    let result = run_sweep(&config, &out, &["--seeds", "0-1", "--jobs", "2"], &[]);
    assert_eq!(result.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(stderr.contains("1 of 2 runs failed"), "{stderr}");
    assert_eq!(
        statuses(&out),
        status_pairs(&[(0, "finished"), (1, "failed")])
    );
    let md = std::fs::read_to_string(out.join(report::SUMMARY_MD)).expect("sweep.md");
    let row = md
        .lines()
        .find(|l| l.starts_with("| nav-walls | dcp | 1 | failed |"))
        .unwrap_or_else(|| panic!("no failed row:\n{md}"));
    assert!(row.contains("exit 2: host-trainer: checkpoint"), "{row}");
    // The mean row covers the finished seed only: n = 1, no interval.
    assert!(
        md.contains("| nav-walls | dcp | 1 | ") && md.contains("(1 seed)"),
        "{md}"
    );
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// Ctrl-C, as a terminal sends it (to the whole process group: the sweep and its children) and
/// as `kill -INT PID` sends it (to the sweep alone, which forwards it): either way the runs
/// checkpoint at the end of their episode (a child takes the terminal's signal and the
/// forwarded one as one press, not as the second press that exits at once), and the sweep
/// exits 130 saying how to continue.
#[test]
fn ctrl_c_stops_the_runs_at_a_checkpoint_and_says_how_to_continue() {
    for (case, to_group) in [("group", true), ("parent", false)] {
        let base = scratch(&format!("sweep-ctrl-c-{case}"));
        let config = smoke_config_file(&base, 100_000);
        let out = base.join("out");
        std::fs::create_dir_all(&out).expect("dir");
        let mut sweep = Group::spawn({
            let mut c = command(&["sweep", "--config", s(&config), "--out", s(&out), "--quiet"]);
            c.args(["--seeds", "0-1", "--jobs", "2"]);
            c
        });
        let runs = [0, 1].map(|seed| out.join(format!("nav-walls__dcp__{seed}")));
        wait_for("both runs' start", || {
            runs.iter().all(|r| r.join(folder::METRICS).exists())
        });
        if to_group {
            sweep.kill("-INT");
        } else {
            let sent = std::process::Command::new("kill")
                .args(["-INT", &sweep.pid()])
                .status()
                .expect("kill");
            assert!(sent.success());
        }
        let result = sweep.wait();
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(130), "{case}: {stderr}");
        assert!(stderr.contains("Re-run the same sweep command"), "{stderr}");
        for run in &runs {
            let kept = Checkpoint::load(&run.join(folder::CHECKPOINT)).expect("checkpoint");
            assert!(
                kept.episode >= 1,
                "{}: the episodes done are kept",
                run.display()
            );
            let name = run.file_name().expect("name").to_string_lossy();
            let log = out.join(supervise::LOGS).join(format!("{name}.log"));
            let log = std::fs::read_to_string(log).expect("log");
            assert!(log.contains("checkpoint written"), "{case}: {log}");
            assert!(
                !log.contains("the last checkpoint is kept"),
                "one press, not two: {log}"
            );
        }
        std::fs::remove_dir_all(&base).expect("cleanup");
    }
}

#[test]
fn bad_arguments_are_one_line_and_create_nothing() {
    let base = scratch("sweep-bad-args");
    let config = smoke_config_file(&base, 3);
    let bad_config = base.join("bad.toml");
    std::fs::write(&bad_config, "episodes = 3\nlearning_rat = 0.1\n").expect("write");
    let out = base.join("out");
    std::fs::create_dir_all(&out).expect("dir");
    let missing = base.join("no-such-folder").join("deeper");
    let (c, o) = (s(&config), s(&out));
    for (args, needle, code) in [
        (vec!["--config", c, "--seeds", "4-2", "--out", o], "4-2", 2),
        (vec!["--config", c, "--seeds", "x", "--out", o], "x", 2),
        (
            vec!["--config", c, "--seeds", "0-1", "--jobs", "0", "--out", o],
            "--jobs",
            2,
        ),
        (
            vec!["--config", c, "--seeds", "0", "--out", s(&missing)],
            "does not exist",
            2,
        ),
        (
            vec!["--config", s(&bad_config), "--seeds", "0", "--out", o],
            "learning_rat",
            2,
        ),
        (
            vec!["--config", "/no/such.toml", "--seeds", "0", "--out", o],
            "/no/such.toml",
            2,
        ),
        (
            vec!["--config", c, "--seeds", "0", "--algo", "sarsa", "--out", o],
            "sarsa",
            2,
        ),
        (
            vec![
                "--config", c, "--seeds", "0", "--task", "nav-maze", "--out", o,
            ],
            "nav-maze",
            2,
        ),
    ] {
        let mut full = vec!["sweep"];
        full.extend(args);
        let result = command(&full).output().expect("runs");
        assert_one_line_error(&result, &[needle]);
        assert_eq!(result.status.code(), Some(code), "{full:?}");
        assert!(
            entries(&out).is_empty(),
            "{full:?} left {:?}",
            entries(&out)
        );
    }
    assert!(!missing.exists());
    std::fs::remove_dir_all(&base).expect("cleanup");
}

#[test]
fn a_run_folder_of_other_settings_is_refused_before_anything_starts() {
    let base = scratch("sweep-differs");
    let three = smoke_config_file(&base, 3);
    let four = smoke_config_file(&base, 4);
    let out = base.join("out");
    let existing = train_alone(&three, &out, 0);
    let result = run_sweep(&four, &out, &["--seeds", "0-1"], &[]);
    assert_one_line_error(
        &result,
        &[s(&existing), "episodes = 3 recorded, 4 in the sweep"],
    );
    // The sweep's folder lock is all it adds.
    assert_eq!(
        entries(&out),
        [".host-trainer.lock", "nav-walls__dcp__0"],
        "nothing started"
    );
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// The process id written in a folder's lock file, once its holder has written it.
fn lock_holder(dir: &Path) -> Option<String> {
    let text = std::fs::read_to_string(dir.join(host_trainer::run::lock::LOCK)).ok()?;
    let pid = text.trim();
    (!pid.is_empty()).then(|| pid.to_string())
}

/// Two sweeps of one `--out` started together: the second is refused with one line naming the
/// first's process, touches nothing, and the first finishes every run.
#[test]
fn a_second_sweep_of_the_same_folder_is_refused_and_the_first_finishes() {
    let base = scratch("sweep-twice");
    let config = smoke_config_file(&base, 12);
    let out = base.join("out");
    std::fs::create_dir_all(&out).expect("dir");
    let args = ["--seeds", "0-1", "--jobs", "1"];
    let mut first = Group::spawn({
        let mut c = command(&["sweep", "--config", s(&config), "--out", s(&out), "--quiet"]);
        c.args(args);
        c
    });
    wait_for("the first sweep's lock", || lock_holder(&out).is_some());
    let holder = lock_holder(&out).expect("holder");
    assert_eq!(holder, first.pid());
    let second = run_sweep(&config, &out, &args, &[]);
    assert_one_line_error(
        &second,
        &[s(&out), &format!("host-trainer process {holder}")],
    );
    let first = first.wait();
    assert_ok(&first);
    assert_eq!(
        statuses(&out),
        status_pairs(&[(0, "finished"), (1, "finished")])
    );
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// A sweep killed with SIGKILL alone (not its process group) takes its running child with it:
/// the child sees its standard input close, writes a checkpoint and exits, releasing its run
/// folder, and the same sweep command then continues the run.
#[test]
fn the_runs_of_a_killed_sweep_stop_with_it() {
    let base = scratch("sweep-orphans");
    let config = smoke_config_file(&base, 60);
    let out = base.join("out");
    std::fs::create_dir_all(&out).expect("dir");
    let args = ["--seeds", "0", "--jobs", "1"];
    let mut sweep = Group::spawn({
        let mut c = command(&["sweep", "--config", s(&config), "--out", s(&out), "--quiet"]);
        c.args(args);
        c
    });
    let run = out.join("nav-walls__dcp__0");
    wait_for("the run's first checkpoint", || {
        run.join(folder::CHECKPOINT).exists() && lock_holder(&run).is_some()
    });
    let sent = std::process::Command::new("kill")
        .args(["-KILL", &sweep.pid()])
        .status()
        .expect("kill");
    assert!(sent.success());
    let _ = sweep.wait();
    // The child released its run folder: it exited (the lock goes with its last descriptor).
    wait_for("the orphaned run to stop", || {
        host_trainer::run::lock::acquire(&run).is_ok()
    });
    let log = std::fs::read_to_string(out.join(supervise::LOGS).join("nav-walls__dcp__0.log"))
        .expect("log");
    assert!(
        log.contains("the sweep that started this run has gone"),
        "{log}"
    );
    assert!(
        !run.join(folder::EVAL).exists(),
        "the run stopped before its end"
    );
    assert_ok(&run_sweep(&config, &out, &args, &[]));
    assert_eq!(statuses(&out), status_pairs(&[(0, "finished")]));
    std::fs::remove_dir_all(&base).expect("cleanup");
}

#[test]
fn task_runs_every_run_of_the_sweep_on_that_scenario() {
    let base = scratch("sweep-task");
    let config = smoke_config_file(&base, 3);
    let out = base.join("out");
    std::fs::create_dir_all(&out).expect("dir");
    let layout = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../experiments/margin/layouts/rings-2-seed11.toml"
    );
    assert_ok(&run_sweep(
        &config,
        &out,
        &["--seeds", "0-1", "--task", layout],
        &[],
    ));
    for seed in 0..2 {
        let run = out.join(format!("rings-2-seed11__dcp__{seed}"));
        let recorded = std::fs::read_to_string(run.join(folder::CONFIG)).expect("config");
        assert!(recorded.contains("rings-2-seed11.toml"), "{recorded}");
        assert!(run.join(folder::POLICY).exists());
    }
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// `sweep` had no `--episodes`: a short sweep needed a config file of its own. It overrides the
/// config's budget, and each run records it in its config.toml (so the next sweep with the same
/// flag skips the finished run).
#[test]
fn sweep_episodes_overrides_the_configs_budget_and_is_recorded() {
    let base = scratch("sweep-episodes");
    let config = smoke_config_file(&base, 3);
    let out = base.join("out");
    let sweep = run_sweep(&config, &out, &["--seeds", "0", "--episodes", "2"], &[]);
    assert_ok(&sweep);
    let run = out.join("nav-walls__dcp__0");
    let recorded = std::fs::read_to_string(run.join(folder::CONFIG)).expect("config");
    assert!(recorded.contains("episodes = 2\n"), "{recorded}");
    let checkpoint = Checkpoint::load(&run.join(folder::CHECKPOINT)).expect("checkpoint");
    assert_eq!(checkpoint.episode, 2);
    let again = run_sweep(&config, &out, &["--seeds", "0", "--episodes", "2"], &[]);
    assert_ok(&again);
    assert_eq!(statuses(&out), status_pairs(&[(0, "skipped")]));
    let out_of_range = run_sweep(&config, &out, &["--seeds", "0", "--episodes", "0"], &[]);
    assert_one_line_error(&out_of_range, &["episodes"]);
    std::fs::remove_dir_all(&base).expect("cleanup");
}
