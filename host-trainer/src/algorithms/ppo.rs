//! Proximal Policy Optimisation (Schulman et al. 2017, "Proximal Policy Optimization
//! Algorithms"), the on-policy baseline of docs/design.md §4, in the shape of CleanRL's
//! `ppo_continuous_action.py`.
//!
//! ```text
//! policy   π(a|s) = N(P(s), diag(exp(log_std))²)   P: the actor (4×48 ReLU, tanh output); log_std: a vector
//! value    V(s): a separate 4×48 network
//! collect  a rollout of 2,048 plant steps with π (episodes run on across rollouts)
//! GAE      A_t = δ_t + γλ A_{t+1},  δ_t = r_t + γ V(s_{t+1}) − V(s_t)
//!          a terminal state is worth 0; the 200-step time limit bootstraps from V(s')
//! update   10 epochs over the rollout in shuffled minibatches of 64:
//!          r = π(a|s) / π_old(a|s),  Â = A standardised over the minibatch
//!          L = mean max(−Â r, −Â clip(r, 1−ε, 1+ε))  −  c_H · entropy  +  c_V · ½ mean (V − R)²
//!          one Adam step of P, log_std and V after clipping the global gradient norm
//! ```
//!
//! The plant executes `clip(a, −1, 1)` scaled to its box; the stored `a` is the unclipped
//! sample, whose log-probability the ratio needs. The exported blob is the mean action P(s):
//! the same actor format, normaliser and `act` as DDPG and DCP.
//!
//! Checkpoints fall between episodes, usually inside a rollout: the unfinished rollout is part
//! of the saved state, so a resumed run continues the same rollout and equals an uninterrupted
//! one, byte for byte.

use serde::{Deserialize, Serialize};

use firmware_sim::seed::{self, SimRng};
use policy_core::normal::standard_normals;

use super::agent_config::AgentConfig;
use super::algorithm::{Algorithm, Step};
use crate::blob::export;
use crate::buffers::rollout::{Rollout, RolloutStep};
use crate::nn::adam::{Adam, VecAdam};
use crate::nn::forward::{self, ActorParts};
use crate::nn::net::{Grads, Matrix, Net, Output, Tape};
use crate::nn::normalize::RunningNorm;
use crate::Error;

/// PPO's own settings. Shared settings come from [`AgentConfig`]: `hidden` and `activation`
/// (both networks), `lr_actor` (actor and log-std), `lr_critic` (value network), `gamma`,
/// `norm_clip` and `reward_scale`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Plant steps per rollout [docs/design.md §4: 2,048].
    pub rollout: usize,
    /// Passes over each rollout [docs/design.md §4: 10].
    pub epochs: usize,
    /// Minibatch size [docs/design.md §4: 64].
    pub minibatch: usize,
    /// Clip range ε of the probability ratio [docs/design.md §4: 0.2].
    pub clip: f32,
    /// GAE's λ [docs/design.md §4: 0.95].
    pub lambda: f32,
    /// Weight c_V of the value loss [ours: 0.5, CleanRL and Stable-Baselines3].
    pub value_coef: f32,
    /// Weight c_H of the entropy bonus [ours: 0.0, CleanRL's continuous-action default].
    pub entropy_coef: f32,
    /// Limit of the global gradient norm [ours: 0.5, CleanRL].
    pub max_grad_norm: f32,
    /// Initial log-std of the policy in the unit action box [ours: 0.0, CleanRL].
    pub init_log_std: f32,
    /// L2 weight decay inside Adam [ours: 0, as CleanRL and Stable-Baselines3]. Not the shared
    /// `agent.l2` (the paper's 1e-4): after the global-norm clip the policy's gradients are far
    /// smaller than 1e-4 · w, so Adam followed the decay alone and the hidden weights of the
    /// actor fell to ~1e-4 within 200 episodes (measured), leaving a policy blind to its input.
    pub l2: f32,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            rollout: 2048,
            epochs: 10,
            minibatch: 64,
            clip: 0.2,
            lambda: 0.95,
            value_coef: 0.5,
            entropy_coef: 0.0,
            max_grad_norm: 0.5,
            init_log_std: 0.0,
            l2: 0.0,
        }
    }
}

