//! Ctrl-C during training writes a checkpoint, exits with 130 and says how to resume.

use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use host_trainer::run::checkpoint::Checkpoint;
use host_trainer::run::folder;

use crate::support::{command, s, scratch, smoke_config_file, temporaries};

/// Kills the child if the test fails before it has exited (a training run of 100,000 episodes
/// must not outlive a failed test).
struct KillOnDrop(Option<Child>);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        if let Some(child) = &mut self.0 {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

#[test]
fn ctrl_c_checkpoints_and_says_how_to_resume() {
    let stderr = stop_training_with("INT", "ctrl-c");
    assert!(stderr.contains("Ctrl-C: stopping"), "{stderr}");
}

/// SIGTERM (a job scheduler's stop) and SIGHUP (a closed terminal) stop a run as Ctrl-C does,
/// but were reported as Ctrl-C; the message names the signal that came.
#[test]
fn sigterm_and_sighup_are_named_not_reported_as_ctrl_c() {
    for (signal, name) in [("TERM", "SIGTERM"), ("HUP", "SIGHUP")] {
        let stderr = stop_training_with(signal, &format!("sig-{signal}"));
        assert!(stderr.contains(name), "{stderr}");
        assert!(!stderr.contains("Ctrl-C"), "{stderr}");
    }
}

/// Starts a long training run, sends it `signal` once it trains, checks it stopped at a
/// checkpoint with exit 130 and the way to resume, and returns its stderr.
fn stop_training_with(signal: &str, tag: &str) -> String {
    let base = scratch(tag);
    // Far more episodes than the test waits for: the run is still training when Ctrl-C comes.
    let config = smoke_config_file(&base, 100_000);
    let mut child = KillOnDrop(Some(
        command(&[
            "train",
            "--config",
            s(&config),
            "--out",
            s(&base),
            "--quiet",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn"),
    ));
    let pid = child.0.as_ref().map_or(0, Child::id);
    let run = base.join("nav-walls__dcp__3");
    // The episode-0 checkpoint exists once training has started (and the handler is set).
    let started = Instant::now();
    while !run.join(folder::METRICS).exists() {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "training never started"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let sent = std::process::Command::new("kill")
        .args([&format!("-{signal}"), &pid.to_string()])
        .status()
        .expect("kill");
    assert!(sent.success());
    let out = child
        .0
        .take()
        .expect("the child")
        .wait_with_output()
        .expect("wait");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("checkpoint written"), "{stderr}");
    assert!(
        stderr.contains(&format!("--resume {}", run.display())),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    let kept = Checkpoint::load(&run.join(folder::CHECKPOINT)).expect("checkpoint");
    assert!(kept.episode >= 1, "the checkpoint holds the episodes done");
    assert_eq!(kept.metrics.len(), kept.episode);
    assert_eq!(temporaries(&run), Vec::<String>::new());
    std::fs::remove_dir_all(&base).expect("cleanup");
    stderr.into_owned()
}
