//! Deep Q-Network (Mnih et al. 2015, "Human-level control through deep reinforcement
//! learning"), the discrete baseline of docs/design.md §4, in the shape of CleanRL's `dqn.py`.
//!
//! ```text
//! moves     8 steps of 0.25 at n·45°, n = 0..7 (the action table)
//! network   Q(s, ·): the 4×48 network with one linear output per move
//! act       ε-greedy: a random move with probability ε, else argmax_k Q(s, k);
//!           ε falls linearly from 1 to 0.05 over the first 10 % of the episodes
//! store     (s, k, r, s', terminal) in the replay buffer
//! update    every plant step after the warm-up, on a minibatch of 64:
//!           y = r + γ (1 − terminal) max_k Q'(s', k)
//!           minimise mean Huber(Q(s, k) − y)  (δ = 1)
//!           θ' ← τθ + (1 − τ)θ'
//! ```
//!
//! The exported blob is a discrete policy: the Q-network, the normaliser and the action table;
//! the chip runs the argmax (policy-core's `Model::choose`, ties to the lowest index). DQN's
//! moves are 0.25 long, so it can never hold within 0.1 of the centre (the paper: it "cannot
//! stop at a stable ending").

use serde::{Deserialize, Serialize};

use firmware_sim::seed::{self, SimRng};

use super::agent_config::AgentConfig;
use super::algorithm::{Algorithm, Means, Step};
use crate::blob::export;
use crate::buffers::replay::{Replay, Transition};
use crate::nn::adam::Adam;
use crate::nn::net::{soft_update, Grads, Matrix, Net, Output, Tape};
use crate::nn::normalize::RunningNorm;
use crate::Error;

/// DQN's own settings. Shared settings come from [`AgentConfig`]: `hidden`, `activation`,
/// `lr_critic` (the Q-network's learning rate), `l2`, `batch`, `gamma`, `tau` (the target
/// network), `replay_capacity`, `warmup_steps`, `updates_per_step`, `norm_clip` and
/// `reward_scale`, so DQN differs from DDPG and DCP only where docs/design.md says it does.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Number of moves, at angles n · 360° / moves [paper: 8].
    pub moves: usize,
    /// Length of every move, in plant units [paper: 0.25].
    pub step: f32,
    /// ε at the first episode [docs/design.md §4: 1].
    pub epsilon_start: f32,
    /// ε after the decay [docs/design.md §4: 0.05].
    pub epsilon_end: f32,
    /// Fraction of the episodes over which ε falls linearly [ours: the first 10 %]. A
    /// 64-bit number, so that 10 % of 20 episodes is exactly 2.
    pub epsilon_fraction: f64,
    /// Huber loss threshold δ [ours: 1, the Nature DQN's error clipping].
    pub huber_delta: f32,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            moves: 8,
            step: 0.25,
            epsilon_start: 1.0,
            epsilon_end: 0.05,
            epsilon_fraction: 0.1,
            huber_delta: 1.0,
        }
    }
}

impl Config {
    /// Checks every value's range, naming the offending setting.
    pub fn validate(&self) -> Result<(), Error> {
        let max = policy_core::blob::MAX_CHOICES;
        Error::check_count("dqn.moves", self.moves, max)?;
        Error::check_range("dqn.step", self.step, f32::MIN_POSITIVE, f32::MAX)?;
        Error::check_range("dqn.epsilon_start", self.epsilon_start, 0.0, 1.0)?;
        Error::check_range("dqn.epsilon_end", self.epsilon_end, 0.0, 1.0)?;
        if !(0.0..=1.0).contains(&self.epsilon_fraction) {
            return Err(Error::invalid(
                "dqn.epsilon_fraction",
                "a number in [0, 1]",
                self.epsilon_fraction,
            ));
        }
        Error::check_range(
            "dqn.huber_delta",
            self.huber_delta,
            f32::MIN_POSITIVE,
            f32::MAX,
        )
    }

    /// The action table: `moves` rows `(step cos θ_n, step sin θ_n)`, θ_n = n · 2π / moves.
    ///
    /// ```
    /// use host_trainer::algorithms::dqn::Config;
    /// let table = Config::default().table();
    /// assert_eq!(table.len(), 16);
    /// assert_eq!((table[0], table[1]), (0.25, 0.0)); // east
    /// assert!((table[4] - 0.0).abs() < 1e-7 && table[5] == 0.25); // north
    /// ```
    pub fn table(&self) -> Vec<f32> {
        (0..self.moves)
            .flat_map(|n| {
                let angle = std::f64::consts::TAU * n as f64 / self.moves as f64;
                let (sin, cos) = angle.sin_cos();
                let step = f64::from(self.step);
                [(step * cos) as f32, (step * sin) as f32]
            })
            .collect()
    }

