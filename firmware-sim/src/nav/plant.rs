//! The navigation plant of experiment 1 (docs/design.md §2): blind navigation among walls.
//!
//! The agent sees only its position and moves by a step in the box `[-0.25, 0.25]²`. Walls are
//! zero-thickness segments resolved exactly by [`super::geometry`]: moving into one keeps only
//! the parallel component. An episode ends when the agent leaves the arena (terminal, with a
//! penalty that makes leaving never better than staying), when it stays within 0.1 of the
//! centre for 10 consecutive steps (terminal), or after 200 steps (truncation).
//!
//! ```
//! use firmware_sim::env::Env;
//! use firmware_sim::nav::NavEnv;
//! use firmware_sim::nav::scenario::Scenario;
//! let mut env = NavEnv::new(&Scenario::builtin("nav-open").unwrap()).unwrap();
//! let obs = env.reset(3);
//! // The start is one step inside the boundary of [-6, 6]².
//! assert!(obs.iter().any(|c| (c.abs() - 5.75).abs() < 1e-6));
//! let toward = [-obs[0].signum() * 0.25, -obs[1].signum() * 0.25];
//! let step = env.step(&toward);
//! assert!(step.reward > 0.0 && !step.terminated && !step.info.margin_touched);
//! ```

use rand_core::SeedableRng;

use super::geometry::{push_out, resolve, Segment, Vec2};
use super::scenario::{Scenario, StartRule};
use crate::boot::PlantSizes;
use crate::env::{BoxSpace, Env, Step, StepInfo};
use crate::seed::{uniform, SimRng};
use crate::Error;

/// The navigation plant.
#[derive(Clone, Debug)]
pub struct NavEnv {
    scenario: Scenario,
    walls: Vec<Segment>,
    observation_space: BoxSpace,
    action_space: BoxSpace,
    position: Vec2,
    steps: u32,
    hold: u32,
    /// Consecutive steps within the success radius: the plant's success flag is the
    /// scenario's settled rule ([`crate::nav::scenario::Metrics::settled`]) on them, or
    /// `reached`.
    settled: u32,
    /// The goal ended the episode with the agent within the success radius: a success too,
    /// though the episode is over before `settle_window` steps could fill (the trainer's rule
    /// for a scenario's episodes, host-trainer's `run_episode`, counts it the same way).
    reached: bool,
    ended: Option<(bool, bool)>,
    goal_terminates: bool,
}

impl NavEnv {
    /// Builds the plant for a scenario (validated again here, so a hand-edited `Scenario` value
    /// cannot build a broken plant).
    pub fn new(scenario: &Scenario) -> Result<NavEnv, Error> {
        scenario.validate()?;
        let h = scenario.arena_half_size as f32;
        let m = scenario.max_step;
        // The step that leaves the arena ends up to one step past its edge: the box holds every
        // observation the plant gives, as Gymnasium's contract asks.
        let reach = h + m;
        Ok(NavEnv {
            walls: scenario.segments(),
            observation_space: BoxSpace {
                low: vec![-reach; 2],
                high: vec![reach; 2],
            },
            action_space: BoxSpace {
                low: vec![-m; 2],
                high: vec![m; 2],
            },
            position: Vec2::ZERO,
            steps: 0,
            hold: 0,
            settled: 0,
            reached: false,
            ended: None,
            goal_terminates: true,
            scenario: scenario.clone(),
        })
    }

    /// Whether reaching the goal ends the episode (true, the training rule). The test protocol
    /// runs every episode for the full time limit, so the harness turns it off.
    ///
    /// ```
    /// use firmware_sim::env::Env;
    /// use firmware_sim::nav::geometry::Vec2;
    /// use firmware_sim::nav::NavEnv;
    /// use firmware_sim::nav::scenario::Scenario;
    /// let mut env = NavEnv::new(&Scenario::builtin("nav-open").unwrap()).unwrap();
    /// env.reset(0);
    /// env.set_goal_terminates(false);
    /// env.set_position(Vec2::ZERO);
    /// assert!((0..50).all(|_| !env.step(&[0.0, 0.0]).terminated));
    /// assert_eq!(env.goal_hold(), 50);
    /// ```
    pub fn set_goal_terminates(&mut self, on: bool) {
        self.goal_terminates = on;
    }

