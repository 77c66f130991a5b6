//! The training run: configuration, the episode loop, metrics, checkpoints, divergence checks.
//!
//! The loop is the same for every algorithm: it asks the run's [`Algorithm`] for an action at
//! the plant's decision point, lets the plant run to the next one (firmware-sim's
//! [`Plant`] interface; navigation decides every step), hands the closed transition back, and at
//! the end of an episode records the metrics.
//! What an algorithm does with a step (replay, rollouts, updates) is its own business
//! ([`crate::algo`]).
//!
//! One seed drives everything: every random stream (initial weights, exploration, replay
//! sampling, dropout masks, DCP proposals, minibatch order, episode starts) is
//! `seed::stream(seed, name)` with its own name, and the loop is single-threaded, so the same
//! seed and configuration give the same blob bytes. Wall-clock times appear only in
//! `metrics.csv`'s `steps_per_s` column.

use std::collections::VecDeque;
use std::ops::ControlFlow;
use std::path::Path;
use std::time::Instant;

use firmware_sim::env::Plant;
use firmware_sim::harness::EvalConfig;
use firmware_sim::nav::Reward;
use firmware_sim::scenario::Scenario;
use rand_core::Rng as _;
use serde::{Deserialize, Serialize};

use crate::agent;
pub use crate::algo::Algo;
use crate::algo::{Algorithm, Learner, Step};
use crate::checkpoint::{Checkpoint, RngState};
use crate::crash_test;
use crate::dcp;
use crate::ddpg;
use crate::dqn;
use crate::export;
use crate::plot::{self, Panel, Series};
use crate::ppo;
use crate::run_dir::{self, RunDir};
use crate::seed::{self, Rng};
use crate::Error;

/// Everything that defines a run (saved as the run's `config.toml`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrainConfig {
    /// Built-in scenario name (`nav-walls`, `nav-open`) or a scenario TOML file.
    pub task: String,
    /// The learning algorithm.
    pub algo: Algo,
    /// The reward, overriding the scenario's [paper: GR for the headline results].
    pub reward: RewardKind,
    /// The one seed of the run.
    pub seed: u64,
    /// Training episodes [paper: 3,000 for navigation].
    pub episodes: usize,
    /// Write a checkpoint (and metrics, plot) every this many episodes.
    pub checkpoint_every: usize,
    /// Test starts for the final firmware-sim evaluation [paper: 100].
    pub eval_episodes: usize,
    /// Settings every algorithm shares (networks, learning rates, γ, normalisation; each
    /// algorithm's file says which it reads).
    pub agent: agent::Config,
    /// DCP settings (used when `algo = "dcp"`).
    pub dcp: dcp::Config,
    /// DDPG settings (used when `algo = "ddpg"` or `"td3"`).
    pub ddpg: ddpg::Config,
    /// TD3 settings (used when `algo = "td3"`; DCP's `target_smoothing` takes its σ and clip).
    pub td3: ddpg::Td3Config,
    /// PPO settings (used when `algo = "ppo"`).
    pub ppo: ppo::Config,
    /// DQN settings (used when `algo = "dqn"`).
    pub dqn: dqn::Config,
}

impl TrainConfig {
    /// The smallest run that still exercises every code path (warm-up, updates, checkpoint,
    /// export, evaluation): 3 episodes of a 2×32 network, batch 16, T = 4, PPO rollouts of 32
    /// steps in minibatches of 8 over 2 epochs. Smoke tests and the end-to-end test use it; it
    /// is far too small to learn anything.
    pub fn smoke(algo: Algo, seed: u64) -> Self {
        let mut c = TrainConfig {
            algo,
            seed,
            episodes: 3,
            checkpoint_every: 2,
            eval_episodes: 5,
            ..TrainConfig::default()
        };
        c.agent.hidden = agent::Hidden {
            depth: 2,
            width: 32,
        };
        c.agent.batch = 16;
        c.agent.warmup_steps = 16;
        c.dcp.t = 4;
        c.ppo.rollout = 32;
        c.ppo.minibatch = 8;
        c.ppo.epochs = 2;
        c
    }
}

