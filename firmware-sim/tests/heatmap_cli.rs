//! `firmware-sim heatmap`: a critic's Q over the court as SVG, and its bad input.

use std::process::{Command, Output};

use firmware_sim::badminton::heatmap::{catch_map, serve_map};
use firmware_sim::badminton::Config;
use policy_core::{Activation, ModelKind, Shape};

use crate::util::runtime_blob;

const BIN: &str = env!("CARGO_BIN_EXE_firmware-sim");
const EXAMPLE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/example-player");

fn heatmap(args: &[&str]) -> Output {
    Command::new(BIN)
        .arg("heatmap")
        .args(args)
        .output()
        .expect("spawn firmware-sim")
}

fn critic(actions: u16, seed: u64) -> Vec<u8> {
    let shape = Shape {
        observations: 10,
        actions,
        width: 16,
        depth: 2,
        choices: 0,
    };
    runtime_blob(ModelKind::Critic, shape, Activation::Relu, seed, "critic")
}

/// The catch map holds every grid target on the own half and the incoming ball's landing point;
/// the serve map places every serve that lands and counts the rest as net balls; both are the
/// same for the same blob, and differ between critics.
#[test]
fn maps_cover_the_grid_and_follow_the_critic() {
    let config = Config::builtin();
    let (a, b) = (critic(2, 1), critic(2, 2));
    let map = catch_map(&config, &a, 7).expect("catch map");
    assert_eq!(map.points.len(), 49);
    let (l, w) = (config.court.half_length, config.court.half_width);
    assert!(map
        .points
        .iter()
        .all(|&(x, y, q)| { (-l..=0.0).contains(&x) && y.abs() <= w && q.is_finite() }));
    assert!(map.ball.is_some(), "the scripted serve lands");
    let again = catch_map(&config, &a, 7).expect("again");
    assert_eq!((&map.points, map.ball), (&again.points, again.ball));
    assert_ne!(map.points, catch_map(&config, &b, 7).expect("other").points);
    let serve = serve_map(&config, &critic(3, 3), 5).expect("serve map");
    assert_eq!(serve.points.len() + serve.net.0, 125);
    assert!(
        serve.net.0 > 0 && !serve.points.is_empty(),
        "{:?}",
        serve.net
    );
}

/// The CLI writes the SVG and refuses a blob that is not a critic, a critic of the other role's
/// size, a grid of 0 and an output it cannot write, in one line, writing nothing.
#[test]
fn heatmap_writes_svg_and_refuses_bad_input() {
    let dir = std::env::temp_dir().join(format!("heatmap-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("dir");
    let write = |name: &str, bytes: &[u8]| {
        let path = dir.join(name);
        std::fs::write(&path, bytes).expect("write");
        path.display().to_string()
    };
    let catch = write("catch-critic.postcard", &critic(2, 1));
    let actor = {
        let shape = Shape {
            observations: 10,
            actions: 2,
            width: 16,
            depth: 2,
            choices: 0,
        };
        write(
            "catch.postcard",
            &runtime_blob(ModelKind::Actor, shape, Activation::Relu, 1, "a"),
        )
    };
    let svg = dir.join("catch.svg").display().to_string();
    let ok = heatmap(&[
        "--critic", &catch, "--role", "catch", "--out", &svg, "--grid", "9",
    ]);
    assert_eq!(
        ok.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let text = std::fs::read_to_string(&svg).expect("svg");
    assert!(
        text.starts_with("<svg") && text.contains("catch critic"),
        "{}",
        &text[..200]
    );

    let bad = dir.join("bad.svg").display().to_string();
    for (args, needle) in [
        (
            vec!["--critic", &actor, "--role", "catch"],
            "expected critic",
        ),
        (vec!["--critic", &catch, "--role", "serve"], "action size"),
        (
            vec!["--critic", &catch, "--role", "catch", "--grid", "0"],
            "--grid",
        ),
        (vec!["--critic", &catch, "--role", "reset"], "reset"),
        (vec!["--role", "catch"], "--critic"),
        (
            vec!["--player", EXAMPLE, "--role", "catch"],
            "names no critics",
        ),
    ] {
        let mut all = args.clone();
        all.extend(["--out", &bad]);
        let out = heatmap(&all);
        let err = String::from_utf8_lossy(&out.stderr).into_owned();
        assert_eq!(out.status.code(), Some(2), "{all:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(needle), "{needle}: {err}");
        assert!(!dir.join("bad.svg").exists(), "{all:?} wrote its output");
    }
    let nowhere = dir.join("missing/x.svg").display().to_string();
    let out = heatmap(&["--critic", &catch, "--role", "catch", "--out", &nowhere]);
    assert_eq!(out.status.code(), Some(2));
    std::fs::remove_dir_all(&dir).expect("cleanup");
}
