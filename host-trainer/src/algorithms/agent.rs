//! The actor-critic machinery that DDPG and DCP share, so neither re-implements it.
//!
//! DCP keeps DDPG's actor P, critic Q, replay buffer and target networks and changes only the
//! actor update (docs/design.md §1). Everything common lives here: the networks and their
//! optimisers, the running observation normaliser, the replay buffer, exploration in the unit
//! action box, the critic's Bellman update and the soft target updates. `ddpg.rs` and `dcp.rs`
//! each add one function: how the actor learns.
//!
//! Two options change the critic (the paper's DDPG and DCP have neither: one critic, one-step
//! targets): [`Critics`] adds TD3's twin critic with clipped double-Q targets and target-policy
//! smoothing (used by `--algo td3` and DCP's twin scoring, DCP's default since the DCP-variants
//! study), and n-step returns (3 in DCP's defaults since that study).
//!
//! Conventions: the actor outputs a *unit* action in `[-1, 1]^n` (tanh output); the plant's
//! bounds are applied only when acting, exactly as policy-core's `act` does. The critic scores
//! `[normalised observation, unit action]`. The replay buffer stores raw observations and unit
//! actions; observations are normalised at sampling time with the current statistics (the
//! paper's "dynamic input normalisation").

use firmware_sim::seed::SimRng;
use policy_core::model::argmax;
use policy_core::normal::standard_normals;
use serde::{Deserialize, Serialize};

use super::agent_config::AgentConfig;
use super::noise::NoiseProcess;
use crate::blob::export;
use crate::buffers::replay::{Replay, Transition};
use crate::nn::adam::Adam;
use crate::nn::forward::{self, ActorParts};
use crate::nn::net::{evaluate, soft_update, Grads, Matrix, Net, Output, Tape};
use crate::nn::normalize::RunningNorm;
use crate::nn::workers::Workers;
use crate::Error;

/// A minibatch with observations already normalised by the current statistics.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    /// Normalised observations z(s), rows = samples.
    pub z: Matrix,
    /// The stored (noisy, executed) unit actions ã.
    pub action: Matrix,
    /// Rewards.
    pub reward: Vec<f32>,
    /// Normalised next observations z(s').
    pub z_next: Matrix,
    /// 1.0 for terminal transitions, else 0.0.
    pub terminal: Vec<f32>,
    /// The bootstrap discount of each row: γ for one-step samples, γ^m after m summed rewards.
    pub discount: Vec<f32>,
}

/// How the critic learns: the paper's one critic and one-step targets by default.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Critics {
    /// A second critic Q2 (and its target), trained on the same targets; the Bellman target
    /// takes min(Q1', Q2') [TD3, Fujimoto et al. 2018: clipped double Q]. Q1 is exported.
    pub twin: bool,
    /// Target-policy smoothing: noise on the target action P'(s') \[TD3\].
    pub smoothing: Option<Smoothing>,
    /// Rewards summed per critic target, n [1: one-step].
    pub n_step: usize,
}

impl Default for Critics {
    fn default() -> Self {
        Critics {
            twin: false,
            smoothing: None,
            n_step: 1,
        }
    }
}

/// TD3's target-policy smoothing: a' = clip(P'(s') + clip(N(0, σ²), -c, c), -1, 1) in the unit
/// action box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Smoothing {
    /// σ of the noise, unit box.
    pub sigma: f32,
    /// The noise clip c, unit box.
    pub clip: f32,
}

/// TD3's second critic with its target and optimiser.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Twin {
    /// Q2.
    pub critic: Net,
    /// Q2'.
    pub critic_target: Net,
    /// Adam for Q2.
    pub critic_opt: Adam,
}

