//! The agent section of a run's configuration: the settings every algorithm shares (networks,
//! learning rates, γ, exploration, replay, normalisation). Each algorithm takes this section and
//! its own; its file says which of these settings it reads.

use std::fmt;

use policy_core::Activation;
use serde::{Deserialize, Serialize};

use super::noise::Noise;
use crate::nn::hidden::Hidden;
use crate::nn::net::{NetConfig, Output};
use crate::Error;

/// Hyper-parameters shared by every actor-critic algorithm. Defaults are the paper's values
/// where it gives them (\[paper\]) and ours where it is silent (\[ours\]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AgentConfig {
    /// Hidden layers of actor and critic, `DEPTHxWIDTH` [paper: 4x48].
    pub hidden: Hidden,
    /// Hidden activation [ours: ReLU; the paper does not say].
    pub activation: Activation,
    /// Actor learning rate [paper: 1/4096].
    pub lr_actor: f32,
    /// Critic learning rate [paper: 1/4096].
    pub lr_critic: f32,
    /// L2 weight decay on weights, not biases [paper: 1e-4].
    pub l2: f32,
    /// Dropout probability on hidden activations while training [paper: 0.5; see
    /// `AgentConfig::default` for the value we use].
    pub dropout: f32,
    /// Minibatch size [paper: 64].
    pub batch: usize,
    /// Discount factor γ [ours: 0.99].
    pub gamma: f32,
    /// Soft target update rate τ [ours: 0.005].
    pub tau: f32,
    /// Exploration noise σ in the unit action box [ours: 0.2].
    pub sigma: f32,
    /// Exploration σ at the first episode, decaying linearly to `sigma` over the first
    /// `sigma_decay` episodes; absent = `sigma` throughout [ours: absent; the schedule of DQN's
    /// ε (Mnih et al. 2015), here for the margin study: start wide enough to find the way round
    /// a margin, the paper's claim being that DCP tolerates noise as large as the action box].
    pub sigma_start: Option<f32>,
    /// Episodes over which `sigma_start` decays to `sigma` [ours: 1,500, half the default
    /// budget]. A count, not a share of the budget, so a run resumed with another budget keeps
    /// its schedule.
    pub sigma_decay: usize,
    /// The exploration process [paper: "random process"; ours: Gaussian].
    pub noise: Noise,
    /// Mean reversion θ of the Ornstein-Uhlenbeck process [ours: 0.15, DDPG's value].
    pub ou_theta: f32,
    /// Replay buffer capacity in transitions [ours: 1,000,000, i.e. every step of 3,000 episodes].
    pub replay_capacity: usize,
    /// Environment steps collected before the first update [ours: 1,000].
    pub warmup_steps: usize,
    /// Updates (critic + actor) per environment step after the warm-up [ours: 1].
    pub updates_per_step: usize,
    /// Normalised observations are clipped to ±clip [ours: 5].
    pub norm_clip: f32,
    /// Rewards are multiplied by this before they are stored \[ours\]. A constant factor changes
    /// no optimal policy; it sets the scale the critic must reach from its ±3e-3 initial output.
    pub reward_scale: f32,
}

impl Default for AgentConfig {
    fn default() -> Self {
        AgentConfig {
            hidden: Hidden {
                depth: 4,
                width: 48,
            },
            activation: Activation::Relu,
            lr_actor: 1.0 / 4096.0,
            lr_critic: 1.0 / 4096.0,
            l2: 1e-4,
            dropout: DEFAULT_DROPOUT,
            batch: 64,
            gamma: 0.99,
            tau: 0.005,
            sigma: 0.2,
            sigma_start: None,
            sigma_decay: 1_500,
            noise: Noise::Gaussian,
            ou_theta: 0.15,
            replay_capacity: 1_000_000,
            warmup_steps: 1_000,
            updates_per_step: 1,
            norm_clip: 5.0,
            reward_scale: DEFAULT_REWARD_SCALE,
        }
    }
}

/// The longest σ schedule, in episodes (a run's largest budget).
pub const MAX_SIGMA_DECAY: usize = 1_000_000;

/// The default reward scale; see the README section "Reward scale" for the measurement.
pub const DEFAULT_REWARD_SCALE: f32 = 1.0;

/// The default dropout probability. The paper trains with 0.5; see the README section
/// "Dropout" for the measured comparison behind the value used here.
pub const DEFAULT_DROPOUT: f32 = 0.0;