impl Default for TrainConfig {
    fn default() -> Self {
        TrainConfig {
            task: "nav-walls".into(),
            algo: Algo::Dcp,
            reward: RewardKind::Gr,
            seed: 0,
            episodes: 3000,
            checkpoint_every: 100,
            eval_episodes: 100,
            agent: agent::Config::default(),
            dcp: dcp::Config::default(),
            ddpg: ddpg::Config::default(),
            td3: ddpg::Td3Config::default(),
            ppo: ppo::Config::default(),
            dqn: dqn::Config::default(),
        }
    }
}

impl TrainConfig {
    /// Parses a config file: TOML, or JSON when the name ends in `.json`. Unknown keys are
    /// errors; missing keys take their defaults.
    pub fn from_file(path: &Path) -> Result<TrainConfig, Error> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let parsed = if path.extension().is_some_and(|e| e == "json") {
            serde_json::from_str(&text).map_err(|e| e.to_string())
        } else {
            toml::from_str(&text).map_err(|e| e.to_string())
        };
        parsed.map_err(|message| Error::ConfigFile {
            path: path.to_path_buf(),
            message: one_line(&message),
        })
    }

    /// The config as TOML text.
    pub fn to_toml(&self) -> String {
        // Serialising plain data with string keys cannot fail; fall back to Debug rather than panic.
        toml::to_string(self)
            .unwrap_or_else(|e| format!("# could not serialise config: {e}\n# {self:?}\n"))
    }

    /// Checks ranges that the types do not.
    pub fn validate(&self) -> Result<(), Error> {
        self.agent.validate()?;
        let positive = |what: &str, n: usize| {
            (n > 0).then_some(()).ok_or_else(|| Error::InvalidConfig {
                what: what.into(),
                expected: "a positive integer".into(),
                found: n.to_string(),
            })
        };
        positive("episodes", self.episodes)?;
        if self.episodes > MAX_EPISODES {
            return Err(Error::InvalidConfig {
                what: "episodes".into(),
                expected: format!("at most {MAX_EPISODES}"),
                found: self.episodes.to_string(),
            });
        }
        positive("checkpoint_every", self.checkpoint_every)?;
        positive("eval_episodes", self.eval_episodes)?;
        Learner::validate(self)
    }

    /// The run folder's name, `{task}__{algo}__{seed}` (a scenario file contributes its stem).
    pub fn run_name(&self) -> String {
        run_dir::run_name(&self.task_name(), &self.algo.to_string(), self.seed)
    }

    /// The label of the run's blobs: the run name, shortened to fit the blob header.
    pub fn blob_label(&self) -> String {
        run_dir::blob_label(&self.task_name(), &self.algo.to_string(), self.seed)
    }

    /// The task as run folders name it: a built-in scenario's name, or a scenario file's stem.
    pub fn task_name(&self) -> String {
        Path::new(&self.task)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| self.task.clone())
    }
}

/// The most training episodes a run may ask for: 1,000,000, over 300 times the paper's budget.
/// Metrics and checkpoints grow with the episode count, so a mistyped count is refused up front.
pub const MAX_EPISODES: usize = 1_000_000;

fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The navigation reward (DESIGN.md section 2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum RewardKind {
    /// Local reward: progress toward the centre per step.
    Lr,
    /// Global reward: minus the distance to the centre / 6.
    Gr,
    /// The mean of LR and GR.
    Lrgr,
}

impl From<RewardKind> for Reward {
    fn from(r: RewardKind) -> Reward {
        match r {
            RewardKind::Lr => Reward::Lr,
            RewardKind::Gr => Reward::Gr,
            RewardKind::Lrgr => Reward::LrGr,
        }
    }
}

/// The plant of a task: a built-in scenario name or a scenario file.
pub fn scenario(task: &str) -> Result<Scenario, Error> {
    Scenario::resolve(task).map_err(|e| Error::Sim {
        context: format!("task {task:?}"),
        message: e.to_string(),
    })
}

/// One row of `metrics.csv`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpisodeRow {
    /// Episode number, from 1.
    pub episode: usize,
    /// Sum of rewards.
    pub ret: f32,
    /// Steps taken.
    pub steps: usize,
    /// Reached the centre, or settled within 2 units of it (DESIGN.md section 2's test rule,
    /// applied to however many of the last 20 positions the episode has).
    pub success: bool,
    /// Distance from the centre at the end.
    pub final_distance: f32,
    /// The algorithm's own columns ([`Algorithm::stat_names`]), e.g. DCP's critic loss, actor
    /// loss and kept fraction (NaN where nothing ran).
    pub stats: Vec<f32>,
    /// Environment steps since the start of the run.
    pub total_steps: u64,
    /// Environment steps per second in this episode, updates included (wall clock).
    pub steps_per_s: f32,
}

/// The header of `metrics.csv`, with the algorithm's columns (`names`) in the middle.
pub fn csv_header(names: &[&str]) -> String {
    let mut h = String::from("episode,return,steps,success,final_distance");
    for n in names {
        h.push(',');
        h.push_str(n);
    }
    h.push_str(",total_steps,steps_per_s");
    h
}

impl EpisodeRow {
    /// The row as CSV (NaN written as an empty field).
    pub fn csv(&self) -> String {
        let f = |v: f32| {
            if v.is_nan() {
                String::new()
            } else {
                format!("{v}")
            }
        };
        let mut out = format!(
            "{},{},{},{},{}",
            self.episode,
            f(self.ret),
            self.steps,
            u8::from(self.success),
            f(self.final_distance),
        );
        for &v in &self.stats {
            out.push(',');
            out.push_str(&f(v));
        }
        out.push_str(&format!(",{},{}", self.total_steps, f(self.steps_per_s)));
        out
    }

    /// The value of the algorithm's column `name` (its position in `names`).
    pub fn stat(&self, names: &[&str], name: &str) -> Option<f32> {
        let i = names.iter().position(|n| *n == name)?;
        self.stats.get(i).copied()
    }
}

/// A training run in progress.
#[derive(Debug)]
pub struct Trainer {
    /// The configuration.
    pub config: TrainConfig,
    /// The algorithm and everything it has learned.
    pub learner: Learner,
    /// Completed episodes.
    pub episode: usize,
    /// Environment steps so far.
    pub total_steps: u64,
    /// One row per completed episode.
    pub metrics: Vec<EpisodeRow>,
    /// The plant, as resolved when the run started (before the reward and γ overrides).
    pub scenario: Scenario,
    env: Box<dyn Plant>,
    /// Episode starts.
    env_rng: Rng,
}

impl Trainer {
    /// A fresh run on the plant `config.task` names: networks initialised from
    /// `seed::stream(seed, "init")`.
    pub fn new(config: TrainConfig) -> Result<Trainer, Error> {
        let scenario = scenario(&config.task)?;
        Trainer::on(config, scenario)
    }

    /// A fresh run on a given plant (a run folder's recorded `scenario.toml`). Every limit is
    /// checked before anything large is allocated.
    pub fn on(config: TrainConfig, scenario: Scenario) -> Result<Trainer, Error> {
        config.validate()?;
        check_eval_episodes(&config, &scenario)?;
        let env = make_env(&config, &scenario)?;
        let agent = &env.agents()[0];
        let (observations, space) = (agent.observation_space.dim(), &agent.action_space);
        export::check_supported(observations, space.dim(), config.agent.hidden)?;
        let learner = Learner::new(&config, observations, &space.low, &space.high)?;
        Ok(Trainer {
            learner,
            env_rng: seed::stream(config.seed, "env"),
            env,
            scenario,
            config,
            episode: 0,
            total_steps: 0,
            metrics: Vec::new(),
        })
    }