    /// ε at the start of episode `episode` (from 0) of a run of `episodes`: linear from
    /// `epsilon_start` to `epsilon_end` over the first `epsilon_fraction` of the episodes.
    ///
    /// ```
    /// use host_trainer::algorithms::dqn::Config;
    /// let c = Config::default();
    /// assert_eq!(c.epsilon(0, 3000), 1.0);
    /// assert!((c.epsilon(150, 3000) - 0.525).abs() < 1e-6);
    /// assert_eq!(c.epsilon(300, 3000), 0.05);
    /// assert_eq!(c.epsilon(2999, 3000), 0.05);
    /// ```
    pub fn epsilon(&self, episode: usize, episodes: usize) -> f32 {
        let span = self.epsilon_fraction * episodes as f64;
        let done = if span > 0.0 {
            (episode as f64 / span).min(1.0)
        } else {
            1.0
        };
        let (a, b) = (f64::from(self.epsilon_start), f64::from(self.epsilon_end));
        (a + (b - a) * done) as f32
    }
}

/// The Huber loss of an error `e` with threshold `delta` and its derivative:
/// ½e² for |e| ≤ δ, δ(|e| − ½δ) beyond; the derivative is e clamped to ±δ.
///
/// ```
/// use host_trainer::algorithms::dqn::huber;
/// assert_eq!(huber(0.5, 1.0), (0.125, 0.5));
/// assert_eq!(huber(-3.0, 1.0), (2.5, -1.0));
/// ```
pub fn huber(e: f32, delta: f32) -> (f32, f32) {
    if e.abs() <= delta {
        (0.5 * e * e, e)
    } else {
        (delta * (e.abs() - 0.5 * delta), delta * e.signum())
    }
}

/// Columns of `metrics.csv`: ε of the episode and the mean Huber loss of its updates.
const STATS: &[&str] = &["epsilon", "q_loss"];

/// The random streams of a DQN run.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Streams {
    /// ε-greedy draws.
    #[serde(with = "crate::rng_state::serde_rng")]
    explore: SimRng,
    /// Minibatch sampling.
    #[serde(with = "crate::rng_state::serde_rng")]
    replay: SimRng,
}

/// A DQN learner.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Dqn {
    /// Q(s, ·), one linear output per move.
    pub q: Net,
    /// The target network Q'.
    pub q_target: Net,
    opt: Adam,
    /// Running observation statistics (exported into the blob).
    pub norm: RunningNorm,
    /// Transitions; the action column holds the move's index.
    pub replay: Replay,
    /// Lower action bounds of the plant.
    pub low: Vec<f32>,
    /// Upper action bounds of the plant.
    pub high: Vec<f32>,
    /// The action table, `moves` rows of the plant's action size.
    pub table: Vec<f32>,
    streams: Streams,
    /// ε of the current episode.
    epsilon: f32,
    #[serde(skip)]
    config: Config,
    #[serde(skip)]
    shared: AgentConfig,
    #[serde(skip)]
    pending: usize,
    #[serde(skip)]
    means: Means,
    #[serde(skip)]
    tapes: (Tape, Tape),
    /// The Q-network's gradients, reused from update to update.
    #[serde(skip)]
    grads: Option<Grads>,
}

