//! docs/design.md §3's gates for the reference players, over the counts of games and points they name.

use firmware_sim::badminton::play::{catch_test, play_match, reset_effect, serve_test, Length};
use firmware_sim::badminton::reference::PlayerKind;
use firmware_sim::badminton::Config;

/// The seed of every gate (fixed before the gates were first run).
const SEED: u64 = 2026;

#[test]
fn scripted_beats_random_on_at_least_90_percent_of_non_let_points() {
    let config = Config::builtin();
    for kinds in [
        [PlayerKind::Scripted, PlayerKind::Random],
        [PlayerKind::Random, PlayerKind::Scripted],
    ] {
        let seat = usize::from(kinds[0] == PlayerKind::Random);
        let r =
            play_match(&config, &kinds, Length::Points(1000), SEED, false, |_| {}).expect("match");
        let decided = r.points - r.lets;
        let won = f64::from(r.players[seat].points_won) / f64::from(decided);
        println!("scripted in seat {seat}: won {won:.4} of {decided} non-let points");
        assert!(won >= 0.9, "{won}");
        assert!(r.pass.passed, "{:?}", r.pass.failures);
    }
}

#[test]
fn scripted_catches_at_least_90_percent_of_randoms_in_balls() {
    let config = Config::builtin();
    let mut catcher = PlayerKind::Scripted.build(&config, SEED, 0);
    let mut server = PlayerKind::Random.build(&config, SEED, 1);
    let rate = catch_test(&config, catcher.as_mut(), server.as_mut(), 1000).expect("test");
    let value = rate.value().expect("some balls landed in");
    println!(
        "scripted caught {}/{} = {value:.4} of random's in-balls",
        rate.hits, rate.of
    );
    assert!(value >= 0.9, "{rate:?}");
}

#[test]
fn scripted_serve_error_rate_is_at_most_8_percent() {
    let config = Config::builtin();
    let mut server = PlayerKind::Scripted.build(&config, SEED, 0);
    let rate = serve_test(&config, server.as_mut(), 1000).expect("test");
    let value = rate.value().expect("serves");
    println!(
        "scripted serve errors {}/{} = {value:.4}",
        rate.hits, rate.of
    );
    assert_eq!(rate.of, 1000);
    assert!(value <= 0.08, "{rate:?}");
}

#[test]
fn scripted_against_scripted_ends_at_least_half_its_points_by_a_fault() {
    let config = Config::builtin();
    let kinds = [PlayerKind::Scripted, PlayerKind::Scripted];
    let r = play_match(&config, &kinds, Length::Points(1000), SEED, false, |_| {}).expect("match");
    let faults = f64::from(r.points - r.lets) / f64::from(r.points);
    println!(
        "scripted vs scripted: {} of {} points by a fault ({faults:.4}), {} lets, {} hits",
        r.points - r.lets,
        r.points,
        r.lets,
        r.hits
    );
    assert!(faults >= 0.5, "{faults}");
    assert!(r.pass.passed, "{:?}", r.pass.failures);
}

#[test]
fn the_reset_measure_reports_both_ways() {
    let config = Config::builtin();
    let (on, off) = reset_effect(
        &config,
        PlayerKind::Scripted,
        PlayerKind::Scripted,
        100,
        SEED,
    )
    .expect("measure");
    println!("scripted catch success, reset enabled {on:?}, disabled {off:?}");
    assert!(on.of > 500 && off.of > 500, "{on:?} {off:?}");
    assert!(on.value().expect("balls") >= 0.9);
}
