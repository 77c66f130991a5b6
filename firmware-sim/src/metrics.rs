//! Margin-behaviour metrics of one test episode (DESIGN.md section 2, issue 3 item 4).
//!
//! - **error**: distance from the centre to where the agent settles, the mean position over its
//!   last `settle_window` (20) steps (which also averages a loop);
//! - **success**: every one of those positions is within `success_radius` (2) of the centre,
//!   and the agent did not leave the arena;
//! - **strict reach**: within `goal_radius` (0.1) for `goal_hold` (10) consecutive steps;
//!   **steps to goal** is the step at which that hold completes (where training would end);
//! - **near pass**: within `near_radius` (0.25) at some step;
//! - **stuck at margin**: for `stuck_window` consecutive steps the agent touched a wall every
//!   step, the actuator commanded a step of at least `stuck_min_command · max_step`, and the
//!   agent moved less than `stuck_max_progress` over the window.

use serde::{Deserialize, Serialize};

use crate::geometry::Vec2;
use crate::scenario::Scenario;

/// What the loop saw at one tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Tick {
    /// True position after the step.
    pub position: Vec2,
    /// Whether the step touched a wall.
    pub touched: bool,
    /// Length of the action the plant received.
    pub command: f64,
}

/// The result of one test episode.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpisodeRecord {
    /// The seed the plant was reset with.
    pub seed: u64,
    /// Start position.
    pub start: [f64; 2],
    /// Position after the last step.
    pub end: [f64; 2],
    /// Mean position over the last `settle_window` steps.
    pub settled: [f64; 2],
    /// Distance of `settled` from the centre.
    pub error: f64,
    /// Settled within `success_radius` (see the module docs).
    pub success: bool,
    /// Held within `goal_radius` for `goal_hold` steps.
    pub reached: bool,
    /// Step (1-based) at which the hold completed.
    pub steps_to_goal: Option<u32>,
    /// Came within `near_radius` of the centre.
    pub near_pass: bool,
    /// Closest distance to the centre.
    pub min_distance: f64,
    /// Steps taken (the time limit unless the agent left the arena).
    pub steps: u32,
    /// Steps that touched a wall.
    pub contact_steps: u32,
    /// Pushing without progress while touching a wall for a whole window.
    pub stuck: bool,
    /// Step (1-based) at which it was first found stuck.
    pub stuck_at: Option<u32>,
    /// Left the arena (the episode ended there).
    pub left_arena: bool,
    /// Steps whose command was at (or beyond) the box bound, per action dimension.
    pub saturated_steps: Vec<u32>,
    /// Positions from the start to the end, when the evaluation records trajectories.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub trajectory: Vec<[f32; 2]>,
}

/// Everything recorded during one episode, turned into an [`EpisodeRecord`] at the end.
#[derive(Debug)]
pub(crate) struct Trace {
    pub seed: u64,
    pub start: Vec2,
    pub ticks: Vec<Tick>,
    pub saturated: Vec<u32>,
    pub left_arena: bool,
}

impl Trace {
    /// An empty trace for an episode starting at `start` with `actions` action dimensions.
    pub(crate) fn new(seed: u64, start: Vec2, actions: usize) -> Trace {
        Trace {
            seed,
            start,
            ticks: Vec::new(),
            saturated: vec![0; actions],
            left_arena: false,
        }
    }

    pub(crate) fn record(&self, s: &Scenario, keep_trajectory: bool) -> EpisodeRecord {
        let m = &s.metrics;
        let positions: Vec<Vec2> = self.ticks.iter().map(|t| t.position).collect();
        let window = &positions[positions.len().saturating_sub(m.settle_window as usize)..];
        let settled = mean(window).unwrap_or(self.start);
        let success = !self.left_arena
            && !window.is_empty()
            && window.iter().all(|p| p.norm() <= m.success_radius);
        let steps_to_goal = first_hold(&positions, s.goal_radius, s.goal_hold);
        let min_distance = positions
            .iter()
            .map(|p| p.norm())
            .fold(self.start.norm(), f64::min);
        let stuck_at = self.first_stuck(s);
        let end = positions.last().copied().unwrap_or(self.start);
        EpisodeRecord {
            seed: self.seed,
            start: [self.start.x, self.start.y],
            end: [end.x, end.y],
            settled: [settled.x, settled.y],
            error: settled.norm(),
            success,
            reached: steps_to_goal.is_some(),
            steps_to_goal,
            near_pass: min_distance <= m.near_radius,
            min_distance,
            steps: self.ticks.len() as u32,
            contact_steps: self.ticks.iter().filter(|t| t.touched).count() as u32,
            stuck: stuck_at.is_some(),
            stuck_at,
            left_arena: self.left_arena,
            saturated_steps: self.saturated.clone(),
            trajectory: if keep_trajectory {
                self.trajectory()
            } else {
                Vec::new()
            },
        }
    }

