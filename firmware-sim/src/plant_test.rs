//! The test protocol for any plant: the firmware loop ([`crate::firmware`]: sensor noise,
//! quantisation, delay, dropouts; actuator saturation, rate limit, a stuck dimension) run
//! against any plant of one agent (any [`crate::env::Env`]), in process or in another process ([`crate::plant_link`]), scored by
//! the margin figures every plant gives and judged by criteria the user declares.
//!
//! Navigation keeps its own protocol ([`crate::nav::test_protocol`]: settled distance to the
//! goal, walls that move), badminton its matches; this one knows only what the
//! [`crate::env::Env`] interface says:
//!
//! - **success**: by the plant's own flag ([`StepInfo::success`] on the episode's last step),
//!   or, for plants with no notion of a goal, by the episode's return reaching a threshold
//!   ([`SuccessRule`]). A plant that never reports the flag fails the success criterion with
//!   a message saying so, rather than passing it unseen.
//! - **contact fraction**: the share of steps on which the plant reported a margin touched.
//! - **saturation**: per action dimension, the share of steps whose command reached the box.
//! - **stuck at margin**, the one definition the toolkit uses (docs/own-plant.md): for
//!   `window` consecutive steps the plant touched a margin on every step, the command (measured
//!   in half-ranges of the action box from its centre) was at least `min_command` long every
//!   step, and the motion the plant carried out (`applied`, summed over the window, in
//!   half-ranges) is at most `max_progress` long. Pushing into a limit and getting nowhere. Navigation's
//!   detector is this rule with the position's displacement as the summed motion.
//!
//! ```
//! use firmware_sim::nav::NavEnv;
//! use firmware_sim::nav::scenario::Scenario;
//! use firmware_sim::nav::straight::Straight;
//! use firmware_sim::plant_test::{evaluate_plant, Criteria, PlantTestConfig, SuccessRule};
//! // Navigation seen as any plant: success by return, stuck by the generic rule.
//! let mut env = NavEnv::new(&Scenario::builtin("nav-walls").unwrap()).unwrap();
//! let cfg = PlantTestConfig {
//!     episodes: 10,
//!     criteria: Criteria { success: SuccessRule::ReturnAtLeast(0.0), ..Criteria::default() },
//!     ..PlantTestConfig::default()
//! };
//! let report = evaluate_plant(&mut Straight { max_step: 0.25 }, &mut env, "nav-walls", &cfg).unwrap();
//! assert!(report.stuck_rate > 0.5); // straight pushes into the pinwheel's walls
//! assert!(!report.pass.passed);
//! ```

use serde::{Deserialize, Serialize};

use crate::actuator::{ActuatorModel, ActuatorStuck};
use crate::boot::{check_sizes, PlantSizes};
use crate::controller::Controller;
use crate::env::{BoxSpace, Plant, StepInfo};
use crate::error::number;
use crate::firmware::{Clock, Firmware, Timing};
use crate::nav::test_protocol::{Stopped, MAX_EPISODES};
use crate::pass::PassOutcome;
use crate::seed::episode_seed;
use crate::sensor::{Dropout, SensorModel};
use crate::Error;

/// What counts as a successful episode.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SuccessRule {
    /// The plant's own flag on the episode's last step ([`StepInfo::success`]).
    PlantFlag,
    /// The episode's return is at least this.
    ReturnAtLeast(f64),
}

/// When stuck at margin is declared (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct StuckRule {
    /// Consecutive steps, at least 1.
    pub window: u32,
    /// Smallest command length, in half-ranges of the action box from its centre, in `[0, 1]`.
    pub min_command: f32,
    /// Largest summed motion over the window, in half-ranges, `>= 0`.
    pub max_progress: f32,
}

impl Default for StuckRule {
    /// Navigation's window and command (20 steps, half the range); a progress of half a full
    /// step over the window.
    fn default() -> Self {
        StuckRule {
            window: 20,
            min_command: 0.5,
            max_progress: 0.5,
        }
    }
}

/// The pass criteria of a test.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Criteria {
    /// What a successful episode is.
    pub success: SuccessRule,
    /// Smallest acceptable success rate, in `[0, 1]`.
    pub min_success_rate: f64,
    /// Largest acceptable stuck-at-margin rate, in `[0, 1]`.
    pub max_stuck_rate: f64,
    /// When an episode is stuck at a margin.
    pub stuck: StuckRule,
}

impl Default for Criteria {
    /// Navigation's gate: 80 % success by the plant's flag, at most 20 % stuck.
    fn default() -> Self {
        Criteria {
            success: SuccessRule::PlantFlag,
            min_success_rate: 0.8,
            max_stuck_rate: 0.2,
            stuck: StuckRule::default(),
        }
    }
}