/// The longest rollout a run may ask for.
pub const MAX_ROLLOUT: usize = 1 << 20;

impl Config {
    /// Checks every value's range, naming the offending setting.
    pub fn validate(&self) -> Result<(), Error> {
        Error::check_count("ppo.rollout", self.rollout, MAX_ROLLOUT)?;
        Error::check_count("ppo.epochs", self.epochs, 1_000)?;
        Error::check_count("ppo.minibatch", self.minibatch, self.rollout)?;
        Error::check_range("ppo.clip", self.clip, 1e-6, 10.0)?;
        Error::check_range("ppo.lambda", self.lambda, 0.0, 1.0)?;
        Error::check_range("ppo.value_coef", self.value_coef, 0.0, 1e6)?;
        Error::check_range("ppo.entropy_coef", self.entropy_coef, 0.0, 1e6)?;
        Error::check_range("ppo.max_grad_norm", self.max_grad_norm, 1e-9, 1e9)?;
        Error::check_range("ppo.init_log_std", self.init_log_std, -20.0, 2.0)?;
        Error::check_range("ppo.l2", self.l2, 0.0, f32::MAX)
    }
}

/// ½ ln(2π): the Gaussian log-density's constant per dimension.
const HALF_LN_2PI: f32 = 0.918_938_5;

/// log N(a; mean, exp(log_std)²), summed over the action dimensions.
///
/// ```
/// use host_trainer::algorithms::ppo::log_prob;
/// let lp = log_prob(&[0.0], &[0.0], &[0.0]);
/// assert!((lp + 0.918_938_5).abs() < 1e-6); // the standard normal density at 0
/// ```
pub fn log_prob(mean: &[f32], log_std: &[f32], action: &[f32]) -> f32 {
    mean.iter()
        .zip(log_std)
        .zip(action)
        .map(|((&m, &ls), &a)| {
            let u = (a - m) * (-ls).exp();
            -0.5 * u * u - ls - HALF_LN_2PI
        })
        .sum()
}

/// The policy part of PPO's loss on one minibatch and its gradients.
#[derive(Clone, Debug, PartialEq)]
pub struct Surrogate {
    /// Clipped surrogate minus the entropy bonus: `mean max(−Â r, −Â clip(r)) − c_H · H`.
    pub loss: f32,
    /// The clipped surrogate alone.
    pub policy_loss: f32,
    /// The policy's entropy H (state-independent: Σ log_std + ½ ln(2πe) per dimension).
    pub entropy: f32,
    /// dL/d(mean), row-major like the means.
    pub d_mean: Vec<f32>,
    /// dL/d(log_std).
    pub d_log_std: Vec<f32>,
    /// The estimate of KL(π_old ‖ π): mean of (r − 1) − ln r (Schulman's k3; CleanRL's
    /// `approx_kl`).
    pub approx_kl: f32,
    /// Fraction of rows whose ratio lies outside [1 − ε, 1 + ε].
    pub clip_fraction: f32,
}