impl AgentConfig {
    /// The exploration σ of episode `episode` (0-based): `sigma`, or with `sigma_start` the
    /// linear decay from it to `sigma` over the first `sigma_decay` episodes.
    ///
    /// ```
    /// use host_trainer::algorithms::agent_config::AgentConfig;
    /// let c = AgentConfig { sigma: 0.2, sigma_start: Some(1.0), sigma_decay: 100, ..AgentConfig::default() };
    /// assert_eq!(c.sigma_at(0), 1.0);
    /// assert!((c.sigma_at(25) - 0.8).abs() < 1e-6);
    /// assert_eq!(c.sigma_at(100), 0.2);
    /// assert_eq!(c.sigma_at(2999), 0.2);
    /// assert_eq!(AgentConfig::default().sigma_at(0), AgentConfig::default().sigma);
    /// ```
    pub fn sigma_at(&self, episode: usize) -> f32 {
        let Some(start) = self.sigma_start else {
            return self.sigma;
        };
        if episode >= self.sigma_decay {
            return self.sigma; // exactly: the schedule ends on the configured σ
        }
        let progress = (episode as f64 / self.sigma_decay as f64) as f32;
        start + (self.sigma - start) * progress
    }

    /// Checks every value's range, naming the offending setting.
    pub fn validate(&self) -> Result<(), Error> {
        let unit = |what: &str, v: f32, lo: f32, hi: f32, hi_open: bool| {
            let ok = v.is_finite() && v >= lo && if hi_open { v < hi } else { v <= hi };
            let close = if hi_open { ")" } else { "]" };
            ok.then_some(())
                .ok_or_else(|| invalid(what, format!("a number in [{lo}, {hi}{close}"), v))
        };
        unit("agent.dropout", self.dropout, 0.0, 1.0, true)?;
        unit("agent.gamma", self.gamma, 0.0, 1.0, true)?;
        unit("agent.tau", self.tau, 0.0, 1.0, false)?;
        unit("agent.sigma", self.sigma, 0.0, f32::MAX, false)?;
        if let Some(start) = self.sigma_start {
            unit("agent.sigma_start", start, 0.0, f32::MAX, false)?;
        }
        if self.sigma_decay == 0 || self.sigma_decay > MAX_SIGMA_DECAY {
            return Err(invalid(
                "agent.sigma_decay",
                format!("a number of episodes in 1..={MAX_SIGMA_DECAY}"),
                self.sigma_decay,
            ));
        }
        unit("agent.ou_theta", self.ou_theta, 0.0, 1.0, false)?;
        unit("agent.l2", self.l2, 0.0, f32::MAX, false)?;
        unit(
            "agent.norm_clip",
            self.norm_clip,
            f32::MIN_POSITIVE,
            f32::MAX,
            false,
        )?;
        for (what, lr) in [
            ("agent.lr_actor", self.lr_actor),
            ("agent.lr_critic", self.lr_critic),
        ] {
            unit(what, lr, f32::MIN_POSITIVE, f32::MAX, false)?;
        }
        // A reward scale of NaN or ±inf poisons the critic; zero or a negative one removes or
        // inverts the objective.
        unit(
            "agent.reward_scale",
            self.reward_scale,
            f32::MIN_POSITIVE,
            f32::MAX,
            false,
        )?;
        // Upper limits too: these size buffers allocated before the first episode, and a
        // mistyped value must be a one-line error, not an allocation failure.
        for (what, n, max) in [
            ("agent.batch", self.batch, MAX_BATCH),
            ("agent.replay_capacity", self.replay_capacity, MAX_REPLAY),
            (
                "agent.updates_per_step",
                self.updates_per_step,
                MAX_UPDATES_PER_STEP,
            ),
        ] {
            if n == 0 || n > max {
                return Err(invalid(what, format!("an integer in [1, {max}]"), n));
            }
        }
        Ok(())
    }
}

impl AgentConfig {
    /// The shape of a network with these hidden layers and activation: `inputs` to `outputs`,
    /// with `output`'s squashing and dropout probability `dropout` (DDPG and DCP train with
    /// `self.dropout`; PPO and DQN with none).
    pub fn net(&self, inputs: usize, outputs: usize, output: Output, dropout: f32) -> NetConfig {
        NetConfig {
            inputs,
            width: self.hidden.width,
            depth: self.hidden.depth,
            outputs,
            activation: self.activation,
            output,
            dropout,
        }
    }

    /// Updates due after a plant step of an off-policy learner (DDPG, DCP, DQN): none before
    /// `warmup_steps` plant steps and a full minibatch in the replay buffer, then
    /// `updates_per_step`.
    pub fn updates_due(&self, total_steps: u64, stored: usize) -> usize {
        if total_steps >= self.warmup_steps as u64 && stored >= self.batch {
            self.updates_per_step
        } else {
            0
        }
    }
}

/// Largest minibatch: 65,536 rows.
pub const MAX_BATCH: usize = 1 << 16;
/// Largest replay buffer: 50 million transitions (1.6 GB for the navigation plant).
pub const MAX_REPLAY: usize = 50_000_000;
/// Most updates per environment step.
pub const MAX_UPDATES_PER_STEP: usize = 1_000;

fn invalid(what: &str, expected: String, found: impl fmt::Display) -> Error {
    Error::InvalidConfig {
        what: what.into(),
        expected,
        found: found.to_string(),
    }
}
