//! Margin-behaviour metrics of one test episode (docs/design.md §2).
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
//!
//! The metrics are computed online, tick by tick, keeping only the windows they need (the last
//! `settle_window` positions, the last `stuck_window + 1` positions, a few counters): an
//! episode's memory does not grow with the time limit, unless the evaluation
//! records trajectories for plots. The results are bit for bit those of the definitions above
//! applied to the whole episode (the sums run in the same order); a property test checks it.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use super::geometry::Vec2;
use super::scenario::{Metrics, Scenario};

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

/// One episode being measured: fed every tick ([`EpisodeMeter::push`]), turned into an
/// [`EpisodeRecord`] at the end ([`EpisodeMeter::record`]).
#[derive(Debug)]
pub(crate) struct EpisodeMeter {
    seed: u64,
    start: Vec2,
    metrics: Metrics,
    goal_radius: f64,
    goal_hold: u32,
    steps: u32,
    contact_steps: u32,
    end: Vec2,
    min_distance: f64,
    /// The last `settle_window` positions.
    settle: Window,
    /// Consecutive steps within `goal_radius` so far.
    hold: u32,
    steps_to_goal: Option<u32>,
    stuck: StuckDetector,
    /// Positions from the start, when the evaluation records trajectories.
    trajectory: Option<Vec<[f32; 2]>>,
    /// Steps whose command was saturated, per action dimension (counted by the loop).
    pub saturated: Vec<u32>,
    /// The episode ended by leaving the arena.
    pub left_arena: bool,
}

impl EpisodeMeter {
    /// An episode of scenario `s` starting at `start`, with `actions` action dimensions.
    pub(crate) fn new(
        seed: u64,
        start: Vec2,
        actions: usize,
        s: &Scenario,
        keep_trajectory: bool,
    ) -> EpisodeMeter {
        let m = &s.metrics;
        EpisodeMeter {
            seed,
            start,
            metrics: m.clone(),
            goal_radius: s.goal_radius,
            goal_hold: s.goal_hold,
            steps: 0,
            contact_steps: 0,
            end: start,
            min_distance: start.norm(),
            settle: Window::new(m.settle_window),
            hold: 0,
            steps_to_goal: None,
            stuck: StuckDetector::new(s, start),
            trajectory: keep_trajectory.then(|| vec![[start.x as f32, start.y as f32]]),
            saturated: vec![0; actions],
            left_arena: false,
        }
    }

    /// Takes in one tick.
    pub(crate) fn push(&mut self, t: Tick) {
        self.steps += 1;
        self.contact_steps += u32::from(t.touched);
        let p = t.position;
        self.end = p;
        self.min_distance = self.min_distance.min(p.norm());
        self.settle.push(p);
        self.hold = if p.norm() <= self.goal_radius {
            self.hold + 1
        } else {
            0
        };
        if self.hold >= self.goal_hold && self.steps_to_goal.is_none() {
            self.steps_to_goal = Some(self.steps);
        }
        self.stuck.push(self.steps, &t);
        if let Some(path) = &mut self.trajectory {
            path.push([p.x as f32, p.y as f32]);
        }
    }

    /// The episode's record.
    pub(crate) fn record(self) -> EpisodeRecord {
        let window = &self.settle.positions;
        let settled = mean(window).unwrap_or(self.start);
        let success = !self.left_arena && self.metrics.settled(window.iter().map(|p| p.norm()));
        let stuck_at = self.stuck.found;
        EpisodeRecord {
            seed: self.seed,
            start: [self.start.x, self.start.y],
            end: [self.end.x, self.end.y],
            settled: [settled.x, settled.y],
            error: settled.norm(),
            success,
            reached: self.steps_to_goal.is_some(),
            steps_to_goal: self.steps_to_goal,
            near_pass: self.min_distance <= self.metrics.near_radius,
            min_distance: self.min_distance,
            steps: self.steps,
            contact_steps: self.contact_steps,
            stuck: stuck_at.is_some(),
            stuck_at,
            left_arena: self.left_arena,
            saturated_steps: self.saturated,
            trajectory: self.trajectory.unwrap_or_default(),
        }
    }
}

