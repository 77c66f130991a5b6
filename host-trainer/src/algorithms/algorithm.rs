//! What the training loop asks of a learning algorithm.
//!
//! The loop in [`crate::run::trainer`] knows nothing about actors, critics, replay or rollouts.
//! Every step it asks the algorithm for an action ([`Algorithm::act`]), runs the plant, and hands
//! the step back ([`Algorithm::learn`]); the algorithm stores it and updates its networks when
//! its own schedule says so. At the end of an episode it asks for the episode's metric values.
//! It exports whatever [`Algorithm::policy_blob`] and [`Algorithm::critic_blob`] return.
//!
//! Every algorithm owns its random streams (`seed::training_stream(seed, name)`), its networks
//! and its buffers, and serialises all of them into the checkpoint, so resuming continues the
//! very run that was interrupted. Checkpoints are taken between episodes only.

use crate::Error;

/// One plant step, as the algorithm learns from it.
#[derive(Clone, Copy, Debug)]
pub struct Step<'a> {
    /// The observation the action was chosen on.
    pub obs: &'a [f32],
    /// The plant's reward (before the algorithm's own reward scale).
    pub reward: f32,
    /// The observation after the step.
    pub next_obs: &'a [f32],
    /// The episode ended in a terminal state (its value is 0).
    pub terminated: bool,
    /// The episode was cut by the time limit (not a terminal state: bootstrap from `next_obs`).
    pub truncated: bool,
    /// Plant steps since the start of the run, this one included.
    pub total_steps: u64,
}

/// What the training loop needs from a learning algorithm.
pub trait Algorithm {
    /// A new episode begins: `episode` episodes are done out of a budget of `episodes`.
    fn start_episode(&mut self, episode: usize, episodes: usize);
    /// The action to execute for `obs`, in plant units, exploration included. The algorithm
    /// remembers what it needs about this choice until [`Algorithm::learn`].
    fn act(&mut self, obs: &[f32]) -> Vec<f32>;
    /// Learns from the step just taken: stores it, and updates when the algorithm's schedule
    /// says so. `Err(what)` names the first non-finite loss (the run has diverged).
    fn learn(&mut self, step: &Step<'_>) -> Result<(), &'static str>;
    /// Sets the exploration σ of the episodes that start from now on, in place of the config's
    /// (a badminton team draws one per game); `None` goes back to the config's schedule.
    /// Algorithms whose exploration has no σ (PPO's learned spread, DQN's ε) ignore it.
    fn set_exploration_sigma(&mut self, _sigma: Option<f32>) {}
    /// Names of the algorithm's own `metrics.csv` columns.
    fn stat_names(&self) -> &'static [&'static str];
    /// The values of those columns for the episode just finished (NaN where nothing ran).
    fn episode_stats(&mut self) -> Vec<f32>;
    /// The exported policy's action for a raw observation, from the trainer's own networks:
    /// bit-exact with policy-core's `Model::act` on [`Algorithm::policy_blob`].
    fn greedy(&self, obs: &[f32]) -> Vec<f32>;
    /// Whether every weight is finite.
    fn is_finite(&self) -> bool;
    /// The policy blob (what gets flashed).
    fn policy_blob(&self, label: &str) -> Result<Vec<u8>, Error>;
    /// The critic blob, for algorithms with a Q(s, a) critic (DCP, DDPG and TD3; Q1 of twins).
    fn critic_blob(&self, label: &str) -> Option<Result<Vec<u8>, Error>>;
}

/// Running means of an algorithm's per-update values over one episode.
#[derive(Clone, Debug, Default)]
pub struct Means {
    sums: Vec<f64>,
    counts: Vec<u32>,
}

impl Means {
    /// Adds one value to column `i`; NaN values are not counted.
    pub fn add(&mut self, i: usize, v: f32) {
        if self.sums.len() <= i {
            self.sums.resize(i + 1, 0.0);
            self.counts.resize(i + 1, 0);
        }
        if !v.is_nan() {
            self.sums[i] += f64::from(v);
            self.counts[i] += 1;
        }
    }

    /// The means of columns `0..n` (NaN for a column without values), and a fresh start.
    pub fn take(&mut self, n: usize) -> Vec<f32> {
        let out = (0..n)
            .map(|i| match self.counts.get(i) {
                Some(&c) if c > 0 => (self.sums[i] / f64::from(c)) as f32,
                _ => f32::NAN,
            })
            .collect();
        *self = Means::default();
        out
    }
}
