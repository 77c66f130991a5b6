//! Crash safety: a training process killed with SIGKILL at seeded points, inside checkpoint
//! writes included, then resumed, gives the same blob bytes as an uninterrupted run and leaves
//! no temporary file behind.
//!
//! Random kills rarely land inside a checkpoint write, so the child kills itself at a chosen
//! point (`HOST_TRAINER_CRASH_AT`, read by the binary's kill points in `src/run/crash_test.rs`,
//! which are not part of the library's API). The points are fixed, so the test cannot be flaky:
//! the same kills land in the same places on every run.
//!
//! Regression: `kill -9` during a checkpoint write left temporaries that
//! nothing removed, and a run killed before its first checkpoint could not be resumed.

use std::os::unix::process::ExitStatusExt;
use std::path::Path;

use host_trainer::run::checkpoint::Checkpoint;
use host_trainer::run::folder;
use rand_core::{Rng as _, SeedableRng};

use crate::support::{assert_ok, command, s, scratch, smoke_config_file, temporaries};

/// The environment variable that arms a kill point in the `host-trainer` binary.
const CRASH_AT: &str = "HOST_TRAINER_CRASH_AT";

const EPISODES: usize = 6; // the smoke config checkpoints every 2 episodes

/// Kill points chosen to cover every crash window once, then more drawn from a fixed seed:
/// - `checkpoint:1` in a fresh run: killed halfway through its very first checkpoint, so the
///   folder holds only its config, its plant and half a temporary file;
/// - `episode:1`: killed between checkpoints (the restart must redo episode 1);
/// - `checkpoint:2`: halfway through a later checkpoint, with a good one on disk;
/// - `episode:4`: killed just before a checkpoint would be written.
fn kill_points() -> Vec<String> {
    let mut points: Vec<String> = ["checkpoint:1", "episode:1", "checkpoint:2", "episode:4"]
        .map(String::from)
        .to_vec();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2026);
    for _ in 0..3 {
        let point = if rng.next_u32() % 2 == 0 {
            format!("episode:{}", 1 + rng.next_u32() as usize % EPISODES)
        } else {
            // A process writes at most EPISODES / 2 + 1 checkpoints.
            format!(
                "checkpoint:{}",
                1 + rng.next_u32() as usize % (EPISODES / 2 + 1)
            )
        };
        points.push(point);
    }
    points
}

fn train(out: &Path, config: &Path, crash_at: Option<&str>) -> std::process::ExitStatus {
    let mut c = command(&["train", "--config", s(config), "--out", s(out), "--quiet"]);
    if let Some(point) = crash_at {
        c.env(CRASH_AT, point);
    }
    c.output().expect("runs").status
}

fn resume(run: &Path, crash_at: Option<&str>) -> std::process::ExitStatus {
    let mut c = command(&["train", "--resume", s(run), "--quiet"]);
    if let Some(point) = crash_at {
        c.env(CRASH_AT, point);
    }
    c.output().expect("runs").status
}

#[test]
fn killed_runs_resume_to_the_same_blob_and_leave_no_temporary_files() {
    let base = scratch("crash");
    let config = smoke_config_file(&base, EPISODES);
    let (whole, parts) = (base.join("whole"), base.join("parts"));
    std::fs::create_dir_all(&whole).expect("dir");
    std::fs::create_dir_all(&parts).expect("dir");
    assert!(matches!(train(&whole, &config, None).code(), Some(0 | 1)));
    let name = "nav-walls__dcp__3";

    let mut kills = 0;
    for (i, point) in kill_points().iter().enumerate() {
        let run = parts.join(name);
        let status = if i == 0 {
            train(&parts, &config, Some(point))
        } else {
            resume(&run, Some(point))
        };
        if status.signal() == Some(9) {
            kills += 1;
            if point.starts_with("checkpoint") {
                // The kill landed inside the write: half a temporary file, and whatever
                // checkpoint exists is a complete, loadable one.
                assert_eq!(
                    temporaries(&run).len(),
                    1,
                    "{point}: {:?}",
                    temporaries(&run)
                );
                let path = run.join(folder::CHECKPOINT);
                if path.exists() {
                    Checkpoint::load(&path).expect("the previous checkpoint is intact");
                }
            }
        } else {
            // 0 or 1: the run finished and its blob was judged.
            assert!(matches!(status.code(), Some(0 | 1)), "{point}: {status}");
        }
    }
    // Not vacuous: the first four points always land (later ones may lie behind the run).
    assert!(kills >= 4, "only {kills} kills landed");
    let run = parts.join(name);
    assert!(matches!(resume(&run, None).code(), Some(0 | 1)));

    for file in [folder::POLICY, folder::CRITIC] {
        let a = std::fs::read(whole.join(name).join(file)).expect("uninterrupted blob");
        let b = std::fs::read(run.join(file)).expect("resumed blob");
        assert_eq!(a, b, "{file} differs after {kills} kills");
    }
    assert_eq!(temporaries(&run), Vec::<String>::new());
    std::fs::remove_dir_all(&base).expect("cleanup");
}

/// A worker thread of the updates that panics (a bug in parallel code; `worker-panic:N` makes
/// the N-th task panic) ends the process with the panic's exit code, never a hang. Checkpoints
/// are written by the loop's own thread between episodes, while the workers are idle, so the
/// panic leaves the last complete checkpoint and no temporary file, and the run continues from
/// it, on another thread count, to the bytes of an uninterrupted one-thread run.
#[test]
fn a_panicking_worker_thread_leaves_the_last_checkpoint_whole() {
    let base = scratch("worker-panic");
    let config = smoke_config_file(&base, EPISODES);
    let (whole, parts) = (base.join("whole"), base.join("parts"));
    std::fs::create_dir_all(&whole).expect("dir");
    std::fs::create_dir_all(&parts).expect("dir");
    let threads = |n: &str| ["--threads".to_string(), n.to_string()];
    let train = |out: &Path, n: &str, crash_at: Option<&str>| {
        let mut c = command(&["train", "--config", s(&config), "--out", s(out), "--quiet"]);
        c.args(threads(n));
        if let Some(point) = crash_at {
            c.env(CRASH_AT, point);
        }
        c.output().expect("runs")
    };
    assert_ok(&train(&whole, "1", None));
    // About six tasks per update on 2 threads: task 300 falls after the checkpoint of episode 2.
    let out = train(&parts, "2", Some("worker-panic:300"));
    assert_eq!(out.status.code(), Some(101), "a panic's exit: {out:?}");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("injected worker panic"), "{stderr}");
    let name = "nav-walls__dcp__3";
    let run = parts.join(name);
    assert_eq!(temporaries(&run), Vec::<String>::new());
    let checkpoint = Checkpoint::load(&run.join(folder::CHECKPOINT)).expect("a whole checkpoint");
    assert!(
        (2..EPISODES).contains(&checkpoint.episode),
        "the panic came mid-run: checkpoint of episode {}",
        checkpoint.episode
    );
    assert!(!run.join(folder::POLICY).exists(), "the run did not finish");

    let mut c = command(&["train", "--resume", s(&run), "--quiet"]);
    assert_ok(&c.args(threads("3")).output().expect("runs"));
    for file in [folder::POLICY, folder::CRITIC] {
        let a = std::fs::read(whole.join(name).join(file)).expect("uninterrupted blob");
        let b = std::fs::read(run.join(file)).expect("resumed blob");
        assert_eq!(a, b, "{file} differs after the worker panic");
    }
    std::fs::remove_dir_all(&base).expect("cleanup");
}