    /// The scenario the plant was built from.
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    /// The true position (the observation is this, rounded to `f32`).
    pub fn position(&self) -> Vec2 {
        self.position
    }

    /// Puts the agent at `p` (moved out of any wall it would touch). For tests and tools.
    pub fn set_position(&mut self, p: Vec2) {
        self.position = push_out(p, &self.walls);
    }

    /// The current walls.
    pub fn walls(&self) -> &[Segment] {
        &self.walls
    }

    /// Replaces the walls mid-episode (a fault: a wall appears or moves). If a new wall lands
    /// on the agent, the agent is moved out of it by the clearance, to the wall's nearer side.
    ///
    /// ```
    /// use firmware_sim::env::Env;
    /// use firmware_sim::nav::geometry::{Segment, Vec2};
    /// use firmware_sim::nav::NavEnv;
    /// use firmware_sim::nav::scenario::Scenario;
    /// let mut env = NavEnv::new(&Scenario::builtin("nav-open").unwrap()).unwrap();
    /// env.reset(0);
    /// env.set_position(Vec2::new(0.0, 1.0));
    /// env.set_walls(vec![Segment::new(Vec2::new(-2.0, 0.9), Vec2::new(2.0, 0.9))]);
    /// let s = env.step(&[0.0, -0.25]);
    /// assert!(s.info.margin_touched && env.position().y > 0.9);
    /// ```
    pub fn set_walls(&mut self, walls: Vec<Segment>) {
        self.walls = walls;
        self.position = push_out(self.position, &self.walls);
    }

    /// Steps taken in this episode.
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// Consecutive steps the agent has been within the goal radius.
    pub fn goal_hold(&self) -> u32 {
        self.hold
    }

    /// Whether the agent is outside the arena.
    pub fn outside(&self) -> bool {
        let h = self.scenario.arena_half_size;
        self.position.x.abs() > h || self.position.y.abs() > h
    }

    fn observation(&self) -> Vec<f32> {
        vec![self.position.x as f32, self.position.y as f32]
    }

    fn start_point(&self, seed: u64) -> Vec2 {
        let mut rng = SimRng::seed_from_u64(seed);
        let h = self.scenario.arena_half_size;
        match &self.scenario.start {
            StartRule::Boundary { inset } => {
                let along = (2.0 * uniform(&mut rng) - 1.0) * (h - inset);
                let side = (uniform(&mut rng) * 4.0) as u32;
                let across = h - inset;
                match side {
                    0 => Vec2::new(along, -across),
                    1 => Vec2::new(across, along),
                    2 => Vec2::new(-along, across),
                    _ => Vec2::new(-across, -along),
                }
            }
            StartRule::Points { points } => {
                let i = ((uniform(&mut rng) * points.len() as f64) as usize).min(points.len() - 1);
                Vec2::new(points[i][0], points[i][1])
            }
        }
    }

    fn saturate(&self, action: &[f32]) -> Vec2 {
        let m = self.scenario.max_step;
        let c = |i: usize| {
            let a = action.get(i).copied().unwrap_or(0.0);
            f64::from(if a.is_finite() { a.clamp(-m, m) } else { 0.0 })
        };
        Vec2::new(c(0), c(1))
    }
}

impl NavEnv {
    /// The plant's success flag: the last `settle_window` steps were all within the success
    /// radius, or the goal ended the episode within it.
    fn success(&self) -> bool {
        self.reached || self.settled >= self.scenario.metrics.settle_window
    }
}

impl Env for NavEnv {
    fn observation_space(&self) -> &BoxSpace {
        &self.observation_space
    }

    fn action_space(&self) -> &BoxSpace {
        &self.action_space
    }

    /// Draws the start from the seed alone (the same seed gives the same start).
    fn reset(&mut self, seed: u64) -> Vec<f32> {
        self.walls = self.scenario.segments();
        self.position = push_out(self.start_point(seed), &self.walls);
        self.steps = 0;
        self.hold = 0;
        self.settled = 0;
        self.reached = false;
        self.ended = None;
        self.observation()
    }