/// PPO's clipped surrogate with the entropy bonus, for `m` rows of `means` (`m × A`, the
/// actor's outputs), the sampled `actions`, their `old_log_prob` and the (already
/// standardised) `advantage`.
///
/// Per row, `L_i = max(−Â r, −Â clip(r, 1−ε, 1+ε))`; its derivative in ln π is `−Â r` where
/// the unclipped term is the larger one and 0 where the clip holds it, and
/// d ln π / d mean_j = (a_j − mean_j) / σ_j², d ln π / d log_std_j = ((a_j − mean_j)/σ_j)² − 1.
pub fn surrogate(
    means: &[f32],
    log_std: &[f32],
    actions: &[f32],
    old_log_prob: &[f32],
    advantage: &[f32],
    clip: f32,
    entropy_coef: f32,
) -> Surrogate {
    let act = log_std.len();
    let m = advantage.len();
    let inv_m = 1.0 / m as f32;
    let mut d_mean = vec![0.0; means.len()];
    let mut d_log_std = vec![0.0; act];
    let (mut policy_loss, mut kl, mut clipped) = (0.0f32, 0.0f32, 0usize);
    for i in 0..m {
        let row = i * act..(i + 1) * act;
        let (mu, a) = (&means[row.clone()], &actions[row.clone()]);
        let log_ratio = log_prob(mu, log_std, a) - old_log_prob[i];
        let ratio = log_ratio.exp();
        let adv = advantage[i];
        let unclipped = -adv * ratio;
        let held = -adv * ratio.clamp(1.0 - clip, 1.0 + clip);
        policy_loss += unclipped.max(held) * inv_m;
        kl += ((ratio - 1.0) - log_ratio) * inv_m;
        if (ratio - 1.0).abs() > clip {
            clipped += 1;
        }
        // dL_i/d ln π: the surrogate moves only where its unclipped term is the larger one.
        let d_log_pi = if unclipped >= held {
            -adv * ratio * inv_m
        } else {
            0.0
        };
        for j in 0..act {
            let inv_var = (-2.0 * log_std[j]).exp();
            let diff = a[j] - mu[j];
            d_mean[row.start + j] = d_log_pi * diff * inv_var;
            d_log_std[j] += d_log_pi * (diff * diff * inv_var - 1.0);
        }
    }
    let entropy: f32 = log_std.iter().map(|ls| ls + 0.5 + HALF_LN_2PI).sum();
    for d in &mut d_log_std {
        *d -= entropy_coef;
    }
    Surrogate {
        loss: policy_loss - entropy_coef * entropy,
        policy_loss,
        entropy,
        d_mean,
        d_log_std,
        approx_kl: kl,
        clip_fraction: clipped as f32 * inv_m,
    }
}

/// The value loss ½ mean (V − R)² and its gradient (V − R) / m.
///
/// ```
/// use host_trainer::algorithms::ppo::value_loss;
/// let (loss, grad) = value_loss(&[1.0, 3.0], &[0.0, 1.0]);
/// assert_eq!(loss, 1.25);
/// assert_eq!(grad, vec![0.5, 1.0]);
/// ```
pub fn value_loss(value: &[f32], target: &[f32]) -> (f32, Vec<f32>) {
    let inv_m = 1.0 / value.len() as f32;
    let grad: Vec<f32> = value
        .iter()
        .zip(target)
        .map(|(v, r)| (v - r) * inv_m)
        .collect();
    let loss = value
        .iter()
        .zip(target)
        .map(|(v, r)| 0.5 * (v - r) * (v - r) * inv_m)
        .sum();
    (loss, grad)
}

/// Advantages standardised to mean 0 and standard deviation 1 (CleanRL's `norm_adv`); a
/// single row or a constant minibatch is only centred.
fn standardise(adv: &mut [f32]) {
    let n = adv.len() as f32;
    let mean = adv.iter().sum::<f32>() / n;
    let var = adv.iter().map(|a| (a - mean) * (a - mean)).sum::<f32>() / (n - 1.0).max(1.0);
    let scale = 1.0 / (var.sqrt() + 1e-8);
    adv.iter_mut().for_each(|a| *a = (*a - mean) * scale);
}

/// What PPO's rows of `metrics.csv` show: the most recent update's values (updates run once per
/// rollout, every ten episodes or so; NaN before the first).
const STATS: &[&str] = &[
    "policy_loss",
    "value_loss",
    "entropy",
    "approx_kl",
    "clip_fraction",
];

/// The random streams of a PPO run.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Streams {
    /// Action sampling.
    #[serde(with = "crate::rng_state::serde_rng")]
    explore: SimRng,
    /// Minibatch shuffling.
    #[serde(with = "crate::rng_state::serde_rng")]
    minibatch: SimRng,
}

/// The sample taken in `act`, kept until `learn`.
#[derive(Clone, Debug, Default)]
struct Pending {
    z: Vec<f32>,
    action: Vec<f32>,
    log_prob: f32,
    value: f32,
}