/// The last `len` positions, oldest first. Grows only as positions arrive, so a window longer
/// than the episode costs no more than the episode.
#[derive(Debug)]
struct Window {
    positions: VecDeque<Vec2>,
    len: usize,
}

impl Window {
    fn new(len: u32) -> Window {
        Window {
            positions: VecDeque::new(),
            len: len as usize,
        }
    }

    fn push(&mut self, p: Vec2) {
        if self.positions.len() == self.len {
            self.positions.pop_front();
        }
        self.positions.push_back(p);
    }
}

/// Finds the first step ending `stuck_window` steps of pushing against a wall without progress.
#[derive(Debug)]
struct StuckDetector {
    window: u32,
    min_command: f64,
    max_progress: f64,
    /// Consecutive steps touching a wall while pushing, so far.
    pushing: u32,
    /// The last `window + 1` positions, the start included: the front is where the current
    /// window began.
    recent: Window,
    /// Step (1-based) at which it was first found stuck.
    found: Option<u32>,
}

impl StuckDetector {
    fn new(s: &Scenario, start: Vec2) -> StuckDetector {
        let m = &s.metrics;
        let mut recent = Window::new(m.stuck_window.saturating_add(1));
        recent.push(start);
        StuckDetector {
            window: m.stuck_window,
            min_command: f64::from(m.stuck_min_command * s.max_step),
            max_progress: m.stuck_max_progress,
            pushing: 0,
            recent,
            found: None,
        }
    }

    /// Takes in step `step` (1-based).
    fn push(&mut self, step: u32, t: &Tick) {
        self.recent.push(t.position);
        self.pushing = if t.touched && t.command >= self.min_command {
            self.pushing + 1
        } else {
            0
        };
        if self.found.is_some() || self.pushing < self.window {
            return;
        }
        if let Some(before) = self.recent.positions.front() {
            if (t.position - *before).norm() <= self.max_progress {
                self.found = Some(step);
            }
        }
    }
}