    /// One step. After the episode has ended, further steps do not move the agent, earn 0 and
    /// repeat the final flags.
    fn step(&mut self, action: &[f32]) -> Step {
        if let Some((terminated, truncated)) = self.ended {
            let info = StepInfo {
                applied: vec![0.0; 2],
                margin_touched: false,
                success: Some(self.success()),
            };
            return Step {
                observation: self.observation(),
                reward: 0.0,
                terminated,
                truncated,
                info,
            };
        }
        let before = self.position;
        let motion = resolve(before, self.saturate(action), &self.walls);
        self.position = motion.end;
        self.steps += 1;
        let s = &self.scenario;
        let (d0, d1) = (before.norm(), self.position.norm());
        self.hold = if d1 <= s.goal_radius {
            self.hold + 1
        } else {
            0
        };
        self.settled = if d1 <= s.metrics.success_radius {
            self.settled + 1
        } else {
            0
        };
        let left = self.outside();
        let reward = if left {
            s.reward.exit_penalty(s.gamma)
        } else {
            s.reward.of_step(d0, d1, s.max_step, s.arena_half_size)
        };
        let at_goal = self.goal_terminates && self.hold >= s.goal_hold;
        let terminated = left || at_goal;
        // A goal radius wider than the success radius is allowed, so the goal alone is not
        // enough: the episode must end within the success radius too.
        self.reached = at_goal && !left && s.metrics.settled([d1]);
        let truncated = !terminated && self.steps >= s.time_limit;
        if terminated || truncated {
            self.ended = Some((terminated, truncated));
        }
        let moved = self.position - before;
        let info = StepInfo {
            applied: vec![moved.x as f32, moved.y as f32],
            margin_touched: motion.touched,
            success: Some(self.success()),
        };
        Step {
            observation: self.observation(),
            reward,
            terminated,
            truncated,
            info,
        }
    }
}

// A scenario builds its plant here, where the plant is, so that the layout's data does not
// depend on the plant that runs it.
impl Scenario {
    /// The plant this scenario describes, behind the interface every caller uses (training and
    /// tools name [`crate::env::Plant`], not a plant type).
    ///
    /// ```
    /// use firmware_sim::nav::scenario::Scenario;
    /// let plant = Scenario::builtin("nav-walls").unwrap().plant().unwrap();
    /// let agents = plant.agents();
    /// assert_eq!((agents.len(), agents[0].observation_space.dim()), (1, 2));
    /// ```
    pub fn plant(&self) -> Result<Box<dyn crate::env::Plant>, Error> {
        Ok(Box::new(NavEnv::new(self)?))
    }
}

