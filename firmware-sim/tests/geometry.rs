use firmware_sim::env::Env;
use firmware_sim::nav::geometry::{
    nearest_wall_distance, push_out, resolve, resolve_traced, Segment, Vec2, CLEARANCE,
};
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::NavEnv;
use proptest::collection::vec;
use proptest::prelude::*;

/// An independent crossing test (parametric, not the orientation test the crate uses).
fn crosses(p: Vec2, q: Vec2, w: &Segment) -> bool {
    let r = q - p;
    let s = w.b - w.a;
    let denom = r.cross(s);
    if denom.abs() < 1e-300 {
        return false; // parallel: a parallel move cannot cross a zero-thickness wall
    }
    let t = (w.a - p).cross(s) / denom;
    let u = (w.a - p).cross(r) / denom;
    (0.0..=1.0).contains(&t) && (0.0..=1.0).contains(&u)
}

fn point(limit: f64) -> impl Strategy<Value = Vec2> {
    (-limit..limit, -limit..limit).prop_map(|(x, y)| Vec2::new(x, y))
}

fn wall() -> impl Strategy<Value = Segment> {
    (point(3.0), point(3.0))
        .prop_filter("non-degenerate", |(a, b)| (*a - *b).norm() > 0.01)
        .prop_map(|(a, b)| Segment::new(a, b))
}

fn pinwheel() -> Vec<Segment> {
    Scenario::builtin("nav-walls").expect("builtin").segments()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    /// Whatever the layout (crossing walls, acute corners) and however long the step, no piece
    /// of the path crosses a wall or comes closer than half the clearance.
    #[test]
    fn no_step_crosses_any_wall(
        walls in vec(wall(), 1..8),
        start in point(3.5),
        delta in point(20.0),
    ) {
        let p = push_out(start, &walls);
        prop_assume!(nearest_wall_distance(p, &walls) >= CLEARANCE);
        let mut pieces = 0;
        let m = resolve_traced(p, delta, &walls, |a, b| {
            pieces += 1;
            for w in &walls {
                assert!(!crosses(a, b, w), "piece {a:?} -> {b:?} crosses {w:?}");
            }
        });
        prop_assert!(nearest_wall_distance(m.end, &walls) >= 0.5 * CLEARANCE);
        prop_assert!(m.end.x.is_finite() && m.end.y.is_finite());
        prop_assert!(pieces <= firmware_sim::nav::geometry::MAX_SUBMOVES);
    }

    /// Walls joined end to end (V shapes, zig-zags, acute corners) and steps of every scale,
    /// from 1e-7 to 20 units, repeated: still no piece of any path crosses a wall.
    #[test]
    fn joined_walls_and_tiny_or_huge_steps_never_cross(
        vertices in vec(point(3.0), 3..7),
        start in point(3.5),
        steps in vec((point(1.0), prop_oneof![Just(1e-7), Just(1e-3), Just(0.25), Just(20.0)]), 1..40),
    ) {
        let walls: Vec<Segment> = vertices
            .windows(2)
            .filter(|v| (v[0] - v[1]).norm() > 0.01)
            .map(|v| Segment::new(v[0], v[1]))
            .collect();
        prop_assume!(!walls.is_empty());
        let mut p = push_out(start, &walls);
        prop_assume!(nearest_wall_distance(p, &walls) >= CLEARANCE);
        for (direction, scale) in steps {
            p = resolve_traced(p, direction.scale(scale), &walls, |a, b| {
                for w in &walls {
                    assert!(!crosses(a, b, w), "piece {a:?} -> {b:?} crosses {w:?}");
                }
            })
            .end;
            prop_assert!(nearest_wall_distance(p, &walls) >= 0.5 * CLEARANCE);
        }
    }

    /// Against a wall, the parallel component of the motion survives in full and the normal
    /// component stops at the wall (any orientation, any approach).
    #[test]
    fn only_the_parallel_component_survives(
        angle in 0.0..std::f64::consts::TAU,
        offset in -3.0..3.0f64,
        gap in 0.001..0.3f64,
        along in -1.0..1.0f64,
        beyond in 0.01..1.0f64,
    ) {
        let tau = Vec2::new(angle.cos(), angle.sin());
        let n = tau.perp();
        let w = Segment::new(tau.scale(-10.0), tau.scale(10.0));
        let p = tau.scale(offset) + n.scale(gap);
        let delta = tau.scale(along) - n.scale(gap + beyond);
        let m = resolve(p, delta, &[w]);
        let expected = p + tau.scale(along) + n.scale(CLEARANCE - gap);
        prop_assert!(m.touched);
        prop_assert!((m.end - expected).norm() < 1e-9, "{:?} vs {:?}", m.end, expected);
    }

    /// A random walk in the pinwheel that starts inside the inner ring leaves it only through
    /// the gap in its north side, and never crosses any wall, even with steps four times the
    /// plant's.
    #[test]
    fn the_inner_ring_is_left_only_through_its_gap(
        start in point(0.95),
        steps in vec(point(1.0), 1..120),
    ) {
        let walls = pinwheel();
        let mut p = push_out(start, &walls);
        for d in steps {
            p = resolve_traced(p, d, &walls, |a, b| {
                for w in &walls {
                    assert!(!crosses(a, b, w), "{a:?} -> {b:?} crosses {w:?}");
                }
                let inside = |q: Vec2| q.x.abs() < 1.0 && q.y.abs() < 1.0;
                if inside(a) && !inside(b) {
                    // Where the piece crosses y = 1 (the only open side).
                    let t = (1.0 - a.y) / (b.y - a.y);
                    let x = a.x + t * (b.x - a.x);
                    assert!(b.y > 1.0 && x.abs() < 0.3, "left the ring at {b:?} from {a:?}");
                }
            })
            .end;
        }
    }

    /// Through the plant: every applied motion is within the action box and the position never
    /// becomes non-finite, for any action, NaN and infinities included.
    #[test]
    fn plant_motion_stays_in_the_box(
        seed in any::<u64>(),
        actions in vec(prop_oneof![
            Just(f32::NAN), Just(f32::INFINITY), Just(-1e30f32), -1.0f32..1.0f32
        ], 2..80),
    ) {
        let mut env = NavEnv::new(&Scenario::builtin("nav-walls").expect("builtin")).expect("env");
        env.reset(seed);
        for a in actions.chunks_exact(2) {
            let s = env.step(a);
            prop_assert!(s.info.applied.iter().all(|v| v.is_finite() && v.abs() <= 0.25 + 1e-6));
            prop_assert!(s.observation.iter().all(|v| v.is_finite()));
            if s.terminated || s.truncated {
                break;
            }
        }
    }
}

/// Regression guard for the rounding-tilted contact normal: computing the normal from the
/// 1e-5 offset to the closest point leaked about 1e-11 of normal motion into every slide.
#[test]
fn sliding_along_a_long_wall_keeps_the_exact_clearance() {
    let w = Segment::new(Vec2::new(-5.0, 0.0), Vec2::new(5.0, 0.0));
    let mut p = Vec2::new(-4.0, 0.1);
    for _ in 0..30 {
        p = resolve(p, Vec2::new(0.25, -0.25), &[w]).end;
    }
    assert!((p.y - CLEARANCE).abs() < 1e-15, "{}", p.y);
}
