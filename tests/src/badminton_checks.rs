//! What must hold for any text given to the badminton scenario parser.
//!
//! Shared by the fuzz target `fuzz/fuzz_targets/badminton.rs` and the proptest in
//! `tests/tests/badminton_mutations.rs`.

use firmware_sim::badminton::play::{play_match, Length};
use firmware_sim::badminton::reference::PlayerKind;
use firmware_sim::badminton::Config;

/// Points played from an accepted scenario: enough to serve, rally and score both ways.
const POINTS: u32 = 3;

/// Parses `text` as a badminton scenario: refused in one line, or it plays a few points.
pub fn check(text: &str) {
    match Config::from_toml_str(text, "fuzz.toml") {
        Ok(config) => check_accepted(&config),
        Err(e) => crate::assert_one_line(&e.to_string()),
    }
}

/// An accepted scenario validates and plays three points between the reference players
/// (scripted against random, both seats), ending with a report or a one-line error.
pub fn check_accepted(config: &Config) {
    if let Err(e) = config.validate() {
        panic!("from_toml_str accepted a badminton scenario that does not validate: {e}");
    }
    let seats = [
        [PlayerKind::Scripted, PlayerKind::Random],
        [PlayerKind::Random, PlayerKind::Scripted],
    ];
    for (seed, kinds) in seats.into_iter().enumerate() {
        let seed = seed as u64;
        match play_match(config, &kinds, Length::Points(POINTS), seed, false, |_| {}) {
            Ok(report) => {
                let text = report.summary();
                assert!(!text.is_empty(), "an empty summary");
            }
            Err(e) => crate::assert_one_line(&e.to_string()),
        }
    }
}