/// How to run a test on any plant.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlantTestConfig {
    /// Test episodes, in `1..=MAX_EPISODES`.
    pub episodes: usize,
    /// Seed of every random stream (episode starts, sensor noise, dropouts).
    pub seed: u64,
    /// The longest episode: the test cuts a plant that never ends its episodes here.
    pub max_steps: u32,
    /// Sensor model.
    pub sensor: SensorModel,
    /// Actuator model.
    pub actuator: ActuatorModel,
    /// Sensor dropouts.
    pub dropout: Option<Dropout>,
    /// An actuator dimension stuck from a tick on.
    pub stuck_actuator: Option<ActuatorStuck>,
    /// The pass criteria.
    pub criteria: Criteria,
}

impl Default for PlantTestConfig {
    fn default() -> Self {
        PlantTestConfig {
            episodes: 100,
            seed: 0,
            max_steps: 1000,
            sensor: SensorModel::default(),
            actuator: ActuatorModel::default(),
            dropout: None,
            stuck_actuator: None,
            criteria: Criteria::default(),
        }
    }
}

impl PlantTestConfig {
    /// Checks every setting against a plant of `actions` action dimensions.
    ///
    /// ```
    /// use firmware_sim::plant_test::PlantTestConfig;
    /// let mut cfg = PlantTestConfig::default();
    /// cfg.criteria.min_success_rate = 1.5;
    /// assert_eq!(
    ///     cfg.validate(2).unwrap_err().to_string(),
    ///     "criteria.min_success_rate: must be in [0, 1], found 1.5"
    /// );
    /// ```
    pub fn validate(&self, actions: usize) -> Result<(), Error> {
        let bad = |field, message| Err(Error::Config { field, message });
        if !(1..=MAX_EPISODES).contains(&self.episodes) {
            return bad(
                "episodes",
                format!("must be in 1..={MAX_EPISODES}, found {}", self.episodes),
            );
        }
        if self.max_steps == 0 {
            return bad("max_steps", "must be at least 1, found 0".into());
        }
        let c = &self.criteria;
        for (field, rate) in [
            ("criteria.min_success_rate", c.min_success_rate),
            ("criteria.max_stuck_rate", c.max_stuck_rate),
        ] {
            if !(0.0..=1.0).contains(&rate) {
                return bad(field, format!("must be in [0, 1], found {}", number(rate)));
            }
        }
        if let SuccessRule::ReturnAtLeast(r) = c.success {
            if !r.is_finite() {
                return bad(
                    "criteria.success",
                    format!("a return threshold must be finite, found {}", number(r)),
                );
            }
        }
        let s = &c.stuck;
        if s.window == 0 {
            return bad(
                "criteria.stuck.window",
                "must be at least 1, found 0".into(),
            );
        }
        if !(0.0..=1.0).contains(&s.min_command) {
            return bad(
                "criteria.stuck.min_command",
                format!("must be in [0, 1], found {}", number(s.min_command)),
            );
        }
        if !(s.max_progress.is_finite() && s.max_progress >= 0.0) {
            return bad(
                "criteria.stuck.max_progress",
                format!("must be finite and >= 0, found {}", number(s.max_progress)),
            );
        }
        crate::firmware::validate_faults(self.dropout, self.stuck_actuator, actions)?;
        crate::firmware::validate_models(&self.sensor, &self.actuator)
    }
}

/// One test episode.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlantEpisode {
    /// The seed the plant was reset with.
    pub seed: u64,
    /// The return (sum of rewards).
    pub ret: f64,
    /// Steps run.
    pub steps: u32,
    /// Successful by the criteria's rule.
    pub success: bool,
    /// Stuck at a margin (see the module docs).
    pub stuck: bool,
    /// Step (1-based) at which it was first found stuck.
    pub stuck_at: Option<u32>,
    /// Steps that touched a margin.
    pub contact_steps: u32,
    /// Steps whose command reached the box, per action dimension.
    pub saturated_steps: Vec<u32>,
    /// The episode ended in a terminal state (not a cut).
    pub terminated: bool,
    /// Whether the plant reported a success flag on the last step.
    pub flag_reported: bool,
}