impl Dqn {
    /// A fresh Q-network from `seed::training_stream(seed, "init")`, DDPG's initialisation. The plant
    /// must take 2-D actions that hold every move of the table.
    pub fn new(
        own: &Config,
        shared: &AgentConfig,
        seed: u64,
        obs_dim: usize,
        low: &[f32],
        high: &[f32],
    ) -> Result<Dqn, Error> {
        let (own, shared) = (own.clone(), shared.clone());
        own.validate()?;
        shared.validate()?;
        if low.len() != 2 {
            return Err(Error::invalid(
                "algo",
                "a plant with 2-D actions for DQN's moves",
                format!("{} action dimensions", low.len()),
            ));
        }
        let table = own.table();
        for row in table.chunks(2) {
            for (j, &v) in row.iter().enumerate() {
                if !(low[j]..=high[j]).contains(&v) {
                    return Err(Error::invalid(
                        "dqn.step",
                        format!(
                            "moves inside the plant's action box [{}, {}]",
                            low[j], high[j]
                        ),
                        own.step,
                    ));
                }
            }
        }
        let net_config = shared.net(obs_dim, own.moves, Output::Linear, 0.0);
        let q = Net::new(net_config, &mut seed::training_stream(seed, "init"));
        Ok(Dqn {
            opt: Adam::new(&q, shared.lr_critic, shared.l2),
            q_target: q.clone(),
            norm: RunningNorm::new(obs_dim, shared.norm_clip),
            replay: Replay::new(shared.replay_capacity, obs_dim, 1),
            low: low.to_vec(),
            high: high.to_vec(),
            table,
            streams: Streams {
                explore: seed::training_stream(seed, "explore"),
                replay: seed::training_stream(seed, "replay"),
            },
            epsilon: own.epsilon_start,
            q,
            config: own,
            shared,
            pending: 0,
            means: Means::default(),
            tapes: Default::default(),
            grads: None,
        })
    }

    /// The run's settings, after a checkpoint load.
    pub fn configure(&mut self, own: &Config, shared: &AgentConfig) {
        self.config = own.clone();
        self.shared = shared.clone();
    }

    /// The move the exported policy picks: the argmax of Q on the normalised observation.
    pub fn choose(&self, obs: &[f32]) -> usize {
        let mut z = vec![0.0; self.norm.dim()];
        self.norm.normalize(obs, &mut z);
        let mut q = vec![0.0; self.q.config.outputs];
        self.q.forward_one(&z, &mut q);
        policy_core::model::argmax(&q)
    }

    /// One Huber step toward y = r + γ(1 − terminal) max_k Q'(s', k) on a minibatch from the
    /// replay buffer (which must hold at least one transition), then the soft update.
    /// `Err(what)` names a non-finite loss.
    pub fn update(&mut self) -> Result<(), &'static str> {
        let b = self
            .replay
            .sample(self.shared.batch, &mut self.streams.replay);
        let z = self.norm.normalize_batch(&b.obs);
        let z_next = self.norm.normalize_batch(&b.next_obs);
        let moves = self.q.config.outputs;
        let q_next = self.q_target.forward(&z_next, &mut self.tapes.1, None);
        let y: Vec<f32> = (0..b.reward.len())
            .map(|i| {
                let best = q_next
                    .row(i)
                    .iter()
                    .copied()
                    .fold(f32::NEG_INFINITY, f32::max);
                b.reward[i] + self.shared.gamma * (1.0 - b.terminal[i]) * best
            })
            .collect();
        let q = self.q.forward(&z, &mut self.tapes.0, None);
        let m = y.len() as f32;
        let mut grad = Matrix::zeros(q.rows, moves);
        let mut loss = 0.0;
        for (i, &target) in y.iter().enumerate() {
            let k = (b.action.row(i)[0] as usize).min(moves - 1);
            let (l, d) = huber(q.row(i)[k] - target, self.config.huber_delta);
            loss += l / m;
            grad.row_mut(i)[k] = d / m;
        }
        if !loss.is_finite() {
            return Err("q loss");
        }
        let grads = self.grads.get_or_insert_with(|| self.q.zero_grads());
        grads.zero();
        self.q.backward(&self.tapes.0, &grad, grads);
        self.opt.step(&mut self.q, grads);
        soft_update(&mut self.q_target, &self.q, self.shared.tau);
        self.means.add(1, loss);
        Ok(())
    }
}

impl Algorithm for Dqn {
    fn start_episode(&mut self, episode: usize, episodes: usize) {
        self.epsilon = self.config.epsilon(episode, episodes);
        self.means = Means::default();
    }

    fn act(&mut self, obs: &[f32]) -> Vec<f32> {
        let explore = seed::uniform_f32(&mut self.streams.explore) < self.epsilon;
        self.pending = if explore {
            seed::index(&mut self.streams.explore, self.config.moves)
        } else {
            self.choose(obs)
        };
        let a = self.low.len();
        self.table[self.pending * a..(self.pending + 1) * a].to_vec()
    }

