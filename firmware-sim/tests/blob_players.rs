//! Player folders: `match` and `match --measures` play a folder's blobs end to end, reproducibly,
//! and every bad folder is one line, exit 2, nothing written; a blob that does not boot plays
//! the safe state and the report says which agent and why.

use std::path::Path;
use std::process::Output;

use firmware_sim::badminton::play::{play_match, Length, MatchReport, MeasuresReport};
use firmware_sim::badminton::reference::PlayerKind;
use firmware_sim::badminton::{Config, Role};
use policy_core::Encoding;

use crate::util::{
    badminton_actor, firmware_sim, stderr, stdout, write_example_player, Scratch, PLAYER_TOML,
};

/// The committed example folder the documentation plays.
const EXAMPLE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/example-player");

/// A scratch folder of this module's tests.
fn scratch(name: &str) -> Scratch {
    Scratch::new("blob-players", name)
}

fn play(args: &[&str]) -> Output {
    firmware_sim("match", args)
}

#[test]
fn the_example_player_folder_is_what_the_builder_writes() {
    let dir = scratch("example");
    let built = dir.path("example-player");
    write_example_player(&built);
    for name in [
        "player.toml",
        "catch.postcard",
        "serve.postcard",
        "reset.postcard",
    ] {
        let want = std::fs::read(built.join(name)).expect("built");
        let have = std::fs::read(Path::new(EXAMPLE).join(name)).expect("committed");
        assert!(
            have == want,
            "{name} differs from what write_example_player writes"
        );
    }
}

#[test]
fn a_blob_player_plays_scripted_end_to_end_and_the_same_folder_and_seed_give_the_same_bytes() {
    let dir = scratch("play");
    let player = dir.player("p", PLAYER_TOML);
    let (one, two) = (dir.file("one.json"), dir.file("two.json"));
    let args = |json: &str| {
        play(&[
            "--p0", &player, "--p1", "scripted", "--games", "1", "--seed", "5", "--json", json,
        ])
    };
    let first = args(&one);
    assert!(
        matches!(first.status.code(), Some(0 | 1)),
        "{}",
        stderr(&first)
    );
    assert!(
        stdout(&first).contains("p0 example vs p1 scripted"),
        "{}",
        stdout(&first)
    );
    let second = args(&two);
    let bytes = std::fs::read(&one).expect("json");
    assert_eq!(bytes, std::fs::read(&two).expect("json"));
    assert_eq!(stdout(&first), stdout(&second));
    let written: MatchReport = serde_json::from_slice(&bytes).expect("a report");
    let kinds = [player.parse().expect("folder"), PlayerKind::Scripted];
    let library = play_match(
        &Config::builtin(),
        &kinds,
        Length::Games(1),
        5,
        false,
        |_| {},
    )
    .expect("lib");
    assert_eq!(written, library);
    assert!(written.players[0].boot_errors.is_empty());
    assert!(written.hits > 0 && written.players[1].points_won > 0);
    // The folder plays its own blobs, not a stand-in: another catch blob, other positions.
    let other = dir.player("other", PLAYER_TOML);
    let catch = badminton_actor(2, 99, Encoding::F32, "other catch");
    std::fs::write(Path::new(&other).join("catch.postcard"), catch).expect("blob");
    let positions = |folder: &str| {
        let kinds = [folder.parse().expect("folder"), PlayerKind::Scripted];
        let mut seen = Vec::new();
        let keep = |game: &firmware_sim::badminton::Badminton| {
            seen.extend(game.rally().expect("recorded").players.iter().map(|p| p[0]));
        };
        play_match(&Config::builtin(), &kinds, Length::Points(3), 5, true, keep).expect("lib");
        seen
    };
    assert_ne!(positions(&player), positions(&other));
}

