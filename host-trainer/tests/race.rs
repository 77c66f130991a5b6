//! `train --race K`: the winner and its bytes do not depend on timing or on a kill mid-race,
//! and bad requests are one-line errors.

use std::path::{Path, PathBuf};

use crate::support::{assert_judged, assert_one_line_error, host_trainer, s, scratch};

/// nav-open with a gate every policy passes, so that validation meets its criteria at once and
/// a race is decided within a few episodes (the winner's path, not only the budget's).
fn lenient_scenario(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../firmware-sim/scenarios/nav-open.toml"
    ))
    .expect("nav-open")
    .replace("min_success_rate = 0.9", "min_success_rate = 0.0")
    .replace("max_stuck_rate = 0.05", "max_stuck_rate = 1.0")
    .replace("name = \"nav-open\"", "name = \"lenient\"");
    let path = dir.join("lenient.toml");
    std::fs::write(&path, text).expect("scenario");
    path
}

/// A small race's settings: 2x32 networks, validation every 5 episodes on 10 starts, and
/// criteria any round of the lenient scenario meets (`in_a_row` rounds in a row).
fn race_config(dir: &Path, episodes: usize, in_a_row: usize) -> PathBuf {
    let text = format!(
        "task = {:?}\nseed = 3\nepisodes = {episodes}\ncheckpoint_every = 5\neval_episodes = 10\n\n[agent]\nhidden = \"2x32\"\nbatch = 16\nwarmup_steps = 16\n\n[dcp]\nt = 4\n\n[validation]\nevery = 5\nstarts = 10\nin_a_row = {in_a_row}\nmin_success = 0.0\nmax_stuck = 1.0\nmax_error = 100.0\n",
        s(&lenient_scenario(dir))
    );
    let path = dir.join(format!("race-{episodes}-{in_a_row}.toml"));
    std::fs::write(&path, text).expect("config");
    path
}

fn race(out: &Path, config: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "train",
        "--config",
        s(config),
        "--out",
        s(out),
        "--race",
        "2",
        "--quiet",
    ];
    args.extend_from_slice(extra);
    host_trainer(&args)
}

