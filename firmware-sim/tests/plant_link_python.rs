//! The Rust host against the Python package's plant server: `python3 -m
//! margin_safe_rl.plant_link serve Pendulum-v1` (python/) started by `ChildPlant`, so the
//! trainer's `--plant-cmd` is known to accept any Gymnasium environment the package serves.
//! Skipped, with the reason printed, where python3 or Gymnasium is missing; python/ci.sh
//! installs both and sets `REQUIRE_PYTHON_PLANT=1`, under which a skip is a failure.

use std::path::PathBuf;
use std::process::{Command, Stdio};

use firmware_sim::env::Env;
use firmware_sim::plant_link::child::{ChildPlant, Timeouts};

fn python_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("python")
}

/// The command that serves Pendulum-v1 from the repository's package, or why it cannot run.
fn pendulum_command() -> Result<String, String> {
    let dir = python_dir();
    let quoted = shlex::try_quote(dir.to_str().ok_or("a non-UTF-8 repository path")?)
        .map_err(|e| e.to_string())?
        .into_owned();
    let probe = Command::new("python3")
        .args(["-c", "import gymnasium, margin_safe_rl.plant_link"])
        .env("PYTHONPATH", &dir)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status();
    match probe {
        Err(e) => Err(format!("no python3 ({e})")),
        Ok(status) if !status.success() => {
            Err("python3 cannot import gymnasium (pip install -r python/requirements.txt)".into())
        }
        // `env` sets the package's path for the plant alone, not for this test process.
        Ok(_) => Ok(format!(
            "env PYTHONPATH={quoted} python3 -m margin_safe_rl.plant_link serve Pendulum-v1"
        )),
    }
}

fn spawn() -> Option<ChildPlant> {
    match pendulum_command() {
        Ok(command) => {
            Some(ChildPlant::spawn(&command, Timeouts::default()).expect("the Python plant starts"))
        }
        Err(why) if std::env::var_os("REQUIRE_PYTHON_PLANT").is_some() => {
            panic!("REQUIRE_PYTHON_PLANT is set but the Python plant server cannot run: {why}")
        }
        Err(why) => {
            eprintln!("skipped: the Python plant server cannot run here: {why}");
            None
        }
    }
}

#[test]
fn rust_host_runs_the_python_pendulum() {
    let Some(mut plant) = spawn() else { return };
    let hello = plant.hello().clone();
    assert_eq!(hello.name, "Pendulum-v1");
    assert_eq!(hello.agents[0].observation_high, [1.0, 1.0, 8.0]);
    assert_eq!(hello.agents[0].action_low, [-2.0]);
    assert_eq!(hello.agents[0].action_high, [2.0]);
    let first = plant.reset(7);
    assert_eq!(first.len(), 3);
    assert_eq!(plant.reset(7), first, "the same seed gives the same start");
    let inside = plant.step(&[0.5]);
    assert_eq!(inside.observation.len(), 3);
    assert!(!inside.info.margin_touched);
    assert_eq!(inside.info.applied, [0.5]);
    assert!(inside.reward <= 0.0 && !inside.terminated && !inside.truncated);
    let clipped = plant.step(&[5.0]);
    assert!(clipped.info.margin_touched, "an action beyond 2 is clipped");
    assert_eq!(clipped.info.applied, [2.0]);
    assert_eq!(clipped.info.success, None);
    assert!(plant.failure().is_none(), "{:?}", plant.failure());
}

#[test]
fn python_plant_answers_a_wrong_size_with_an_error() {
    let Some(mut plant) = spawn() else { return };
    plant.reset(0);
    let step = plant.step(&[0.1, 0.2]);
    assert!(step.terminated, "a failed plant ends the episode");
    let failure = plant
        .failure()
        .expect("the plant's error is recorded")
        .to_string();
    assert!(
        failure.contains("the plant says: an action of 2 values, expected 1"),
        "{failure}"
    );
}
