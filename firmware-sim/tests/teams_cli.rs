//! `firmware-sim teams`: team against team from trained player folders, and its bad input.

use std::path::Path;
use std::process::Output;

use crate::util::{firmware_sim, stderr, Scratch};

const EXAMPLE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/example-player");

fn teams(args: &[&str]) -> Output {
    firmware_sim("teams", args)
}

/// A team folder of two copies of the example player (under `players/`, as `host-trainer team`
/// writes it).
fn team_folder(dir: &Path) -> String {
    for p in ["p00", "p01"] {
        let to = dir.join("players").join(p);
        std::fs::create_dir_all(&to).expect("dir");
        for entry in std::fs::read_dir(EXAMPLE).expect("example") {
            let from = entry.expect("entry").path();
            std::fs::copy(&from, to.join(from.file_name().expect("name"))).expect("copy");
        }
    }
    dir.display().to_string()
}

/// Every point is played by one player of each team; the scores add up; the same seed writes
/// the same JSON bytes; scripted beats the untrained example team; bad input is one line, exit
/// 2, nothing written.
#[test]
fn teams_play_pairings_and_refuse_bad_input() {
    let dir = Scratch::new("teams-cli", "play");
    let team = team_folder(&dir.path("team"));
    let (first, second) = (dir.file("a.json"), dir.file("b.json"));
    for out in [&first, &second] {
        let o = teams(&[
            "--a", &team, "--b", "scripted", "--points", "30", "--json", out,
        ]);
        assert_eq!(
            o.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    let (a, b) = (
        std::fs::read(&first).expect("a"),
        std::fs::read(&second).expect("b"),
    );
    assert_eq!(a, b, "same seed, same bytes");
    let report: serde_json::Value = serde_json::from_slice(&a).expect("json");
    assert_eq!(report["points"], 30);
    let won = |t: usize| report["won"][t].as_u64().expect("won");
    assert_eq!(won(0) + won(1) + report["lets"].as_u64().expect("lets"), 30);
    assert!(won(1) > won(0), "scripted beats random weights: {report}");
    let played: u64 = (report["players"][0].as_array().expect("team A").iter())
        .map(|p| p["played"].as_u64().expect("played"))
        .sum();
    assert_eq!(played, 30);

    let bad = dir.file("bad.json");
    std::fs::create_dir_all(dir.path("empty")).expect("dir");
    let empty = dir.file("empty");
    for (args, needle) in [
        (vec!["--a", &empty, "--b", "scripted"], "no player folder"),
        (
            vec!["--a", "scripted", "--b", "random", "--points", "0"],
            "points",
        ),
        (vec!["--a", "nobody", "--b", "random"], "nobody"),
    ] {
        let mut all = args.clone();
        all.extend(["--json", &bad]);
        let o = teams(&all);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{all:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(needle), "{needle}: {err}");
        assert!(!Path::new(&bad).exists(), "{all:?} wrote its output");
    }
}

/// `teams` exited 1 with nothing on stderr when a player's blob did not boot, where `match`
/// prints `FAIL:`; now it says why on stderr too.
#[test]
fn teams_with_a_blob_that_does_not_boot_says_fail_on_stderr() {
    let dir = Scratch::new("teams-cli", "fail");
    let team = team_folder(&dir.path("team"));
    let blob = Path::new(&team).join("players/p00/catch.postcard");
    let mut bytes = std::fs::read(&blob).expect("blob");
    let last = bytes.len() - 1;
    bytes[last] ^= 0xFF;
    std::fs::write(&blob, bytes).expect("corrupt");
    let o = teams(&["--a", &team, "--b", "scripted", "--points", "4"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("FAIL: "), "{err}");
    assert!(err.contains("did not boot"), "{err}");
}

/// A player folder without `player.toml` among a team's players (an export killed mid-way)
/// was skipped, and the smaller team played with exit 0: it is refused in one line, naming the
/// folder. A hidden folder (where an export writes before its players take their place) is not
/// a player.
#[test]
fn a_player_folder_without_its_manifest_is_refused_not_skipped() {
    let dir = Scratch::new("teams-cli", "incomplete");
    let team = team_folder(&dir.path("team"));
    std::fs::create_dir_all(dir.path("team/players/.players.partial/p00")).expect("dir");
    let ok = teams(&["--a", &team, "--b", "scripted", "--points", "4"]);
    assert_eq!(ok.status.code(), Some(0), "{}", stderr(&ok));
    let cut = dir.path("team/players/p02");
    std::fs::create_dir_all(&cut).expect("dir");
    std::fs::copy(
        Path::new(EXAMPLE).join("catch.postcard"),
        cut.join("catch.postcard"),
    )
    .expect("copy");
    let o = teams(&["--a", &team, "--b", "scripted", "--points", "4"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        err.contains(&format!("{}", cut.display()))
            && err.contains("without player.toml: an incomplete player"),
        "{err}"
    );
}
