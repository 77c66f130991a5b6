//! Training on a plant in another process (`--plant-cmd`, the plant link) and on a plant given
//! in process (`Trainer::with_plant`): the same bytes as training on the scenario itself, the
//! plant recorded and checked on resume, a plant that fails stopping the run with its reason
//! and leaving the checkpoint as it was.

use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::NavEnv;
use host_trainer::algorithms::Algo;
use host_trainer::run::checkpoint::Checkpoint;
use host_trainer::run::config::TrainConfig;
use host_trainer::run::folder;
use host_trainer::run::plant::RunPlant;
use host_trainer::run::trainer::Trainer;

use crate::support::{assert_one_line_error, firmware_sim, host_trainer, s, scratch};

/// nav-walls with the trainer's reward (gr) rather than the scenario file's (lr): the same
/// plant the trainer builds in process.
fn serve_nav_walls() -> String {
    format!(
        "{} serve-plant --scenario nav-walls --reward gr",
        firmware_sim().display()
    )
}

use crate::support::train_trainer as train;

#[test]
fn a_plant_served_through_the_link_trains_to_the_same_bytes_as_in_process() {
    let (direct_dir, process_dir, given_dir) = (
        scratch("link-direct"),
        scratch("link-process"),
        scratch("link-given"),
    );
    let config = TrainConfig::smoke(Algo::Dcp, 4);
    let (direct, _) = train(Trainer::new(config.clone()).expect("direct"), &direct_dir);
    let linked_config = TrainConfig {
        plant_cmd: Some(serve_nav_walls()),
        ..config.clone()
    };
    let linked = Trainer::new(linked_config).expect("a plant process");
    assert!(matches!(&linked.plant, RunPlant::Process { hello, .. } if hello.name == "nav-walls"));
    let (linked, _) = train(linked, &process_dir);
    let mut scenario = Scenario::builtin("nav-walls").expect("builtin");
    scenario.reward = firmware_sim::nav::Reward::Gr;
    let given = NavEnv::new(&scenario).expect("plant");
    let with_plant = TrainConfig {
        task: "nav-walls".into(),
        ..config
    };
    let (given, _) = train(
        Trainer::with_plant(with_plant, Box::new(given)).expect("a plant in process"),
        &given_dir,
    );
    let blob = |t: &Trainer| t.policy_blob("same").expect("blob");
    // Every column but the wall-clock speed.
    let rows = |t: &Trainer| {
        let mut rows = t.metrics.clone();
        rows.iter_mut().for_each(|r| r.steps_per_s = 0.0);
        rows
    };
    assert_eq!(rows(&linked), rows(&direct));
    assert!(blob(&linked) == blob(&direct), "the blobs differ");
    assert!(blob(&given) == blob(&direct), "the blobs differ");
    assert_eq!(rows(&given), rows(&direct));
    for dir in [direct_dir, process_dir, given_dir] {
        let _ = std::fs::remove_dir_all(dir);
    }
}