    fn trajectory(&self) -> Vec<[f32; 2]> {
        let start = [self.start.x as f32, self.start.y as f32];
        let rest = self
            .ticks
            .iter()
            .map(|t| [t.position.x as f32, t.position.y as f32]);
        std::iter::once(start).chain(rest).collect()
    }

    /// The first step ending a window of pushing against a wall without progress.
    fn first_stuck(&self, s: &Scenario) -> Option<u32> {
        let w = s.metrics.stuck_window as usize;
        let min_command = f64::from(s.metrics.stuck_min_command * s.max_step);
        for end in w..=self.ticks.len() {
            let window = &self.ticks[end - w..end];
            let before = if end > w {
                self.ticks[end - w - 1].position
            } else {
                self.start
            };
            let pushing = window.iter().all(|t| t.touched && t.command >= min_command);
            let progress = (window[w - 1].position - before).norm();
            if pushing && progress <= s.metrics.stuck_max_progress {
                return Some(end as u32);
            }
        }
        None
    }
}

fn mean(points: &[Vec2]) -> Option<Vec2> {
    if points.is_empty() {
        return None;
    }
    let sum = points.iter().fold(Vec2::ZERO, |acc, p| acc + *p);
    Some(sum.scale(1.0 / points.len() as f64))
}

/// The 1-based step at which the agent has been within `radius` for `hold` consecutive steps.
fn first_hold(positions: &[Vec2], radius: f64, hold: u32) -> Option<u32> {
    let mut run = 0;
    for (i, p) in positions.iter().enumerate() {
        run = if p.norm() <= radius { run + 1 } else { 0 };
        if run >= hold {
            return Some(i as u32 + 1);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scenario() -> Scenario {
        Scenario::builtin("nav-walls").expect("builtin")
    }

    fn trace(ticks: Vec<Tick>) -> Trace {
        Trace {
            seed: 0,
            start: Vec2::new(0.0, -3.6),
            ticks,
            saturated: vec![0, 0],
            left_arena: false,
        }
    }

    #[test]
    fn pushing_a_wall_without_progress_is_stuck() {
        let tick = Tick {
            position: Vec2::new(0.0, -3.50001),
            touched: true,
            command: 0.25,
        };
        let r = trace(vec![tick; 25]).record(&scenario(), false);
        assert!(r.stuck && !r.success);
        // The first window ends at step 20 but the move from the start (0.1) is progress.
        assert_eq!(r.stuck_at, Some(21));
    }

    #[test]
    fn sliding_along_a_wall_is_not_stuck() {
        let ticks = (0..40)
            .map(|i| Tick {
                position: Vec2::new(f64::from(i) * 0.1, -3.5),
                touched: true,
                command: 0.25,
            })
            .collect();
        assert!(!trace(ticks).record(&scenario(), false).stuck);
    }

    #[test]
    fn resting_against_a_wall_without_pushing_is_not_stuck() {
        let tick = Tick {
            position: Vec2::new(0.0, -3.50001),
            touched: true,
            command: 0.0,
        };
        assert!(!trace(vec![tick; 40]).record(&scenario(), false).stuck);
    }

    #[test]
    fn settling_and_holding_at_the_centre() {
        let mut ticks: Vec<Tick> = (0..28)
            .map(|i| Tick {
                position: Vec2::new(3.0 - f64::from(i) * 0.1, 0.0),
                touched: false,
                command: 0.1,
            })
            .collect();
        ticks.extend((0..20).map(|_| Tick {
            position: Vec2::new(0.05, 0.0),
            touched: false,
            command: 0.0,
        }));
        let r = trace(ticks).record(&scenario(), true);
        assert!(r.success && r.reached && r.near_pass);
        assert_eq!(r.steps_to_goal, Some(38));
        assert!((r.error - 0.05).abs() < 1e-12);
        assert_eq!(r.trajectory.len(), 49);
    }
}