/// Actor, critic, their targets and optimisers, the normaliser and the replay buffer.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Agent {
    /// The hyper-parameters. Not part of the binary checkpoint encoding: the checkpoint keeps
    /// them in its TOML config, so adding a setting does not silently shift the binary layout.
    #[serde(skip)]
    pub config: AgentConfig,
    /// The actor P: normalised observation -> unit action (tanh output).
    pub actor: Net,
    /// The critic Q: [normalised observation, unit action] -> value (linear output).
    pub critic: Net,
    /// The target actor P'.
    pub actor_target: Net,
    /// The target critic Q'.
    pub critic_target: Net,
    /// Adam for the actor.
    pub actor_opt: Adam,
    /// Adam for the critic.
    pub critic_opt: Adam,
    /// Running observation statistics (exported into the blob's normaliser).
    pub norm: RunningNorm,
    /// Transitions with raw observations and unit actions.
    pub replay: Replay,
    /// Lower action bounds of the plant.
    pub low: Vec<f32>,
    /// Upper action bounds of the plant.
    pub high: Vec<f32>,
    /// TD3's second critic, when [`Critics::twin`] is set.
    pub twin: Option<Box<Twin>>,
    /// How the critic learns; like `config`, set from the run's config, not saved.
    #[serde(skip)]
    pub critics: Critics,
    /// The run's worker threads (one unless [`Agent::set_workers`]); not saved: the thread count
    /// is the machine's business, not the run's, and changes no bit.
    #[serde(skip)]
    workers: Workers,
    #[serde(skip)]
    scratch: Scratch,
}

/// Buffers reused between updates; rebuilt empty after a clone or a checkpoint load.
#[derive(Debug, Default)]
struct Scratch {
    actor_tape: Tape,
    critic_tape: Tape,
    twin_tape: Tape,
    target_tape: Tape,
    /// The split inference passes' ([`evaluate`]) tapes and outputs.
    split: Split,
    actor_grads: Option<Grads>,
    critic_grads: Option<Grads>,
    twin_grads: Option<Grads>,
    /// dQ/d(critic input) of DDPG's actor step.
    d_input: Matrix,
    /// TD3's target-smoothing draws, one per action component of a batch.
    smoothing_noise: Vec<f32>,
}

/// Scratch space of [`min_values`].
#[derive(Debug, Default)]
struct Split {
    /// One tape per task, kept per batch height: an update alternates between heights (DCP
    /// scores B × (T + 1) rows, then its Bellman targets take B), and one set of tapes for both
    /// would shrink and zero-fill its buffers again at every pass (a tenth of a DCP run's time,
    /// measured with `perf`).
    tapes: Vec<(usize, Vec<Tape>)>,
    /// One output per network.
    outs: Vec<Matrix>,
}

impl Split {
    /// Heights kept at once; beyond them the oldest set is dropped (training uses two or three).
    const HEIGHTS: usize = 4;

    /// The tapes of [`Split::tapes`] for passes of `rows` rows.
    fn tapes_for(tapes: &mut Vec<(usize, Vec<Tape>)>, rows: usize) -> &mut Vec<Tape> {
        let i = match tapes.iter().position(|(r, _)| *r == rows) {
            Some(i) => i,
            None => {
                if tapes.len() == Self::HEIGHTS {
                    tapes.remove(0);
                }
                tapes.push((rows, Vec::new()));
                tapes.len() - 1
            }
        };
        &mut tapes[i].1
    }
}

impl Clone for Scratch {
    fn clone(&self) -> Self {
        Scratch::default()
    }
}

impl Agent {
    /// Fresh networks (DDPG initialisation) for a plant with `obs_dim` observations and the
    /// action box `low..high`. All initial weights come from `rng`.
    pub fn new(
        config: AgentConfig,
        obs_dim: usize,
        low: &[f32],
        high: &[f32],
        rng: &mut SimRng,
    ) -> Result<Agent, Error> {
        Agent::with_heads(config, obs_dim, low, high, 1, rng)
    }