    /// Continues a run from its checkpoint; `episodes` (if given) replaces the episode budget.
    pub fn resume(
        checkpoint: Checkpoint,
        episodes: Option<usize>,
        path: &Path,
    ) -> Result<Trainer, Error> {
        let bad = |message: String| Error::Checkpoint {
            path: path.to_path_buf(),
            message,
        };
        let mut config: TrainConfig =
            toml::from_str(&checkpoint.config_toml).map_err(|e| bad(one_line(&e.to_string())))?;
        if let Some(n) = episodes {
            config.episodes = n;
        }
        config.validate()?;
        let scenario = Scenario::from_toml_str(&checkpoint.scenario_toml)
            .map_err(|e| bad(format!("its recorded plant does not load: {e}")))?;
        let mut learner = checkpoint.learner;
        learner.configure(&config).map_err(bad)?;
        Ok(Trainer {
            learner,
            env: make_env(&config, &scenario)?,
            env_rng: checkpoint.env_rng.restore(),
            scenario,
            episode: checkpoint.episode,
            total_steps: checkpoint.total_steps,
            metrics: checkpoint.metrics,
            config,
        })
    }

    /// The state to save.
    pub fn checkpoint(&self) -> Checkpoint {
        Checkpoint {
            config_toml: self.config.to_toml(),
            scenario_toml: scenario_toml(&self.scenario),
            learner: self.learner.clone(),
            episode: self.episode,
            total_steps: self.total_steps,
            metrics: self.metrics.clone(),
            env_rng: RngState::of(&self.env_rng),
        }
    }

    /// The run's algorithm.
    pub fn algorithm(&self) -> &dyn Algorithm {
        self.learner.get()
    }

    /// Whether the episode budget is used up.
    pub fn done(&self) -> bool {
        self.episode >= self.config.episodes
    }

    /// Success rate over the last `window` episodes.
    pub fn recent_success(&self, window: usize) -> f32 {
        let recent = &self.metrics[self.metrics.len().saturating_sub(window)..];
        recent.iter().filter(|r| r.success).count() as f32 / recent.len().max(1) as f32
    }

    /// The value of the algorithm's metrics column `name` in the last episode's row.
    pub fn last_stat(&self, name: &str) -> Option<f32> {
        self.metrics
            .last()?
            .stat(self.algorithm().stat_names(), name)
    }

    /// Runs one episode with exploration and updates. On a non-finite loss or weight it returns
    /// `Error::Diverged` (without a checkpoint path: [`run`] adds it) and the trainer must be
    /// dropped: its state is no longer good.
    pub fn run_episode(&mut self) -> Result<&EpisodeRow, Error> {
        let started = Instant::now();
        let mut turn = self.env.reset(self.env_rng.next_u64());
        let (mut ret, mut steps) = (0.0f32, 0usize);
        let (mut reached, mut final_distance) = (false, 0.0);
        // The success rule is the scenario's (firmware-sim's `Metrics::settled`), on the
        // distances of the last `settle_window` steps.
        let rule = &self.scenario.metrics;
        let window = rule.settle_window as usize;
        let mut recent = VecDeque::with_capacity(window);
        let algo = self.learner.algorithm();
        algo.start_episode(self.episode, self.config.episodes);
        while let Some(decision) = turn.decide.take() {
            let action = algo.act(&decision.observation);
            turn = self.env.act(&action);
            // One agent: its transition from this decision closes with this action.
            for outcome in &turn.closed {
                self.total_steps += 1;
                let learned = algo.learn(&Step {
                    obs: &decision.observation,
                    reward: outcome.reward,
                    next_obs: &outcome.observation,
                    terminated: outcome.terminated,
                    truncated: outcome.truncated,
                    total_steps: self.total_steps,
                });
                if let Err(what) = learned {
                    return Err(diverged(self.episode, what));
                }
                ret += outcome.reward;
                steps += 1;
                final_distance = distance(&outcome.observation);
                if recent.len() == window {
                    recent.pop_front();
                }
                recent.push_back(final_distance);
                reached = outcome.terminated && rule.settled([f64::from(final_distance)]);
            }
        }
        if !algo.is_finite() {
            return Err(diverged(self.episode, "network weights"));
        }
        let stats = algo.episode_stats();
        let settled = rule.settled(recent.iter().map(|&d| f64::from(d)));
        self.episode += 1;
        self.metrics.push(EpisodeRow {
            episode: self.episode,
            ret,
            steps,
            success: reached || settled,
            final_distance,
            stats,
            total_steps: self.total_steps,
            steps_per_s: steps as f32 / started.elapsed().as_secs_f32().max(1e-9),
        });
        Ok(&self.metrics[self.metrics.len() - 1])
    }

