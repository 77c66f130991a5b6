//! The plant/environment interface shared by training (host-trainer) and the firmware loop.
//!
//! Gymnasium-style: `reset(seed)` then `step(action)` until `terminated` or `truncated`. The
//! policy sees only the observation; `info` tells the harness what really happened at the
//! margins (the motion the plant applied, whether a margin was touched).

/// A box `low[i] <= x[i] <= high[i]`.
#[derive(Clone, Debug, PartialEq)]
pub struct BoxSpace {
    /// Lower bounds, one per dimension.
    pub low: Vec<f32>,
    /// Upper bounds, one per dimension.
    pub high: Vec<f32>,
}

impl BoxSpace {
    /// Number of dimensions.
    pub fn dim(&self) -> usize {
        self.low.len()
    }
}

/// What the plant did in a step, for the harness and the metrics; never shown to the policy.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepInfo {
    /// The motion the plant actually applied (after walls, limits, faults), in action units.
    pub applied: Vec<f32>,
    /// Whether the step touched a hard margin (a wall, a joint limit).
    pub margin_touched: bool,
}

/// The result of one step.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    /// The next observation.
    pub observation: Vec<f32>,
    /// The reward for this step.
    pub reward: f32,
    /// The episode ended in a terminal state (goal reached, left the arena).
    pub terminated: bool,
    /// The episode was cut by the time limit (not a terminal state for bootstrapping).
    pub truncated: bool,
    /// Ground truth about the step, for the harness.
    pub info: StepInfo,
}

/// A plant with declared observation and action boxes.
pub trait Env {
    /// The observation box (used for documentation and sanity checks; observations may be
    /// outside it only when the plant says so).
    fn observation_space(&self) -> &BoxSpace;
    /// The action box the actuator accepts; actions outside it are saturated by the plant.
    fn action_space(&self) -> &BoxSpace;
    /// Starts a new episode; the same seed gives the same start.
    fn reset(&mut self, seed: u64) -> Vec<f32>;
    /// Applies one action. Non-finite components are treated as 0 by every plant.
    fn step(&mut self, action: &[f32]) -> Step;
}