/// A PPO learner.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Ppo {
    /// The mean of the policy, P(s) in the unit box (tanh output).
    pub actor: Net,
    /// The state-independent log standard deviation, one per action dimension.
    pub log_std: Vec<f32>,
    /// The value network V(s).
    pub value: Net,
    actor_opt: Adam,
    log_std_opt: VecAdam,
    value_opt: Adam,
    /// Running observation statistics (exported into the blob).
    pub norm: RunningNorm,
    /// Lower action bounds of the plant.
    pub low: Vec<f32>,
    /// Upper action bounds of the plant.
    pub high: Vec<f32>,
    /// The rollout being collected.
    pub rollout: Rollout,
    streams: Streams,
    /// The latest update's [`STATS`].
    latest: Vec<f32>,
    #[serde(skip)]
    config: Config,
    #[serde(skip)]
    shared: AgentConfig,
    #[serde(skip)]
    pending: Pending,
    #[serde(skip)]
    tapes: (Tape, Tape),
}

impl Ppo {
    /// Fresh networks from `seed::training_stream(seed, "init")` (actor first, then the value network),
    /// with the same initialisation as DDPG's.
    pub fn new(
        own: &Config,
        shared: &AgentConfig,
        seed: u64,
        obs_dim: usize,
        low: &[f32],
        high: &[f32],
    ) -> Result<Ppo, Error> {
        let (own, shared) = (own.clone(), shared.clone());
        shared.validate()?;
        own.validate()?;
        let act_dim = low.len();
        let mut init = seed::training_stream(seed, "init");
        let actor = Net::new(shared.net(obs_dim, act_dim, Output::Tanh, 0.0), &mut init);
        let value = Net::new(shared.net(obs_dim, 1, Output::Linear, 0.0), &mut init);
        Ok(Ppo {
            actor_opt: Adam::new(&actor, shared.lr_actor, own.l2),
            log_std_opt: VecAdam::new(act_dim, shared.lr_actor),
            value_opt: Adam::new(&value, shared.lr_critic, own.l2),
            log_std: vec![own.init_log_std; act_dim],
            norm: RunningNorm::new(obs_dim, shared.norm_clip),
            low: low.to_vec(),
            high: high.to_vec(),
            rollout: Rollout::new(obs_dim, act_dim),
            streams: Streams {
                explore: seed::training_stream(seed, "explore"),
                minibatch: seed::training_stream(seed, "minibatch"),
            },
            latest: vec![f32::NAN; STATS.len()],
            actor,
            value,
            config: own,
            shared,
            pending: Pending::default(),
            tapes: Default::default(),
        })
    }

    /// The run's settings, after a checkpoint load.
    pub fn configure(&mut self, own: &Config, shared: &AgentConfig) {
        self.config = own.clone();
        self.shared = shared.clone();
    }

