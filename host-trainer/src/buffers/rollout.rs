//! The on-policy rollout buffer and generalised advantage estimation (GAE), beside the replay
//! buffer of the off-policy algorithms.
//!
//! A rollout is a fixed number of consecutive plant steps collected with one policy; it may
//! start and end in the middle of an episode. Each step keeps what the policy-gradient update
//! needs: the normalised observation the action was chosen on, the sampled action, its
//! log-probability and the value estimate at that time, and the reward.
//!
//! Where an episode ends, the value of what follows is known only to the caller: 0 after a
//! terminal state, V(s') after a cut by the time limit (a truncation is not a terminal state),
//! and V(s') after the rollout's last step when the episode goes on. [`Rollout::push`] takes
//! that value with the step.

use serde::{Deserialize, Serialize};

/// Steps of one rollout, in the order they happened.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Rollout {
    /// Observation size.
    pub obs_dim: usize,
    /// Action size.
    pub act_dim: usize,
    /// Normalised observations, `len × obs_dim`.
    pub z: Vec<f32>,
    /// Sampled actions (unit box, before clipping), `len × act_dim`.
    pub action: Vec<f32>,
    /// log π(a | s) when the action was sampled.
    pub log_prob: Vec<f32>,
    /// V(s) when the action was sampled.
    pub value: Vec<f32>,
    /// Rewards.
    pub reward: Vec<f32>,
    /// The value of the state after each step when the episode does not simply go on in the
    /// next row: `Some(0.0)` after a terminal state, `Some(V(s'))` after a truncation or at
    /// the end of the rollout; `None` when the next row continues the episode.
    pub bootstrap: Vec<Option<f32>>,
}

/// One step to append.
#[derive(Clone, Copy, Debug)]
pub struct RolloutStep<'a> {
    /// Normalised observation.
    pub z: &'a [f32],
    /// Sampled action.
    pub action: &'a [f32],
    /// Its log-probability.
    pub log_prob: f32,
    /// V(s).
    pub value: f32,
    /// Reward.
    pub reward: f32,
    /// See [`Rollout::bootstrap`].
    pub bootstrap: Option<f32>,
}

impl Rollout {
    /// An empty rollout.
    pub fn new(obs_dim: usize, act_dim: usize) -> Rollout {
        Rollout {
            obs_dim,
            act_dim,
            ..Rollout::default()
        }
    }

    /// Steps stored.
    pub fn len(&self) -> usize {
        self.reward.len()
    }

    /// Whether no step is stored.
    pub fn is_empty(&self) -> bool {
        self.reward.is_empty()
    }

    /// Appends a step.
    pub fn push(&mut self, s: &RolloutStep<'_>) {
        self.z.extend_from_slice(s.z);
        self.action.extend_from_slice(s.action);
        self.log_prob.push(s.log_prob);
        self.value.push(s.value);
        self.reward.push(s.reward);
        self.bootstrap.push(s.bootstrap);
    }

    /// Sets the value after the last step (the rollout ends while the episode goes on).
    pub fn close(&mut self, value_after: f32) {
        if let Some(last @ None) = self.bootstrap.last_mut() {
            *last = Some(value_after);
        }
    }

    /// Forgets every step.
    pub fn clear(&mut self) {
        *self = Rollout::new(self.obs_dim, self.act_dim);
    }

    /// Advantages and returns by GAE; see [`gae`].
    pub fn advantages(&self, gamma: f32, lambda: f32) -> (Vec<f32>, Vec<f32>) {
        gae(&self.reward, &self.value, &self.bootstrap, gamma, lambda)
    }
}