/// The optional keys: critics are read (not run) and the scenario must load.
#[test]
fn a_folder_with_critics_and_its_scenario_loads() {
    let dir = scratch("full");
    let manifest = PLAYER_TOML.replace(
        "label = \"example\"",
        "label = \"full\"\nscenario = \"badminton.toml\"",
    )
        + "[critics]\ncatch = \"c.postcard\"\nserve = \"c.postcard\"\nreset = \"c.postcard\"\n";
    let player = dir.player("p", &manifest);
    let folder = Path::new(&player);
    std::fs::write(folder.join("badminton.toml"), Config::BUILTIN).expect("scenario");
    std::fs::write(folder.join("c.postcard"), b"any bytes").expect("critic");
    let PlayerKind::Folder(loaded) = player.parse::<PlayerKind>().expect("loads") else {
        panic!("a folder")
    };
    assert_eq!(loaded.label, "full");
    assert!(loaded
        .scenario
        .as_ref()
        .is_some_and(|p| p.ends_with("badminton.toml")));
    assert_eq!(loaded.critics.as_ref().map(|c| c[1].1.len()), Some(9));
    // A scenario that does not load is refused, naming its file and key.
    let text = Config::BUILTIN.replace("dt = 0.001", "dt = nan");
    std::fs::write(folder.join("badminton.toml"), text).expect("scenario");
    let e = player
        .parse::<PlayerKind>()
        .expect_err("bad scenario")
        .to_string();
    assert!(e.contains("badminton.toml:17: shuttle.dt"), "{e}");
}

