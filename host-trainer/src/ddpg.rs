//! DDPG (Lillicrap et al. 2016), the baseline DCP is compared with: the actor ascends the
//! critic's action-gradient ∇aQ.
//!
//! Everything but the actor update (networks, replay, normalisation, exploration, the critic's
//! Bellman step, soft target updates) is shared with DCP in [`crate::agent`], whose
//! [`agent::Config`](crate::agent::Config) holds the shared hyper-parameters with the paper's
//! values as defaults: learning rate 1/4096, L2 1e-4, minibatch 64, γ 0.99, τ 0.005, σ 0.2.
//!
//! At a hard margin the plant stops but ∇aQ keeps pointing outward, so the actor saturates
//! against the wall: this is the failure DCP is meant to avoid (DESIGN.md section 1).

use serde::{Deserialize, Serialize};

use crate::agent::{Agent, Sample};
use crate::net::Matrix;
use crate::seed::Rng;

/// DDPG's own settings (the shared ones are in [`crate::agent::Config`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Where ∇aQ is taken [default: the textbook form].
    pub actor_gradient: ActorGradient,
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
    pub fn actor_update(&self, agent: &mut Agent, s: &Sample, dropout_rng: &mut Rng) -> ActorStats {
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