    /// Writes checkpoint, metrics and plot of the current state.
    pub fn save(&self, run: &RunDir) -> Result<(), Error> {
        self.checkpoint().save(&run.file(run_dir::CHECKPOINT))?;
        self.save_metrics(run)
    }

    /// Writes `metrics.csv` and the learning-curve SVG.
    pub fn save_metrics(&self, run: &RunDir) -> Result<(), Error> {
        let names = self.algorithm().stat_names();
        run.write(
            run_dir::METRICS,
            metrics_csv(names, &self.metrics).as_bytes(),
        )?;
        run.write(
            run_dir::CURVE,
            learning_curve(&self.config.run_name(), &self.metrics).as_bytes(),
        )
    }

    /// The policy blob (what gets flashed), from the current networks.
    pub fn policy_blob(&self, label: &str) -> Result<Vec<u8>, Error> {
        self.algorithm().policy_blob(label)
    }

    /// Exports `policy.postcard` and, for algorithms with a Q(s, a) critic, `critic.postcard`;
    /// returns the policy blob.
    pub fn export(&self, run: &RunDir) -> Result<Vec<u8>, Error> {
        let label = self.config.blob_label();
        let policy = self.policy_blob(&label)?;
        run.write(run_dir::POLICY, &policy)?;
        if let Some(critic) = self.algorithm().critic_blob(&label) {
            run.write(run_dir::CRITIC, &critic?)?;
        }
        Ok(policy)
    }
}

fn diverged(done: usize, what: &str) -> Error {
    Error::Diverged {
        episode: done + 1,
        what: what.into(),
        checkpoint: None,
    }
}

/// The training plant: the run's scenario with its reward, and the learner's γ for the exit
/// penalty (leaving the arena pays worst/(1 - γ), so leaving never pays).
fn make_env(config: &TrainConfig, base: &Scenario) -> Result<Box<dyn Plant>, Error> {
    let mut scenario = base.clone();
    scenario.reward = config.reward.into();
    scenario.gamma = config.agent.gamma;
    let sim = |message: String| Error::Sim {
        context: format!("task {:?}", config.task),
        message,
    };
    let plant = scenario.plant().map_err(|e| sim(e.to_string()))?;
    match plant.agents().len() {
        1 => Ok(plant),
        n => Err(sim(format!(
            "the trainer trains one agent; this plant has {n}"
        ))),
    }
}

/// The end-of-training evaluation's settings must pass firmware-sim's checks (its episode
/// maximum among them) before the run starts, not after it.
fn check_eval_episodes(config: &TrainConfig, scenario: &Scenario) -> Result<(), Error> {
    let eval = EvalConfig {
        episodes: config.eval_episodes,
        ..EvalConfig::default()
    };
    eval.validate(scenario).map_err(|e| Error::InvalidConfig {
        what: "eval_episodes".into(),
        expected: "a count firmware-sim accepts".into(),
        found: e.to_string(),
    })
}

/// A scenario as TOML text (how run folders and checkpoints record the plant).
pub fn scenario_toml(scenario: &Scenario) -> String {
    // Plain data with string keys always serialises; fall back to Debug rather than panic.
    toml::to_string(scenario)
        .unwrap_or_else(|e| format!("# could not serialise the scenario: {e}\n# {scenario:?}\n"))
}

