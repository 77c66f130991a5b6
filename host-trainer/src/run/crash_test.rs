//! Test-only kill points for the crash-safety test (`tests/crash.rs`).
//!
//! Random `kill -9`s rarely land inside a checkpoint write, which is exactly where a crash could
//! corrupt a run. So the test sets `HOST_TRAINER_CRASH_AT` in a child process's environment and
//! the child kills itself with SIGKILL (no destructors, no flushing, no clean-up: the same as a
//! power cut for the files it has written) at a chosen point:
//!
//! - `episode:N`: right after episode N completes, before anything about it is written;
//! - `checkpoint:N`: halfway through writing this process's N-th checkpoint file, after the
//!   first half has reached the temporary file;
//! - `worker-panic:N`: the N-th task handed to the update's worker threads panics (a bug in
//!   parallel code): the process must die without a half-written checkpoint.
//!
//! Unset (always, outside that test), every function here does nothing. The module is private to
//! the crate: the test arms it through the environment of the `host-trainer` binary it runs,
//! which is the only place the kill points matter.

use std::io::Write;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::OnceLock;

/// The environment variable that arms a kill point.
pub const ENV: &str = "HOST_TRAINER_CRASH_AT";

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum KillPoint {
    Episode(usize),
    Checkpoint(usize),
    WorkerPanic(usize),
}

fn armed() -> Option<KillPoint> {
    static POINT: OnceLock<Option<KillPoint>> = OnceLock::new();
    *POINT.get_or_init(|| parse(&std::env::var(ENV).ok()?))
}

fn parse(text: &str) -> Option<KillPoint> {
    let (kind, n) = text.split_once(':')?;
    let n = n.parse().ok()?;
    match kind {
        "episode" => Some(KillPoint::Episode(n)),
        "checkpoint" => Some(KillPoint::Checkpoint(n)),
        "worker-panic" => Some(KillPoint::WorkerPanic(n)),
        _ => None,
    }
}

/// Called after each completed episode.
pub fn episode_done(episode: usize) {
    if armed() == Some(KillPoint::Episode(episode)) {
        die();
    }
}

/// The worker task that must panic, when `worker-panic:N` is armed.
pub fn worker_fault() -> Option<usize> {
    match armed() {
        Some(KillPoint::WorkerPanic(task)) => Some(task),
        _ => None,
    }
}

/// Called halfway through every checkpoint write.
pub fn checkpoint_half_written(file: &mut impl Write) {
    static WRITES: AtomicUsize = AtomicUsize::new(0);
    let Some(KillPoint::Checkpoint(n)) = armed() else {
        return;
    };
    if WRITES.fetch_add(1, Ordering::Relaxed) + 1 == n {
        // The half must really be in the file, as it would be when a kill lands here.
        let _ = file.flush();
        die();
    }
}

/// SIGKILL to ourselves: nothing runs after it.
fn die() -> ! {
    let pid = std::process::id().to_string();
    let _ = std::process::Command::new("kill")
        .args(["-KILL", &pid])
        .status();
    // `kill` missing: abort is the nearest thing (no destructors either).
    std::process::abort()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kill_points_parse() {
        assert_eq!(parse("episode:3"), Some(KillPoint::Episode(3)));
        assert_eq!(parse("checkpoint:1"), Some(KillPoint::Checkpoint(1)));
        assert_eq!(parse("worker-panic:7"), Some(KillPoint::WorkerPanic(7)));
        assert_eq!(parse("episode"), None);
        assert_eq!(parse("lunch:1"), None);
    }
}
