//! The learning algorithms, and the one list of them.
//!
//! Each algorithm is one file that starts with its `Config` (a doc line per field, the paper's
//! value as default) and then its update, in the order the maths happens: [`dcp`], [`ddpg`]
//! (with TD3, which is DDPG's actor step on TD3's critics), [`ppo`] and [`dqn`]. What they share
//! sits below them: [`algorithm`] (what the training loop asks of an algorithm),
//! [`agent_config`] (the agent section of a run's configuration, which every algorithm reads),
//! [`agent`] (the actor-critic machinery DCP, DDPG and TD3 share), [`noise`] (their exploration
//! process) and [`actor_critic`] (the three as one [`algorithm::Algorithm`]).
//!
//! An algorithm takes its own config section and the agent section, never the whole run's
//! configuration: the run's configuration ([`crate::run::config`]) composes the sections and
//! hands them down as [`Sections`].
//!
//! Adding an algorithm: write its file (config first, then the update), and list it here: a
//! `pub mod` line, a variant of [`Algo`] and of [`Learner`] with their arms, and its section in
//! [`Sections`] and the run's configuration. Nothing in the training loop changes.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::nn::workers::Workers;
use crate::Error;

pub mod actor_critic;
pub mod agent;
pub mod agent_config;
pub mod algorithm;
pub mod dcp;
pub mod ddpg;
pub mod dqn;
pub mod noise;
pub mod ppo;

use actor_critic::ActorCritic;
use agent_config::AgentConfig;
use algorithm::Algorithm;
use dqn::Dqn;
use ppo::Ppo;

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

/// The algorithms that read a setting of the run's configuration, named as in `config.toml`
/// (`section`, `key`; the run's own top-level settings have the section `""`). A setting that
/// its run's algorithm does not read is refused when it is set away from its default, so this
/// list must follow the algorithms' files: each says which shared settings it reads.
pub fn readers(section: &str, key: &str) -> &'static [Algo] {
    use Algo::{Dcp, Ddpg, Dqn, Ppo, Td3};
    const ALL: &[Algo] = &[Dcp, Ddpg, Td3, Ppo, Dqn];
    const ACTOR_CRITIC: &[Algo] = &[Dcp, Ddpg, Td3];
    // The algorithms with a replay buffer, a target network and Adam's L2 on every net.
    const REPLAY: &[Algo] = &[Dcp, Ddpg, Td3, Dqn];
    match (section, key) {
        ("agent", "lr_actor") => &[Dcp, Ddpg, Td3, Ppo],
        ("agent", "dropout" | "sigma" | "sigma_start" | "sigma_decay" | "noise" | "ou_theta") => {
            ACTOR_CRITIC
        }
        (
            "agent",
            "batch" | "tau" | "l2" | "replay_capacity" | "warmup_steps" | "updates_per_step",
        ) => REPLAY,
        ("dcp", _) => &[Dcp],
        ("ddpg", _) => &[Ddpg, Td3],
        ("td3", "policy_delay") => &[Td3],
        // DCP's target smoothing takes TD3's σ and clip.
        ("td3", _) => &[Td3, Dcp],
        ("ppo", _) => &[Ppo],
        ("dqn", _) => &[Dqn],
        _ => ALL,
    }
}

/// Algorithm names for a message: `dcp, ddpg`.
pub fn names(algos: &[Algo]) -> String {
    algos
        .iter()
        .map(Algo::to_string)
        .collect::<Vec<_>>()
        .join(", ")
}

/// The config sections the algorithms read, borrowed from the run's configuration.
#[derive(Clone, Copy, Debug)]
pub struct Sections<'a> {
    /// The learning algorithm.
    pub algo: Algo,
    /// The one seed of the run.
    pub seed: u64,
    /// The agent section every algorithm reads.
    pub agent: &'a AgentConfig,
    /// DCP's section.
    pub dcp: &'a dcp::Config,
    /// DDPG's section (DDPG and TD3).
    pub ddpg: &'a ddpg::Config,
    /// TD3's section (TD3, and DCP's target smoothing).
    pub td3: &'a ddpg::Td3Config,
    /// PPO's section.
    pub ppo: &'a ppo::Config,
    /// DQN's section.
    pub dqn: &'a dqn::Config,
}

impl Sections<'_> {
    /// The sections of an actor-critic algorithm (DCP, DDPG or TD3).
    fn actor_critic(&self) -> Option<actor_critic::Sections> {
        let (dcp, ddpg, td3) = (self.dcp.clone(), self.ddpg.clone(), self.td3.clone());
        match self.algo {
            Algo::Dcp => Some(actor_critic::Sections::Dcp(dcp, td3)),
            Algo::Ddpg => Some(actor_critic::Sections::Ddpg(ddpg)),
            Algo::Td3 => Some(actor_critic::Sections::Td3(ddpg, td3)),
            Algo::Ppo | Algo::Dqn => None,
        }
    }
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
        config: &Sections<'_>,
        obs_dim: usize,
        low: &[f32],
        high: &[f32],
    ) -> Result<Learner, Error> {
        let (shared, seed) = (config.agent, config.seed);
        Ok(match (config.actor_critic(), config.algo) {
            (Some(own), _) => Learner::ActorCritic(Box::new(ActorCritic::new(
                &own, shared, seed, obs_dim, low, high,
            )?)),
            (None, Algo::Ppo) => Learner::Ppo(Box::new(Ppo::new(
                config.ppo, shared, seed, obs_dim, low, high,
            )?)),
            (None, _) => Learner::Dqn(Box::new(Dqn::new(
                config.dqn, shared, seed, obs_dim, low, high,
            )?)),
        })
    }

    /// Checks the algorithm's own settings.
    pub fn validate(config: &Sections<'_>) -> Result<(), Error> {
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
    pub fn configure(&mut self, config: &Sections<'_>) -> Result<(), String> {
        match (self, config.actor_critic(), config.algo) {
            (Learner::ActorCritic(l), Some(own), _) => l.configure(&own, config.agent)?,
            (Learner::Ppo(l), None, Algo::Ppo) => l.configure(config.ppo, config.agent),
            (Learner::Dqn(l), None, Algo::Dqn) => l.configure(config.dqn, config.agent),
            (_, _, algo) => return Err(format!("its state is not the state of a {algo} run")),
        }
        Ok(())
    }

    /// The worker threads of the updates. DCP, DDPG and TD3 use them (the critics over DCP's
    /// proposals, twin critics side by side); PPO and DQN train on one thread whatever the
    /// count. Any count gives the same bits.
    pub fn set_workers(&mut self, workers: Workers) {
        if let Learner::ActorCritic(l) = self {
            l.agent.set_workers(workers);
        }
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
