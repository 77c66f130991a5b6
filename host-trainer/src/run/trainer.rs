//! The training loop: a run in progress ([`Trainer`]), its episodes, checkpoints and divergence
//! checks.
//!
//! The loop is the same for every algorithm: it asks the run's [`Algorithm`] for an action at
//! the plant's decision point, lets the plant run to the next one (firmware-sim's
//! [`Plant`] interface; navigation decides every step), hands the closed transition back, and at
//! the end of an episode records the metrics.
//! What an algorithm does with a step (replay, rollouts, updates) is its own business
//! ([`crate::algorithms`]).
//!
//! One seed drives everything: every random stream (initial weights, exploration, replay
//! sampling, dropout masks, DCP proposals, minibatch order, episode starts) is
//! `seed::training_stream(seed, name)` with its own name, and every draw is made by the loop's
//! one thread in a fixed order; the worker threads of the updates ([`Trainer::set_workers`]) only
//! split work whose every number is computed as one thread would, so the same seed and
//! configuration give the same blob bytes for any thread count. Wall-clock times appear only in
//! `metrics.csv`'s `steps_per_s` column.

use std::collections::VecDeque;
use std::ops::ControlFlow;
use std::path::Path;
use std::time::Instant;

use firmware_sim::env::Plant;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::EvalConfig;
use firmware_sim::plant_link::child::Timeouts;
use firmware_sim::seed::{self, SimRng};
use rand_core::Rng as _;

use crate::algorithms::algorithm::{Algorithm, Step};
use crate::algorithms::Learner;
use crate::blob::export;
use crate::nn::workers::Workers;
use crate::rng_state::RngState;
use crate::run::checkpoint::Checkpoint;
use crate::run::config::{one_line, TrainConfig};
use crate::run::crash_test;
use crate::run::folder::{self, RunDir};
use crate::run::metrics::{learning_curve, metrics_csv, EpisodeRow};
use crate::run::plant::{self, RunPlant};
use crate::run::validation::{self, Ground, Kept, Round};
use crate::Error;

/// The plant of a task: a built-in scenario name or a scenario file.
pub fn scenario(task: &str) -> Result<Scenario, Error> {
    let sim = |e: firmware_sim::Error| Error::Sim {
        context: format!("task {task:?}"),
        message: e.to_string(),
    };
    if Scenario::builtin(task).is_none() && std::path::Path::new(task).exists() {
        // A scenario file is read through the one bounded reader, then parsed.
        return scenario_file(std::path::Path::new(task));
    }
    Scenario::resolve(task).map_err(sim)
}

/// A scenario file (a task, or a run's recorded plant), read with the bounded
/// [`read_text`](crate::run::config::read_text).
pub fn scenario_file(path: &std::path::Path) -> Result<Scenario, Error> {
    let text = crate::run::config::read_text(path)?;
    Scenario::from_toml_str(&text).map_err(|e| Error::Sim {
        context: format!("scenario {}", path.display()),
        message: e.to_string(),
    })
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
    /// The validation rounds so far, oldest first (none without a `[validation]` section).
    pub validation: Vec<Round>,
    /// The best policy by validation ([`Round::better_than`]): what `policy.postcard` holds.
    pub kept: Option<Kept>,
    /// The plant, as resolved when the run started (a scenario before the reward and γ
    /// overrides, or a plant of the user's by its hello).
    pub plant: RunPlant,
    /// Also keep a copy of every checkpoint, `checkpoints/episode-NNNNNNN.postcard` in the run
    /// folder, to study how the run learned (the studies crate's `margin-diagnosis`). Not part of the
    /// run: it changes no bit, and is not saved.
    pub keep_checkpoints: bool,
    env: Box<dyn Plant>,
    /// Episode starts.
    env_rng: SimRng,
}

impl Trainer {
    /// A fresh run on the plant `config.task` names (or `config.plant_cmd` starts): networks
    /// initialised from `seed::training_stream(seed, "init")`.
    pub fn new(config: TrainConfig) -> Result<Trainer, Error> {
        Trainer::new_with(config, Timeouts::default())
    }

    /// [`Trainer::new`] with the plant process's time-outs (`--plant-timeout`).
    pub fn new_with(mut config: TrainConfig, timeouts: Timeouts) -> Result<Trainer, Error> {
        let Some(command) = config.plant_cmd.clone() else {
            let scenario = scenario(&config.task)?;
            return Trainer::on(config, scenario);
        };
        let (child, hello) = RunPlant::start_process(&command, timeouts)?;
        config.task = plant::folder_safe(&hello.name);
        Trainer::build(
            config,
            RunPlant::Process { command, hello },
            Box::new(child),
        )
    }