#[test]
fn a_run_on_a_plant_process_resumes_and_refuses_a_plant_whose_hello_changed() {
    let out = scratch("link-resume");
    let config = TrainConfig {
        plant_cmd: Some(serve_nav_walls()),
        episodes: 2,
        ..TrainConfig::smoke(Algo::Dcp, 0)
    };
    let (_, run) = train(Trainer::new(config).expect("trainer"), &out);
    let path = run.file(folder::CHECKPOINT);
    let resumed = Trainer::resume(Checkpoint::load(&path).expect("load"), Some(3), &path);
    assert_eq!(resumed.expect("resume").episode, 2);
    // The same command now serves another plant: its boxes differ (nav-open's arena is the
    // same size, so the name tells them apart).
    let mut checkpoint = Checkpoint::load(&path).expect("load");
    checkpoint.scenario_toml = checkpoint
        .scenario_toml
        .replace("--scenario nav-walls", "--scenario nav-open");
    assert!(checkpoint.scenario_toml.contains("nav-open"));
    let e = Trainer::resume(checkpoint, Some(3), &path).expect_err("refused");
    let text = e.to_string();
    assert!(
        text.contains("its hello has changed since the run started") && text.contains("nav-open"),
        "{text}"
    );
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn train_plant_cmd_names_the_run_for_the_plant_and_a_missing_plant_is_one_line() {
    let out = scratch("link-cli");
    let cmd = serve_nav_walls();
    let ok = host_trainer(&[
        "train",
        "--plant-cmd",
        &cmd,
        "--episodes",
        "2",
        "--out",
        s(&out),
        "--quiet",
    ]);
    assert!(
        ok.status.code().is_some_and(|c| c <= 1),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let stdout = String::from_utf8_lossy(&ok.stdout);
    assert!(stdout.contains("on nav-walls, 100 test starts"), "{stdout}");
    let config =
        std::fs::read_to_string(out.join("nav-walls__dcp__0/config.toml")).expect("config");
    assert!(config.contains(&format!("plant_cmd = {cmd:?}")), "{config}");
    let missing = host_trainer(&["train", "--plant-cmd", "no-such-plant", "--out", s(&out)]);
    assert_one_line_error(
        &missing,
        &["plant \"no-such-plant\": cannot start: no program no-such-plant on PATH"],
    );
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn a_sweep_on_a_plant_process_names_its_runs_for_the_plant_and_summarises_them() {
    let out = scratch("link-sweep");
    let config = crate::support::smoke_config_file(&out, 2);
    let cmd = serve_nav_walls();
    let args = [
        "sweep",
        "--config",
        s(&config),
        "--plant-cmd",
        &cmd,
        "--seeds",
        "0-1",
        "--jobs",
        "2",
        "--out",
        s(&out),
        "--quiet",
    ];
    let swept = host_trainer(&args);
    assert!(
        swept.status.success(),
        "{}",
        String::from_utf8_lossy(&swept.stderr)
    );
    let summary = std::fs::read_to_string(out.join("sweep.md")).expect("sweep.md");
    for seed in 0..2 {
        assert!(out
            .join(format!("nav-walls__dcp__{seed}/policy.postcard"))
            .is_file());
    }
    assert!(summary.contains("nav-walls"), "{summary}");
    // Finished runs are skipped on the second call, as for scenarios.
    let again = host_trainer(&args);
    assert!(
        again.status.success(),
        "{}",
        String::from_utf8_lossy(&again.stderr)
    );
    let _ = std::fs::remove_dir_all(&out);
}

/// The pids of `pid`'s children, from /proc.
fn children(pid: u32) -> Vec<u32> {
    let tasks = std::fs::read_dir(format!("/proc/{pid}/task"))
        .into_iter()
        .flatten();
    tasks
        .flatten()
        .filter_map(|t| std::fs::read_to_string(t.path().join("children")).ok())
        .flat_map(|c| {
            c.split_whitespace()
                .filter_map(|p| p.parse().ok())
                .collect::<Vec<u32>>()
        })
        .collect()
}

/// Whether a process is still running (a zombie awaiting its reaper counts as gone).
fn alive(pid: u32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat")).is_ok_and(|stat| {
        !stat
            .rsplit(')')
            .next()
            .is_some_and(|s| s.trim_start().starts_with('Z'))
    })
}

/// A trainer on a plant process, far from done; its pid and the plant's.
// The child is handed to the caller, which kills or waits for it (clippy cannot see that).
#[allow(clippy::zombie_processes)]
fn trainer_with_plant(base: &std::path::Path) -> (std::process::Child, u32) {
    let config = crate::support::smoke_config_file(base, 100_000);
    let cmd = serve_nav_walls();
    let mut child = crate::support::command(&[
        "train",
        "--config",
        s(&config),
        "--plant-cmd",
        &cmd,
        "--out",
        s(base),
        "--quiet",
    ])
    .stdout(std::process::Stdio::null())
    .stderr(std::process::Stdio::piped())
    .spawn()
    .expect("spawn");
    let started = std::time::Instant::now();
    let metrics = base.join("nav-walls__dcp__3").join(folder::METRICS);
    loop {
        let plants = children(child.id());
        if metrics.exists() && !plants.is_empty() {
            return (child, plants[0]);
        }
        if started.elapsed().as_secs() >= 60 {
            let _ = child.kill();
            let _ = child.wait();
            panic!("training never started");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

fn assert_gone(plant: u32) {
    let started = std::time::Instant::now();
    while alive(plant) {
        assert!(
            started.elapsed().as_secs() < 10,
            "the plant {plant} outlived its trainer"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

#[test]
fn kill_9_of_the_trainer_leaves_no_plant_behind() {
    let base = scratch("link-kill9");
    let (mut trainer, plant) = trainer_with_plant(&base);
    assert!(alive(plant));
    trainer.kill().expect("kill -9");
    trainer.wait().expect("reaped");
    assert_gone(plant);
    let _ = std::fs::remove_dir_all(&base);
}

#[test]
fn ctrl_c_of_the_trainer_checkpoints_closes_the_plant_and_resumes() {
    let base = scratch("link-ctrl-c");
    let (trainer, plant) = trainer_with_plant(&base);
    let sent = std::process::Command::new("kill")
        .args(["-INT", &trainer.id().to_string()])
        .status()
        .expect("kill");
    assert!(sent.success());
    let out = trainer.wait_with_output().expect("exits");
    assert_eq!(
        out.status.code(),
        Some(130),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_gone(plant);
    let run = base.join("nav-walls__dcp__3");
    let path = run.join(folder::CHECKPOINT);
    let episode = Checkpoint::load(&path).expect("checkpoint").episode;
    let resumed = host_trainer(&[
        "train",
        "--resume",
        s(&run),
        "--episodes",
        &(episode + 1).to_string(),
        "--quiet",
    ]);
    assert!(
        resumed.status.code().is_some_and(|c| c <= 1),
        "{}",
        String::from_utf8_lossy(&resumed.stderr)
    );
    let _ = std::fs::remove_dir_all(&base);
}

#[test]
fn a_plant_that_dies_mid_run_stops_it_in_one_line_and_the_run_resumes_once_it_is_fixed() {
    use std::os::unix::fs::PermissionsExt;
    let base = scratch("link-dies");
    let plant = base.join("plant.sh");
    let write = |body: &str| {
        std::fs::write(&plant, format!("#!/bin/sh\n{body}\n")).expect("script");
        std::fs::set_permissions(&plant, std::fs::Permissions::from_mode(0o755)).expect("chmod");
    };
    // The plant reads its first 3,000 bytes of requests (about 170 steps; dd passes each
    // byte on as it comes), then its input ends and it exits, mid-episode.
    write(&format!(
        "dd bs=1 count=3000 status=none | {}",
        serve_nav_walls()
    ));
    let config = crate::support::smoke_config_file(&base, 20);
    let cmd = plant.display().to_string();
    let args = [
        "train",
        "--config",
        s(&config),
        "--plant-cmd",
        &cmd,
        "--out",
        s(&base),
        "--quiet",
    ];
    let died = host_trainer(&args);
    let text = assert_one_line_error(
        &died,
        &[&format!("plant {cmd:?}: step"), "before answering"],
    );
    assert!(text.contains("after reset(seed"), "{text}");
    let run = base.join("nav-walls__dcp__3");
    let path = run.join(folder::CHECKPOINT);
    let saved = Checkpoint::load(&path).expect("the last checkpoint is intact");
    assert!(saved.episode < 20, "{}", saved.episode);
    // Fixed: the same command now serves every request.
    write(&format!("exec {}", serve_nav_walls()));
    let resumed = host_trainer(&["train", "--resume", s(&run), "--quiet"]);
    assert!(
        resumed.status.code().is_some_and(|c| c <= 1),
        "{}",
        String::from_utf8_lossy(&resumed.stderr)
    );
    assert_eq!(Checkpoint::load(&path).expect("checkpoint").episode, 20);
    let _ = std::fs::remove_dir_all(&base);
}
