//! Deep Comparative Policy (DCP): the actor learns by comparison, never from ∇aQ.
//!
//! DCP keeps DDPG's actor, critic, replay buffer, target networks and critic update (all in
//! [`crate::agent`]) and replaces only the actor step with a T-fold comparison, exactly as
//! DESIGN.md section 1 reconstructs it:
//!
//! ```text
//! for every s in the minibatch:
//!     a0 = P(s)
//!     a_t = clip(a0 + N(0, σc²), -1, 1), t = 1..T            proposals
//!     A_t = Q(s, a_t) - Q(s, a0)                              advantages (one batched forward)
//!     target = a_t* with t* = argmax A_t, kept only if A_t* > 0
//!     w = A_t*, normalised over the batch
//! minimise Σ w ‖P(s) - target‖² / Σ w                         no gradient from Q into P
//! ```
//!
//! At a wall, pushing outward does not raise Q (the plant does not move), so no outward
//! proposal wins: the regression target slides along the wall instead of into it.

use serde::{Deserialize, Serialize};

use crate::agent::{critic_input, Agent, Sample};
use crate::net::Matrix;
use crate::seed::{self, Rng};

/// DCP's own settings (the shared ones, σ included, are in [`crate::agent::Config`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Number of proposals T per state [paper: T-fold compare; 16 is the largest T it tests].
    pub t: usize,
    /// Proposal noise σc in the unit box; absent = the exploration σ \[ours\].
    pub sigma_c: Option<f32>,
    /// How proposals become regression targets [ours: best-of-T].
    pub variant: Variant,
    /// How kept samples are weighted [paper: "weighted factor" = the advantage].
    pub weighting: Weighting,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            t: 16,
            sigma_c: None,
            variant: Variant::Best,
            weighting: Weighting::Advantage,
        }
    }
}

/// The most proposals per state.
pub const MAX_T: usize = 4096;

impl Config {
    /// Checks every value's range, naming the offending setting.
    pub fn validate(&self) -> Result<(), crate::Error> {
        crate::Error::check_count("dcp.t", self.t, MAX_T)?;
        if let Some(s) = self.sigma_c {
            crate::Error::check_range("dcp.sigma_c", s, f32::MIN_POSITIVE, f32::MAX)?;
        }
        Ok(())
    }
}

/// How the T proposals turn into regression targets.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Variant {
    /// The best proposal, if it beats P(s).
    Best,
    /// Every proposal that beats P(s) is a target, weighted by its advantage.
    Weighted,
    /// Proposal t perturbs the best so far (T sequential critic passes); the final best is the
    /// target.
    HillClimb,
}

/// The weight of a kept target.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Weighting {
    /// w = A, divided by the mean kept A of the batch.
    Advantage,
    /// w = 1 for every kept target.
    Uniform,
}

/// What one actor update did, for the metrics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ActorStats {
    /// The weighted regression loss Σ w ‖P(s) - target‖² / Σ w (0 when nothing was kept).
    pub loss: f32,
    /// Fraction of the minibatch whose best proposal beat the actor.
    pub kept: f32,
    /// Mean best advantage over the kept samples.
    pub advantage: f32,
}

/// The DCP actor learner.
#[derive(Clone, Debug, PartialEq)]
pub struct Dcp {
    /// Its settings.
    pub config: Config,
    sigma_c: f32,
}

/// Candidate actions, `per_state` consecutive rows per minibatch state, with their advantages.
struct Candidates {
    actions: Matrix,
    advantage: Vec<f32>,
    per_state: usize,
}

/// A regression target: minibatch row, candidate row, weight.
struct Target {
    row: usize,
    candidate: usize,
    weight: f32,
}

impl Dcp {
    /// A learner; `sigma` (the exploration σ) is the proposal noise unless `sigma_c` is set.
    pub fn new(config: Config, sigma: f32) -> Dcp {
        let sigma_c = config.sigma_c.unwrap_or(sigma);
        Dcp { config, sigma_c }
    }

    /// The proposal noise actually used.
    pub fn sigma_c(&self) -> f32 {
        self.sigma_c
    }

    /// One actor step: propose, compare under Q, regress P toward the winners.
    pub fn actor_update(
        &self,
        agent: &mut Agent,
        s: &Sample,
        proposal_rng: &mut Rng,
        dropout_rng: &mut Rng,
    ) -> ActorStats {
        let a0 = agent.actor_eval(&s.z);
        let candidates = match self.config.variant {
            Variant::Best | Variant::Weighted => self.compare_fan(agent, &s.z, &a0, proposal_rng),
            Variant::HillClimb => self.compare_climb(agent, &s.z, &a0, proposal_rng),
        };
        let targets = self.select(&candidates, s.z.rows);
        let mut stats = summarise(&targets, &candidates, s.z.rows);
        if targets.is_empty() {
            return stats;
        }
        // The compare step ran only the critic, so the actor's last pass is still `a0`'s.
        let p = agent.actor_forward_train_after_eval(&s.z, a0, dropout_rng);
        let (loss, grad) = weighted_regression(&p, &candidates.actions, &targets);
        agent.actor_step(&grad);
        stats.loss = loss;
        stats
    }

