//! `firmware-sim heatmap`: a critic's Q over the court as SVG, and its bad input.

use firmware_sim::badminton::heatmap::{catch_map, serve_map};
use firmware_sim::badminton::Config;
use policy_core::ModelKind;

use crate::util::{badminton_blob, firmware_sim, stderr, Scratch};

const EXAMPLE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/example-player");

fn critic(actions: u16, seed: u64) -> Vec<u8> {
    badminton_blob(ModelKind::Critic, actions, seed, "critic")
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
    let dir = Scratch::new("heatmap-cli", "svg");
    let write = |name: &str, bytes: &[u8]| {
        std::fs::write(dir.path(name), bytes).expect("write");
        dir.file(name)
    };
    let catch = write("catch-critic.postcard", &critic(2, 1));
    let actor = write(
        "catch.postcard",
        &badminton_blob(ModelKind::Actor, 2, 1, "a"),
    );
    let svg = dir.file("catch.svg");
    let ok = firmware_sim(
        "heatmap",
        &[
            "--critic", &catch, "--role", "catch", "--out", &svg, "--grid", "9",
        ],
    );
    assert_eq!(ok.status.code(), Some(0), "{}", stderr(&ok));
    let text = std::fs::read_to_string(&svg).expect("svg");
    assert!(
        text.starts_with("<svg") && text.contains("catch critic"),
        "{}",
        &text[..200]
    );

    let bad = dir.file("bad.svg");
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
        let out = firmware_sim("heatmap", &all);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{all:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(needle), "{needle}: {err}");
        assert!(!dir.path("bad.svg").exists(), "{all:?} wrote its output");
    }
    let nowhere = dir.file("missing/x.svg");
    let out = firmware_sim(
        "heatmap",
        &["--critic", &catch, "--role", "catch", "--out", &nowhere],
    );
    assert_eq!(out.status.code(), Some(2));
}

/// `heatmap --role serve --grid 200` played 8,000,000 serves (minutes) and wrote an SVG of about
/// 400 MB, a square per serve. The serve grid is capped at what the picture can show, and
/// the picture bins its points into the squares it draws, so its size does not grow with the
/// grid.
#[test]
fn a_fine_serve_grid_is_refused_and_the_picture_is_bounded_by_its_squares() {
    use firmware_sim::badminton::heatmap::{svg, MAX_SERVE_GRID};
    let config = Config::builtin();
    let serve = critic(3, 3);
    let e = serve_map(&config, &serve, MAX_SERVE_GRID + 1).expect_err("too fine");
    assert!(
        e.to_string()
            .starts_with("--grid: expected 1..=64 steps per action for a serve map"),
        "{e}"
    );
    let dir = Scratch::new("heatmap-cli", "serve-grid");
    std::fs::write(dir.path("serve-critic.postcard"), &serve).expect("write");
    let out = dir.file("serve.svg");
    let o = firmware_sim(
        "heatmap",
        &[
            "--critic",
            &dir.file("serve-critic.postcard"),
            "--role",
            "serve",
            "--grid",
            "200",
            "--out",
            &out,
        ],
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(!std::path::Path::new(&out).exists());
    // The catch map's finest grid: 40,000 points, drawn as the squares they fall in.
    let catch = catch_map(&config, &critic(2, 1), 200).expect("catch map");
    assert_eq!(catch.points.len(), 40_000);
    let picture = svg(&catch, &config, "fine").expect("svg");
    let coarse = svg(
        &catch_map(&config, &critic(2, 1), 41).expect("catch map"),
        &config,
        "coarse",
    )
    .expect("svg");
    assert!(picture.len() < 100_000, "{} bytes", picture.len());
    let squares = |s: &str| s.matches("<rect").count();
    assert!(
        squares(&picture) <= squares(&coarse) + 40,
        "{} squares for 40,000 points, {} for 1,681",
        squares(&picture),
        squares(&coarse)
    );
}