    /// [`Agent::new`] with an actor of `heads` heads: its output holds `heads` actions one after
    /// the other, and the critic chooses among them ([`Agent::chosen_unit`]). One head is the
    /// plain actor, with the same initial weights as [`Agent::new`].
    pub fn with_heads(
        config: AgentConfig,
        obs_dim: usize,
        low: &[f32],
        high: &[f32],
        heads: usize,
        rng: &mut SimRng,
    ) -> Result<Agent, Error> {
        config.validate()?;
        if low.len() != high.len() {
            return Err(Error::ShapeMismatch {
                what: "action bounds",
                expected: low.len(),
                found: high.len(),
            });
        }
        let act_dim = low.len();
        let actor = Net::new(
            config.net(obs_dim, heads * act_dim, Output::Tanh, config.dropout),
            rng,
        );
        let critic = Net::new(
            config.net(obs_dim + act_dim, 1, Output::Linear, config.dropout),
            rng,
        );
        Ok(Agent {
            actor_opt: Adam::new(&actor, config.lr_actor, config.l2),
            critic_opt: Adam::new(&critic, config.lr_critic, config.l2),
            actor_target: actor.clone(),
            critic_target: critic.clone(),
            norm: RunningNorm::new(obs_dim, config.norm_clip),
            replay: Replay::new(config.replay_capacity, obs_dim, act_dim),
            low: low.to_vec(),
            high: high.to_vec(),
            actor,
            critic,
            config,
            twin: None,
            critics: Critics::default(),
            workers: Workers::default(),
            scratch: Scratch::default(),
        })
    }

    /// The worker threads the updates use from now on. Any count gives the same bits.
    pub fn set_workers(&mut self, workers: Workers) {
        self.workers = workers;
    }

    /// Sets how the critic learns. A twin critic, when asked for and not yet there, is drawn
    /// from `rng` (after actor and critic, so runs without one keep their initial weights).
    pub fn set_critics(&mut self, critics: Critics, rng: &mut SimRng) {
        if critics.twin && self.twin.is_none() {
            let critic = Net::new(self.critic.config.clone(), rng);
            self.twin = Some(Box::new(Twin {
                critic_opt: Adam::new(&critic, self.config.lr_critic, self.config.l2),
                critic_target: critic.clone(),
                critic,
            }));
        }
        self.critics = critics;
    }

    /// Observation size.
    pub fn obs_dim(&self) -> usize {
        self.actor.config.inputs
    }

    /// Action size (of the plant; an actor of several heads outputs this many per head).
    pub fn act_dim(&self) -> usize {
        self.low.len()
    }

    /// The actor's heads: 1, or several whose actions the critic chooses among.
    pub fn heads(&self) -> usize {
        self.actor.config.outputs / self.act_dim().max(1)
    }