/// Generalised advantage estimation (Schulman et al. 2016, eq. 16), backwards over the steps:
///
/// ```text
/// next_t  = bootstrap_t                 if the episode does not go on in row t + 1
///         = value_{t+1}                 otherwise
/// δ_t     = r_t + γ next_t − V_t
/// A_t     = δ_t + γλ A_{t+1}            (A_{t+1} = 0 where the episode does not go on)
/// return_t = A_t + V_t                  (the value target)
/// ```
///
/// A missing bootstrap on the last row counts as 0.
///
/// ```
/// use host_trainer::buffers::rollout::gae;
/// // Two steps, then a terminal state: with λ = 1 the returns are the discounted sums.
/// let (adv, ret) = gae(&[1.0, 1.0], &[0.0, 0.0], &[None, Some(0.0)], 0.5, 1.0);
/// assert_eq!(ret, vec![1.5, 1.0]);
/// assert_eq!(adv, ret);
/// ```
pub fn gae(
    reward: &[f32],
    value: &[f32],
    bootstrap: &[Option<f32>],
    gamma: f32,
    lambda: f32,
) -> (Vec<f32>, Vec<f32>) {
    let n = reward.len();
    let mut adv = vec![0.0; n];
    let mut following = 0.0; // A_{t+1} of the same episode
    for t in (0..n).rev() {
        let (next, goes_on) = match bootstrap[t] {
            Some(v) => (v, false),
            None => (value.get(t + 1).copied().unwrap_or(0.0), t + 1 < n),
        };
        let delta = reward[t] + gamma * next - value[t];
        let carried = if goes_on { following } else { 0.0 };
        adv[t] = delta + gamma * lambda * carried;
        following = adv[t];
    }
    let returns = adv.iter().zip(value).map(|(a, v)| a + v).collect();
    (adv, returns)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-made trajectory across three episode ends: a terminal state, a truncation and
    /// the end of the rollout mid-episode, each bootstrapped as it must be.
    #[test]
    fn gae_on_a_hand_made_trajectory() {
        let (g, l) = (0.9f32, 0.5f32);
        let reward = [1.0, 2.0, 3.0, 4.0, 5.0];
        let value = [0.5, 1.0, 1.5, 2.0, 2.5];
        // Rows 0-1: an episode ending in a terminal state. Row 2: an episode cut by the time
        // limit with V(s') = 10. Rows 3-4: an episode the rollout ends in, V(s') = 7.
        let boot = [None, Some(0.0), Some(10.0), None, Some(7.0)];
        let (adv, ret) = gae(&reward, &value, &boot, g, l);
        let d1 = 2.0 - 1.0;
        let d0 = 1.0 + g * 1.0 - 0.5;
        let d2 = 3.0 + g * 10.0 - 1.5;
        let d4 = 5.0 + g * 7.0 - 2.5;
        let d3 = 4.0 + g * 2.5 - 2.0;
        let want = [d0 + g * l * d1, d1, d2, d3 + g * l * d4, d4];
        for (a, w) in adv.iter().zip(want) {
            assert!((a - w).abs() < 1e-5, "{adv:?} vs {want:?}");
        }
        for t in 0..5 {
            assert!((ret[t] - (adv[t] + value[t])).abs() < 1e-6);
        }
    }

    /// With λ = 1 and zero values, the returns are the discounted reward sums to each episode's
    /// end plus the discounted bootstrap.
    #[test]
    fn lambda_one_gives_discounted_returns() {
        let g = 0.99f32;
        let reward = [1.0, 0.0, 2.0];
        let (_, ret) = gae(&reward, &[0.0; 3], &[None, None, Some(4.0)], g, 1.0);
        let want2 = 2.0 + g * 4.0;
        let want1 = g * want2;
        let want0 = 1.0 + g * want1;
        assert!((ret[2] - want2).abs() < 1e-5);
        assert!((ret[1] - want1).abs() < 1e-5);
        assert!((ret[0] - want0).abs() < 1e-5);
    }

    #[test]
    fn close_sets_only_an_open_end() {
        let mut r = Rollout::new(1, 1);
        let step = |boot| RolloutStep {
            z: &[0.0],
            action: &[0.0],
            log_prob: 0.0,
            value: 0.0,
            reward: 0.0,
            bootstrap: boot,
        };
        r.push(&step(None));
        r.close(3.0);
        assert_eq!(r.bootstrap, vec![Some(3.0)]);
        r.push(&step(Some(0.0)));
        r.close(5.0);
        assert_eq!(r.bootstrap[1], Some(0.0), "a terminal end stays terminal");
        r.clear();
        assert!(r.is_empty());
    }
}
