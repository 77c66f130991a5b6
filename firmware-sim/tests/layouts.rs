use firmware_sim::nav::generator::{generate, Kind, CHECK_STARTS};
use firmware_sim::nav::oracle::Oracle;
use firmware_sim::nav::reference::reference;
use firmware_sim::nav::test_protocol::{evaluate_controller, EvalConfig};

#[test]
fn generated_layouts_are_reproducible_valid_and_solved_by_the_oracle() {
    for kind in [Kind::Rings, Kind::Maze] {
        for level in 1..=2 {
            for seed in 0..3 {
                let g = generate(kind, level, seed).expect("a solvable layout");
                let s = &g.scenario;
                assert_eq!(s.name, format!("{}-{level}-seed{seed}", kind.name()));
                s.validate().expect("valid");
                assert_eq!(*s, generate(kind, level, seed).expect("again").scenario);
                assert_ne!(
                    s.walls,
                    generate(kind, level, seed + 100)
                        .expect("another")
                        .scenario
                        .walls,
                    "{} level {level}: seeds {seed} and {} gave one layout",
                    kind.name(),
                    seed + 100
                );
                // Solved from other starts than the check's too.
                let cfg = EvalConfig {
                    episodes: 50,
                    seed: seed + 1000,
                    ..EvalConfig::default()
                };
                let report = evaluate_controller(&mut Oracle::new(s), s, &cfg).expect("runs");
                assert_eq!(report.strict_reach_rate, 1.0, "{}", s.name);
            }
        }
    }
    const { assert!(CHECK_STARTS >= 100) };
}

#[test]
fn generated_rings_have_their_level_in_rings_and_are_margins_for_straight() {
    for level in 1..=4 {
        let s = generate(Kind::Rings, level, 5).expect("layout").scenario;
        // Every ring is a square of four sides, each whole or split around one gap.
        let gaps = usize::from(level) + usize::from(level >= 3);
        assert_eq!(
            s.walls.len(),
            4 * usize::from(level) + gaps,
            "level {level}"
        );
        // Heading straight for the centre is caught at a wall from some starts: the layout
        // has margins that matter.
        let cfg = EvalConfig::default();
        let mut straight = reference("straight", &s).expect("straight");
        let report = evaluate_controller(straight.as_mut(), &s, &cfg).expect("runs");
        assert!(
            report.stuck_rate > 0.1,
            "level {level}: {}",
            report.stuck_rate
        );
    }
}

#[test]
fn a_level_outside_1_to_4_is_refused() {
    for level in [0, 5] {
        let err = generate(Kind::Maze, level, 0)
            .expect_err("refused")
            .to_string();
        assert!(
            err.contains("level") && err.contains("1, 2, 3 or 4"),
            "{err}"
        );
    }
}
