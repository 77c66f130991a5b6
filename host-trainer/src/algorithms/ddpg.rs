//! DDPG (Lillicrap et al. 2016), the baseline DCP is compared with: the actor ascends the
//! critic's action-gradient ∇aQ.
//!
//! Everything but the actor update (networks, replay, normalisation, exploration, the critic's
//! Bellman step, soft target updates) is shared with DCP in [`super::agent`], whose
//! [`AgentConfig`](super::agent_config::AgentConfig) holds the shared hyper-parameters with the paper's
//! values as defaults: learning rate 1/4096, L2 1e-4, minibatch 64, γ 0.99, τ 0.005, σ 0.2.
//!
//! At a hard margin the plant stops but ∇aQ keeps pointing outward, so the actor saturates
//! against the wall: this is the failure DCP is meant to avoid (docs/design.md §1).
//!
//! **TD3** (Fujimoto et al. 2018; `--algo td3`) is this actor update with TD3's three changes,
//! set in [`Td3Config`]: twin critics with the clipped double-Q target min(Q1', Q2'), the
//! actor and the targets updated after every second critic update only, and target-policy
//! smoothing. Everything else is the shared agent's (the same networks, learning rates, batch,
//! τ and exploration as DDPG here, not TD3's paper values), so the comparison with DDPG isolates
//! those three changes. The actor ascends ∇aQ1; the exported critic blob is Q1.

use serde::{Deserialize, Serialize};

use firmware_sim::seed::SimRng;

use super::agent::{Agent, Critics, Sample, Smoothing};
use crate::nn::net::Matrix;

/// DDPG's own settings (the shared ones are in [`AgentConfig`](super::agent_config::AgentConfig)).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Where ∇aQ is taken [default: the textbook form].
    pub actor_gradient: ActorGradient,
}

/// TD3's settings (`[td3]`, used when `algo = "td3"`; DDPG's `[ddpg]` settings apply too).
/// TD3's σ and clip are in action units of its benchmarks' boxes, mostly [-1, 1]; here they act
/// in the unit box, i.e. as fractions 0.2 and 0.5 of each action's half-range (±0.05 and
/// ±0.125 of the navigation plant's ±0.25 steps).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Td3Config {
    /// Critic updates per actor (and target) update d [TD3: 2].
    pub policy_delay: usize,
    /// σ of the target-policy smoothing noise, unit box [TD3: 0.2].
    pub target_noise: f32,
    /// The smoothing noise is clipped to ±c, unit box [TD3: 0.5].
    pub target_noise_clip: f32,
}

impl Default for Td3Config {
    fn default() -> Self {
        Td3Config {
            policy_delay: 2,
            target_noise: 0.2,
            target_noise_clip: 0.5,
        }
    }
}

/// The most critic updates per actor update.
pub const MAX_POLICY_DELAY: usize = 1000;

impl Td3Config {
    /// Checks every value's range, naming the offending setting.
    ///
    /// ```
    /// let mut c = host_trainer::algorithms::ddpg::Td3Config::default();
    /// assert!(c.validate().is_ok());
    /// c.policy_delay = 0;
    /// assert!(c.validate().expect_err("an invalid value").to_string().contains("td3.policy_delay"));
    /// ```
    pub fn validate(&self) -> Result<(), crate::Error> {
        use crate::Error;
        Error::check_count("td3.policy_delay", self.policy_delay, MAX_POLICY_DELAY)?;
        Error::check_range("td3.target_noise", self.target_noise, 0.0, f32::MAX)?;
        Error::check_range(
            "td3.target_noise_clip",
            self.target_noise_clip,
            0.0,
            f32::MAX,
        )
    }

    /// Target-policy smoothing with these settings.
    pub fn smoothing(&self) -> Smoothing {
        Smoothing {
            sigma: self.target_noise,
            clip: self.target_noise_clip,
        }
    }

    /// How TD3's critic learns: twin critics, smoothing, one-step targets.
    pub fn critics(&self) -> Critics {
        Critics {
            twin: true,
            smoothing: Some(self.smoothing()),
            n_step: 1,
        }
    }
}

/// Where the critic's action-gradient is evaluated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ActorGradient {
    /// Textbook DDPG: ∇aQ(s, a) at a = P(s), back-propagated through P.
    #[default]
    Textbook,
    /// The paper's DDPG: ∇aQ(s, ã) at the stored noisy action ã, back-propagated through P(s).
    NoisyAction,
}

/// What one actor update did, for the metrics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ActorStats {
    /// The actor loss: -mean Q(s, ·) at the point where the gradient was taken.
    pub loss: f32,
}

/// The DDPG actor learner.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Ddpg {
    /// Its settings.
    pub config: Config,
}

impl Ddpg {
    /// A learner with these settings.
    pub fn new(config: Config) -> Ddpg {
        Ddpg { config }
    }

    /// One actor step: maximise Q(s, P(s)) by following ∇aQ back through P.
    ///
    /// The loss is L = -mean_i Q(s_i, a_i), so dL/dP(s_i) = -∇aQ(s_i, a_i) / B; the critic is
    /// not changed (its own parameter gradients are discarded).
    pub fn actor_update(
        &self,
        agent: &mut Agent,
        s: &Sample,
        dropout_rng: &mut SimRng,
    ) -> ActorStats {
        let p = agent.actor_forward_train(&s.z, dropout_rng);
        let at = match self.config.actor_gradient {
            ActorGradient::Textbook => &p,
            ActorGradient::NoisyAction => &s.action,
        };
        let (q, dq_da) = agent.action_gradient(&s.z, at);
        let n = q.len() as f32;
        let grad = Matrix {
            rows: dq_da.rows,
            cols: dq_da.cols,
            data: dq_da.data.iter().map(|g| -g / n).collect(),
        };
        agent.actor_step(&grad);
        ActorStats {
            loss: -q.iter().sum::<f32>() / n,
        }
    }
}