    fn learn(&mut self, step: &Step<'_>) -> Result<(), &'static str> {
        self.norm.update(step.obs);
        self.replay.push(&Transition {
            obs: step.obs.to_vec(),
            action: vec![self.pending as f32],
            reward: step.reward * self.shared.reward_scale,
            next_obs: step.next_obs.to_vec(),
            terminal: step.terminated,
            truncated: step.truncated,
        });
        for _ in 0..self.shared.updates_due(step.total_steps, self.replay.len()) {
            self.update()?;
        }
        Ok(())
    }

    fn stat_names(&self) -> &'static [&'static str] {
        STATS
    }

    fn episode_stats(&mut self) -> Vec<f32> {
        self.means.add(0, self.epsilon);
        self.means.take(STATS.len())
    }

    fn greedy(&self, obs: &[f32]) -> Vec<f32> {
        let a = self.low.len();
        let k = self.choose(obs);
        self.table[k * a..(k + 1) * a].to_vec()
    }

    fn is_finite(&self) -> bool {
        self.q.is_finite() && self.q_target.is_finite()
    }

    fn policy_blob(&self, label: &str) -> Result<Vec<u8>, Error> {
        export::discrete_blob(
            &self.q,
            &self.norm,
            &self.low,
            &self.high,
            &self.table,
            label,
        )
    }

    fn critic_blob(&self, _label: &str) -> Option<Result<Vec<u8>, Error>> {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huber_gradient_matches_finite_differences() {
        for delta in [0.5f32, 1.0, 2.0] {
            for e in [-3.1f32, -0.7, -0.2, 0.0, 0.3, 0.9, 1.7, 4.2] {
                if (e.abs() - delta).abs() < 1e-2 {
                    continue; // the kink
                }
                let h = 1e-3;
                let n = (huber(e + h, delta).0 - huber(e - h, delta).0) / (2.0 * h);
                let (_, g) = huber(e, delta);
                assert!((n - g).abs() < 1e-3, "e {e} delta {delta}: {n} vs {g}");
            }
        }
    }

    #[test]
    fn huber_is_continuous_at_the_threshold() {
        let (inside, _) = huber(1.0, 1.0);
        let (outside, _) = huber(1.0 + 1e-6, 1.0);
        assert!((inside - outside).abs() < 1e-5);
    }

    #[test]
    fn epsilon_decays_over_the_first_tenth_then_holds() {
        let c = Config::default();
        let eps: Vec<f32> = (0..1000).map(|e| c.epsilon(e, 1000)).collect();
        assert_eq!(eps[0], 1.0);
        assert!(eps.windows(2).all(|w| w[1] <= w[0]), "never rises");
        assert!((eps[50] - 0.525).abs() < 1e-6, "halfway: {}", eps[50]);
        assert!(eps[100..].iter().all(|&e| e == 0.05));
        assert!(eps[99] > 0.05);
    }

    /// A plant DQN's moves do not fit (other action sizes, a box smaller than a move) is a
    /// clear configuration error, before any network exists.
    #[test]
    fn moves_that_do_not_fit_the_plant_are_refused() {
        let (own, shared) = (Config::default(), AgentConfig::default());
        let err = Dqn::new(&own, &shared, 0, 2, &[-0.25; 3], &[0.25; 3]).expect_err("3-D actions");
        assert!(err.to_string().contains("2-D actions"), "{err}");
        let mut long = own.clone();
        long.step = 0.5;
        let err = Dqn::new(&long, &shared, 0, 2, &[-0.25; 2], &[0.25; 2]).expect_err("0.5 > 0.25");
        assert!(err.to_string().contains("dqn.step"), "{err}");
        long.epsilon_fraction = 2.0;
        let err = long.validate().expect_err("fraction > 1");
        assert!(err.to_string().contains("dqn.epsilon_fraction"), "{err}");
    }

    #[test]
    fn the_table_holds_eight_moves_of_a_quarter() {
        let t = Config::default().table();
        for (n, row) in t.chunks(2).enumerate() {
            let len = (row[0] * row[0] + row[1] * row[1]).sqrt();
            assert!((len - 0.25).abs() < 1e-6, "move {n}: {row:?}");
            let angle = f32::atan2(row[1], row[0]).rem_euclid(std::f32::consts::TAU);
            let want = n as f32 * std::f32::consts::FRAC_PI_4;
            assert!((angle - want).abs() < 1e-5, "move {n} at {angle}");
        }
    }
}
