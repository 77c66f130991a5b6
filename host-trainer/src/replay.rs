//! The replay buffer: a ring of transitions in flat `f32` storage, sampled uniformly.
//!
//! Observations are stored raw; the trainer normalises each sampled batch with the statistics
//! of the moment (see [`crate::normalize`]).

use serde::{Deserialize, Serialize};

use crate::net::Matrix;
use crate::seed;

/// One environment step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Transition {
    /// Raw observation before the step.
    pub obs: Vec<f32>,
    /// The action executed, in the unit box `[-1, 1]`.
    pub action: Vec<f32>,
    /// Reward of the step.
    pub reward: f32,
    /// Raw observation after the step.
    pub next_obs: Vec<f32>,
    /// Whether the step ended the episode in a terminal state (not a time-limit truncation).
    pub terminal: bool,
}

/// A fixed-capacity ring buffer of transitions; once full, each push replaces the oldest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Replay {
    capacity: usize,
    obs_dim: usize,
    act_dim: usize,
    /// Slots filled so far (at most `capacity`).
    len: usize,
    /// The slot the next push writes.
    head: usize,
    obs: Vec<f32>,
    action: Vec<f32>,
    reward: Vec<f32>,
    next_obs: Vec<f32>,
    terminal: Vec<f32>,
}

/// A sampled minibatch, one transition per row.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Batch {
    /// Raw observations.
    pub obs: Matrix,
    /// Unit-box actions.
    pub action: Matrix,
    /// Rewards.
    pub reward: Vec<f32>,
    /// Raw next observations.
    pub next_obs: Matrix,
    /// 1.0 for terminal transitions, 0.0 otherwise.
    pub terminal: Vec<f32>,
}

impl Replay {
    /// An empty buffer for `capacity` transitions (the storage is allocated up front).
    ///
    /// # Panics
    /// If `capacity` is 0.
    ///
    /// ```
    /// use host_trainer::replay::{Replay, Transition};
    /// let mut replay = Replay::new(2, 1, 1);
    /// for r in [1.0, 2.0, 3.0] {
    ///     replay.push(&Transition { obs: vec![r], action: vec![0.0], reward: r,
    ///                               next_obs: vec![r], terminal: false });
    /// }
    /// assert_eq!(replay.len(), 2);
    /// let batch = replay.sample(8, &mut host_trainer::seed::stream(0, "replay"));
    /// assert!(batch.reward.iter().all(|&r| r == 2.0 || r == 3.0)); // 1.0 was overwritten
    /// ```
    pub fn new(capacity: usize, obs_dim: usize, act_dim: usize) -> Self {
        assert!(capacity > 0, "Replay::new: capacity must be positive");
        Self {
            capacity,
            obs_dim,
            act_dim,
            len: 0,
            head: 0,
            obs: vec![0.0; capacity * obs_dim],
            action: vec![0.0; capacity * act_dim],
            reward: vec![0.0; capacity],
            next_obs: vec![0.0; capacity * obs_dim],
            terminal: vec![0.0; capacity],
        }
    }

    /// Stores a transition, replacing the oldest one when full.
    ///
    /// # Panics
    /// If the observation or action sizes differ from the buffer's (a programming error).
    pub fn push(&mut self, t: &Transition) {
        assert_eq!(t.obs.len(), self.obs_dim, "Replay::push: observation size");
        assert_eq!(
            t.next_obs.len(),
            self.obs_dim,
            "Replay::push: next observation size"
        );
        assert_eq!(t.action.len(), self.act_dim, "Replay::push: action size");
        let i = self.head;
        slot_mut(&mut self.obs, self.obs_dim, i).copy_from_slice(&t.obs);
        slot_mut(&mut self.next_obs, self.obs_dim, i).copy_from_slice(&t.next_obs);
        slot_mut(&mut self.action, self.act_dim, i).copy_from_slice(&t.action);
        self.reward[i] = t.reward;
        self.terminal[i] = if t.terminal { 1.0 } else { 0.0 };
        self.head = (i + 1) % self.capacity;
        self.len = (self.len + 1).min(self.capacity);
    }

    /// Transitions stored.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether nothing has been stored yet.
    ///
    /// ```
    /// assert!(host_trainer::replay::Replay::new(4, 2, 2).is_empty());
    /// ```
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Maximum number of transitions kept.
    ///
    /// ```
    /// assert_eq!(host_trainer::replay::Replay::new(4, 2, 2).capacity(), 4);
    /// ```
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// `batch` transitions drawn uniformly with replacement (raw observations).
    ///
    /// # Panics
    /// If the buffer is empty.
    pub fn sample(&self, batch: usize, rng: &mut seed::Rng) -> Batch {
        let mut out = Batch::default();
        self.sample_into(batch, rng, &mut out);
        out
    }