#[test]
fn measures_run_on_a_player_folder_as_the_library_gives_them() {
    let dir = scratch("measures");
    let player = dir.player("p", PLAYER_TOML);
    let json = dir.file("measures.json");
    let o = play(&[
        "--p0",
        &player,
        "--p1",
        "scripted",
        "--measures",
        "--balls",
        "40",
        "--points",
        "4",
        "--seed",
        "2",
        "--json",
        &json,
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for needle in ["catch test (40 serves", "serve test", "reset on (4 points)"] {
        assert!(stdout(&o).contains(needle), "{needle:?}: {}", stdout(&o));
    }
    let written: MeasuresReport =
        serde_json::from_slice(&std::fs::read(&json).expect("json")).expect("a report");
    let kinds = [player.parse().expect("folder"), PlayerKind::Scripted];
    let library = MeasuresReport::of(&Config::builtin(), &kinds, 40, 4, 2).expect("lib");
    assert_eq!(written, library);
    assert_eq!(written.players[0].serve_errors.of, 40);
    assert_eq!(written.players[0].name, "example");
    assert_eq!(written.players[1].opponent, "example");
    // Flags of the measures only, without --measures; --measures with --svg.
    let o = play(&["--p0", "random", "--p1", "random", "--balls", "5"]);
    assert_bad_input(&o, "--measures");
    let svg = dir.file("x.svg");
    let o = play(&[
        "--p0",
        "random",
        "--p1",
        "random",
        "--measures",
        "--svg",
        &svg,
    ]);
    assert_bad_input(&o, "--svg");
    let o = play(&[
        "--p0",
        "random",
        "--p1",
        "random",
        "--measures",
        "--balls",
        "0",
    ]);
    assert_bad_input(&o, "--balls must be in 1..=1000000, found 0");
}

fn assert_bad_input(o: &Output, needle: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{needle:?}: stderr: {err}");
    assert_eq!(err.lines().count(), 1, "one line, got: {err}");
    assert!(
        !err.contains("panicked") && err.contains(needle),
        "{needle:?}: {err}"
    );
}

/// Every bad folder: one line naming the problem, exit 2, no output file.
#[test]
fn a_bad_player_folder_is_one_line_exit_2_and_nothing_written() {
    let dir = scratch("bad");
    let json = dir.file("out.json");
    let svg = dir.file("out.svg");
    let refused = |player: &str, needle: &str| {
        for seat in ["--p0", "--p1"] {
            let other = if seat == "--p0" { "--p1" } else { "--p0" };
            let o = play(&[
                seat, player, other, "scripted", "--json", &json, "--svg", &svg,
            ]);
            assert_bad_input(&o, needle);
            assert!(!Path::new(&json).exists() && !Path::new(&svg).exists());
            let o = play(&[seat, player, other, "random", "--measures", "--json", &json]);
            assert_bad_input(&o, needle);
            assert!(!Path::new(&json).exists());
        }
    };
    let empty = dir.path("empty");
    std::fs::create_dir(&empty).expect("dir");
    refused(
        empty.to_str().expect("utf-8"),
        "no player.toml in the folder",
    );
    let swap = |from: &str, to: &str| PLAYER_TOML.replace(from, to);
    let cases = [
        ("format", swap("format = 1", "format = 2"), "format 2 is not one this build reads (format 1)"),
        ("unparsable", swap("[actors]", "[actors"), "player.toml:3:"),
        ("unknown", swap("[actors]", "seed = 3\n[actors]"), "unknown field `seed`"),
        (
            "no-actors",
            "format = 1\nlabel = \"x\"\n".to_string(),
            "missing field `actors`",
        ),
        (
            "no-reset",
            swap("reset = \"reset.postcard\"\n", ""),
            "missing field `reset`",
        ),
        (
            "dotdot",
            swap("\"catch.postcard\"", "\"../x.postcard\""),
            "actors.catch = \"../x.postcard\": a `..` component leaves the folder",
        ),
        (
            "inner-dotdot",
            swap("\"catch.postcard\"", "\"sub/../catch.postcard\""),
            "a `..` component leaves the folder",
        ),
        (
            "absolute",
            swap("\"serve.postcard\"", &format!("{:?}", dir.file("abs/serve.postcard"))),
            "actors.serve = ",
        ),
        (
            "missing",
            swap("\"reset.postcard\"", "\"nowhere.postcard\""),
            "actors.reset = \"nowhere.postcard\": cannot read",
        ),
        (
            "wrong-shape",
            swap("\"catch.postcard\"", "\"serve.postcard\""),
            "actors.catch = \"serve.postcard\": not a catch agent (action size: the plant needs 2, found 3; the catch agent takes 10 observations and gives 2 actions)",
        ),
        (
            "a-folder",
            swap("\"catch.postcard\"", "\".\""),
            "actors.catch = \".\": not a file",
        ),
        (
            "long-label",
            swap("\"example\"", &format!("{:?}", "x".repeat(65))),
            "must be at most 64 characters",
        ),
        (
            "critic-missing",
            format!("{PLAYER_TOML}[critics]\ncatch = \"c.postcard\"\nserve = \"c.postcard\"\nreset = \"c.postcard\"\n"),
            "critics.catch = \"c.postcard\": cannot read",
        ),
        (
            "scenario-missing",
            swap("label = \"example\"", "label = \"example\"\nscenario = \"s.toml\""),
            "scenario = \"s.toml\": cannot read",
        ),
    ];
    std::fs::create_dir(dir.path("abs")).expect("dir");
    std::fs::write(
        dir.path("abs/serve.postcard"),
        badminton_actor(3, 1, Encoding::F32, "a"),
    )
    .expect("blob");
    for (name, manifest, needle) in &cases {
        let player = dir.player(name, manifest);
        refused(&player, needle);
    }
    refused(
        &dir.file("absolute"),
        "must be a path relative to the folder",
    );
    // A wrong-shape blob under its own name: an observation size of 2.
    let narrow = dir.player("narrow", PLAYER_TOML);
    std::fs::write(
        Path::new(&narrow).join("reset.postcard"),
        crate::util::random_blob::<16, 1>(1, "nav"),
    )
    .expect("blob");
    refused(
        &narrow,
        "not a reset agent (observation size: the plant needs 10, found 2",
    );
    // A critic given as an actor.
    let critic = dir.player("critic", PLAYER_TOML);
    let shape = policy_core::Shape {
        observations: 10,
        actions: 3,
        width: 8,
        depth: 1,
        choices: 0,
    };
    let bytes = crate::util::runtime_blob(
        policy_core::ModelKind::Critic,
        shape,
        policy_core::Activation::Relu,
        1,
        "critic",
    );
    std::fs::write(Path::new(&critic).join("serve.postcard"), bytes).expect("blob");
    refused(&critic, "not a serve agent");
    // A symbolic link inside the folder to a blob outside it.
    #[cfg(unix)]
    {
        // Moves `file` of `folder` out of it, to `outside`, and links it back in.
        let link_from_outside = |folder: &str, file: &str, outside: &str| {
            let (inside, outside) = (Path::new(folder).join(file), dir.path(outside));
            std::fs::rename(&inside, &outside).expect("move");
            std::os::unix::fs::symlink(&outside, &inside).expect("symlink");
        };
        let linked = dir.player("linked", PLAYER_TOML);
        link_from_outside(&linked, "serve.postcard", "outside.postcard");
        refused(
            &linked,
            "actors.serve = \"serve.postcard\": resolves outside the folder",
        );
        // The manifest itself, linked from outside.
        let manifest_out = dir.player("manifest-link", PLAYER_TOML);
        link_from_outside(&manifest_out, "player.toml", "outside.toml");
        refused(
            &manifest_out,
            "player.toml = \"player.toml\": resolves outside the folder",
        );
        // A link that stays inside is followed.
        let inner = dir.player("inner-link", PLAYER_TOML);
        let inner = Path::new(&inner);
        std::fs::rename(inner.join("serve.postcard"), inner.join("real.postcard")).expect("mv");
        std::os::unix::fs::symlink(inner.join("real.postcard"), inner.join("serve.postcard"))
            .expect("symlink");
        assert!(inner.display().to_string().parse::<PlayerKind>().is_ok());
    }
    // A file, and a name that is neither a word nor a folder.
    let file = dir.file("absolute/player.toml");
    refused(
        &file,
        "a player folder (a directory holding player.toml), found a file",
    );
    refused("smash", "expected scripted or random, or a player folder");
    assert!(!Path::new(&json).exists() && !Path::new(&svg).exists());
}

/// A blob that does not verify: its agent plays the safe state (zero action), the match runs,
/// fails (exit 1), and the report and summary say which agent and why.
#[test]
fn a_corrupt_blob_plays_the_safe_state_and_the_report_says_so() {
    let dir = scratch("corrupt");
    let player = dir.player("p", PLAYER_TOML);
    let serve = Path::new(&player).join("serve.postcard");
    let mut bytes = std::fs::read(&serve).expect("blob");
    let at = bytes.len() / 2;
    bytes[at] ^= 0x10;
    std::fs::write(&serve, bytes).expect("blob");
    let json = dir.file("report.json");
    let o = play(&[
        "--p0", &player, "--p1", "random", "--games", "1", "--json", &json,
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.starts_with("FAIL: p0 example: the serve blob did not boot: blob rejected: ")
            && err.contains("(played the safe state: zero action)"),
        "{err}"
    );
    assert!(
        stdout(&o).contains("safe state (blob did not boot) p0 serve: blob rejected"),
        "{}",
        stdout(&o)
    );
    let report: MatchReport =
        serde_json::from_slice(&std::fs::read(&json).expect("json")).expect("report");
    let errors = &report.players[0].boot_errors;
    assert_eq!(errors.len(), 1, "{errors:?}");
    assert!(
        errors[0].starts_with("serve: blob rejected: checksum"),
        "{errors:?}"
    );
    assert!(!report.pass.passed && report.pass.failures[0].contains("serve blob did not boot"));
    // The safe state: a zero hit, whatever it sees; the other agents still play their blobs.
    let kind: PlayerKind = player.parse().expect("folder");
    let mut p = kind.build(&Config::builtin(), 0, 0);
    let mut hit = [1.0f32; 3];
    p.act(Role::Serve, &[0.5; 10], &mut hit);
    assert_eq!(hit, [0.0; 3]);
    let mut target = [0.0f32; 2];
    p.act(Role::Catch, &[0.5; 10], &mut target);
    assert_ne!(target, [0.0; 2]);
    // --measures says so too, and exits 1.
    let o = play(&[
        "--p0",
        &player,
        "--p1",
        "random",
        "--measures",
        "--balls",
        "5",
        "--points",
        "1",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("p0 serve: blob rejected"),
        "{}",
        stdout(&o)
    );
}