fn mean(points: &VecDeque<Vec2>) -> Option<Vec2> {
    if points.is_empty() {
        return None;
    }
    let sum = points.iter().fold(Vec2::ZERO, |acc, p| acc + *p);
    Some(sum.scale(1.0 / points.len() as f64))
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn scenario() -> Scenario {
        Scenario::builtin("nav-walls").expect("builtin")
    }

    fn record(ticks: &[Tick], s: &Scenario, keep_trajectory: bool) -> EpisodeRecord {
        let mut meter = EpisodeMeter::new(0, Vec2::new(0.0, -3.6), 2, s, keep_trajectory);
        for t in ticks {
            meter.push(*t);
        }
        meter.record()
    }

    #[test]
    fn pushing_a_wall_without_progress_is_stuck() {
        let tick = Tick {
            position: Vec2::new(0.0, -3.50001),
            touched: true,
            command: 0.25,
        };
        let r = record(&[tick; 25], &scenario(), false);
        assert!(r.stuck && !r.success);
        // The first window ends at step 20 but the move from the start (0.1) is progress.
        assert_eq!(r.stuck_at, Some(21));
    }

    #[test]
    fn sliding_along_a_wall_is_not_stuck() {
        let ticks: Vec<Tick> = (0..40)
            .map(|i| Tick {
                position: Vec2::new(f64::from(i) * 0.1, -3.5),
                touched: true,
                command: 0.25,
            })
            .collect();
        assert!(!record(&ticks, &scenario(), false).stuck);
    }

    #[test]
    fn resting_against_a_wall_without_pushing_is_not_stuck() {
        let tick = Tick {
            position: Vec2::new(0.0, -3.50001),
            touched: true,
            command: 0.0,
        };
        assert!(!record(&[tick; 40], &scenario(), false).stuck);
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
        let r = record(&ticks, &scenario(), true);
        assert!(r.success && r.reached && r.near_pass);
        assert_eq!(r.steps_to_goal, Some(38));
        assert!((r.error - 0.05).abs() < 1e-12);
        assert_eq!(r.trajectory.len(), 49);
    }

    /// The metrics as first written: over the whole stored episode, one slice at a time.
    fn reference(start: Vec2, ticks: &[Tick], s: &Scenario) -> EpisodeRecord {
        let m = &s.metrics;
        let positions: Vec<Vec2> = ticks.iter().map(|t| t.position).collect();
        let window = &positions[positions.len().saturating_sub(m.settle_window as usize)..];
        let settled = mean(&window.iter().copied().collect()).unwrap_or(start);
        let mut run = 0;
        let mut steps_to_goal = None;
        for (i, p) in positions.iter().enumerate() {
            run = if p.norm() <= s.goal_radius {
                run + 1
            } else {
                0
            };
            if run >= s.goal_hold && steps_to_goal.is_none() {
                steps_to_goal = Some(i as u32 + 1);
            }
        }
        let min_distance = positions
            .iter()
            .map(|p| p.norm())
            .fold(start.norm(), f64::min);
        let w = m.stuck_window as usize;
        let min_command = f64::from(m.stuck_min_command * s.max_step);
        let stuck_at = (w..=ticks.len()).find_map(|end| {
            let window = &ticks[end - w..end];
            let before = if end > w {
                ticks[end - w - 1].position
            } else {
                start
            };
            let pushing = window.iter().all(|t| t.touched && t.command >= min_command);
            let progress = (window[w - 1].position - before).norm();
            (pushing && progress <= m.stuck_max_progress).then_some(end as u32)
        });
        let end = positions.last().copied().unwrap_or(start);
        EpisodeRecord {
            seed: 0,
            start: [start.x, start.y],
            end: [end.x, end.y],
            settled: [settled.x, settled.y],
            error: settled.norm(),
            success: !window.is_empty() && window.iter().all(|p| p.norm() <= m.success_radius),
            reached: steps_to_goal.is_some(),
            steps_to_goal,
            near_pass: min_distance <= m.near_radius,
            min_distance,
            steps: ticks.len() as u32,
            contact_steps: ticks.iter().filter(|t| t.touched).count() as u32,
            stuck: stuck_at.is_some(),
            stuck_at,
            left_arena: false,
            saturated_steps: vec![0, 0],
            trajectory: Vec::new(),
        }
    }

    fn tick() -> impl Strategy<Value = Tick> {
        // A coarse grid near the centre and the wall, so holds, settling and stuck windows
        // all happen often.
        (-4i32..=4, -4i32..=4, any::<bool>(), 0u8..=2).prop_map(|(x, y, touched, c)| Tick {
            position: Vec2::new(f64::from(x) * 0.03, f64::from(y) * 0.03 - 0.02),
            touched,
            command: f64::from(c) * 0.125,
        })
    }

    proptest! {
        /// Regression: the metrics stored every tick of an episode, so a
        /// huge time limit grew memory without bound. The online metrics, which keep only
        /// their windows, must equal the whole-episode definitions bit for bit.
        #[test]
        fn online_metrics_equal_the_whole_episode_definitions(
            ticks in prop::collection::vec(tick(), 0..80),
            settle in 1u32..30,
            stuck in 1u32..12,
            hold in 1u32..6,
        ) {
            let mut s = scenario();
            s.metrics.settle_window = settle;
            s.metrics.stuck_window = stuck;
            s.goal_hold = hold;
            s.goal_radius = 0.07;
            s.metrics.near_radius = 0.03;
            let start = Vec2::new(0.0, -0.1);
            let mut meter = EpisodeMeter::new(0, start, 2, &s, false);
            for t in &ticks {
                meter.push(*t);
            }
            prop_assert_eq!(meter.record(), reference(start, &ticks, &s));
        }
    }
}