impl PlantSizes {
    /// The sizes of the plant a scenario builds.
    ///
    /// ```
    /// use firmware_sim::boot::PlantSizes;
    /// use firmware_sim::nav::scenario::Scenario;
    /// let s = PlantSizes::of(&Scenario::builtin("nav-walls").unwrap()).unwrap();
    /// assert_eq!((s.observations, s.actions), (2, 2));
    /// ```
    pub fn of(scenario: &Scenario) -> Result<PlantSizes, Error> {
        let agent = &scenario.plant()?.agents()[0];
        Ok(PlantSizes {
            observations: agent.observation_space.dim(),
            actions: agent.action_space.dim(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::reward::Reward;
    use super::*;

    fn env(name: &str) -> NavEnv {
        NavEnv::new(&Scenario::builtin(name).expect("builtin")).expect("valid")
    }

    #[test]
    fn starts_are_one_step_inside_the_boundary_and_spread_over_all_sides() {
        let mut e = env("nav-walls");
        let mut sides = [0; 4];
        for seed in 0..200 {
            let o = e.reset(seed);
            let (x, y) = (o[0], o[1]);
            assert!(x.abs() <= 5.75 + 1e-6 && y.abs() <= 5.75 + 1e-6);
            assert!((x.abs().max(y.abs()) - 5.75).abs() < 1e-6, "{x} {y}");
            let side = if y <= -5.75 + 1e-6 {
                0
            } else if x >= 5.75 - 1e-6 {
                1
            } else if y >= 5.75 - 1e-6 {
                2
            } else {
                3
            };
            sides[side] += 1;
        }
        assert!(sides.iter().all(|&n| n > 30), "{sides:?}");
    }

    #[test]
    fn leaving_is_terminal_and_never_better_than_staying() {
        let mut e = env("nav-open");
        e.reset(0);
        e.set_position(Vec2::new(5.9, 0.0));
        let s = e.step(&[0.25, 0.0]);
        assert!(s.terminated && !s.truncated);
        // Staying forever at the worst reward is worth worst / (1 - gamma); leaving is not more.
        let staying_worst: f32 = (0..2000)
            .map(|k| 0.99f32.powi(k) * Reward::Lr.worst())
            .sum();
        assert!(
            s.reward <= staying_worst + 1e-3,
            "{} vs {staying_worst}",
            s.reward
        );
    }

    #[test]
    fn holding_the_centre_for_ten_steps_ends_the_episode() {
        let mut e = env("nav-open");
        e.reset(1);
        e.set_position(Vec2::new(0.05, 0.0));
        for k in 1..=10 {
            let s = e.step(&[0.0, 0.0]);
            assert_eq!(s.terminated, k == 10, "step {k}");
        }
    }

    #[test]
    fn an_episode_the_goal_ends_is_a_success_before_the_settle_window_fills() {
        let mut e = env("nav-walls");
        e.reset(1);
        e.set_position(Vec2::new(0.05, 0.0));
        let flags: Vec<bool> = (0..12)
            .map(|_| e.step(&[0.0, 0.0]).info.success == Some(true))
            .collect();
        // Ten steps at the goal end it (the settle window is 20); the flag rises on the last
        // and stays up on the steps past the end.
        assert_eq!(flags, [vec![false; 9], vec![true; 3]].concat());
        // Within the goal, not yet ended (the harness runs full episodes): the window decides.
        e.reset(1);
        e.set_goal_terminates(false);
        e.set_position(Vec2::new(0.05, 0.0));
        let first_up = (1..=30).find(|_| e.step(&[0.0, 0.0]).info.success == Some(true));
        assert_eq!(first_up, Some(20));
    }

    #[test]
    fn a_goal_wider_than_the_success_radius_is_not_a_success_by_itself() {
        let mut s = Scenario::builtin("nav-open").expect("builtin");
        s.goal_radius = 3.0;
        s.metrics.success_radius = 1.0;
        let mut e = NavEnv::new(&s).expect("a scenario with a wide goal is valid");
        e.reset(1);
        e.set_position(Vec2::new(2.0, 0.0));
        let last = (0..s.goal_hold)
            .map(|_| e.step(&[0.0, 0.0]))
            .last()
            .expect("steps");
        assert!(last.terminated && last.info.success == Some(false));
    }

    #[test]
    fn rewards_follow_the_design_formulas() {
        for (reward, expected) in [
            (Reward::Lr, 1.0f32),
            (Reward::Gr, -2.75 / 6.0),
            (Reward::LrGr, 0.5 * 1.0 + 0.5 * (-2.75 / 6.0)),
        ] {
            let mut s = Scenario::builtin("nav-open").expect("builtin");
            s.reward = reward;
            let mut e = NavEnv::new(&s).expect("env");
            e.reset(0);
            e.set_position(Vec2::new(3.0, 0.0));
            let r = e.step(&[-0.25, 0.0]).reward;
            assert!((r - expected).abs() < 1e-6, "{reward}: {r} vs {expected}");
        }
    }

    #[test]
    fn time_limit_truncates() {
        let mut e = env("nav-open");
        e.reset(2);
        let mut last = None;
        for _ in 0..200 {
            last = Some(e.step(&[0.0, 0.0]));
        }
        let s = last.expect("stepped");
        assert!(s.truncated && !s.terminated);
        assert_eq!(e.step(&[0.25, 0.25]).info.applied, vec![0.0, 0.0]);
    }

    #[test]
    fn non_finite_and_oversized_actions_are_saturated() {
        let mut e = env("nav-open");
        e.reset(4);
        e.set_position(Vec2::new(0.0, 0.0));
        let s = e.step(&[f32::NAN, 9.0]);
        assert_eq!(s.info.applied, vec![0.0, 0.25]);
    }

    #[test]
    fn straight_into_the_outer_wall_is_blocked_and_touched() {
        let mut e = env("nav-walls");
        e.reset(0);
        e.set_position(Vec2::new(0.0, -3.6));
        let s = e.step(&[0.0, 0.25]);
        assert!(s.info.margin_touched);
        assert!(e.position().y < -3.5);
        assert!(
            s.reward > 0.0 && s.reward < 0.5,
            "partial progress: {}",
            s.reward
        );
    }
}
