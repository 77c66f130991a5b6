//! The replay buffer: a ring of transitions in flat `f32` storage, sampled uniformly.
//!
//! Observations are stored raw; the trainer normalises each sampled batch with the statistics
//! of the moment (see [`crate::nn::normalize`]).
//!
//! Besides one-step transitions it forms n-step ones ([`Replay::sample_n_step_into`]) from the
//! slots that follow a drawn one: the ring is written in time order, and every slot records
//! whether its episode ended there, so a window never crosses an episode boundary.

use serde::{Deserialize, Serialize};

use crate::nn::net::Matrix;
use firmware_sim::seed;

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
    /// Whether the time limit cut the episode after this step (its value is not 0: an n-step
    /// return stops here and bootstraps from `next_obs`).
    pub truncated: bool,
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
    /// Whether the episode ended with the slot's step (terminal or truncated).
    end: Vec<bool>,
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
    /// The discount of each row's bootstrap value, γ^m after m summed rewards (n-step samples
    /// only; [`Replay::sample_into`] leaves it empty).
    pub discount: Vec<f32>,
}

impl Replay {
    /// An empty buffer for `capacity` transitions. The storage grows with the transitions
    /// stored, up to the capacity, so a buffer (and a checkpoint) holds only what was stored: a
    /// badminton team keeps 48 buffers that each see a few thousand transitions.
    ///
    /// # Panics
    /// If `capacity` is 0.
    ///
    /// ```
    /// use host_trainer::buffers::replay::{Replay, Transition};
    /// let mut replay = Replay::new(2, 1, 1);
    /// for r in [1.0, 2.0, 3.0] {
    ///     replay.push(&Transition { obs: vec![r], action: vec![0.0], reward: r,
    ///                               next_obs: vec![r], terminal: false, truncated: false });
    /// }
    /// assert_eq!(replay.len(), 2);
    /// let batch = replay.sample(8, &mut firmware_sim::seed::training_stream(0, "replay"));
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
            obs: Vec::new(),
            action: Vec::new(),
            reward: Vec::new(),
            next_obs: Vec::new(),
            terminal: Vec::new(),
            end: Vec::new(),
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
        put(&mut self.obs, self.obs_dim, i, &t.obs);
        put(&mut self.next_obs, self.obs_dim, i, &t.next_obs);
        put(&mut self.action, self.act_dim, i, &t.action);
        put(&mut self.reward, 1, i, &[t.reward]);
        put(
            &mut self.terminal,
            1,
            i,
            &[if t.terminal { 1.0 } else { 0.0 }],
        );
        put(&mut self.end, 1, i, &[t.terminal || t.truncated]);
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
    /// assert!(host_trainer::buffers::replay::Replay::new(4, 2, 2).is_empty());
    /// ```
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The stored transitions' raw observation before and after the step, oldest slot first
    /// once the ring has wrapped (slot order before): what an analysis of the buffer's coverage
    /// reads (the studies crate's `margin-diagnosis`).
    ///
    /// ```
    /// use host_trainer::buffers::replay::{Replay, Transition};
    /// let mut replay = Replay::new(2, 1, 1);
    /// for x in [1.0, 2.0, 3.0] {
    ///     let t = Transition { obs: vec![x], action: vec![0.0], reward: 0.0,
    ///         next_obs: vec![x + 0.5], terminal: false, truncated: false };
    ///     replay.push(&t);
    /// }
    /// let moves: Vec<_> = replay.moves().map(|(s, s2)| (s[0], s2[0])).collect();
    /// assert_eq!(moves, [(2.0, 2.5), (3.0, 3.5)]); // the oldest, 1.0, was replaced
    /// ```
    pub fn moves(&self) -> impl Iterator<Item = (&[f32], &[f32])> + '_ {
        let start = if self.len == self.capacity {
            self.head
        } else {
            0
        };
        (0..self.len).map(move |k| {
            let i = (start + k) % self.capacity;
            (
                slot(&self.obs, self.obs_dim, i),
                slot(&self.next_obs, self.obs_dim, i),
            )
        })
    }

    /// Maximum number of transitions kept.
    ///
    /// ```
    /// assert_eq!(host_trainer::buffers::replay::Replay::new(4, 2, 2).capacity(), 4);
    /// ```
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// `batch` transitions drawn uniformly with replacement (raw observations).
    ///
    /// # Panics
    /// If the buffer is empty.
    pub fn sample(&self, batch: usize, rng: &mut seed::SimRng) -> Batch {
        let mut out = Batch::default();
        self.sample_into(batch, rng, &mut out);
        out
    }

    /// [`Replay::sample`] into a reused batch (no allocation once warm).
    ///
    /// ```
    /// use host_trainer::buffers::replay::{Batch, Replay, Transition};
    /// let mut replay = Replay::new(10, 1, 1);
    /// replay.push(&Transition { obs: vec![1.0], action: vec![0.5], reward: -1.0,
    ///                           next_obs: vec![2.0], terminal: true, truncated: false });
    /// let mut batch = Batch::default();
    /// replay.sample_into(3, &mut firmware_sim::seed::training_stream(0, "replay"), &mut batch);
    /// assert_eq!(batch.terminal, vec![1.0; 3]);
    /// assert_eq!(batch.next_obs.data, vec![2.0; 3]);
    /// ```
    ///
    /// # Panics
    /// If the buffer is empty.
    pub fn sample_into(&self, batch: usize, rng: &mut seed::SimRng, out: &mut Batch) {
        assert!(!self.is_empty(), "Replay::sample: the buffer is empty");
        self.shape(batch, out);
        out.discount.clear();
        for r in 0..batch {
            let i = seed::index(rng, self.len);
            self.copy_row(i, r, out);
        }
    }
}