    /// A fresh run on a given plant (a run folder's recorded `scenario.toml`). Every limit is
    /// checked before anything large is allocated.
    pub fn on(config: TrainConfig, scenario: Scenario) -> Result<Trainer, Error> {
        config.validate()?;
        check_eval_episodes(&config, &scenario)?;
        let env = make_env(&config, &scenario)?;
        Trainer::build(config, RunPlant::Scenario(scenario), env)
    }

    /// A fresh run on a plant of the caller's own: any one-agent [`Plant`] (every
    /// [`firmware_sim::env::Env`] is one), named by `config.task`. The run records the plant's
    /// boxes; it is resumed with [`Trainer::resume_with_plant`] and the same plant.
    ///
    /// ```
    /// use firmware_sim::nav::NavEnv;
    /// use firmware_sim::nav::scenario::Scenario;
    /// use host_trainer::algorithms::Algo;
    /// use host_trainer::run::config::TrainConfig;
    /// use host_trainer::run::trainer::Trainer;
    /// // Any Env of the caller's: here firmware-sim's own navigation plant, given as one.
    /// let plant = NavEnv::new(&Scenario::builtin("nav-open").unwrap()).unwrap();
    /// let config = TrainConfig { task: "my-plant".into(), ..TrainConfig::smoke(Algo::Dcp, 0) };
    /// let mut trainer = Trainer::with_plant(config, Box::new(plant)).unwrap();
    /// trainer.run_episode().unwrap();
    /// assert_eq!(trainer.config.run_name(), "my-plant__dcp__0");
    /// ```
    pub fn with_plant(config: TrainConfig, plant: Box<dyn Plant>) -> Result<Trainer, Error> {
        let hello = plant::hello_of(&config.task, plant.as_ref());
        Trainer::build(config, RunPlant::Given { hello }, plant)
    }

    fn build(config: TrainConfig, record: RunPlant, env: Box<dyn Plant>) -> Result<Trainer, Error> {
        config.validate()?;
        let agents = env.agents();
        let [agent] = agents.as_slice() else {
            return Err(Error::Sim {
                context: format!("plant {:?}", record.name()),
                message: format!(
                    "the trainer trains one agent; this plant has {}",
                    agents.len()
                ),
            });
        };
        let (observations, space) = (agent.observation_space.dim(), &agent.action_space);
        export::check_supported(observations, space.dim(), config.agent.hidden)?;
        let learner = Learner::new(&config.sections(), observations, &space.low, &space.high)?;
        Ok(Trainer {
            learner,
            env_rng: seed::training_stream(config.seed, "env"),
            env,
            plant: record,
            keep_checkpoints: false,
            config,
            episode: 0,
            total_steps: 0,
            metrics: Vec::new(),
            validation: Vec::new(),
            kept: None,
        })
    }

    /// Continues a run from its checkpoint; `episodes` (if given) replaces the episode budget.
    /// A run on a plant process starts the recorded command again and refuses it if its hello
    /// has changed.
    pub fn resume(
        checkpoint: Checkpoint,
        episodes: Option<usize>,
        path: &Path,
    ) -> Result<Trainer, Error> {
        Trainer::resume_on(checkpoint, episodes, path, None, Timeouts::default())
    }

    /// [`Trainer::resume`] with the plant process's time-outs (`--plant-timeout`).
    pub fn resume_with(
        checkpoint: Checkpoint,
        episodes: Option<usize>,
        path: &Path,
        timeouts: Timeouts,
    ) -> Result<Trainer, Error> {
        Trainer::resume_on(checkpoint, episodes, path, None, timeouts)
    }

    /// Continues a run started by [`Trainer::with_plant`], on the same plant; refused if the
    /// plant's boxes have changed.
    pub fn resume_with_plant(
        checkpoint: Checkpoint,
        episodes: Option<usize>,
        path: &Path,
        plant: Box<dyn Plant>,
    ) -> Result<Trainer, Error> {
        Trainer::resume_on(checkpoint, episodes, path, Some(plant), Timeouts::default())
    }

