//! DCP, DDPG and TD3 as a training-loop [`Algorithm`]: act with exploration noise, store every
//! step in the replay buffer, and after the warm-up run one critic step, one actor step (DCP's
//! or DDPG's) and the soft target update per plant step. TD3 takes the actor step and the
//! target update after every `policy_delay`-th critic step only.
//!
//! The machinery both share (networks, replay, normaliser, the Bellman step) is
//! [`crate::agent`]; the two actor updates are [`crate::dcp`] and [`crate::ddpg`].

use serde::{Deserialize, Serialize};

use crate::agent::{Agent, Critics};
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
            Algo::Ddpg | Algo::Td3 => ActorUpdate::Ddpg(Ddpg::new(config.ddpg.clone())),
            _ => ActorUpdate::Dcp(Dcp::new(config.dcp.clone(), config.agent.sigma)),
        }
    }
}

/// How the run's critic learns: TD3's twin critics and smoothing, DCP's options, or DDPG's
/// single critic.
fn critics(config: &TrainConfig) -> Critics {
    match config.algo {
        Algo::Td3 => config.td3.critics(),
        Algo::Dcp => config.dcp.critics(&config.td3),
        _ => Critics::default(),
    }
}

/// Critic updates per actor update: TD3's delay, else 1.
fn policy_delay(config: &TrainConfig) -> u64 {
    match config.algo {
        Algo::Td3 => config.td3.policy_delay as u64,
        _ => 1,
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
    /// TD3's target-policy smoothing noise.
    #[serde(with = "crate::checkpoint::rng")]
    smoothing: Rng,
}

/// A DCP or DDPG learner.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ActorCritic {
    /// Networks, optimisers, normaliser, replay buffer.
    pub agent: Agent,
    streams: Streams,
    /// Critic updates so far (TD3 updates the actor on every `policy_delay`-th).
    updates: u64,
    /// Set from the config (new run or resume), never saved.
    #[serde(skip, default = "one")]
    policy_delay: u64,
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

fn one() -> u64 {
    1
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
        let mut agent = Agent::new(config.agent.clone(), obs_dim, low, high, &mut init)?;
        agent.set_critics(critics(config), &mut init);
        Ok(ActorCritic {
            agent,
            streams: Streams {
                explore: seed::stream(seed, "explore"),
                replay: seed::stream(seed, "replay"),
                dropout: seed::stream(seed, "dropout"),
                proposals: seed::stream(seed, "proposals"),
                smoothing: seed::stream(seed, "smoothing"),
            },
            updates: 0,
            policy_delay: policy_delay(config),
            update: ActorUpdate::of(config),
            noise: None,
            pending: Vec::new(),
            means: Means::default(),
        })
    }

    /// The run's settings, after a checkpoint load. Fails if the config asks for twin critics
    /// and the checkpoint has none, or the other way round.
    pub fn configure(&mut self, config: &TrainConfig) -> Result<(), String> {
        let critics = critics(config);
        if critics.twin != self.agent.twin.is_some() {
            return Err(format!(
                "the config {} twin critics and the checkpoint {} them",
                if critics.twin { "asks for" } else { "has no" },
                if self.agent.twin.is_some() {
                    "holds"
                } else {
                    "lacks"
                }
            ));
        }
        self.agent.config = config.agent.clone();
        self.agent.critics = critics;
        self.update = ActorUpdate::of(config);
        self.policy_delay = policy_delay(config);
        Ok(())
    }

    /// One critic step and one actor step on the same minibatch, then the soft target update
    /// (TD3: the actor step and the target update on every `policy_delay`-th call only).
    fn update(&mut self) -> Result<(), &'static str> {
        let s = self.agent.sample(&mut self.streams.replay);
        let streams = &mut self.streams;
        let critic_loss =
            (self.agent).critic_update_with(&s, &mut streams.dropout, Some(&mut streams.smoothing));
        if !critic_loss.is_finite() {
            return Err("critic loss");
        }
        self.updates += 1;
        if self.updates % self.policy_delay != 0 {
            self.means.add(0, critic_loss);
            return Ok(());
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
            truncated: step.truncated,
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
