//! A two-joint planar arm whose joints have hard limits: the paper's first kind of margin.
//!
//! The shoulder turns in [-2.6, 2.6] rad and the elbow in [-2.5, 2.5] rad, so neither joint
//! turns all the way round. A target behind the shoulder's gap (near ±π) is close to a start
//! on the other side of the gap the short way round, through the gap, and the short way is
//! exactly what the shoulder's limit forbids: the arm must go the long way. A policy that
//! follows the distance to the target greedily pushes the shoulder into its stop and stays
//! there; that is what the test's "stuck at margin" catches.
//!
//! - action: the two joints' velocity commands in [-1, 1], times [`MAX_STEP`] rad per tick;
//! - a joint that would pass its limit stops at it: the step touched a margin, and `applied`
//!   is the motion carried out, in action units;
//! - observation (6 values): the joint angles over π, the target (x, y), and the hand minus the
//!   target (x, y);
//! - reward: minus the hand's distance to the target over the arm's reach, every step;
//! - success: the hand within [`SUCCESS_RADIUS`] of the target for the last [`HOLD`] steps;
//! - episodes are cut after [`TIME_LIMIT`] steps; start and target come from the reset seed.

use firmware_sim::env::{BoxSpace, Env, Step, StepInfo};

/// Upper arm and forearm lengths.
pub const LINKS: [f32; 2] = [1.0, 0.8];
/// Joint limits, rad: shoulder, elbow.
pub const LIMITS: [f32; 2] = [2.6, 2.5];
/// The largest joint motion per tick, rad.
pub const MAX_STEP: f32 = 0.1;
/// Steps per episode.
pub const TIME_LIMIT: u32 = 100;
/// How near the hand must hold, and for how many steps.
pub const SUCCESS_RADIUS: f32 = 0.1;
/// Steps the hand must hold within [`SUCCESS_RADIUS`].
pub const HOLD: u32 = 10;

/// The arm.
#[derive(Clone, Debug)]
pub struct Arm {
    q: [f32; 2],
    target: [f32; 2],
    steps: u32,
    held: u32,
    observation_space: BoxSpace,
    action_space: BoxSpace,
}

impl Default for Arm {
    fn default() -> Self {
        Arm::new()
    }
}

impl Arm {
    /// The arm at rest, aimed at nothing until the first reset.
    pub fn new() -> Arm {
        let reach = LINKS[0] + LINKS[1];
        Arm {
            q: [0.0; 2],
            target: [reach, 0.0],
            steps: 0,
            held: 0,
            observation_space: BoxSpace {
                low: vec![-1.0, -1.0, -reach, -reach, -2.0 * reach, -2.0 * reach],
                high: vec![1.0, 1.0, reach, reach, 2.0 * reach, 2.0 * reach],
            },
            action_space: BoxSpace {
                low: vec![-1.0; 2],
                high: vec![1.0; 2],
            },
        }
    }

    /// The joint angles.
    pub fn joints(&self) -> [f32; 2] {
        self.q
    }

    /// Where the hand is.
    pub fn hand(&self) -> [f32; 2] {
        forward(self.q)
    }

    fn distance(&self) -> f32 {
        let [x, y] = self.hand();
        (x - self.target[0]).hypot(y - self.target[1])
    }

    fn observation(&self) -> Vec<f32> {
        let [x, y] = self.hand();
        let pi = std::f32::consts::PI;
        let [tx, ty] = self.target;
        vec![self.q[0] / pi, self.q[1] / pi, tx, ty, x - tx, y - ty]
    }
}

/// The hand's position for joint angles `q`.
pub fn forward(q: [f32; 2]) -> [f32; 2] {
    let a = q[0] + q[1];
    [
        LINKS[0] * q[0].cos() + LINKS[1] * a.cos(),
        LINKS[0] * q[0].sin() + LINKS[1] * a.sin(),
    ]
}

/// splitmix64: a small, well-mixed generator, enough for starts and targets from a seed.
fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Uniform in [-limit, limit].
fn within(state: &mut u64, limit: f32) -> f32 {
    let unit = (splitmix(state) >> 40) as f32 / (1u64 << 24) as f32;
    limit * (2.0 * unit - 1.0)
}

impl Env for Arm {
    fn observation_space(&self) -> &BoxSpace {
        &self.observation_space
    }

    fn action_space(&self) -> &BoxSpace {
        &self.action_space
    }

    /// A start and a target, both from joint angles inside the limits (every target is
    /// reachable), drawn from the seed alone.
    fn reset(&mut self, seed: u64) -> Vec<f32> {
        let mut state = seed;
        self.q = [within(&mut state, LIMITS[0]), within(&mut state, LIMITS[1])];
        let goal = [within(&mut state, LIMITS[0]), within(&mut state, LIMITS[1])];
        self.target = forward(goal);
        (self.steps, self.held) = (0, 0);
        self.observation()
    }

    fn step(&mut self, action: &[f32]) -> Step {
        let mut touched = false;
        let mut applied = vec![0.0; 2];
        for j in 0..2 {
            let a = action.get(j).copied().unwrap_or(0.0);
            let a = if a.is_finite() {
                a.clamp(-1.0, 1.0)
            } else {
                0.0
            };
            let wanted = self.q[j] + a * MAX_STEP;
            let reached = wanted.clamp(-LIMITS[j], LIMITS[j]);
            // At a stop, pushing further: the joint stays at its limit.
            touched |= reached != wanted;
            applied[j] = (reached - self.q[j]) / MAX_STEP;
            self.q[j] = reached;
        }
        self.steps += 1;
        let d = self.distance();
        self.held = if d <= SUCCESS_RADIUS {
            self.held + 1
        } else {
            0
        };
        Step {
            observation: self.observation(),
            reward: -d / (LINKS[0] + LINKS[1]),
            terminated: false,
            truncated: self.steps >= TIME_LIMIT,
            info: StepInfo {
                applied,
                margin_touched: touched,
                success: Some(self.held >= HOLD),
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_joint_never_passes_its_limit_and_a_stop_is_a_margin() {
        let mut arm = Arm::new();
        let mut state = 7u64;
        for episode in 0..50 {
            arm.reset(episode);
            for _ in 0..TIME_LIMIT {
                let action = [within(&mut state, 3.0), within(&mut state, 3.0)];
                let before = arm.joints();
                let step = arm.step(&action);
                let q = arm.joints();
                assert!(q[0].abs() <= LIMITS[0] && q[1].abs() <= LIMITS[1], "{q:?}");
                for j in 0..2 {
                    assert!((before[j] + step.info.applied[j] * MAX_STEP - q[j]).abs() < 1e-6);
                }
            }
        }
        arm.reset(1);
        // Far more steps than the shoulder needs to reach its stop.
        let last = (0..60)
            .map(|_| arm.step(&[1.0, 0.0]))
            .last()
            .expect("steps");
        assert_eq!(arm.joints()[0], LIMITS[0]);
        assert!(last.info.margin_touched);
        assert_eq!(last.info.applied[0], 0.0);
    }

    #[test]
    fn the_same_seed_gives_the_same_episode() {
        let run = |seed| {
            let mut arm = Arm::new();
            let mut out = arm.reset(seed);
            for i in 0..TIME_LIMIT {
                let step = arm.step(&[(i as f32 * 0.37).sin(), (i as f32 * 0.11).cos()]);
                out.extend(step.observation);
                out.push(step.reward);
            }
            out
        };
        assert_eq!(run(3), run(3));
        assert_ne!(run(3), run(4));
    }
}