/// The summary of a test on any plant.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlantReport {
    /// The plant's name.
    pub plant: String,
    /// The controller's name.
    pub controller: String,
    /// Why the blob did not boot (the loop then ran in the safe state).
    pub boot_error: Option<String>,
    /// The settings.
    pub config: PlantTestConfig,
    /// Share of successful episodes.
    pub success_rate: f64,
    /// Mean return.
    pub mean_return: f64,
    /// Standard deviation of the returns (over episodes).
    pub std_return: f64,
    /// Mean episode length in steps.
    pub mean_steps: f64,
    /// Share of episodes stuck at a margin.
    pub stuck_rate: f64,
    /// Share of steps that touched a margin.
    pub contact_fraction: f64,
    /// Share of steps whose command reached the box, per action dimension.
    pub saturation_fraction: Vec<f64>,
    /// Commands that were NaN or infinite, replaced by 0 by the actuator.
    pub sanitized_commands: u64,
    /// Steps run.
    pub total_steps: u64,
    /// Inference time (wall clock; the only part that is not deterministic).
    pub timing: Timing,
    /// The criteria's verdict.
    pub pass: PassOutcome,
    /// Why the run stopped before its last episode, if it did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stopped: Option<Stopped>,
    /// The chip's side of a hardware-in-the-loop run (`run --hil`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub chip: Option<crate::hil::ChipReport>,
    /// One record per episode.
    pub episodes: Vec<PlantEpisode>,
}

impl PlantReport {
    /// The report with `timing` zeroed: what the determinism guarantee covers.
    pub fn without_timing(&self) -> PlantReport {
        PlantReport {
            timing: Timing::default(),
            ..self.clone()
        }
    }

    /// Records that the blob did not boot (the loop ran in the safe state): the report fails.
    pub fn mark_boot_failure(&mut self, e: &Error) {
        self.boot_error = Some(e.to_string());
        self.pass.passed = false;
        self.pass
            .failures
            .insert(0, format!("blob did not boot: {e}"));
    }

    /// The summary table the CLI prints.
    pub fn summary(&self) -> String {
        let rule = match self.config.criteria.success {
            SuccessRule::PlantFlag => "success rate (the plant's flag)".to_string(),
            SuccessRule::ReturnAtLeast(r) => format!("success rate (return >= {r})"),
        };
        let sat: Vec<String> = self
            .saturation_fraction
            .iter()
            .map(|f| format!("{f:.3}"))
            .collect();
        let boot = self
            .boot_error
            .as_ref()
            .map_or("ok".to_string(), |e| format!("FAILED, safe state: {e}"));
        let verdict = self.pass.verdict();
        let rows = [
            (rule, format!("{:.3}", self.success_rate)),
            (
                "mean return".into(),
                format!("{:.3} (sd {:.3})", self.mean_return, self.std_return),
            ),
            (
                "mean episode length".into(),
                format!("{:.1}", self.mean_steps),
            ),
            ("stuck at margin".into(), format!("{:.3}", self.stuck_rate)),
            (
                "contact fraction".into(),
                format!("{:.3}", self.contact_fraction),
            ),
            ("saturated fraction per dim".into(), sat.join(" / ")),
            (
                "sanitised commands".into(),
                self.sanitized_commands.to_string(),
            ),
            (
                "inference mean / worst".into(),
                format!(
                    "{:.0} ns / {} ns",
                    self.timing.mean_ns, self.timing.worst_ns
                ),
            ),
            ("boot".into(), boot),
            ("pass criteria".into(), verdict),
        ];
        crate::pass::summary_table(
            (&self.plant, &self.controller, self.config.seed),
            (self.config.episodes, self.stopped.as_ref()),
            rows,
            self.chip.as_ref(),
        )
    }
}

/// Runs the test: `cfg.episodes` episodes of the firmware loop, each reset with
/// `episode_seed(cfg.seed, i)`, on a one-agent plant (any [`crate::env::Env`] is one). `Err`
/// for bad settings or sizes; a plant or controller that fails mid-run stops the run, and the
/// report says after how many episodes and why.
pub fn evaluate_plant(
    controller: &mut dyn Controller,
    plant: &mut dyn Plant,
    name: &str,
    cfg: &PlantTestConfig,
) -> Result<PlantReport, Error> {
    let agents = plant.agents();
    let [agent] = agents.as_slice() else {
        return Err(Error::Config {
            field: "plant",
            message: format!(
                "the test protocol for any plant runs plants of one agent; this one has {}",
                agents.len()
            ),
        });
    };
    let space = agent.action_space.clone();
    cfg.validate(space.dim())?;
    let sizes = PlantSizes {
        observations: agent.observation_space.dim(),
        actions: space.dim(),
    };
    check_sizes(controller, &sizes)?;
    let mut clock = Clock::default();
    let mut episodes = Vec::with_capacity(cfg.episodes.min(100_000));
    let (mut sanitized, mut stopped) = (0, None);
    for index in 0..cfg.episodes as u64 {
        let ran = run_episode(controller, plant, &space, cfg, index, &mut clock);
        let failure = plant.failure().or_else(|| controller.failure());
        match (ran, failure) {
            (Ok((episode, n)), None) => {
                sanitized += n;
                episodes.push(episode);
            }
            (_, Some(e)) | (Err(e), None) => {
                stopped = Some(Stopped {
                    episodes_run: index,
                    reason: e.to_string(),
                });
                break;
            }
        }
    }
    let mut report = summarise(
        name,
        controller.name(),
        cfg,
        episodes,
        sanitized,
        clock.timing(),
    );
    if let Some(s) = stopped {
        report.pass.passed = false;
        report.pass.failures.insert(
            0,
            format!("stopped after {} episodes: {}", s.episodes_run, s.reason),
        );
        report.stopped = Some(s);
    }
    Ok(report)
}