    fn parts(&self) -> ActorParts<'_> {
        ActorParts {
            net: &self.actor,
            norm: &self.norm,
            low: &self.low,
            high: &self.high,
        }
    }

    fn value_of(&self, obs: &[f32]) -> f32 {
        let mut z = vec![0.0; self.norm.dim()];
        self.norm.normalize(obs, &mut z);
        let mut v = [0.0];
        self.value.forward_one(&z, &mut v);
        v[0]
    }

    /// The update at the end of a rollout: GAE, then `epochs` passes of shuffled minibatches
    /// over the stored rollout (which it leaves in place; [`Algorithm::learn`] clears it).
    /// `Err(what)` names the first non-finite loss.
    pub fn update(&mut self) -> Result<(), &'static str> {
        let (advantages, returns) = self
            .rollout
            .advantages(self.shared.gamma, self.config.lambda);
        let n = self.rollout.len();
        let (obs_dim, act_dim) = (self.rollout.obs_dim, self.rollout.act_dim);
        let mut order: Vec<usize> = (0..n).collect();
        let mut sums = vec![0.0f64; STATS.len()];
        let mut minibatches = 0u32;
        let mut actor_grads = self.actor.zero_grads();
        let mut value_grads = self.value.zero_grads();
        for _ in 0..self.config.epochs {
            shuffle(&mut order, &mut self.streams.minibatch);
            for rows in order.chunks(self.config.minibatch) {
                let m = rows.len();
                let gather = |src: &[f32], k: usize| {
                    let mut out = Matrix::zeros(m, k);
                    for (r, &i) in rows.iter().enumerate() {
                        out.row_mut(r).copy_from_slice(&src[i * k..(i + 1) * k]);
                    }
                    out
                };
                let z = gather(&self.rollout.z, obs_dim);
                let actions = gather(&self.rollout.action, act_dim);
                let old_log_prob: Vec<f32> =
                    rows.iter().map(|&i| self.rollout.log_prob[i]).collect();
                let mut adv: Vec<f32> = rows.iter().map(|&i| advantages[i]).collect();
                let target: Vec<f32> = rows.iter().map(|&i| returns[i]).collect();
                standardise(&mut adv);

                // The policy: forward, clipped surrogate, backward.
                let means = self.actor.forward(&z, &mut self.tapes.0, None).clone();
                let mut s = surrogate(
                    &means.data,
                    &self.log_std,
                    &actions.data,
                    &old_log_prob,
                    &adv,
                    self.config.clip,
                    self.config.entropy_coef,
                );
                if !s.loss.is_finite() {
                    return Err("policy loss");
                }
                actor_grads.zero();
                self.actor.backward(
                    &self.tapes.0,
                    &Matrix::from_vec(m, act_dim, std::mem::take(&mut s.d_mean)),
                    &mut actor_grads,
                );

                // The value: forward, ½ mean squared error weighted by c_V, backward.
                let v = self.value.forward(&z, &mut self.tapes.1, None).data.clone();
                let (v_loss, mut d_v) = value_loss(&v, &target);
                if !v_loss.is_finite() {
                    return Err("value loss");
                }
                d_v.iter_mut().for_each(|d| *d *= self.config.value_coef);
                value_grads.zero();
                self.value.backward(
                    &self.tapes.1,
                    &Matrix::from_vec(m, 1, d_v),
                    &mut value_grads,
                );

                // One step of everything, after clipping the global gradient norm.
                clip_global_norm(
                    &mut actor_grads,
                    &mut value_grads,
                    &mut s.d_log_std,
                    self.config.max_grad_norm,
                );
                self.actor_opt.step(&mut self.actor, &actor_grads);
                self.value_opt.step(&mut self.value, &value_grads);
                self.log_std_opt.step(&mut self.log_std, &s.d_log_std);

                for (sum, v) in sums.iter_mut().zip([
                    s.policy_loss,
                    v_loss,
                    s.entropy,
                    s.approx_kl,
                    s.clip_fraction,
                ]) {
                    *sum += f64::from(v);
                }
                minibatches += 1;
            }
        }
        self.latest = sums
            .iter()
            .map(|s| (s / f64::from(minibatches.max(1))) as f32)
            .collect();
        Ok(())
    }
}

/// Scales all three gradients by `max / norm` when their joint Euclidean norm exceeds `max`
/// (PyTorch's `clip_grad_norm_` over all parameters, as CleanRL uses it).
fn clip_global_norm(actor: &mut Grads, value: &mut Grads, log_std: &mut [f32], max: f32) {
    let sq = actor.norm().powi(2)
        + value.norm().powi(2)
        + log_std.iter().map(|&g| f64::from(g).powi(2)).sum::<f64>();
    let norm = sq.sqrt();
    if norm > f64::from(max) {
        let k = (f64::from(max) / (norm + 1e-6)) as f32;
        actor.scale(k);
        value.scale(k);
        log_std.iter_mut().for_each(|g| *g *= k);
    }
}

/// Fisher-Yates shuffle.
fn shuffle(order: &mut [usize], rng: &mut SimRng) {
    for i in (1..order.len()).rev() {
        order.swap(i, seed::index(rng, i + 1));
    }
}

impl Algorithm for Ppo {
    fn start_episode(&mut self, _episode: usize, _episodes: usize) {}

