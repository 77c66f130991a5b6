//! DCP, DDPG and TD3 as a training-loop [`Algorithm`]: act with exploration noise, store every
//! step in the replay buffer, and after the warm-up run one critic step, one actor step (DCP's
//! or DDPG's) and the soft target update per plant step. TD3 takes the actor step and the
//! target update after every `policy_delay`-th critic step only.
//!
//! The machinery both share (networks, replay, normaliser, the Bellman step) is
//! [`super::agent`]; the two actor updates are [`super::dcp`] and [`super::ddpg`].

use serde::{Deserialize, Serialize};

use firmware_sim::seed::{self, SimRng};

use super::agent::{Agent, Critics};
use super::agent_config::AgentConfig;
use super::algorithm::{Algorithm, Means, Step};
use super::dcp::{self, Dcp};
use super::ddpg::{self, Ddpg, Td3Config};
use super::noise::NoiseProcess;
use crate::buffers::replay::Transition;
use crate::Error;

/// Which actor-critic algorithm a run trains, with its own config sections.
#[derive(Clone, Debug)]
pub enum Sections {
    /// DCP (its `target_smoothing` takes TD3's σ and clip).
    Dcp(dcp::Config, Td3Config),
    /// DDPG.
    Ddpg(ddpg::Config),
    /// TD3: DDPG's actor step with TD3's critics and delay.
    Td3(ddpg::Config, Td3Config),
}

impl Sections {
    /// How the actor learns.
    fn update(&self, agent: &AgentConfig) -> ActorUpdate {
        match self {
            Sections::Dcp(dcp, _) => ActorUpdate::Dcp(Dcp::new(dcp.clone(), agent.sigma)),
            Sections::Ddpg(ddpg) | Sections::Td3(ddpg, _) => {
                ActorUpdate::Ddpg(Ddpg::new(ddpg.clone()))
            }
        }
    }

    /// How the run's critic learns: TD3's twin critics and smoothing, DCP's options, or DDPG's
    /// single critic.
    fn critics(&self) -> Critics {
        match self {
            Sections::Td3(_, td3) => td3.critics(),
            Sections::Dcp(dcp, td3) => dcp.critics(td3),
            Sections::Ddpg(_) => Critics::default(),
        }
    }

    /// The actor's heads: DCP's `heads`, else 1.
    fn heads(&self) -> usize {
        match self {
            Sections::Dcp(dcp, _) => dcp.heads,
            _ => 1,
        }
    }

    /// Critic updates per actor update: TD3's delay, else 1.
    fn policy_delay(&self) -> u64 {
        match self {
            Sections::Td3(_, td3) => td3.policy_delay as u64,
            _ => 1,
        }
    }
}

/// How the actor learns.
#[derive(Clone, Debug)]
enum ActorUpdate {
    Dcp(Dcp),
    Ddpg(Ddpg),
}

/// The random streams of an actor-critic run.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Streams {
    #[serde(with = "crate::rng_state::serde_rng")]
    explore: SimRng,
    #[serde(with = "crate::rng_state::serde_rng")]
    replay: SimRng,
    #[serde(with = "crate::rng_state::serde_rng")]
    dropout: SimRng,
    #[serde(with = "crate::rng_state::serde_rng")]
    proposals: SimRng,
    /// TD3's target-policy smoothing noise.
    #[serde(with = "crate::rng_state::serde_rng")]
    smoothing: SimRng,
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
    /// The exploration σ set by [`Algorithm::set_exploration_sigma`], never saved.
    #[serde(skip)]
    sigma: Option<f32>,
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
    /// Fresh networks from `seed::training_stream(seed, "init")` (actor first, then critic).
    pub fn new(
        own: &Sections,
        shared: &AgentConfig,
        seed: u64,
        obs_dim: usize,
        low: &[f32],
        high: &[f32],
    ) -> Result<ActorCritic, Error> {
        let mut init = seed::training_stream(seed, "init");
        let mut agent =
            Agent::with_heads(shared.clone(), obs_dim, low, high, own.heads(), &mut init)?;
        agent.set_critics(own.critics(), &mut init);
        Ok(ActorCritic {
            agent,
            streams: Streams {
                explore: seed::training_stream(seed, "explore"),
                replay: seed::training_stream(seed, "replay"),
                dropout: seed::training_stream(seed, "dropout"),
                proposals: seed::training_stream(seed, "proposals"),
                smoothing: seed::training_stream(seed, "smoothing"),
            },
            updates: 0,
            policy_delay: own.policy_delay(),
            update: own.update(shared),
            noise: None,
            sigma: None,
            pending: Vec::new(),
            means: Means::default(),
        })
    }

    /// The run's settings, after a checkpoint load. Fails if the config asks for twin critics
    /// and the checkpoint has none, or the other way round.
    pub fn configure(&mut self, own: &Sections, shared: &AgentConfig) -> Result<(), String> {
        let critics = own.critics();
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
        if own.heads() != self.agent.heads() {
            return Err(format!(
                "the config asks for {} actor head(s) and the checkpoint's actor has {}",
                own.heads(),
                self.agent.heads()
            ));
        }
        self.agent.config = shared.clone();
        self.agent.critics = critics;
        self.update = own.update(shared);
        self.policy_delay = own.policy_delay();
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
    fn start_episode(&mut self, episode: usize, _episodes: usize) {
        // At rest: no exploration state crosses an episode boundary (where checkpoints are).
        self.noise = Some(match self.sigma {
            Some(sigma) => self.agent.noise_process_with(sigma),
            None => self.agent.noise_process(episode),
        });
        self.means = Means::default();
    }

    fn act(&mut self, obs: &[f32]) -> Vec<f32> {
        let agent = &self.agent;
        // Only reached without `start_episode` (a learner driven by hand): the constant σ.
        let noise = self.noise.get_or_insert_with(|| agent.noise_process(0));
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

    fn set_exploration_sigma(&mut self, sigma: Option<f32>) {
        self.sigma = sigma;
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