    /// What export and evaluation see: the actor, the frozen normaliser, the bounds (one
    /// head's; [`Agent::actor_blob`] repeats them per head).
    pub fn parts(&self) -> ActorParts<'_> {
        ActorParts {
            net: &self.actor,
            norm: &self.norm,
            low: &self.low,
            high: &self.high,
        }
    }

    /// The greedy action in plant units from the trainer's own networks, bit-exact with
    /// policy-core's `Model::act` on the exported blob (with several heads, with policy-core's
    /// `compare::choose_head` on the exported actor and critic).
    pub fn greedy(&self, obs: &[f32]) -> Vec<f32> {
        if self.heads() == 1 {
            return forward::act(&self.parts(), obs);
        }
        let unit = self.chosen_unit(obs);
        let bounds = self.low.iter().zip(&self.high);
        let scale = |(&u, (&lo, &hi))| policy_core::bounds::scale_value(u, lo, hi);
        unit.iter().zip(bounds).map(scale).collect()
    }

    /// The actor's unit action for a raw observation: its only head's, or the head the critic
    /// values most, Q(s, head) under the online critic Q1 (the exported one), by policy-core's
    /// [`argmax`] rule (ties to the lowest head, NaN never wins), as `compare::choose_head`.
    pub fn chosen_unit(&self, obs: &[f32]) -> Vec<f32> {
        let mut unit = forward::act_unit(&self.parts(), obs);
        let a = self.act_dim();
        if self.heads() > 1 {
            let q: Vec<f32> = (0..self.heads())
                .map(|k| forward::q(&self.critic, &self.norm, obs, &unit[k * a..(k + 1) * a]))
                .collect();
            let best = argmax(&q);
            unit.copy_within(best * a..(best + 1) * a, 0);
            unit.truncate(a);
        }
        unit
    }

    /// Exploration: ã = clip(P(s) + noise, -1, 1) in the unit box, with the next draw of the
    /// episode's noise process (see [`super::noise`]); P(s) the chosen head's action.
    pub fn explore(&self, obs: &[f32], noise: &mut NoiseProcess, rng: &mut SimRng) -> Vec<f32> {
        let mut unit = self.chosen_unit(obs);
        for (u, n) in unit.iter_mut().zip(noise.sample(rng)) {
            *u = (*u + n).clamp(-1.0, 1.0);
        }
        unit
    }

    /// A noise process at rest with this agent's settings, for episode `episode` (its σ
    /// follows [`AgentConfig::sigma_at`]).
    pub fn noise_process(&self, episode: usize) -> NoiseProcess {
        self.noise_process_with(self.config.sigma_at(episode))
    }

    /// A noise process at rest with this agent's settings and the σ given.
    pub fn noise_process_with(&self, sigma: f32) -> NoiseProcess {
        NoiseProcess::new(
            self.config.noise,
            sigma,
            self.config.ou_theta,
            self.low.len(),
        )
    }

    /// Maps a unit action to the plant's box, with policy-core's formula.
    pub fn scale(&self, unit: &[f32]) -> Vec<f32> {
        unit.iter()
            .zip(self.low.iter().zip(&self.high))
            .map(|(&u, (&lo, &hi))| (lo + (u + 1.0) * 0.5 * (hi - lo)).clamp(lo, hi))
            .collect()
    }

    /// Stores a transition and feeds its observation to the normaliser.
    pub fn remember(&mut self, t: &Transition) {
        self.norm.update(&t.obs);
        self.replay.push(t);
    }

    /// Samples a minibatch and normalises it with the current statistics.
    /// With `n_step` > 1 the rows are n-step transitions ([`Replay::sample_n_step_into`]).
    pub fn sample(&self, rng: &mut SimRng) -> Sample {
        let (batch, gamma) = (self.config.batch, self.config.gamma);
        let mut b = crate::buffers::replay::Batch::default();
        if self.critics.n_step > 1 {
            (self.replay).sample_n_step_into(batch, self.critics.n_step, gamma, rng, &mut b);
        } else {
            self.replay.sample_into(batch, rng, &mut b);
            b.discount = vec![gamma; batch];
        }
        Sample {
            z: self.norm.normalize_batch(&b.obs),
            action: b.action,
            reward: b.reward,
            z_next: self.norm.normalize_batch(&b.next_obs),
            terminal: b.terminal,
            discount: b.discount,
        }
    }

    /// One critic step on the Bellman target y = r + γ(1 - terminal) Q'(s', P'(s')); returns
    /// the mean squared TD error before the step. (For the n-step, twin and smoothing options
    /// see [`Agent::critic_update_with`].)
    pub fn critic_update(&mut self, s: &Sample, dropout_rng: &mut SimRng) -> f32 {
        self.critic_update_with(s, dropout_rng, None)
    }

    /// One critic step as [`Critics`] says: y = R + discount·(1 - terminal)·Q'(s', a'), where
    /// Q' is min(Q1', Q2') with a twin and a' is P'(s'), smoothed with noise from
    /// `smoothing_rng` when smoothing is on. A twin Q2 takes a step on the same y. Returns Q1's
    /// mean squared TD error before the step.
    ///
    /// # Panics
    /// If smoothing is on and `smoothing_rng` is `None`.
    pub fn critic_update_with(
        &mut self,
        s: &Sample,
        dropout_rng: &mut SimRng,
        smoothing_rng: Option<&mut SimRng>,
    ) -> f32 {
        let y = self.bellman_targets(s, smoothing_rng);
        let input = critic_input(&s.z, &s.action, 1);
        let scratch = &mut self.scratch;
        let mut q1 = Fit {
            net: &mut self.critic,
            opt: &mut self.critic_opt,
            tape: &mut scratch.critic_tape,
            grads: &mut scratch.critic_grads,
        };
        let Some(twin) = self.twin.as_deref_mut() else {
            return q1.step(&input, &y, Some(dropout_rng));
        };
        let mut q2 = Fit {
            net: &mut twin.critic,
            opt: &mut twin.critic_opt,
            tape: &mut scratch.twin_tape,
            grads: &mut scratch.twin_grads,
        };
        // Without dropout neither step draws from the stream, so the two are independent and
        // run at once; with dropout Q2's masks are the draws after Q1's, so Q1 goes first.
        if q1.net.config.dropout == 0.0 && q2.net.config.dropout == 0.0 {
            let (loss, _) =
                (self.workers).join(|| q1.step(&input, &y, None), || q2.step(&input, &y, None));
            loss
        } else {
            let loss = q1.step(&input, &y, Some(dropout_rng));
            q2.step(&input, &y, Some(dropout_rng));
            loss
        }
    }

    fn bellman_targets(&mut self, s: &Sample, smoothing_rng: Option<&mut SimRng>) -> Vec<f32> {
        let mut next_action = self
            .actor_target
            .forward(&s.z_next, &mut self.scratch.target_tape, None)
            .clone();
        if self.heads() > 1 {
            next_action = self.target_choice(&s.z_next, &next_action);
        }
        if let Some(sm) = self.critics.smoothing {
            let rng = smoothing_rng.expect("target smoothing needs its random stream");
            let noise = &mut self.scratch.smoothing_noise;
            noise.resize(next_action.data.len(), 0.0);
            standard_normals(rng, noise);
            for (a, &n) in next_action.data.iter_mut().zip(noise.iter()) {
                let noise = (sm.sigma * n).clamp(-sm.clip, sm.clip);
                *a = (*a + noise).clamp(-1.0, 1.0);
            }
        }
        let input = critic_input(&s.z_next, &next_action, 1);

        // Clipped double Q: the smaller estimate curbs the critic's overestimation.
        let target_twin = self.twin.as_deref().map(|t| &t.critic_target);
        let (split, workers) = (&mut self.scratch.split, &self.workers);
        let q_next = min_values(&self.critic_target, target_twin, &input, split, workers);
        (0..s.reward.len())
            .map(|i| s.reward[i] + s.discount[i] * (1.0 - s.terminal[i]) * q_next[i])
            .collect()
    }

    /// The target actor's action a' of several heads: per row of `heads` (B × K·A), the head
    /// the target critic Q1' values most ([`argmax`]), as the policy chooses
    /// with Q1 at run time.
    fn target_choice(&mut self, z_next: &Matrix, heads: &Matrix) -> Matrix {
        let (k, a) = (self.heads(), self.act_dim());
        let per_head = Matrix::from_vec(heads.rows * k, a, heads.data.clone());
        let input = critic_input(z_next, &per_head, k);
        let split = &mut self.scratch.split;
        let q = min_values(&self.critic_target, None, &input, split, &self.workers);
        let mut chosen = Matrix::zeros(heads.rows, a);
        for i in 0..heads.rows {
            let best = argmax(&q[i * k..(i + 1) * k]);
            chosen
                .row_mut(i)
                .copy_from_slice(per_head.row(i * k + best));
        }
        chosen
    }

    /// Q for each row of a critic input built by [`critic_input`] (inference: no dropout).
    pub fn q_values(&mut self, input: &Matrix) -> Vec<f32> {
        min_values(
            &self.critic,
            None,
            input,
            &mut self.scratch.split,
            &self.workers,
        )
    }

    /// Q' (the target critic) for each row of a critic input (DCP's target scoring).
    pub fn q_target_values(&mut self, input: &Matrix) -> Vec<f32> {
        let split = &mut self.scratch.split;
        min_values(&self.critic_target, None, input, split, &self.workers)
    }

    /// min(Q1, Q2) for each row of a critic input (DCP's twin scoring; Q1 alone without a twin).
    pub fn q_min_values(&mut self, input: &Matrix) -> Vec<f32> {
        let twin = self.twin.as_deref().map(|t| &t.critic);
        min_values(
            &self.critic,
            twin,
            input,
            &mut self.scratch.split,
            &self.workers,
        )
    }

    /// The target actor's unit actions on a batch (DCP's trust region).
    pub fn actor_target_eval(&mut self, z: &Matrix) -> Matrix {
        self.actor_target
            .forward(z, &mut self.scratch.target_tape, None)
            .clone()
    }

    /// The actor's unit actions on a batch, inference mode (no dropout).
    pub fn actor_eval(&mut self, z: &Matrix) -> Matrix {
        self.actor
            .forward(z, &mut self.scratch.actor_tape, None)
            .clone()
    }

    /// Q(s, a) and ∇aQ(s, a) for each row (critic in inference mode). DDPG's actor gradient.
    pub fn action_gradient(&mut self, z: &Matrix, action: &Matrix) -> (Vec<f32>, Matrix) {
        let input = critic_input(z, action, 1);
        let q = self
            .critic
            .forward(&input, &mut self.scratch.critic_tape, None)
            .data
            .clone();
        let ones = Matrix {
            rows: q.len(),
            cols: 1,
            data: vec![1.0; q.len()],
        };
        // Only dQ/d(input): the critic's parameter gradients would be thrown away.
        let d_input = &mut self.scratch.d_input;
        self.critic
            .input_grads_into(&mut self.scratch.critic_tape, &ones, d_input);
        let obs_dim = z.cols;
        let mut d_action = Matrix::zeros(q.len(), action.cols);
        for i in 0..q.len() {
            d_action
                .row_mut(i)
                .copy_from_slice(&d_input.row(i)[obs_dim..]);
        }
        (q, d_action)
    }

    /// The training-mode actor forward (dropout on); its tape is kept for [`Agent::actor_step`].
    pub fn actor_forward_train(&mut self, z: &Matrix, dropout_rng: &mut SimRng) -> Matrix {
        self.actor
            .forward(z, &mut self.scratch.actor_tape, Some(dropout_rng))
            .clone()
    }

    /// The training-mode actor forward on the batch `z` whose evaluation pass
    /// ([`Agent::actor_eval`], output `eval`) was the actor's last. Without dropout the two passes
    /// are one computation, so the evaluation tape stands in for the training one and `eval` is
    /// returned as it is (no second pass); with dropout the pass runs with its masks.
    pub fn actor_forward_train_after_eval(
        &mut self,
        z: &Matrix,
        eval: Matrix,
        dropout_rng: &mut SimRng,
    ) -> Matrix {
        if self.config.dropout > 0.0 {
            self.actor_forward_train(z, dropout_rng)
        } else {
            eval
        }
    }

    /// One Adam step of the actor from dL/d(output) of the last [`Agent::actor_forward_train`].
    pub fn actor_step(&mut self, grad_out: &Matrix) {
        let grads = self
            .scratch
            .actor_grads
            .get_or_insert_with(|| self.actor.zero_grads());
        grads.zero();
        self.actor
            .backward(&self.scratch.actor_tape, grad_out, grads);
        self.actor_opt.step(&mut self.actor, grads);
    }

    /// θ' ← τθ + (1-τ)θ' for both target networks.
    pub fn soft_update(&mut self) {
        soft_update(&mut self.actor_target, &self.actor, self.config.tau);
        soft_update(&mut self.critic_target, &self.critic, self.config.tau);
        if let Some(twin) = self.twin.as_deref_mut() {
            soft_update(&mut twin.critic_target, &twin.critic, self.config.tau);
        }
    }

    /// Whether every weight of every network is finite.
    pub fn is_finite(&self) -> bool {
        self.actor.is_finite()
            && self.critic.is_finite()
            && self.actor_target.is_finite()
            && self.critic_target.is_finite()
            && self
                .twin
                .as_deref()
                .is_none_or(|t| t.critic.is_finite() && t.critic_target.is_finite())
    }

    /// The actor blob (what gets flashed). An actor of K heads has K·A outputs and its bounds
    /// K times; it runs with its critic ([`Agent::critic_blob`]) choosing the head.
    pub fn actor_blob(&self, label: &str) -> Result<Vec<u8>, Error> {
        let k = self.heads();
        let (low, high) = (self.low.repeat(k), self.high.repeat(k));
        let parts = ActorParts {
            low: &low,
            high: &high,
            ..self.parts()
        };
        export::actor_blob(&parts, label)
    }

    /// The critic blob (for the on-device compare step).
    pub fn critic_blob(&self, label: &str) -> Result<Vec<u8>, Error> {
        export::critic_blob(&self.critic, &self.norm, self.act_dim(), label)
    }
}

