//! The algorithm plug-in: what the training loop asks of a learning algorithm, and the one
//! place that lists the algorithms.
//!
//! The loop in [`crate::train`] knows nothing about actors, critics, replay or rollouts. Every
//! step it asks the algorithm for an action ([`Algorithm::act`]), runs the plant, and hands the
//! step back ([`Algorithm::learn`]); the algorithm stores it and updates its networks when its
//! own schedule says so. At the end of an episode it asks for the episode's metric values. It
//! exports whatever [`Algorithm::policy_blob`] and [`Algorithm::critic_blob`] return.
//!
//! Adding an algorithm: write its file (config first, then the update in the order the maths
//! happens), add a variant to [`Algo`] and to [`Learner`] below, and a config section to
//! [`crate::train::TrainConfig`]. Nothing else in the loop changes.
//!
//! Every algorithm owns its random streams (`seed::stream(seed, name)`), its networks and its
//! buffers, and serialises all of them into the checkpoint, so resuming continues the very run
//! that was interrupted. Checkpoints are taken between episodes only.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::actor_critic::ActorCritic;
use crate::dqn::Dqn;
use crate::ppo::Ppo;
use crate::train::TrainConfig;
use crate::Error;

/// The learning algorithm of a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Algo {
    /// Deep Comparative Policy.
    Dcp,
    /// Deep Deterministic Policy Gradient.
    Ddpg,
    /// Twin Delayed DDPG (TD3): DDPG with twin critics, delayed actor updates and target
    /// smoothing.
    Td3,
    /// Proximal Policy Optimisation (continuous Gaussian policy).
    Ppo,
    /// Deep Q-Network over 8 moves.
    Dqn,
}

impl fmt::Display for Algo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Algo::Dcp => "dcp",
            Algo::Ddpg => "ddpg",
            Algo::Td3 => "td3",
            Algo::Ppo => "ppo",
            Algo::Dqn => "dqn",
        })
    }
}

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

/// The state of a run's algorithm: everything it learns and remembers, saved in checkpoints.
/// Settings are not part of it; they come back from the run's config on resume.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub enum Learner {
    /// DCP, DDPG and TD3: one actor-critic machinery, two actor updates.
    ActorCritic(Box<ActorCritic>),
    /// PPO.
    Ppo(Box<Ppo>),
    /// DQN.
    Dqn(Box<Dqn>),
}

impl Learner {
    /// A fresh learner for a plant with `obs_dim` observations and the action box `low..high`.
    pub fn new(
        config: &TrainConfig,
        obs_dim: usize,
        low: &[f32],
        high: &[f32],
    ) -> Result<Learner, Error> {
        Ok(match config.algo {
            Algo::Dcp | Algo::Ddpg | Algo::Td3 => {
                Learner::ActorCritic(Box::new(ActorCritic::new(config, obs_dim, low, high)?))
            }
            Algo::Ppo => Learner::Ppo(Box::new(Ppo::new(config, obs_dim, low, high)?)),
            Algo::Dqn => Learner::Dqn(Box::new(Dqn::new(config, obs_dim, low, high)?)),
        })
    }

    /// Checks the algorithm's own settings.
    pub fn validate(config: &TrainConfig) -> Result<(), Error> {
        match config.algo {
            Algo::Dcp => {
                config.dcp.validate()?;
                config.td3.validate()
            }
            Algo::Ddpg => Ok(()),
            Algo::Td3 => config.td3.validate(),
            Algo::Ppo => config.ppo.validate(),
            Algo::Dqn => config.dqn.validate(),
        }
    }

    /// Gives a learner loaded from a checkpoint the run's settings. Fails if the checkpoint
    /// holds another algorithm's state than the config names.
    pub fn configure(&mut self, config: &TrainConfig) -> Result<(), String> {
        match (self, config.algo) {
            (Learner::ActorCritic(l), Algo::Dcp | Algo::Ddpg | Algo::Td3) => l.configure(config)?,
            (Learner::Ppo(l), Algo::Ppo) => l.configure(config),
            (Learner::Dqn(l), Algo::Dqn) => l.configure(config),
            (_, algo) => return Err(format!("its state is not the state of a {algo} run")),
        }
        Ok(())
    }

    /// The algorithm, to run.
    pub fn algorithm(&mut self) -> &mut dyn Algorithm {
        match self {
            Learner::ActorCritic(l) => l.as_mut(),
            Learner::Ppo(l) => l.as_mut(),
            Learner::Dqn(l) => l.as_mut(),
        }
    }

    /// The algorithm, to read.
    pub fn get(&self) -> &dyn Algorithm {
        match self {
            Learner::ActorCritic(l) => l.as_ref(),
            Learner::Ppo(l) => l.as_ref(),
            Learner::Dqn(l) => l.as_ref(),
        }
    }
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