    /// `a_t = clip(a0 + N(0, σc²), -1, 1)` for t = 1..T around each state's a0, scored together
    /// with a0 itself in ONE critic forward of B × (T + 1) rows.
    fn compare_fan(&self, agent: &mut Agent, z: &Matrix, a0: &Matrix, rng: &mut Rng) -> Candidates {
        let per = self.config.t + 1;
        let mut actions = Matrix::zeros(a0.rows * per, a0.cols);
        for i in 0..a0.rows {
            actions.row_mut(i * per).copy_from_slice(a0.row(i));
            for t in 1..per {
                perturb(a0.row(i), actions.row_mut(i * per + t), self.sigma_c, rng);
            }
        }
        let q = agent.q_values(&critic_input(z, &actions, per));
        let advantage = (0..q.len()).map(|r| q[r] - q[r - r % per]).collect();
        Candidates {
            actions,
            advantage,
            per_state: per,
        }
    }

    /// Hill climbing: proposal t perturbs the best action so far; T critic passes of B rows.
    /// The single candidate per state is the final best.
    fn compare_climb(
        &self,
        agent: &mut Agent,
        z: &Matrix,
        a0: &Matrix,
        rng: &mut Rng,
    ) -> Candidates {
        let q0 = agent.q_values(&critic_input(z, a0, 1));
        let mut best = a0.clone();
        let mut q_best = q0.clone();
        let mut proposal = Matrix::zeros(a0.rows, a0.cols);
        for _ in 0..self.config.t {
            for i in 0..a0.rows {
                perturb(best.row(i), proposal.row_mut(i), self.sigma_c, rng);
            }
            let q = agent.q_values(&critic_input(z, &proposal, 1));
            for i in 0..a0.rows {
                if q[i] > q_best[i] {
                    best.row_mut(i).copy_from_slice(proposal.row(i));
                    q_best[i] = q[i];
                }
            }
        }
        let advantage = q_best.iter().zip(&q0).map(|(b, q)| b - q).collect();
        Candidates {
            actions: best,
            advantage,
            per_state: 1,
        }
    }

    /// Keeps candidates with a positive advantage: the best per state (`best`, `hill-climb`) or
    /// all of them (`weighted`), with weights normalised so the kept weights average 1.
    fn select(&self, c: &Candidates, states: usize) -> Vec<Target> {
        let mut targets = Vec::new();
        for row in 0..states {
            let range = row * c.per_state..(row + 1) * c.per_state;
            match self.config.variant {
                Variant::Weighted => {
                    targets.extend(range.filter(|&k| c.advantage[k] > 0.0).map(|k| Target {
                        row,
                        candidate: k,
                        weight: c.advantage[k],
                    }))
                }
                Variant::Best | Variant::HillClimb => {
                    let best = range.max_by(|&a, &b| c.advantage[a].total_cmp(&c.advantage[b]));
                    targets.extend(best.filter(|&k| c.advantage[k] > 0.0).map(|k| Target {
                        row,
                        candidate: k,
                        weight: c.advantage[k],
                    }));
                }
            }
        }
        self.normalise_weights(&mut targets);
        targets
    }

    /// Batch normalisation of the weights. The loss divides by Σw, so this does not change the
    /// update; it keeps logged weights comparable across batches and critic scales.
    fn normalise_weights(&self, targets: &mut [Target]) {
        if self.config.weighting == Weighting::Uniform {
            targets.iter_mut().for_each(|t| t.weight = 1.0);
            return;
        }
        let mean = targets.iter().map(|t| t.weight).sum::<f32>() / targets.len().max(1) as f32;
        if mean > 0.0 && mean.is_finite() {
            targets.iter_mut().for_each(|t| t.weight /= mean);
        }
    }
}

/// `out = clip(center + N(0, σ²), -1, 1)`, one draw per dimension in order.
fn perturb(center: &[f32], out: &mut [f32], sigma: f32, rng: &mut Rng) {
    for (o, &c) in out.iter_mut().zip(center) {
        *o = (c + sigma * seed::normal(rng)).clamp(-1.0, 1.0);
    }
}