/// One episode; its record and the number of sanitised commands.
fn run_episode(
    controller: &mut dyn Controller,
    plant: &mut dyn Plant,
    space: &BoxSpace,
    cfg: &PlantTestConfig,
    index: u64,
    clock: &mut Clock,
) -> Result<(PlantEpisode, u64), Error> {
    let seed = episode_seed(cfg.seed, index);
    let turn = plant.reset(seed);
    if let Some(e) = plant.failure() {
        return Err(e);
    }
    let Some(mut truth) = turn.decide.map(|d| d.observation) else {
        return Err(Error::Config {
            field: "plant",
            message: format!("reset(seed {seed}) ended the episode before its first step"),
        });
    };
    controller.reset();
    let mut firmware = Firmware::new(
        space,
        cfg.sensor,
        cfg.actuator,
        cfg.dropout,
        cfg.stuck_actuator,
        cfg.seed,
        index,
    );
    let mut meter = Meter::new(seed, space, cfg.criteria.stuck);
    for tick in 0..cfg.max_steps {
        let action = firmware
            .control(tick, &truth, controller, clock, &mut meter.saturated)
            .to_vec();
        let turn = plant.act(&action);
        if let Some(e) = plant.failure() {
            return Err(e);
        }
        let (reward, terminated) = turn
            .closed
            .first()
            .map_or((0.0, false), |o| (o.reward, o.terminated));
        meter.push(&action, reward, &turn.info);
        match turn.decide {
            Some(next) => truth = next.observation,
            None => {
                meter.terminated = terminated;
                break;
            }
        }
    }
    Ok((meter.record(&cfg.criteria.success), firmware.sanitized()))
}

/// The running figures of one episode.
struct Meter {
    seed: u64,
    ret: f64,
    steps: u32,
    contact_steps: u32,
    saturated: Vec<u32>,
    terminated: bool,
    last_flag: Option<bool>,
    stuck: StuckDetector,
}

impl Meter {
    fn new(seed: u64, space: &BoxSpace, rule: StuckRule) -> Meter {
        Meter {
            seed,
            ret: 0.0,
            steps: 0,
            contact_steps: 0,
            saturated: vec![0; space.dim()],
            terminated: false,
            last_flag: None,
            stuck: StuckDetector::new(space, rule),
        }
    }

    fn push(&mut self, action: &[f32], reward: f32, info: &StepInfo) {
        self.steps += 1;
        self.ret += f64::from(reward);
        self.contact_steps += u32::from(info.margin_touched);
        self.last_flag = info.success;
        self.stuck.push(self.steps, action, info);
    }

    fn record(self, rule: &SuccessRule) -> PlantEpisode {
        let success = match rule {
            SuccessRule::PlantFlag => self.last_flag == Some(true),
            SuccessRule::ReturnAtLeast(r) => self.ret >= *r,
        };
        PlantEpisode {
            seed: self.seed,
            ret: self.ret,
            steps: self.steps,
            success,
            stuck: self.stuck.found.is_some(),
            stuck_at: self.stuck.found,
            contact_steps: self.contact_steps,
            saturated_steps: self.saturated,
            terminated: self.terminated,
            flag_reported: self.last_flag.is_some(),
        }
    }
}

/// The generic stuck-at-margin rule over a sliding window (see the module docs).
struct StuckDetector {
    rule: StuckRule,
    mid: Vec<f32>,
    half: Vec<f32>,
    /// Per step of the current run of pushing contacts: the applied motion in half-ranges.
    window: std::collections::VecDeque<Vec<f64>>,
    found: Option<u32>,
}

