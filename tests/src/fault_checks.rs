//! What must hold for any text given to the fault-string parser (`--faults`).
//!
//! Shared by the fuzz target `fuzz/fuzz_targets/faults.rs` and the proptest in
//! `tests/tests/fault_mutations.rs`.

use std::sync::OnceLock;

use firmware_sim::nav::faults::Faults;
use firmware_sim::nav::scenario::{Scenario, BUILTIN_NAMES};
use firmware_sim::nav::test_protocol::EvalConfig;
use firmware_sim::sensor::DropoutMode;

/// Parses `text` as a fault list and checks all properties against the built-in scenarios.
pub fn check(text: &str) {
    let faults = match text.parse::<Faults>() {
        Ok(f) => f,
        Err(e) => return crate::assert_one_line(&e.to_string()),
    };
    let canonical = spec(&faults);
    match canonical.parse::<Faults>() {
        Ok(again) => assert_eq!(spec(&again), canonical, "fault list round trip"),
        Err(e) => panic!("canonical form {canonical:?} of {text:?} is refused: {e}"),
    }
    for scenario in builtins() {
        check_against(&faults, scenario);
    }
}

/// The built-in scenarios, parsed once (a fuzzer calls [`check`] millions of times).
fn builtins() -> &'static [Scenario] {
    static BUILTINS: OnceLock<Vec<Scenario>> = OnceLock::new();
    BUILTINS.get_or_init(|| {
        BUILTIN_NAMES
            .iter()
            .map(|n| Scenario::builtin(n).expect("built-in scenarios parse"))
            .collect()
    })
}

/// The canonical fault string of `faults` (firmware-sim has no `Display` for them yet): the
/// items in the order dropout, stuck, wall, numbers in Rust's shortest round-trip form.
pub fn spec(faults: &Faults) -> String {
    let mut items = Vec::new();
    if let Some(d) = faults.dropout {
        let mode = match d.mode {
            DropoutMode::Nan => "nan",
            DropoutMode::Stale => "stale",
        };
        items.push(format!("dropout-{mode}:{}", d.probability));
    }
    if let Some(s) = faults.stuck {
        items.push(format!("stuck:{}@{}", s.dim, s.from_tick));
    }
    if let Some(w) = faults.wall {
        let ([x0, y0], [x1, y1]) = (w.wall.from, w.wall.to);
        let mut item = format!("wall:{}@{x0}/{y0}/{x1}/{y1}", w.at_tick);
        if let Some(i) = w.replaces {
            item.push_str(&format!("@{i}"));
        }
        items.push(item);
    }
    items.join(",")
}

/// Faults that validate against a scenario are usable in it: probabilities in `[0, 1]`, a
/// stuck dimension that exists, a changed wall layout that is a valid scenario.
fn check_against(faults: &Faults, scenario: &Scenario) {
    let valid = faults.validate(scenario, 2);
    let config = EvalConfig {
        faults: faults.clone(),
        ..EvalConfig::default()
    };
    assert_eq!(
        config.validate(scenario).is_ok(),
        valid.is_ok(),
        "EvalConfig disagrees"
    );
    if let Err(e) = valid {
        return crate::assert_one_line(&e.to_string());
    }
    if let Some(d) = faults.dropout {
        assert!(
            (0.0..=1.0).contains(&d.probability),
            "dropout {}",
            d.probability
        );
    }
    if let Some(s) = faults.stuck {
        assert!(s.dim < 2, "stuck dimension {}", s.dim);
    }
    if faults.wall.is_some() {
        let walls = faults
            .changed_walls(scenario)
            .expect("a valid wall change applies");
        let changed = Scenario {
            walls,
            ..scenario.clone()
        };
        if let Err(e) = changed.validate() {
            panic!("a validated wall change gives an invalid scenario: {e}");
        }
    }
}