    fn resume_on(
        checkpoint: Checkpoint,
        episodes: Option<usize>,
        path: &Path,
        given: Option<Box<dyn Plant>>,
        timeouts: Timeouts,
    ) -> Result<Trainer, Error> {
        let bad = |message: String| Error::Checkpoint {
            path: path.to_path_buf(),
            message,
        };
        let mut config: TrainConfig =
            toml::from_str(&checkpoint.config_toml).map_err(|e| bad(one_line(&e.to_string())))?;
        if let Some(n) = episodes {
            // The budget can grow, not shrink below what is trained: a smaller one would mark
            // the run finished with more episodes than its budget says.
            if n < checkpoint.episode {
                return Err(Error::invalid(
                    "--episodes",
                    format!(
                        "at least the {} episodes the checkpoint has trained",
                        checkpoint.episode
                    ),
                    n,
                ));
            }
            config.episodes = n;
        }
        config.validate()?;
        let record = RunPlant::from_toml(&checkpoint.scenario_toml)
            .map_err(|e| bad(format!("its recorded plant does not load: {e}")))?;
        let env = resume_env(&config, &record, given, timeouts)?;
        let mut learner = checkpoint.learner;
        learner.configure(&config.sections()).map_err(bad)?;
        Ok(Trainer {
            learner,
            env,
            env_rng: checkpoint.env_rng.restore(),
            plant: record,
            keep_checkpoints: false,
            episode: checkpoint.episode,
            total_steps: checkpoint.total_steps,
            metrics: checkpoint.metrics,
            validation: checkpoint.validation,
            kept: checkpoint.kept,
            config,
        })
    }

    /// The worker threads of the updates (`train --threads`). Not part of the run: any count
    /// gives the same bytes, and a run may continue with another.
    pub fn set_workers(&mut self, workers: Workers) {
        let workers = match crash_test::worker_fault() {
            Some(task) => workers.with_fault_at(task),
            None => workers,
        };
        self.learner.set_workers(workers);
    }

    /// The state to save.
    pub fn checkpoint(&self) -> Checkpoint {
        Checkpoint {
            config_toml: self.config.to_toml(),
            scenario_toml: self.plant.to_toml(),
            learner: self.learner.clone(),
            episode: self.episode,
            total_steps: self.total_steps,
            metrics: self.metrics.clone(),
            env_rng: RngState::of(&self.env_rng),
            validation: self.validation.clone(),
            kept: self.kept.clone(),
        }
    }

    /// The run's algorithm.
    pub fn algorithm(&self) -> &dyn Algorithm {
        self.learner.get()
    }

    /// Whether the run is over: its budget is used up ([`Trainer::budget_used`]) or its
    /// validation has met the criteria for enough rounds in a row, with stopping on.
    pub fn done(&self) -> bool {
        self.budget_used() || self.stopped_at_gate()
    }

    /// Whether the budget is used up: the episodes, or the environment steps where the run
    /// has a step budget (checked between episodes, so the last episode runs to its end).
    pub fn budget_used(&self) -> bool {
        self.episode >= self.config.episodes
            || self.config.env_steps.is_some_and(|n| self.total_steps >= n)
    }

    /// Whether validation has ended the run: the last rounds met the criteria, as many in a
    /// row as the configuration asks, with stopping on.
    pub fn stopped_at_gate(&self) -> bool {
        self.config
            .validation
            .as_ref()
            .is_some_and(|v| v.stops_after(&self.validation))
    }

    /// Whether a validation round is due after the episode just completed: every
    /// `validation.every` episodes and at the end of the budget, once per episode.
    pub fn validation_due(&self) -> bool {
        let Some(v) = &self.config.validation else {
            return false;
        };
        let fresh = self
            .validation
            .last()
            .is_none_or(|r| r.episode < self.episode);
        fresh && self.episode > 0 && (self.episode % v.every == 0 || self.budget_used())
    }