fn read(path: PathBuf) -> Vec<u8> {
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn a_race_names_the_same_winner_with_the_same_bytes_every_time() {
    let dir = scratch("race-same");
    let config = race_config(&dir, 30, 2);
    let (a, b) = (dir.join("a"), dir.join("b"));
    for out in [&a, &b] {
        std::fs::create_dir_all(out).expect("out");
        let run = race(out, &config, &[]);
        assert_judged(&run);
        let stdout = String::from_utf8_lossy(&run.stdout);
        assert!(stdout.contains("raced 2 seeds from seed 3"), "{stdout}");
        assert!(
            stdout.contains("was the first whose validation met the criteria 2 rounds in a row"),
            "{stdout}"
        );
    }
    let race_dir = |out: &Path| out.join("lenient__dcp__3");
    for file in [
        "policy.postcard",
        "critic.postcard",
        "race.json",
        "eval.json",
    ] {
        let (x, y) = (race_dir(&a).join(file), race_dir(&b).join(file));
        // eval.json carries the test's timing; every other byte must agree.
        if file == "eval.json" {
            continue;
        }
        assert_eq!(read(x), read(y), "{file} differs between two races");
    }
    // The race stopped at its second round (episode 10), well before the budget of 30, and the
    // race folder's blob is the winner's kept policy, as its own folder holds it.
    let record: serde_json::Value =
        serde_json::from_slice(&read(race_dir(&a).join("race.json"))).expect("json");
    let winner = record["winner"].as_u64().expect("a winner") as usize;
    let racer = &record["racers"][winner];
    assert_eq!(racer["ending"], "Won");
    assert_eq!(racer["episodes"], 10);
    let folder = racer["folder"].as_str().expect("folder");
    assert_eq!(
        read(race_dir(&a).join("policy.postcard")),
        read(race_dir(&a).join(folder).join("policy.postcard"))
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_race_killed_mid_way_resumes_to_the_winner_of_an_unbroken_race() {
    let dir = scratch("race-kill");
    // Three rounds in a row: the race runs to episode 15 at least, long enough to be killed.
    let config = race_config(&dir, 40, 3);
    let whole = dir.join("whole");
    std::fs::create_dir_all(&whole).expect("out");
    assert_judged(&race(&whole, &config, &[]));
    for point in ["episode:3", "episode:7", "episode:12", "checkpoint:4"] {
        let out = dir.join(point.replace(':', "-"));
        std::fs::create_dir_all(&out).expect("out");
        let killed = crate::support::command(&[
            "train",
            "--config",
            s(&config),
            "--out",
            s(&out),
            "--race",
            "2",
            "--quiet",
        ])
        .env("HOST_TRAINER_CRASH_AT", point)
        .output()
        .expect("runs");
        assert!(
            !killed.status.success(),
            "{point}: the crash point must stop the race"
        );
        let race_dir = out.join("lenient__dcp__3");
        let resumed = host_trainer(&["train", "--resume", s(&race_dir), "--quiet"]);
        assert_judged(&resumed);
        assert_eq!(
            read(race_dir.join("policy.postcard")),
            read(whole.join("lenient__dcp__3/policy.postcard")),
            "{point}: the resumed race kept another policy"
        );
        assert_eq!(
            read(race_dir.join("race.json")),
            read(whole.join("lenient__dcp__3/race.json")),
            "{point}: the resumed race's record differs"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_racer_whose_folder_was_never_written_starts_again_to_the_same_winner() {
    let dir = scratch("race-lost");
    let config = race_config(&dir, 30, 2);
    let (whole, cut) = (dir.join("whole"), dir.join("cut"));
    for out in [&whole, &cut] {
        std::fs::create_dir_all(out).expect("out");
    }
    assert_judged(&race(&whole, &config, &[]));
    // A race killed right after it recorded itself, before its second racer's folder held
    // anything: here, a race stopped mid-way whose second racer's folder is then emptied.
    let killed = crate::support::command(&[
        "train",
        "--config",
        s(&config),
        "--out",
        s(&cut),
        "--race",
        "2",
        "--quiet",
    ])
    .env("HOST_TRAINER_CRASH_AT", "episode:4")
    .output()
    .expect("runs");
    assert!(!killed.status.success());
    let race_dir = cut.join("lenient__dcp__3");
    let record: serde_json::Value =
        serde_json::from_slice(&read(race_dir.join("race.json"))).expect("json");
    let second = race_dir.join(record["racers"][1]["folder"].as_str().expect("folder"));
    std::fs::remove_dir_all(&second).expect("remove");
    std::fs::create_dir(&second).expect("an empty folder");
    assert_judged(&host_trainer(&[
        "train",
        "--resume",
        s(&race_dir),
        "--quiet",
    ]));
    for file in ["policy.postcard", "race.json"] {
        assert_eq!(
            read(race_dir.join(file)),
            read(whole.join("lenient__dcp__3").join(file)),
            "{file}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_race_requests_are_one_line_errors_and_write_nothing() {
    let dir = scratch("race-bad");
    let config = race_config(&dir, 10, 2);
    let c = s(&config);
    let o = s(&dir);
    let cases: [(Vec<&str>, Vec<&str>); 6] = [
        (vec!["--race", "0"], vec!["--race"]),
        (vec!["--validate-every", "0"], vec!["--validate-every"]),
        (
            vec!["--validate-every", "11", "--race", "1"],
            vec!["--validate-every 11", "budget"],
        ),
        (
            vec!["--race", "2", "--no-validation"],
            vec!["needs validation"],
        ),
        (
            vec!["--race", "2", "--threads", "2"],
            vec!["--threads", "one thread each"],
        ),
        (vec!["--race", "65"], vec!["--race 65", "1 to 64"]),
    ];
    for (extra, needles) in cases {
        let mut args = vec!["train", "--config", c, "--out", o, "--quiet"];
        args.extend_from_slice(&extra);
        let out = host_trainer(&args);
        assert_eq!(out.status.code(), Some(2), "{extra:?}");
        assert_one_line_error(&out, &needles);
    }
    assert!(
        !dir.join("lenient__dcp__3").exists(),
        "a refused race made a folder"
    );
    // A second race into a finished race's folder is refused; the first keeps its files.
    assert_judged(&race(&dir, &config, &[]));
    let before = read(dir.join("lenient__dcp__3/race.json"));
    let again = race(&dir, &config, &[]);
    assert_one_line_error(&again, &["--resume"]);
    assert_eq!(read(dir.join("lenient__dcp__3/race.json")), before);
    // A record edited to point outside the race is refused, not followed.
    let edited = String::from_utf8(before).expect("utf-8").replacen(
        "racers/lenient__dcp__3",
        "../../elsewhere",
        1,
    );
    std::fs::write(dir.join("lenient__dcp__3/race.json"), edited).expect("edit");
    let resumed = host_trainer(&[
        "train",
        "--resume",
        s(&dir.join("lenient__dcp__3")),
        "--quiet",
    ]);
    assert_one_line_error(&resumed, &["racer folder", "racers/"]);
    // A record cut short is named as such by every command that reads it, and left as it is.
    let race_dir = dir.join("lenient__dcp__3");
    std::fs::write(race_dir.join("race.json"), "{\"base_seed\": 3").expect("cut");
    for args in [
        ["train", "--resume", s(&race_dir)],
        ["export", "--run", s(&race_dir)],
    ] {
        let out = host_trainer(&args);
        assert_one_line_error(&out, &["race.json", "is not a race's record"]);
    }
    assert_eq!(read(race_dir.join("race.json")), b"{\"base_seed\": 3");
    let _ = std::fs::remove_dir_all(&dir);
}