impl Replay {
    /// `batch` n-step transitions drawn uniformly with replacement (raw observations), with the
    /// same random draws as [`Replay::sample_into`].
    ///
    /// From a drawn slot i the window runs over the m ≤ n steps i, i+1, … that belong to i's
    /// episode and are stored: it stops after a terminal step (no bootstrap: `terminal` 1), after
    /// a time-limit truncation (bootstrap from that step's next observation), after n steps, or
    /// at the newest slot. The row holds R = Σ_{k<m} γ^k r_{i+k}, the observation after the last
    /// step, and `discount` γ^m, so the Bellman target is R + discount·(1 − terminal)·V(s').
    /// The later actions are the stored (noisy) ones, uncorrected, as in Rainbow and D4PG.
    ///
    /// ```
    /// use host_trainer::buffers::replay::{Batch, Replay, Transition};
    /// let mut replay = Replay::new(8, 1, 1);
    /// for k in 0..3 {
    ///     replay.push(&Transition { obs: vec![k as f32], action: vec![0.0], reward: 1.0,
    ///                               next_obs: vec![k as f32 + 1.0], terminal: k == 2,
    ///                               truncated: false });
    /// }
    /// let mut batch = Batch::default();
    /// replay.sample_n_step_into(16, 3, 0.5, &mut firmware_sim::seed::training_stream(0, "replay"), &mut batch);
    /// for r in 0..16 {
    ///     if batch.obs.row(r)[0] == 0.0 {
    ///         // 1 + 0.5 + 0.25, ending in the terminal step: nothing to bootstrap.
    ///         assert_eq!((batch.reward[r], batch.terminal[r]), (1.75, 1.0));
    ///     }
    /// }
    /// ```
    ///
    /// # Panics
    /// If the buffer is empty or `n` is 0.
    pub fn sample_n_step_into(
        &self,
        batch: usize,
        n: usize,
        gamma: f32,
        rng: &mut seed::SimRng,
        out: &mut Batch,
    ) {
        assert!(n > 0, "Replay::sample_n_step_into: n must be positive");
        assert!(!self.is_empty(), "Replay::sample: the buffer is empty");
        self.shape(batch, out);
        out.discount.resize(batch, 0.0);
        for r in 0..batch {
            let i = seed::index(rng, self.len);
            self.copy_row(i, r, out);
            let w = self.window(i, n, gamma);
            out.reward[r] = w.ret;
            out.terminal[r] = w.terminal;
            out.discount[r] = w.discount;
            out.next_obs
                .row_mut(r)
                .copy_from_slice(slot(&self.next_obs, self.obs_dim, w.last));
        }
    }

