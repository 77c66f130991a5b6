use firmware_sim::nav::reference::reference;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::{evaluate_controller, EvalConfig, Report};

fn run(controller: &str, scenario: &str, episodes: usize) -> Report {
    let s = Scenario::builtin(scenario).expect("builtin");
    let mut c = reference(controller, &s).expect("controller");
    let cfg = EvalConfig {
        episodes,
        seed: 3,
        ..EvalConfig::default()
    };
    evaluate_controller(c.as_mut(), &s, &cfg).expect("eval")
}

#[test]
fn straight_is_caught_stuck_at_the_outer_wall_of_the_pinwheel() {
    let r = run("straight", "nav-walls", 60);
    assert!(r.stuck_rate >= 0.6, "stuck rate {}", r.stuck_rate);
    let at_outer = r
        .episodes
        .iter()
        .filter(|e| e.stuck && (e.end[0].abs().max(e.end[1].abs()) - 3.5).abs() < 0.01)
        .count();
    // docs/design.md §2: about two starts in three stop at the outer ring.
    assert!(
        at_outer as f64 >= 0.5 * r.episodes.len() as f64,
        "{at_outer} of {}",
        r.episodes.len()
    );
    assert!(r.contact_fraction > 0.5);
    assert!(!r.pass.passed);
}

#[test]
fn straight_succeeds_without_walls() {
    let r = run("straight", "nav-open", 60);
    assert_eq!(
        (r.success_rate, r.strict_reach_rate, r.stuck_rate),
        (1.0, 1.0, 0.0)
    );
    assert_eq!(r.contact_fraction, 0.0);
    assert!(r.pass.passed);
}

#[test]
fn oracle_follows_the_gaps_of_the_pinwheel() {
    let r = run("oracle", "nav-walls", 60);
    assert_eq!(
        (r.success_rate, r.strict_reach_rate, r.stuck_rate),
        (1.0, 1.0, 0.0)
    );
    assert!(r.mean_error < 1e-6, "{}", r.mean_error);
    assert!(r.pass.passed);
}