/// Distance of a navigation observation (the position) from the goal at the origin.
fn distance(obs: &[f32]) -> f32 {
    obs.iter().map(|x| x * x).sum::<f32>().sqrt()
}

/// How a call to [`run`] ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// The episode budget is used up.
    Finished,
    /// `on_episode` asked to stop (Ctrl-C); a checkpoint of the last episode was written.
    Stopped {
        /// Completed episodes.
        episode: usize,
    },
}

/// Trains until the budget is used, checkpointing every `checkpoint_every` episodes, or until
/// `on_episode` returns `ControlFlow::Break`, which writes a checkpoint and stops.
///
/// A fresh run writes its config, its plant and an episode-0 checkpoint first, so a diverged or
/// killed run always has a last good state to continue from. On divergence, the metrics of the
/// completed episodes are written, the checkpoint is left untouched, and `Error::Diverged`
/// names it.
pub fn run(
    trainer: &mut Trainer,
    run: &RunDir,
    on_episode: &mut dyn FnMut(&EpisodeRow, &Trainer) -> ControlFlow<()>,
) -> Result<Outcome, Error> {
    if trainer.episode == 0 {
        run.write(run_dir::CONFIG, trainer.config.to_toml().as_bytes())?;
        run.write(
            run_dir::SCENARIO,
            scenario_toml(&trainer.scenario).as_bytes(),
        )?;
        trainer.save(run)?;
    }
    while !trainer.done() {
        let row = match trainer.run_episode() {
            Ok(row) => row.clone(),
            Err(Error::Diverged { episode, what, .. }) => {
                trainer.save_metrics(run)?;
                return Err(Error::Diverged {
                    episode,
                    what,
                    checkpoint: Some(run.file(run_dir::CHECKPOINT)),
                });
            }
            Err(e) => return Err(e),
        };
        crash_test::episode_done(trainer.episode);
        let flow = on_episode(&row, trainer);
        if flow.is_break() {
            trainer.save(run)?;
            return Ok(Outcome::Stopped {
                episode: trainer.episode,
            });
        }
        if trainer.episode % trainer.config.checkpoint_every == 0 || trainer.done() {
            trainer.save(run)?;
        }
    }
    Ok(Outcome::Finished)
}

/// The whole `metrics.csv`.
pub fn metrics_csv(names: &[&str], rows: &[EpisodeRow]) -> String {
    let mut out = csv_header(names);
    out.push('\n');
    for r in rows {
        out.push_str(&r.csv());
        out.push('\n');
    }
    out
}

/// The learning curve: return (raw and 100-episode average) and the 100-episode success rate.
pub fn learning_curve(title: &str, rows: &[EpisodeRow]) -> String {
    let x: Vec<f64> = rows.iter().map(|r| r.episode as f64).collect();
    let ret: Vec<f64> = rows.iter().map(|r| f64::from(r.ret)).collect();
    let success: Vec<f64> = rows
        .iter()
        .map(|r| f64::from(u8::from(r.success)))
        .collect();
    let zip = |ys: Vec<f64>| x.iter().copied().zip(ys).collect::<Vec<_>>();
    let returns = Panel {
        y_label: "return".into(),
        y_range: None,
        series: vec![
            Series {
                name: "episode".into(),
                color: "#1f77b4",
                opacity: 0.25,
                points: zip(ret.clone()),
            },
            Series {
                name: "mean of 100".into(),
                color: "#1f77b4",
                opacity: 1.0,
                points: zip(plot::moving_average(&ret, 100)),
            },
        ],
    };
    let rate = Panel {
        y_label: "success rate".into(),
        y_range: Some((0.0, 1.0)),
        series: vec![Series {
            name: "mean of 100".into(),
            color: "#2ca02c",
            opacity: 1.0,
            points: zip(plot::moving_average(&success, 100)),
        }],
    };
    plot::svg(title, "episode", &[returns, rate])
}