    fn act(&mut self, obs: &[f32]) -> Vec<f32> {
        let mut z = vec![0.0; self.norm.dim()];
        self.norm.normalize(obs, &mut z);
        let mut mean = vec![0.0; self.actor.config.outputs];
        self.actor.forward_one(&z, &mut mean);
        let mut action = vec![0.0; mean.len()];
        standard_normals(&mut self.streams.explore, &mut action);
        for ((a, &m), &ls) in action.iter_mut().zip(&mean).zip(&self.log_std) {
            *a = m + ls.exp() * *a;
        }
        let mut v = [0.0];
        self.value.forward_one(&z, &mut v);
        let plant = action
            .iter()
            .zip(self.low.iter().zip(&self.high))
            .map(|(&u, (&lo, &hi))| policy_core::bounds::scale_value(u, lo, hi))
            .collect();
        self.pending = Pending {
            log_prob: log_prob(&mean, &self.log_std, &action),
            value: v[0],
            z,
            action,
        };
        plant
    }

    fn learn(&mut self, step: &Step<'_>) -> Result<(), &'static str> {
        self.norm.update(step.obs);
        let bootstrap = if step.terminated {
            Some(0.0)
        } else if step.truncated {
            Some(self.value_of(step.next_obs))
        } else {
            None
        };
        let p = std::mem::take(&mut self.pending);
        self.rollout.push(&RolloutStep {
            z: &p.z,
            action: &p.action,
            log_prob: p.log_prob,
            value: p.value,
            reward: step.reward * self.shared.reward_scale,
            bootstrap,
        });
        if self.rollout.len() >= self.config.rollout {
            self.rollout.close(self.value_of(step.next_obs));
            self.update()?;
            self.rollout.clear();
        }
        Ok(())
    }

    fn stat_names(&self) -> &'static [&'static str] {
        STATS
    }

    fn episode_stats(&mut self) -> Vec<f32> {
        self.latest.clone()
    }

    fn greedy(&self, obs: &[f32]) -> Vec<f32> {
        forward::act(&self.parts(), obs)
    }

    fn is_finite(&self) -> bool {
        self.actor.is_finite()
            && self.value.is_finite()
            && self.log_std.iter().all(|v| v.is_finite())
    }

    fn policy_blob(&self, label: &str) -> Result<Vec<u8>, Error> {
        export::actor_blob(&self.parts(), label)
    }