/// `first`'s values of the rows of `input`, or the smaller of `first`'s and `second`'s: one
/// inference pass of both, its rows split over `workers`.
fn min_values(
    first: &Net,
    second: Option<&Net>,
    input: &Matrix,
    split: &mut Split,
    workers: &Workers,
) -> Vec<f32> {
    let nets: &[&Net] = match second {
        Some(second) => &[first, second],
        None => &[first],
    };
    split.outs.resize_with(nets.len(), Matrix::default);
    let tapes = Split::tapes_for(&mut split.tapes, input.rows);
    evaluate(nets, input, &mut split.outs, tapes, workers);
    let mut q = std::mem::take(&mut split.outs[0].data);
    if second.is_some() {
        for (q, &q2) in q.iter_mut().zip(&split.outs[1].data) {
            *q = q.min(q2);
        }
    }
    q
}

/// One critic's Adam step toward Bellman targets, with the buffers it works in.
struct Fit<'a> {
    net: &'a mut Net,
    opt: &'a mut Adam,
    tape: &'a mut Tape,
    grads: &'a mut Option<Grads>,
}

impl Fit<'_> {
    /// One Adam step toward `y`; the mean squared error before it.
    fn step(&mut self, input: &Matrix, y: &[f32], dropout_rng: Option<&mut SimRng>) -> f32 {
        let q = self.net.forward(input, self.tape, dropout_rng).clone();
        let (loss, grad) = squared_error(&q, y);
        let grads = self.grads.get_or_insert_with(|| self.net.zero_grads());
        grads.zero();
        self.net.backward(self.tape, &grad, grads);
        self.opt.step(self.net, grads);
        loss
    }
}