    /// The n-step window that starts at slot `i` (see [`Replay::sample_n_step_into`]).
    fn window(&self, i: usize, n: usize, gamma: f32) -> Window {
        let (mut j, mut ret, mut g) = (i, 0.0f32, 1.0f32);
        for k in 0..n {
            ret += g * self.reward[j];
            g *= gamma;
            let next = (j + 1) % self.capacity;
            // `next == head`: j is the newest slot (or the ring would wrap to the oldest).
            if self.end[j] || k + 1 == n || next == self.head {
                break;
            }
            j = next;
        }
        Window {
            ret,
            terminal: self.terminal[j],
            discount: g,
            last: j,
        }
    }

    fn shape(&self, batch: usize, out: &mut Batch) {
        out.obs.reshape(batch, self.obs_dim);
        out.next_obs.reshape(batch, self.obs_dim);
        out.action.reshape(batch, self.act_dim);
        out.reward.resize(batch, 0.0);
        out.terminal.resize(batch, 0.0);
    }

    /// Slot `i` into row `r` of `out`.
    fn copy_row(&self, i: usize, r: usize, out: &mut Batch) {
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

/// An n-step window: its discounted return, whether it ends in a terminal step, the bootstrap
/// discount γ^m and its last slot.
struct Window {
    ret: f32,
    terminal: f32,
    discount: f32,
    last: usize,
}

fn slot(data: &[f32], dim: usize, i: usize) -> &[f32] {
    &data[i * dim..(i + 1) * dim]
}

/// Writes slot `i` (of `dim` values): appended while the storage is still growing (slots are
/// filled in order until the ring wraps), overwritten after. A buffer saved before storage
/// grew (every slot allocated) takes the second branch from the start.
fn put<T: Copy>(data: &mut Vec<T>, dim: usize, i: usize, values: &[T]) {
    if data.len() <= i * dim {
        data.extend_from_slice(values);
    } else {
        data[i * dim..(i + 1) * dim].copy_from_slice(values);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firmware_sim::seed::training_stream;

    fn transition(k: usize) -> Transition {
        let k = k as f32;
        Transition {
            obs: vec![k, -k],
            action: vec![k / 100.0],
            reward: k,
            next_obs: vec![k + 0.5, -k],
            terminal: k as usize % 3 == 0,
            truncated: false,
        }
    }

    #[test]
    fn ring_wraps_and_keeps_the_newest() {
        let mut replay = Replay::new(5, 2, 1);
        assert!(replay.is_empty());
        (0..12).for_each(|k| replay.push(&transition(k)));
        assert_eq!((replay.len(), replay.capacity()), (5, 5));
        let batch = replay.sample(400, &mut training_stream(1, "replay"));
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
        let batch = replay.sample(64, &mut training_stream(2, "replay"));
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
        let a = replay.sample(64, &mut training_stream(3, "replay"));
        assert_eq!(a, replay.sample(64, &mut training_stream(3, "replay")));
        assert_ne!(a, replay.sample(64, &mut training_stream(4, "replay")));
        let mut reused = Batch::default();
        replay.sample_into(64, &mut training_stream(3, "replay"), &mut reused);
        assert_eq!(a, reused);
    }

    /// A hand-made trajectory in a ring of 16: an episode ending in a terminal step (slots
    /// 0–2), one cut by the time limit (3–4), and one still running (5–8, 8 the newest).
    /// Rewards are k + 1 at slot k.
    fn trajectory() -> Replay {
        let mut replay = Replay::new(16, 1, 1);
        for k in 0..9 {
            replay.push(&Transition {
                obs: vec![k as f32],
                action: vec![0.0],
                reward: k as f32 + 1.0,
                next_obs: vec![k as f32 + 0.5],
                terminal: k == 2,
                truncated: k == 4,
            });
        }
        replay
    }

    #[test]
    fn n_step_windows_stop_at_terminals_truncations_and_the_newest_step() {
        let replay = trajectory();
        let w = |i| {
            let w = replay.window(i, 3, 0.5);
            (w.ret, w.terminal, w.discount, w.last)
        };
        // Terminal inside the window: no bootstrap (terminal 1).
        assert_eq!(w(0), (1.0 + 0.5 * 2.0 + 0.25 * 3.0, 1.0, 0.125, 2));
        assert_eq!(w(1), (2.0 + 0.5 * 3.0, 1.0, 0.25, 2));
        assert_eq!(w(2), (3.0, 1.0, 0.5, 2));
        // Truncation inside the window: bootstrap from slot 4's next observation with γ^2.
        assert_eq!(w(3), (4.0 + 0.5 * 5.0, 0.0, 0.25, 4));
        assert_eq!(w(4), (5.0, 0.0, 0.5, 4));
        // Full windows, bootstrapped with γ^3.
        assert_eq!(w(5), (6.0 + 0.5 * 7.0 + 0.25 * 8.0, 0.0, 0.125, 7));
        assert_eq!(w(6), (7.0 + 0.5 * 8.0 + 0.25 * 9.0, 0.0, 0.125, 8));
        // The newest step ends the window: bootstrap from it.
        assert_eq!(w(7), (8.0 + 0.5 * 9.0, 0.0, 0.25, 8));
        assert_eq!(w(8), (9.0, 0.0, 0.5, 8));
        // n = 1 is the one-step transition.
        for i in 0..9 {
            let one = replay.window(i, 1, 0.5);
            assert_eq!((one.ret, one.discount, one.last), (i as f32 + 1.0, 0.5, i));
        }
    }

    #[test]
    fn n_step_window_does_not_wrap_from_the_newest_to_the_oldest_slot() {
        let mut replay = Replay::new(4, 1, 1);
        (0..6).for_each(|k| {
            replay.push(&Transition {
                obs: vec![k as f32],
                action: vec![0.0],
                reward: 1.0,
                next_obs: vec![k as f32 + 0.5],
                terminal: false,
                truncated: false,
            })
        });
        // Slots hold steps [4, 5, 2, 3]; step 5 (slot 1) is the newest, step 2 (slot 2) the oldest.
        let newest = replay.window(1, 3, 0.9);
        assert_eq!((newest.ret, newest.last), (1.0, 1));
        let oldest = replay.window(2, 3, 0.9);
        assert_eq!(oldest.last, 0, "2 → 3 → 4 wraps the ring in time order");
    }

    #[test]
    fn n_step_sample_rows_are_their_windows_with_the_one_step_draws() {
        let replay = trajectory();
        let mut batch = Batch::default();
        replay.sample_n_step_into(64, 3, 0.5, &mut training_stream(5, "replay"), &mut batch);
        let one = replay.sample(64, &mut training_stream(5, "replay"));
        assert_eq!(batch.obs, one.obs, "the same slots are drawn");
        for r in 0..64 {
            let i = batch.obs.row(r)[0] as usize;
            let w = replay.window(i, 3, 0.5);
            assert_eq!(batch.reward[r], w.ret);
            assert_eq!(batch.terminal[r], w.terminal);
            assert_eq!(batch.discount[r], w.discount);
            assert_eq!(batch.next_obs.row(r), &[w.last as f32 + 0.5]);
        }
    }
}