    fn critic_blob(&self, _label: &str) -> Option<Result<Vec<u8>, Error>> {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows chosen so that some ratios sit inside the clip range and some outside it, on both
    /// signs of the advantage, and none at a kink (where the derivative is undefined).
    type Case = (Vec<f32>, Vec<f32>, Vec<f32>, Vec<f32>, Vec<f32>);

    /// (means, log_std, actions, old log-probabilities, advantages).
    fn case() -> Case {
        let means = vec![0.1, -0.3, 0.5, 0.2, -0.6, 0.0, 0.3, 0.4];
        let log_std = vec![-0.5, 0.2];
        let actions = vec![0.3, -0.1, 0.2, 0.9, -0.4, -0.7, 0.1, 0.1];
        let offsets = [0.05, -0.5, 0.6, -0.02];
        let old: Vec<f32> = (0..4)
            .map(|i| {
                log_prob(
                    &means[2 * i..2 * i + 2],
                    &log_std,
                    &actions[2 * i..2 * i + 2],
                ) + offsets[i]
            })
            .collect();
        // Row 1 (ratio 1.65, Â > 0) is held by the clip; row 2 (ratio 0.55, Â > 0) is outside
        // the range but its unclipped term is the larger one, so it still moves.
        let adv = vec![1.0, 0.7, 0.8, -1.2];
        (means, log_std, actions, old, adv)
    }

    fn numeric(
        f: &dyn Fn(&[f32], &[f32]) -> f32,
        x: &[f32],
        y: &[f32],
        i: usize,
        in_x: bool,
    ) -> f32 {
        let h = 1e-3f32;
        let (mut a, mut b) = (x.to_vec(), x.to_vec());
        let (mut c, mut d) = (y.to_vec(), y.to_vec());
        if in_x {
            a[i] += h;
            b[i] -= h;
        } else {
            c[i] += h;
            d[i] -= h;
        }
        (f(&a, &c) - f(&b, &d)) / (2.0 * h)
    }

    #[test]
    fn surrogate_gradients_match_finite_differences() {
        let (means, log_std, actions, old, adv) = case();
        for entropy_coef in [0.0, 0.01] {
            let s = surrogate(&means, &log_std, &actions, &old, &adv, 0.2, entropy_coef);
            assert!(
                s.clip_fraction > 0.0 && s.clip_fraction < 1.0,
                "both cases: {s:?}"
            );
            let loss = |m: &[f32], ls: &[f32]| {
                surrogate(m, ls, &actions, &old, &adv, 0.2, entropy_coef).loss
            };
            for i in 0..means.len() {
                let n = numeric(&loss, &means, &log_std, i, true);
                assert!(
                    (n - s.d_mean[i]).abs() < 2e-3,
                    "d mean[{i}]: {n} vs {}",
                    s.d_mean[i]
                );
            }
            for j in 0..log_std.len() {
                let n = numeric(&loss, &means, &log_std, j, false);
                assert!(
                    (n - s.d_log_std[j]).abs() < 2e-3,
                    "d log_std[{j}]: {n} vs {}",
                    s.d_log_std[j]
                );
            }
        }
    }

    #[test]
    fn value_loss_gradient_matches_finite_differences() {
        let v = vec![0.5, -1.0, 2.0];
        let r = vec![1.0, -3.0, 2.5];
        let (_, g) = value_loss(&v, &r);
        for i in 0..3 {
            let (mut a, mut b) = (v.clone(), v.clone());
            a[i] += 1e-3;
            b[i] -= 1e-3;
            let n = (value_loss(&a, &r).0 - value_loss(&b, &r).0) / 2e-3;
            assert!((n - g[i]).abs() < 1e-3, "{n} vs {}", g[i]);
        }
    }

    #[test]
    fn at_the_old_policy_the_ratio_is_one_and_nothing_is_clipped() {
        let (means, log_std, actions, _, adv) = case();
        let old: Vec<f32> = (0..4)
            .map(|i| {
                log_prob(
                    &means[2 * i..2 * i + 2],
                    &log_std,
                    &actions[2 * i..2 * i + 2],
                )
            })
            .collect();
        let s = surrogate(&means, &log_std, &actions, &old, &adv, 0.2, 0.0);
        assert_eq!(s.clip_fraction, 0.0);
        assert!(s.approx_kl.abs() < 1e-6);
        let mean_adv = adv.iter().sum::<f32>() / 4.0;
        assert!(
            (s.policy_loss + mean_adv).abs() < 1e-6,
            "L = -mean Â at r = 1"
        );
    }

    #[test]
    fn log_prob_matches_the_normal_density() {
        let (m, ls, a) = (0.3f32, -0.4f32, 0.7f32);
        let sd = ls.exp();
        let density =
            (-(a - m).powi(2) / (2.0 * sd * sd)).exp() / (sd * (std::f32::consts::TAU).sqrt());
        assert!((log_prob(&[m], &[ls], &[a]) - density.ln()).abs() < 1e-5);
    }

    #[test]
    fn standardised_advantages_have_mean_zero_and_unit_deviation() {
        let mut a = vec![1.0, 2.0, 3.0, 6.0];
        standardise(&mut a);
        let mean = a.iter().sum::<f32>() / 4.0;
        let var = a.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / 3.0;
        assert!(mean.abs() < 1e-6 && (var - 1.0).abs() < 1e-5, "{a:?}");
    }

    #[test]
    fn the_config_is_checked() {
        let bad = Config {
            minibatch: 4096,
            ..Config::default()
        };
        let err = bad.validate().expect_err("minibatch > rollout").to_string();
        assert!(err.contains("ppo.minibatch"), "{err}");
        let bad = Config {
            lambda: 1.5,
            ..Config::default()
        };
        assert!(bad
            .validate()
            .expect_err("lambda > 1")
            .to_string()
            .contains("ppo.lambda"));
    }
}