    /// [`Replay::sample`] into a reused batch (no allocation once warm).
    ///
    /// ```
    /// use host_trainer::replay::{Batch, Replay, Transition};
    /// let mut replay = Replay::new(10, 1, 1);
    /// replay.push(&Transition { obs: vec![1.0], action: vec![0.5], reward: -1.0,
    ///                           next_obs: vec![2.0], terminal: true });
    /// let mut batch = Batch::default();
    /// replay.sample_into(3, &mut host_trainer::seed::stream(0, "replay"), &mut batch);
    /// assert_eq!(batch.terminal, vec![1.0; 3]);
    /// assert_eq!(batch.next_obs.data, vec![2.0; 3]);
    /// ```
    ///
    /// # Panics
    /// If the buffer is empty.
    pub fn sample_into(&self, batch: usize, rng: &mut seed::Rng, out: &mut Batch) {
        assert!(!self.is_empty(), "Replay::sample: the buffer is empty");
        out.obs.reshape(batch, self.obs_dim);
        out.next_obs.reshape(batch, self.obs_dim);
        out.action.reshape(batch, self.act_dim);
        out.reward.resize(batch, 0.0);
        out.terminal.resize(batch, 0.0);
        for r in 0..batch {
            let i = seed::index(rng, self.len);
            out.obs
                .row_mut(r)
                .copy_from_slice(slot(&self.obs, self.obs_dim, i));
            out.next_obs
                .row_mut(r)
                .copy_from_slice(slot(&self.next_obs, self.obs_dim, i));
            out.action
                .row_mut(r)
                .copy_from_slice(slot(&self.action, self.act_dim, i));
            out.reward[r] = self.reward[i];
            out.terminal[r] = self.terminal[i];
        }
    }
}

fn slot(data: &[f32], dim: usize, i: usize) -> &[f32] {
    &data[i * dim..(i + 1) * dim]
}

fn slot_mut(data: &mut [f32], dim: usize, i: usize) -> &mut [f32] {
    &mut data[i * dim..(i + 1) * dim]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seed::stream;

    fn transition(k: usize) -> Transition {
        let k = k as f32;
        Transition {
            obs: vec![k, -k],
            action: vec![k / 100.0],
            reward: k,
            next_obs: vec![k + 0.5, -k],
            terminal: k as usize % 3 == 0,
        }
    }

    #[test]
    fn ring_wraps_and_keeps_the_newest() {
        let mut replay = Replay::new(5, 2, 1);
        assert!(replay.is_empty());
        (0..12).for_each(|k| replay.push(&transition(k)));
        assert_eq!((replay.len(), replay.capacity()), (5, 5));
        let batch = replay.sample(400, &mut stream(1, "replay"));
        let mut seen: Vec<u32> = batch.reward.iter().map(|&r| r as u32).collect();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(
            seen,
            vec![7, 8, 9, 10, 11],
            "only the last 5 pushes survive, all reachable"
        );
    }

    #[test]
    fn rows_stay_together() {
        let mut replay = Replay::new(16, 2, 1);
        (0..10).for_each(|k| replay.push(&transition(k)));
        let batch = replay.sample(64, &mut stream(2, "replay"));
        for r in 0..64 {
            let k = batch.reward[r];
            assert_eq!(batch.obs.row(r), &[k, -k]);
            assert_eq!(batch.next_obs.row(r), &[k + 0.5, -k]);
            assert_eq!(batch.action.row(r), &[k / 100.0]);
            assert_eq!(
                batch.terminal[r],
                if k as usize % 3 == 0 { 1.0 } else { 0.0 }
            );
        }
    }

    #[test]
    fn sampling_is_deterministic_per_seed() {
        let mut replay = Replay::new(100, 2, 1);
        (0..100).for_each(|k| replay.push(&transition(k)));
        let a = replay.sample(64, &mut stream(3, "replay"));
        assert_eq!(a, replay.sample(64, &mut stream(3, "replay")));
        assert_ne!(a, replay.sample(64, &mut stream(4, "replay")));
        let mut reused = Batch::default();
        replay.sample_into(64, &mut stream(3, "replay"), &mut reused);
        assert_eq!(a, reused);
    }
}