impl StuckDetector {
    fn new(space: &BoxSpace, rule: StuckRule) -> StuckDetector {
        let mid = space
            .low
            .iter()
            .zip(&space.high)
            .map(|(l, h)| (l + h) / 2.0);
        let half = space
            .low
            .iter()
            .zip(&space.high)
            .map(|(l, h)| (h - l) / 2.0);
        StuckDetector {
            rule,
            mid: mid.collect(),
            half: half.collect(),
            window: std::collections::VecDeque::new(),
            found: None,
        }
    }

    fn push(&mut self, step_number: u32, action: &[f32], info: &StepInfo) {
        if self.found.is_some() {
            return;
        }
        // The command's length in half-ranges (navigation's: the step's length over max_step).
        let command = action
            .iter()
            .zip(self.mid.iter().zip(&self.half))
            .map(|(a, (m, h))| ((a - m) / h).powi(2))
            .sum::<f32>()
            .sqrt();
        let pushing = info.margin_touched && command >= self.rule.min_command;
        if !pushing {
            self.window.clear();
            return;
        }
        let applied = info.applied.iter().zip(&self.half);
        self.window
            .push_back(applied.map(|(a, h)| f64::from(a / h)).collect());
        if self.window.len() > self.rule.window as usize {
            self.window.pop_front();
        }
        if self.window.len() == self.rule.window as usize {
            let mut sum = vec![0.0f64; self.half.len()];
            for motion in &self.window {
                for (s, m) in sum.iter_mut().zip(motion) {
                    *s += m;
                }
            }
            let progress = sum.iter().map(|s| s * s).sum::<f64>().sqrt();
            if progress <= f64::from(self.rule.max_progress) {
                self.found = Some(step_number);
            }
        }
    }
}

fn summarise(
    plant: &str,
    controller: String,
    cfg: &PlantTestConfig,
    episodes: Vec<PlantEpisode>,
    sanitized: u64,
    timing: Timing,
) -> PlantReport {
    // At least one: a run that stopped in its first episode has rates of 0, not NaN.
    let n = episodes.len().max(1) as f64;
    let count = |f: fn(&PlantEpisode) -> bool| episodes.iter().filter(|e| f(e)).count() as f64;
    let total_steps: u64 = episodes.iter().map(|e| u64::from(e.steps)).sum();
    let per_step = |c: u64| c as f64 / total_steps.max(1) as f64;
    let mean_return = episodes.iter().map(|e| e.ret).sum::<f64>() / n;
    let var = episodes
        .iter()
        .map(|e| (e.ret - mean_return).powi(2))
        .sum::<f64>()
        / (n - 1.0).max(1.0);
    let dims = cfg_dims(&episodes);
    let saturation_fraction = (0..dims)
        .map(|d| {
            per_step(
                episodes
                    .iter()
                    .map(|e| u64::from(e.saturated_steps[d]))
                    .sum(),
            )
        })
        .collect();
    let mut report = PlantReport {
        plant: plant.to_string(),
        controller,
        boot_error: None,
        config: cfg.clone(),
        success_rate: count(|e| e.success) / n,
        mean_return,
        std_return: var.sqrt(),
        mean_steps: total_steps as f64 / n,
        stuck_rate: count(|e| e.stuck) / n,
        contact_fraction: per_step(episodes.iter().map(|e| u64::from(e.contact_steps)).sum()),
        saturation_fraction,
        sanitized_commands: sanitized,
        total_steps,
        timing,
        pass: PassOutcome {
            passed: true,
            failures: Vec::new(),
        },
        stopped: None,
        chip: None,
        episodes,
    };
    report.pass = judge(&report);
    report
}

fn cfg_dims(episodes: &[PlantEpisode]) -> usize {
    episodes.first().map_or(0, |e| e.saturated_steps.len())
}

fn judge(r: &PlantReport) -> PassOutcome {
    let c = &r.config.criteria;
    let mut failures = Vec::new();
    let flagless = c.success == SuccessRule::PlantFlag
        && !r.episodes.is_empty()
        && r.episodes.iter().all(|e| !e.flag_reported);
    if flagless {
        failures.push(
            "the plant reports no success flag: give a return threshold (--success-return) or \
             have the plant report success"
                .to_string(),
        );
    } else if r.success_rate < c.min_success_rate {
        failures.push(format!(
            "success rate {:.3} is below the minimum {:.3}",
            r.success_rate, c.min_success_rate
        ));
    }
    if r.stuck_rate > c.max_stuck_rate {
        failures.push(format!(
            "stuck-at-margin rate {:.3} is above the maximum {:.3}",
            r.stuck_rate, c.max_stuck_rate
        ));
    }
    PassOutcome {
        passed: failures.is_empty(),
        failures,
    }
}