/// Mean squared error of `q` against `y` and its gradient dL/dq.
fn squared_error(q: &Matrix, y: &[f32]) -> (f32, Matrix) {
    let n = y.len() as f32;
    let mut grad = Matrix::zeros(q.rows, 1);
    let mut loss = 0.0;
    for (i, &target) in y.iter().enumerate() {
        let err = q.data[i] - target;
        loss += err * err / n;
        grad.data[i] = 2.0 * err / n;
    }
    (loss, grad)
}

/// The critic's input rows `[z, a]`. Row `r` pairs action row `r` with observation row
/// `r / repeat`, so `repeat` candidate actions per observation are scored in one forward pass.
///
/// ```
/// use host_trainer::{algorithms::agent::critic_input, nn::net::Matrix};
/// let z = Matrix { rows: 1, cols: 2, data: vec![0.5, -0.5] };
/// let a = Matrix { rows: 2, cols: 1, data: vec![0.1, 0.2] };
/// let x = critic_input(&z, &a, 2);
/// assert_eq!(x.data, vec![0.5, -0.5, 0.1, 0.5, -0.5, 0.2]);
/// ```
pub fn critic_input(z: &Matrix, action: &Matrix, repeat: usize) -> Matrix {
    let mut x = Matrix::zeros(action.rows, z.cols + action.cols);
    for r in 0..action.rows {
        let row = x.row_mut(r);
        row[..z.cols].copy_from_slice(z.row(r / repeat));
        row[z.cols..].copy_from_slice(action.row(r));
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use firmware_sim::seed;

    /// A 1-observation, 1-action agent with twin critics whose target networks are set by
    /// hand: P'(s) = 0.5, Q1'(s, a) = a, Q2'(s, a) = 0.2 − a.
    fn hand_made(smoothing: Option<Smoothing>) -> Agent {
        let config = AgentConfig {
            hidden: "1x2".parse().expect("a shape"),
            ..AgentConfig::default()
        };
        let mut init = seed::training_stream(0, "init");
        let mut agent =
            Agent::new(config, 1, &[-1.0], &[1.0], &mut init).expect("hand-made test value");
        let critics = Critics {
            twin: true,
            smoothing,
            n_step: 1,
        };
        agent.set_critics(critics, &mut init);
        let linear = |net: &mut Net, slope: f32, offset: f32| {
            net.layers[0].w.iter_mut().for_each(|w| *w = 0.0);
            net.layers[0].b = vec![10.0, 0.0];
            net.layers[0].w[2] = 1.0; // the action to unit 0, shifted positive for the ReLU
            net.layers[1].w = vec![slope, 0.0];
            net.layers[1].b = vec![offset - 10.0 * slope];
        };
        linear(&mut agent.critic_target, 1.0, 0.0);
        linear(
            &mut agent
                .twin
                .as_mut()
                .expect("hand-made test value")
                .critic_target,
            -1.0,
            0.2,
        );
        let actor = &mut agent.actor_target;
        actor.layers.iter_mut().for_each(|l| {
            l.w.iter_mut().for_each(|w| *w = 0.0);
            l.b.iter_mut().for_each(|b| *b = 0.0);
        });
        actor.layers[1].b = vec![0.5f32.atanh()];
        agent
    }

    fn sample() -> Sample {
        let z = Matrix::from_vec(3, 1, vec![0.0, 0.3, -0.3]);
        Sample {
            z: z.clone(),
            action: Matrix::zeros(3, 1),
            reward: vec![1.0, 2.0, 3.0],
            z_next: z,
            terminal: vec![0.0, 0.0, 1.0],
            // One-step, a 3-step window (γ³ with γ 0.5), a terminal.
            discount: vec![0.5, 0.125, 0.5],
        }
    }

    #[test]
    fn twin_targets_take_the_smaller_critic_and_each_row_its_discount() {
        let mut agent = hand_made(None);
        let y = agent.bellman_targets(&sample(), None);
        // min(Q1', Q2') at a' = 0.5 is Q2' = -0.3.
        let want = [1.0 - 0.5 * 0.3, 2.0 - 0.125 * 0.3, 3.0];
        for (y, w) in y.iter().zip(want) {
            assert!((y - w).abs() < 1e-5, "{y} vs {w}");
        }
        // Without the twin, Q1' = 0.5 is the value.
        agent.twin = None;
        let y = agent.bellman_targets(&sample(), None);
        assert!((y[0] - (1.0 + 0.5 * 0.5)).abs() < 1e-5, "{}", y[0]);
    }

    #[test]
    fn target_smoothing_noise_is_clipped() {
        let smoothing = Smoothing {
            sigma: 100.0,
            clip: 0.1,
        };
        let mut agent = hand_made(Some(smoothing));
        let mut rng = seed::training_stream(1, "smoothing");
        let mut values = Vec::new();
        for _ in 0..20 {
            let y = agent.bellman_targets(&sample(), Some(&mut rng));
            // a' in [0.4, 0.6], so min(Q1', Q2') = 0.2 − a' in [-0.4, -0.2].
            let v = (y[0] - 1.0) / 0.5;
            assert!((-0.4 - 1e-5..=-0.2 + 1e-5).contains(&v), "{v}");
            values.push(v);
        }
        assert!(
            values.iter().any(|&v| (v + 0.3).abs() > 0.05),
            "the noise moved a'"
        );
        // σ = 100 saturates nearly every draw at the clip.
        assert!(
            values
                .iter()
                .filter(|&&v| (v + 0.4).abs() < 1e-4 || (v + 0.2).abs() < 1e-4)
                .count()
                >= 18
        );
    }

    #[test]
    fn a_twin_critic_takes_its_own_step_on_the_same_targets() {
        let mut agent = hand_made(None);
        let q1 = agent.critic.clone();
        let q2 = agent
            .twin
            .as_ref()
            .expect("hand-made test value")
            .critic
            .clone();
        agent.critic_update(&sample(), &mut seed::training_stream(2, "dropout"));
        assert_ne!(
            agent.twin.as_ref().expect("hand-made test value").critic,
            q2,
            "Q2 took a step"
        );
        assert_ne!(agent.critic, q1, "Q1 took a step");
        assert_ne!(
            agent.critic,
            agent.twin.as_ref().expect("hand-made test value").critic
        );
    }
}