    /// Runs a validation round on the current networks, exported as the blobs they would be:
    /// records it and keeps the blobs if the round is the best so far. Validation draws from no
    /// training stream, so the run learns the same bits with it as without.
    pub fn validate(&mut self) -> Result<&Round, Error> {
        let Some(config) = self.config.validation.clone() else {
            return Err(Error::InvalidConfig {
                what: "validation".into(),
                expected: "a [validation] section to validate by".into(),
                found: "none".into(),
            });
        };
        let label = self.config.blob_label();
        let policy = self.policy_blob(&label)?;
        let critic = self.algorithm().critic_blob(&label).transpose()?;
        // An actor of several heads runs with its critic choosing the head, as on the chip.
        let heads = self.config.algo == crate::algorithms::Algo::Dcp && self.config.dcp.heads > 1;
        let chooser = critic.as_deref().filter(|_| heads);
        let seed = validation::validation_seed(self.config.seed);
        let at = (self.episode, self.total_steps);
        let round = match &self.plant {
            RunPlant::Scenario(scenario) => validation::round(
                &config,
                Ground::Scenario(scenario),
                (&policy, chooser),
                seed,
                at,
            )?,
            other => {
                let name = other.name();
                validation::round(
                    &config,
                    Ground::Plant(self.env.as_mut(), &name),
                    (&policy, chooser),
                    seed,
                    at,
                )?
            }
        };
        if self
            .kept
            .as_ref()
            .is_none_or(|k| round.better_than(&k.round))
        {
            self.kept = Some(Kept {
                round: round.clone(),
                policy,
                critic,
            });
        }
        self.validation.push(round);
        Ok(&self.validation[self.validation.len() - 1])
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
        if let Some(e) = self.env.failure() {
            return Err(plant::plant_error(e));
        }
        let (mut ret, mut steps) = (0.0f32, 0usize);
        // A plant of the user's says itself whether the episode succeeded (its flag on the
        // last step); a scenario by its settled rule below.
        let mut flag = false;
        let (mut reached, mut final_distance) = (false, 0.0);
        // The success rule is the scenario's (firmware-sim's `Metrics::settled`), on the
        // distances of the last `settle_window` steps.
        let default_rule = firmware_sim::nav::scenario::Metrics::default();
        let rule = self.plant.scenario().map_or(&default_rule, |s| &s.metrics);
        let window = rule.settle_window as usize;
        let mut recent = VecDeque::with_capacity(window);
        let algo = self.learner.algorithm();
        algo.start_episode(self.episode, self.config.episodes);
        while let Some(decision) = turn.decide.take() {
            let action = algo.act(&decision.observation);
            turn = self.env.act(&action);
            if let Some(e) = self.env.failure() {
                return Err(plant::plant_error(e));
            }
            flag = turn.info.success == Some(true);
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
        let settled = match self.plant {
            RunPlant::Scenario(_) => rule.settled(recent.iter().map(|&d| f64::from(d))),
            _ => flag,
        };
        self.episode += 1;
        self.metrics.push(EpisodeRow {
            episode: self.episode,
            ret,
            steps,
            success: (reached && self.plant.scenario().is_some()) || settled,
            final_distance,
            stats,
            total_steps: self.total_steps,
            steps_per_s: steps as f32 / started.elapsed().as_secs_f32().max(1e-9),
        });
        Ok(&self.metrics[self.metrics.len() - 1])
    }

    /// Writes checkpoint, metrics and plot of the current state.
    pub fn save(&self, run: &RunDir) -> Result<(), Error> {
        let checkpoint = self.checkpoint();
        checkpoint.save(&run.file(folder::CHECKPOINT))?;
        if self.keep_checkpoints {
            let kept = folder::kept_checkpoints(run)?;
            checkpoint.save(&kept.join(folder::kept_checkpoint(self.episode)))?;
        }
        self.save_metrics(run)
    }

    /// Writes `metrics.csv`, `validation.csv` (with validation) and the learning-curve SVG.
    pub fn save_metrics(&self, run: &RunDir) -> Result<(), Error> {
        let names = self.algorithm().stat_names();
        run.write(
            folder::METRICS,
            metrics_csv(names, &self.metrics).as_bytes(),
        )?;
        if self.config.validation.is_some() {
            run.write(
                folder::VALIDATION,
                validation::csv(&self.validation).as_bytes(),
            )?;
        }
        run.write(
            folder::CURVE,
            learning_curve(&self.config.run_name(), &self.metrics, &self.validation).as_bytes(),
        )
    }

    /// The plant the run trains on, for an evaluation on it after training (a plant process
    /// is then not started twice).
    pub fn plant_mut(&mut self) -> &mut dyn Plant {
        self.env.as_mut()
    }

    /// The policy blob (what gets flashed), from the current networks.
    pub fn policy_blob(&self, label: &str) -> Result<Vec<u8>, Error> {
        self.algorithm().policy_blob(label)
    }

    /// The blobs the run hands over: the kept policy (the best by validation) where the run
    /// validates, else the current networks'; the critic where the algorithm has one.
    pub fn kept_blobs(&self) -> Result<(Vec<u8>, Option<Vec<u8>>), Error> {
        match &self.kept {
            Some(kept) => Ok((kept.policy.clone(), kept.critic.clone())),
            None => self.last_blobs(),
        }
    }

    /// The current networks' blobs (the last networks, whatever validation kept).
    pub fn last_blobs(&self) -> Result<(Vec<u8>, Option<Vec<u8>>), Error> {
        let label = self.config.blob_label();
        let policy = self.policy_blob(&label)?;
        let critic = self.algorithm().critic_blob(&label).transpose()?;
        Ok((policy, critic))
    }

    /// Exports the kept policy ([`Trainer::kept_blobs`]) as `policy.postcard` and, for
    /// algorithms with a Q(s, a) critic, `critic.postcard`; returns the policy blob.
    pub fn export(&self, run: &RunDir) -> Result<Vec<u8>, Error> {
        write_blobs(run, self.kept_blobs()?)
    }

    /// Exports the last networks instead (`export --last`); returns the policy blob.
    pub fn export_last(&self, run: &RunDir) -> Result<Vec<u8>, Error> {
        write_blobs(run, self.last_blobs()?)
    }
}

/// Writes a policy blob and its critic into the run folder; returns the policy blob.
fn write_blobs(
    run: &RunDir,
    (policy, critic): (Vec<u8>, Option<Vec<u8>>),
) -> Result<Vec<u8>, Error> {
    run.write(folder::POLICY, &policy)?;
    if let Some(critic) = critic {
        run.write(folder::CRITIC, &critic)?;
    }
    Ok(policy)
}

impl Trainer {}

fn diverged(done: usize, what: &str) -> Error {
    Error::Diverged {
        episode: done + 1,
        what: what.into(),
        checkpoint: None,
    }
}

/// The plant a resumed run trains on: its scenario, its plant process started again (refused
/// if its hello changed), or the plant its caller gives again.
fn resume_env(
    config: &TrainConfig,
    record: &RunPlant,
    given: Option<Box<dyn Plant>>,
    timeouts: Timeouts,
) -> Result<Box<dyn Plant>, Error> {
    match (record, given) {
        (RunPlant::Scenario(scenario), None) => make_env(config, scenario),
        (RunPlant::Process { command, hello }, None) => {
            let (child, now) = RunPlant::start_process(command, timeouts)?;
            plant::check_same_hello(hello, &now, command)?;
            Ok(Box::new(child))
        }
        (RunPlant::Given { hello }, Some(plant)) => {
            plant::check_same_hello(
                hello,
                &plant::hello_of(&hello.name, plant.as_ref()),
                &hello.name,
            )?;
            Ok(plant)
        }
        (RunPlant::Given { hello }, None) => Err(Error::Sim {
            context: format!("plant {:?}", hello.name),
            message: "the run trains on a plant its program gave (Trainer::with_plant): resume \
                      it there with Trainer::resume_with_plant"
                .into(),
        }),
        (_, Some(_)) => Err(Error::Sim {
            context: format!("plant {:?}", record.name()),
            message: "the run trains on a recorded scenario or plant command, not on a plant \
                      given in process: resume it with Trainer::resume"
                .into(),
        }),
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
    /// The budget is used up, or validation ended the run ([`Trainer::stopped_at_gate`]).
    Finished,
    /// `on_episode` asked to stop (Ctrl-C); a checkpoint of the last episode was written.
    Stopped {
        /// Completed episodes.
        episode: usize,
    },
}

/// Trains until the budget is used or validation ends the run ([`Trainer::done`]),
/// checkpointing every `checkpoint_every` episodes and after every validation round, or until
/// `on_episode` returns `ControlFlow::Break`, which writes a checkpoint and stops. A validation
/// round that is due runs before `on_episode` sees the episode, so the callback finds it in
/// [`Trainer::validation`].
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
        run.write(folder::CONFIG, trainer.config.to_toml().as_bytes())?;
        run.write(folder::SCENARIO, trainer.plant.to_toml().as_bytes())?;
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
                    checkpoint: Some(run.file(folder::CHECKPOINT)),
                });
            }
            Err(e) => return Err(e),
        };
        // A round is saved with the checkpoint it belongs to: a run resumed from any
        // checkpoint has validated exactly the rounds before it.
        let validated = trainer.validation_due();
        if validated {
            trainer.validate()?;
        }
        crash_test::episode_done(trainer.episode);
        let flow = on_episode(&row, trainer);
        if flow.is_break() {
            trainer.save(run)?;
            return Ok(Outcome::Stopped {
                episode: trainer.episode,
            });
        }
        if validated || trainer.episode % trainer.config.checkpoint_every == 0 || trainer.done() {
            trainer.save(run)?;
        }
    }
    Ok(Outcome::Finished)
}
