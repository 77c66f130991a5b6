//! What must hold for any text given to the scenario parser.
//!
//! Shared by the fuzz target `fuzz/fuzz_targets/scenario.rs` and the proptest in
//! `tests/tests/scenario_mutations.rs`.

use firmware_sim::env::Env;
use firmware_sim::nav::faults::Faults;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::NavEnv;

/// Parses `text` as a scenario and checks all properties.
pub fn check(text: &str) {
    match Scenario::from_toml_str(text) {
        Ok(s) => check_accepted(&s),
        Err(e) => crate::assert_one_line(&e.to_string()),
    }
}

/// An accepted scenario validates, survives a TOML round trip unchanged, and builds a plant
/// whose observations and rewards are finite.
pub fn check_accepted(s: &Scenario) {
    if let Err(e) = s.validate() {
        panic!("from_toml_str accepted a scenario that does not validate: {e}");
    }
    Faults::default()
        .validate(s, 2)
        .expect("no faults are valid for every scenario");
    let text = toml::to_string(s).expect("an accepted scenario serialises");
    match Scenario::from_toml_str(&text) {
        Ok(again) => assert_eq!(&again, s, "TOML round trip changed the scenario:\n{text}"),
        Err(e) => panic!("re-serialised scenario is refused: {e}\n{text}"),
    }
    check_plant(s);
}

/// A few steps of the plant: actions at the box corners and non-finite ones.
fn check_plant(s: &Scenario) {
    let mut env = NavEnv::new(s).expect("an accepted scenario builds a plant");
    let m = s.max_step;
    for seed in 0..2 {
        let obs = env.reset(seed);
        assert!(
            obs.iter().all(|o| o.is_finite()),
            "reset({seed}) observed {obs:?}"
        );
        for action in [[m, m], [-m, m], [f32::NAN, f32::INFINITY], [m, -m]] {
            let step = env.step(&action);
            assert!(
                step.observation.iter().all(|o| o.is_finite()) && step.reward.is_finite(),
                "step({action:?}) gave observation {:?}, reward {}",
                step.observation,
                step.reward
            );
            if step.terminated || step.truncated {
                break;
            }
        }
    }
}
