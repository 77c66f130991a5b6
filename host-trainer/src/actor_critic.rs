//! DCP and DDPG as a training-loop [`Algorithm`]: act with exploration noise, store every step
//! in the replay buffer, and after the warm-up run one critic step, one actor step (DCP's or
//! DDPG's) and the soft target update per plant step.
//!
//! The machinery both share (networks, replay, normaliser, the Bellman step) is
//! [`crate::agent`]; the two actor updates are [`crate::dcp`] and [`crate::ddpg`].

use serde::{Deserialize, Serialize};

use crate::agent::Agent;
use crate::algo::{Algo, Algorithm, Means, Step};
use crate::dcp::Dcp;
use crate::ddpg::Ddpg;
use crate::noise::NoiseProcess;
use crate::replay::Transition;
use crate::seed::{self, Rng};
use crate::train::TrainConfig;
use crate::Error;

/// How the actor learns.
#[derive(Clone, Debug)]
enum ActorUpdate {
    Dcp(Dcp),
    Ddpg(Ddpg),
}

impl ActorUpdate {
    fn of(config: &TrainConfig) -> ActorUpdate {
        match config.algo {
            Algo::Ddpg => ActorUpdate::Ddpg(Ddpg::new(config.ddpg.clone())),
            _ => ActorUpdate::Dcp(Dcp::new(config.dcp.clone(), config.agent.sigma)),
        }
    }
}

/// The random streams of an actor-critic run.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Streams {
    #[serde(with = "crate::checkpoint::rng")]
    explore: Rng,
    #[serde(with = "crate::checkpoint::rng")]
    replay: Rng,
    #[serde(with = "crate::checkpoint::rng")]
    dropout: Rng,
    #[serde(with = "crate::checkpoint::rng")]
    proposals: Rng,
}

/// A DCP or DDPG learner.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ActorCritic {
    /// Networks, optimisers, normaliser, replay buffer.
    pub agent: Agent,
    streams: Streams,
    /// Set from the config (new run or resume), never saved.
    #[serde(skip, default = "placeholder_update")]
    update: ActorUpdate,
    /// The episode's exploration process (at rest at every episode start).
    #[serde(skip)]
    noise: Option<NoiseProcess>,
    /// The unit action of the step between `act` and `learn`.
    #[serde(skip)]
    pending: Vec<f32>,
    #[serde(skip)]
    means: Means,
}

fn placeholder_update() -> ActorUpdate {
    ActorUpdate::Ddpg(Ddpg::default())
}

/// Columns of `metrics.csv`: mean critic loss, mean actor loss and (DCP) the mean fraction of
/// the minibatch with a winning proposal, over the episode's updates.
const DCP_STATS: &[&str] = &["critic_loss", "actor_loss", "dcp_kept"];
const DDPG_STATS: &[&str] = &["critic_loss", "actor_loss"];

impl ActorCritic {
    /// Fresh networks from `seed::stream(seed, "init")` (actor first, then critic).
    pub fn new(
        config: &TrainConfig,
        obs_dim: usize,
        low: &[f32],
        high: &[f32],
    ) -> Result<ActorCritic, Error> {
        let seed = config.seed;
        let mut init = seed::stream(seed, "init");
        let agent = Agent::new(config.agent.clone(), obs_dim, low, high, &mut init)?;
        Ok(ActorCritic {
            agent,
            streams: Streams {
                explore: seed::stream(seed, "explore"),
                replay: seed::stream(seed, "replay"),
                dropout: seed::stream(seed, "dropout"),
                proposals: seed::stream(seed, "proposals"),
            },
            update: ActorUpdate::of(config),
            noise: None,
            pending: Vec::new(),
            means: Means::default(),
        })
    }

    /// The run's settings, after a checkpoint load.
    pub fn configure(&mut self, config: &TrainConfig) {
        self.agent.config = config.agent.clone();
        self.update = ActorUpdate::of(config);
    }

    /// One critic step and one actor step on the same minibatch, then the soft target update.
    fn update(&mut self) -> Result<(), &'static str> {
        let s = self.agent.sample(&mut self.streams.replay);
        let critic_loss = self.agent.critic_update(&s, &mut self.streams.dropout);
        if !critic_loss.is_finite() {
            return Err("critic loss");
        }
        let (actor_loss, kept) = match &self.update {
            ActorUpdate::Dcp(d) => {
                let st = d.actor_update(
                    &mut self.agent,
                    &s,
                    &mut self.streams.proposals,
                    &mut self.streams.dropout,
                );
                (st.loss, st.kept)
            }
            ActorUpdate::Ddpg(d) => (
                d.actor_update(&mut self.agent, &s, &mut self.streams.dropout)
                    .loss,
                f32::NAN,
            ),
        };
        if !actor_loss.is_finite() {
            return Err("actor loss");
        }
        self.agent.soft_update();
        self.means.add(0, critic_loss);
        self.means.add(1, actor_loss);
        self.means.add(2, kept);
        Ok(())
    }
}

impl Algorithm for ActorCritic {
    fn start_episode(&mut self, _episode: usize, _episodes: usize) {
        // At rest: no exploration state crosses an episode boundary (where checkpoints are).
        self.noise = Some(self.agent.noise_process());
        self.means = Means::default();
    }

    fn act(&mut self, obs: &[f32]) -> Vec<f32> {
        let agent = &self.agent;
        let noise = self.noise.get_or_insert_with(|| agent.noise_process());
        self.pending = agent.explore(obs, noise, &mut self.streams.explore);
        self.agent.scale(&self.pending)
    }

    fn learn(&mut self, step: &Step<'_>) -> Result<(), &'static str> {
        self.agent.remember(&Transition {
            obs: step.obs.to_vec(),
            action: std::mem::take(&mut self.pending),
            reward: step.reward * self.agent.config.reward_scale,
            next_obs: step.next_obs.to_vec(),
            terminal: step.terminated,
        });
        let due = (self.agent.config).updates_due(step.total_steps, self.agent.replay.len());
        for _ in 0..due {
            self.update()?;
        }
        Ok(())
    }

    fn stat_names(&self) -> &'static [&'static str] {
        match self.update {
            ActorUpdate::Dcp(_) => DCP_STATS,
            ActorUpdate::Ddpg(_) => DDPG_STATS,
        }
    }

    fn episode_stats(&mut self) -> Vec<f32> {
        let n = self.stat_names().len();
        self.means.take(n)
    }

    fn greedy(&self, obs: &[f32]) -> Vec<f32> {
        self.agent.greedy(obs)
    }

    fn is_finite(&self) -> bool {
        self.agent.is_finite()
    }

    fn policy_blob(&self, label: &str) -> Result<Vec<u8>, Error> {
        self.agent.actor_blob(label)
    }

    fn critic_blob(&self, label: &str) -> Option<Result<Vec<u8>, Error>> {
        Some(self.agent.critic_blob(label))
    }
}
