use firmware_sim::controller::Controller;
use firmware_sim::nav::reference::reference;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::straight::Straight;
use firmware_sim::nav::test_protocol::{evaluate_controller, EvalConfig, Report};

/// Writes the worst commands it can think of, in turn; counts the non-finite components.
struct Garbage {
    tick: usize,
    non_finite: u64,
}

impl Controller for Garbage {
    fn name(&self) -> String {
        "garbage".into()
    }
    fn observations(&self) -> usize {
        2
    }
    fn actions(&self) -> usize {
        2
    }
    fn act(&mut self, _obs: &[f32], action: &mut [f32]) {
        const MENU: [f32; 6] = [f32::NAN, f32::INFINITY, -1e30, 1e30, f32::NEG_INFINITY, 0.1];
        for (i, a) in action.iter_mut().enumerate() {
            *a = MENU[(self.tick + 3 * i) % MENU.len()];
            self.non_finite += u64::from(!a.is_finite());
        }
        self.tick += 1;
    }
}

fn run(c: &mut dyn Controller, scenario: &str, cfg: EvalConfig) -> Report {
    let s = Scenario::builtin(scenario).expect("builtin");
    evaluate_controller(
        c,
        &s,
        &EvalConfig {
            record_trajectories: true,
            ..cfg
        },
    )
    .expect("eval")
}

fn cfg(episodes: usize, faults: &str) -> EvalConfig {
    EvalConfig {
        episodes,
        faults: faults.parse().expect("faults"),
        ..EvalConfig::default()
    }
}

/// Largest per-axis motion between consecutive recorded positions.
fn largest_move(r: &Report) -> f32 {
    r.episodes
        .iter()
        .flat_map(|e| {
            e.trajectory
                .windows(2)
                .map(|w| (w[1][0] - w[0][0]).abs().max((w[1][1] - w[0][1]).abs()))
        })
        .fold(0.0, f32::max)
}

#[test]
fn nothing_non_finite_or_out_of_bounds_reaches_the_plant() {
    let mut g = Garbage {
        tick: 0,
        non_finite: 0,
    };
    let r = run(&mut g, "nav-walls", cfg(3, ""));
    assert_eq!(r.sanitized_commands, g.non_finite);
    assert!(g.non_finite > 0);
    assert!(r
        .episodes
        .iter()
        .flat_map(|e| &e.trajectory)
        .flatten()
        .all(|v| v.is_finite()));
    assert!(largest_move(&r) <= 0.25 + 1e-5, "{}", largest_move(&r));
    // Five of the six commands on the menu are non-finite or beyond the bound.
    assert!(
        r.saturation_fraction
            .iter()
            .all(|f| (f - 5.0 / 6.0).abs() < 0.02),
        "{:?}",
        r.saturation_fraction
    );
}

#[test]
fn nan_dropouts_freeze_a_controller_that_cannot_read() {
    let mut s = Straight { max_step: 0.25 };
    let r = run(&mut s, "nav-open", cfg(5, "dropout-nan:1.0"));
    assert!(r.episodes.iter().all(|e| e.start == e.end));
    let r = run(&mut s, "nav-open", cfg(5, "dropout-nan:0.3"));
    assert_eq!(
        r.success_rate, 1.0,
        "straight still gets there, more slowly"
    );
}

#[test]
fn stale_readings_make_straight_overshoot_and_leave() {
    // Every reading after the first repeats the first: straight keeps its first heading
    // across the centre and out of the far side.
    let r = run(
        &mut Straight { max_step: 0.25 },
        "nav-open",
        cfg(5, "dropout-stale:1.0"),
    );
    assert_eq!(r.left_arena_rate, 1.0);
    assert!(r.episodes.iter().all(|e| e.steps < 200));
}

#[test]
fn a_stuck_actuator_holds_its_value() {
    let r = run(
        &mut Straight { max_step: 0.25 },
        "nav-open",
        cfg(5, "stuck:0@0"),
    );
    assert!(
        r.episodes.iter().all(|e| e.end[0] == e.start[0]),
        "x never moves"
    );
    assert!(
        r.episodes.iter().any(|e| e.end[1] != e.start[1]),
        "y still does"
    );
}

#[test]
fn the_rate_limit_bounds_the_change_per_tick() {
    let c = EvalConfig {
        actuator: firmware_sim::actuator::ActuatorModel {
            rate_limit: Some(0.02),
        },
        ..cfg(4, "")
    };
    let r = run(&mut Straight { max_step: 0.25 }, "nav-open", c);
    for e in &r.episodes {
        for w in e.trajectory.windows(3) {
            let change = |d: usize| (w[2][d] - w[1][d]) - (w[1][d] - w[0][d]);
            assert!(
                change(0).abs() <= 0.02 + 1e-5 && change(1).abs() <= 0.02 + 1e-5,
                "{w:?}"
            );
        }
    }
    assert_eq!(r.success_rate, 1.0);
}

#[test]
fn a_wall_that_appears_mid_episode_is_never_crossed() {
    // A long wall appears across the north half at tick 5.
    let r = run(
        &mut Straight { max_step: 0.25 },
        "nav-open",
        cfg(40, "wall:5@-5/2/5/2"),
    );
    let mut blocked = 0;
    for e in &r.episodes {
        let from_north = e.start[1] > 2.0 && e.start[0].abs() < 5.0;
        for w in e.trajectory.windows(2).skip(5) {
            assert!(
                !((w[0][1] > 2.0) && (w[1][1] < 2.0) && w[1][0].abs() < 5.0),
                "crossed at {w:?}"
            );
        }
        if from_north {
            blocked += 1;
            assert!(e.stuck && e.end[1] > 2.0, "{e:?}");
        }
    }
    assert!(blocked > 0);
}

#[test]
fn a_wall_that_moves_onto_the_agent_pushes_it_out_not_through() {
    // Inner south wall (index 8) jumps to y = -3.0 at tick 0, where some agents stand.
    let s = Scenario::builtin("nav-walls").expect("builtin");
    let mut oracle = reference("oracle", &s).expect("oracle");
    let r = run(oracle.as_mut(), "nav-walls", cfg(20, "wall:0@-1/-3/1/-3@8"));
    assert!(r
        .episodes
        .iter()
        .flat_map(|e| &e.trajectory)
        .flatten()
        .all(|v| v.is_finite()));
    // The oracle's map is stale (the inner south side is now open, and a new wall stands
    // below); it still reaches the centre from every start.
    assert_eq!(r.success_rate, 1.0);
}

#[test]
fn sensor_noise_quantisation_and_delay_are_tolerated_by_straight() {
    let mut c = cfg(10, "");
    c.sensor.noise_std = 0.01;
    c.sensor.quantum = 0.05;
    c.sensor.delay = true;
    let r = run(&mut Straight { max_step: 0.25 }, "nav-open", c);
    assert_eq!(r.success_rate, 1.0);
    assert!(r.mean_error < 0.2, "{}", r.mean_error);
}

#[test]
fn bad_fault_settings_are_refused() {
    let s = Scenario::builtin("nav-walls").expect("builtin");
    for spec in [
        "dropout-nan:1.5",
        "stuck:2@0",
        "wall:0@0/0/9/0",
        "wall:0@0/0/1/0@99",
    ] {
        let c = cfg(1, spec);
        let e = evaluate_controller(&mut Straight { max_step: 0.25 }, &s, &c).expect_err(spec);
        assert!(e.to_string().starts_with("faults:"), "{e}");
    }
}