/// L = Σ w ‖p_row - a_candidate‖² / Σ w and dL/dp. The targets are constants: nothing flows
/// from Q into P.
fn weighted_regression(p: &Matrix, actions: &Matrix, targets: &[Target]) -> (f32, Matrix) {
    let total: f32 = targets.iter().map(|t| t.weight).sum();
    let mut grad = Matrix::zeros(p.rows, p.cols);
    let mut loss = 0.0;
    for t in targets {
        let w = t.weight / total;
        for ((g, &pk), &ak) in grad
            .row_mut(t.row)
            .iter_mut()
            .zip(p.row(t.row))
            .zip(actions.row(t.candidate))
        {
            let d = pk - ak;
            loss += w * d * d;
            *g += 2.0 * w * d;
        }
    }
    (loss, grad)
}

fn summarise(targets: &[Target], c: &Candidates, states: usize) -> ActorStats {
    let mut kept_rows: Vec<usize> = targets.iter().map(|t| t.row).collect();
    kept_rows.dedup();
    let best = |row: usize| {
        (row * c.per_state..(row + 1) * c.per_state)
            .map(|k| c.advantage[k])
            .fold(f32::NEG_INFINITY, f32::max)
    };
    let advantage = kept_rows.iter().map(|&r| best(r)).sum::<f32>() / kept_rows.len().max(1) as f32;
    ActorStats {
        loss: 0.0,
        kept: kept_rows.len() as f32 / states.max(1) as f32,
        advantage,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn candidates(advantage: Vec<f32>, per_state: usize) -> Candidates {
        let rows = advantage.len();
        let actions = Matrix {
            rows,
            cols: 1,
            data: (0..rows).map(|r| r as f32 / 10.0).collect(),
        };
        Candidates {
            actions,
            advantage,
            per_state,
        }
    }

    #[test]
    fn best_keeps_only_states_whose_best_proposal_beats_the_actor() {
        let dcp = Dcp::new(
            Config {
                t: 2,
                ..Config::default()
            },
            0.2,
        );
        // State 0: proposals +1, +3 (keep candidate 2); state 1: -1, -2 (drop).
        let c = candidates(vec![0.0, 1.0, 3.0, 0.0, -1.0, -2.0], 3);
        let t = dcp.select(&c, 2);
        assert_eq!(t.len(), 1);
        assert_eq!((t[0].row, t[0].candidate, t[0].weight), (0, 2, 1.0));
    }

    #[test]
    fn weighted_keeps_every_positive_proposal_with_weight_proportional_to_advantage() {
        let dcp = Dcp::new(
            Config {
                t: 2,
                variant: Variant::Weighted,
                ..Config::default()
            },
            0.2,
        );
        let c = candidates(vec![0.0, 1.0, 3.0, 0.0, 2.0, -2.0], 3);
        let t = dcp.select(&c, 2);
        let w: Vec<_> = t.iter().map(|t| (t.candidate, t.weight)).collect();
        assert_eq!(w, vec![(1, 0.5), (2, 1.5), (4, 1.0)]);
    }

    #[test]
    fn regression_gradient_matches_finite_differences() {
        let p = Matrix {
            rows: 2,
            cols: 2,
            data: vec![0.1, -0.3, 0.5, 0.2],
        };
        let actions = Matrix {
            rows: 3,
            cols: 2,
            data: vec![0.4, 0.0, -0.2, 0.9, 0.3, 0.3],
        };
        let targets = [
            Target {
                row: 0,
                candidate: 0,
                weight: 2.0,
            },
            Target {
                row: 1,
                candidate: 1,
                weight: 1.0,
            },
            Target {
                row: 1,
                candidate: 2,
                weight: 0.5,
            },
        ];
        let (_, grad) = weighted_regression(&p, &actions, &targets);
        for k in 0..4 {
            let mut hi = p.clone();
            let mut lo = p.clone();
            hi.data[k] += 1e-3;
            lo.data[k] -= 1e-3;
            let fd = (weighted_regression(&hi, &actions, &targets).0
                - weighted_regression(&lo, &actions, &targets).0)
                / 2e-3;
            assert!(
                (fd - grad.data[k]).abs() < 1e-3,
                "param {k}: fd {fd} vs {}",
                grad.data[k]
            );
        }
    }

    #[test]
    fn sigma_c_defaults_to_the_exploration_sigma() {
        assert_eq!(Dcp::new(Config::default(), 0.7).sigma_c(), 0.7);
        assert_eq!(
            Dcp::new(
                Config {
                    sigma_c: Some(0.1),
                    ..Config::default()
                },
                0.7
            )
            .sigma_c(),
            0.1
        );
    }
}
