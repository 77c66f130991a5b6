//! Navigation's test protocol: the firmware loop run against the navigation plant, episode by
//! episode, scored by the margin metrics.
//!
//! [`evaluate`] boots from blob bytes the way the chip does ([`crate::boot`]); a blob that fails
//! to boot leaves the loop in the safe state (zero action) and the report says why. Then, for
//! each of `episodes` test starts, every tick the firmware ([`crate::firmware`]) reads the
//! sensor, runs the controller and drives the actuator, and the plant steps. Each test runs the
//! full time limit (docs/design.md §2's protocol: reaching the centre does not end a test;
//! leaving the arena does).
//!
//! The protocol is navigation's own (walls that move as a fault, metrics on the true position),
//! so its episode loop holds the navigation plant; sizes come from the plant's declared
//! [`crate::env::Plant`] agents. Badminton's matches and measures are in
//! [`crate::badminton::play`].
//!
//! [`evaluate_streaming`] is the core: it hands each episode's record to a callback as soon as
//! the episode ends and keeps only running totals, so its memory does not depend on the episode
//! count (the CLI streams the records into its JSON report and SVG plot). [`evaluate`] and
//! [`evaluate_controller`] are built on it and keep every record in [`Report::episodes`]. One
//! evaluation runs at most [`MAX_EPISODES`] episodes.
//!
//! ```
//! use firmware_sim::nav::straight::Straight;
//! use firmware_sim::nav::test_protocol::{evaluate, evaluate_controller, EvalConfig};
//! use firmware_sim::nav::scenario::Scenario;
//! let open = Scenario::builtin("nav-open").unwrap();
//! let cfg = EvalConfig { episodes: 10, ..EvalConfig::default() };
//! let report = evaluate_controller(&mut Straight { max_step: 0.25 }, &open, &cfg).unwrap();
//! assert_eq!(report.success_rate, 1.0);
//! assert!(report.pass.passed);
//! // Corrupt bytes: no error, a report of the safe state.
//! let report = evaluate(b"not a blob", &open, &cfg).unwrap();
//! assert!(report.boot_error.as_deref().unwrap().contains("magic"));
//! assert_eq!(report.success_rate, 0.0);
//! assert!(!report.pass.passed);
//! ```

use serde::{Deserialize, Serialize};

use super::metrics::{EpisodeMeter, EpisodeRecord, Tick};
use super::plant::NavEnv;
use super::scenario::Scenario;
use crate::actuator::ActuatorModel;
use crate::boot::{boot_or_safe_state, check_sizes, PlantSizes};
use crate::controller::Controller;
use crate::env::Env;
use crate::firmware::{Clock, Firmware, Timing};
use crate::nav::faults::Faults;
use crate::pass::PassOutcome;
use crate::seed::episode_seed;
use crate::sensor::SensorModel;
use crate::Error;

/// The most episodes one evaluation runs (1,000,000). A larger count is refused by
/// [`EvalConfig::validate`] before anything is allocated or run: a million episodes of the
/// shipped 200-step scenarios already take minutes (100,000 take about 30 s), so a larger
/// count is almost surely a typo, and `Report::episodes` stays a size a caller can hold.
pub const MAX_EPISODES: usize = 1_000_000;

/// How to run a test: how many starts, which seed, which sensor, actuator and faults.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EvalConfig {
    /// Number of test episodes (100, as in the paper), in `1..=MAX_EPISODES`.
    pub episodes: usize,
    /// Seed of every random stream (starts, sensor noise, dropouts).
    pub seed: u64,
    /// Sensor model (ideal by default).
    pub sensor: SensorModel,
    /// Actuator model (saturation only by default).
    pub actuator: ActuatorModel,
    /// Injected faults (none by default).
    pub faults: Faults,
    /// Keep every episode's positions in the report (for SVG plots).
    pub record_trajectories: bool,
}

impl Default for EvalConfig {
    fn default() -> Self {
        Self {
            episodes: 100,
            seed: 0,
            sensor: SensorModel::default(),
            actuator: ActuatorModel::default(),
            faults: Faults::default(),
            record_trajectories: false,
        }
    }
}

impl EvalConfig {
    /// Checks the settings against the scenario.
    ///
    /// ```
    /// use firmware_sim::nav::test_protocol::{EvalConfig, MAX_EPISODES};
    /// use firmware_sim::nav::scenario::Scenario;
    /// let s = Scenario::builtin("nav-open").unwrap();
    /// let cfg = EvalConfig { episodes: MAX_EPISODES + 1, ..EvalConfig::default() };
    /// let err = cfg.validate(&s).unwrap_err().to_string();
    /// assert_eq!(err, "episodes: must be in 1..=1000000, found 1000001");
    /// ```
    pub fn validate(&self, scenario: &Scenario) -> Result<(), Error> {
        let bad = |field, message| Err(Error::Config { field, message });
        if !(1..=MAX_EPISODES).contains(&self.episodes) {
            return bad(
                "episodes",
                format!("must be in 1..={MAX_EPISODES}, found {}", self.episodes),
            );
        }
        crate::firmware::validate_models(&self.sensor, &self.actuator)?;
        self.faults.validate(scenario, 2)
    }
}

/// The summary of an evaluation (serialised as the CLI's JSON report).
///
/// Everything except `timing` is a pure function of the controller, scenario and config: the
/// same seed gives the same report bit for bit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// Scenario name.
    pub scenario: String,
    /// Controller name (for blobs: label, shape, activation).
    pub controller: String,
    /// Why the blob did not boot (the loop then ran in the safe state).
    pub boot_error: Option<String>,
    /// The evaluation settings.
    pub config: EvalConfig,
    /// Fraction of tests that settled within `success_radius` (2) of the centre.
    pub success_rate: f64,
    /// Mean settled distance from the centre.
    pub mean_error: f64,
    /// Fraction that held within 0.1 of the centre for 10 steps.
    pub strict_reach_rate: f64,
    /// Fraction that came within 0.25 of the centre.
    pub near_pass_rate: f64,
    /// Mean steps to the goal over the tests that reached it (`None` if none did).
    pub mean_steps_to_goal: Option<f64>,
    /// Fraction of tests flagged stuck at a margin.
    pub stuck_rate: f64,
    /// Fraction of tests that left the arena.
    pub left_arena_rate: f64,
    /// Fraction of all steps that touched a wall.
    pub contact_fraction: f64,
    /// Fraction of all steps whose command was saturated, per action dimension.
    pub saturation_fraction: Vec<f64>,
    /// Commands that were NaN or infinite and were replaced by 0 by the actuator.
    pub sanitized_commands: u64,
    /// Total steps run.
    pub total_steps: u64,
    /// Inference time.
    pub timing: Timing,
    /// The scenario's pass criteria.
    pub pass: PassOutcome,
    /// Why the run stopped before its last episode (a chip in the loop failed), if it did: the
    /// totals are those of the episodes that ran to the end.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stopped: Option<Stopped>,
    /// The chip's side of a hardware-in-the-loop run (`run --hil`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub chip: Option<crate::hil::ChipReport>,
    /// One record per test.
    pub episodes: Vec<EpisodeRecord>,
}

/// Why and when a run stopped early (the episode it stopped in is not counted).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stopped {
    /// Episodes that ran to the end before the failure.
    pub episodes_run: u64,
    /// The failure, one line.
    pub reason: String,
}

impl Report {
    /// The report with `timing` zeroed: what the determinism guarantee covers.
    ///
    /// ```
    /// use firmware_sim::nav::reference::reference;
    /// use firmware_sim::nav::test_protocol::{evaluate_controller, EvalConfig};
    /// use firmware_sim::nav::scenario::Scenario;
    /// let s = Scenario::builtin("nav-walls").unwrap();
    /// let cfg = EvalConfig { episodes: 3, seed: 9, ..EvalConfig::default() };
    /// let mut run = || {
    ///     let mut c = reference("straight", &s).unwrap();
    ///     evaluate_controller(c.as_mut(), &s, &cfg).unwrap().without_timing()
    /// };
    /// assert_eq!(run(), run());
    /// ```
    pub fn without_timing(&self) -> Report {
        Report {
            timing: Timing::default(),
            ..self.clone()
        }
    }

    /// Episodes that ran to the end (all of them unless the run [`stopped`](Report::stopped)).
    pub fn ran(&self) -> u64 {
        match &self.stopped {
            Some(s) => s.episodes_run,
            None => self.config.episodes as u64,
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
    ///
    /// ```
    /// use firmware_sim::nav::straight::Straight;
    /// use firmware_sim::nav::test_protocol::{evaluate_controller, EvalConfig};
    /// use firmware_sim::nav::scenario::Scenario;
    /// let s = Scenario::builtin("nav-open").unwrap();
    /// let cfg = EvalConfig { episodes: 2, ..EvalConfig::default() };
    /// let r = evaluate_controller(&mut Straight { max_step: 0.25 }, &s, &cfg).unwrap();
    /// let table = r.summary();
    /// assert!(table.starts_with("nav-open | straight | 2 tests, seed 0"));
    /// assert!(table.contains("pass criteria") && table.contains("PASS"));
    /// ```
    pub fn summary(&self) -> String {
        let steps = self
            .mean_steps_to_goal
            .map_or("-".to_string(), |s| format!("{s:.1}"));
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
            (
                "success rate (settled within 2)",
                format!("{:.3}", self.success_rate),
            ),
            ("mean settled error", format!("{:.3}", self.mean_error)),
            (
                "strict reach (0.1 for 10 steps)",
                format!("{:.3}", self.strict_reach_rate),
            ),
            (
                "near pass (within 0.25)",
                format!("{:.3}", self.near_pass_rate),
            ),
            ("mean steps to goal", steps),
            ("stuck at margin", format!("{:.3}", self.stuck_rate)),
            ("left the arena", format!("{:.3}", self.left_arena_rate)),
            ("contact fraction", format!("{:.3}", self.contact_fraction)),
            ("saturated fraction per dim", sat.join(" / ")),
            ("sanitised commands", self.sanitized_commands.to_string()),
            (
                "inference mean / worst",
                format!(
                    "{:.0} ns / {} ns",
                    self.timing.mean_ns, self.timing.worst_ns
                ),
            ),
            ("boot", boot),
            ("pass criteria", verdict),
        ];
        crate::pass::summary_table(
            (&self.scenario, &self.controller, self.config.seed),
            (self.config.episodes, self.stopped.as_ref()),
            rows,
            self.chip.as_ref(),
        )
    }
}

/// Boots a blob and runs the test protocol. `Err` only for an invalid scenario or config; a
/// blob that fails to boot gives a report with `boot_error` set.
pub fn evaluate(blob: &[u8], scenario: &Scenario, cfg: &EvalConfig) -> Result<Report, Error> {
    let (mut controller, boot_error) = boot_or_safe_state(blob, &PlantSizes::of(scenario)?);
    let mut report = evaluate_controller(controller.as_mut(), scenario, cfg)?;
    if let Some(e) = boot_error {
        report.mark_boot_failure(&e);
    }
    Ok(report)
}

/// Runs the test protocol with any controller (a booted blob, `straight`, `oracle`, or the
/// trainer's own), keeping every episode's record in [`Report::episodes`] (for large counts,
/// [`evaluate_streaming`] keeps none).
///
/// ```
/// use firmware_sim::nav::reference::reference;
/// use firmware_sim::nav::test_protocol::{evaluate_controller, EvalConfig};
/// use firmware_sim::nav::scenario::Scenario;
/// let s = Scenario::builtin("nav-walls").unwrap();
/// let cfg = EvalConfig { episodes: 5, ..EvalConfig::default() };
/// let r = evaluate_controller(reference("oracle", &s).unwrap().as_mut(), &s, &cfg).unwrap();
/// assert_eq!((r.success_rate, r.stuck_rate), (1.0, 0.0));
/// assert_eq!(r.episodes.len(), 5);
/// ```
pub fn evaluate_controller(
    controller: &mut dyn Controller,
    scenario: &Scenario,
    cfg: &EvalConfig,
) -> Result<Report, Error> {
    let mut episodes = Vec::new();
    let mut report = evaluate_streaming(controller, scenario, cfg, |e| {
        episodes.push(e);
        Ok::<(), Error>(())
    })?;
    report.episodes = episodes;
    Ok(report)
}

/// Runs the test protocol, handing each episode's record to `on_episode` as soon as the
/// episode ends, in order; returns the report of running totals, with `episodes` empty. Its
/// memory does not grow with the episode count. An error from `on_episode` stops the run and
/// is returned.
///
/// ```
/// use firmware_sim::nav::straight::Straight;
/// use firmware_sim::nav::test_protocol::{evaluate_controller, evaluate_streaming, EvalConfig};
/// use firmware_sim::nav::scenario::Scenario;
/// let s = Scenario::builtin("nav-walls").unwrap();
/// let cfg = EvalConfig { episodes: 4, ..EvalConfig::default() };
/// let mut stuck = 0;
/// let report = evaluate_streaming(&mut Straight { max_step: 0.25 }, &s, &cfg, |e| {
///     stuck += usize::from(e.stuck);
///     Ok::<(), firmware_sim::Error>(())
/// })
/// .unwrap();
/// assert!(report.episodes.is_empty());
/// assert_eq!(report.stuck_rate, stuck as f64 / 4.0);
/// let mut full = evaluate_controller(&mut Straight { max_step: 0.25 }, &s, &cfg).unwrap();
/// full.episodes.clear();
/// assert_eq!(report.without_timing(), full.without_timing());
/// ```
pub fn evaluate_streaming<E: From<Error>>(
    controller: &mut dyn Controller,
    scenario: &Scenario,
    cfg: &EvalConfig,
    mut on_episode: impl FnMut(EpisodeRecord) -> Result<(), E>,
) -> Result<Report, E> {
    cfg.validate(scenario)?;
    let mut env = NavEnv::new(scenario)?;
    check_sizes(controller, &PlantSizes::of_env(&env))?;
    env.set_goal_terminates(false);
    let mut clock = Clock::default();
    let mut totals = Totals::default();
    let mut stopped = None;
    for i in 0..cfg.episodes as u64 {
        let (record, sanitized) = run_episode(controller, &mut env, cfg, i, &mut clock);
        if let Some(e) = controller.failure() {
            // The episode the controller failed in did not run as the protocol says: dropped.
            stopped = Some(Stopped {
                episodes_run: i,
                reason: e.to_string(),
            });
            break;
        }
        totals.add(&record, sanitized);
        on_episode(record)?;
    }
    let mut report = totals.report(controller.name(), scenario, cfg, clock.timing());
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

/// One test episode of the firmware loop; returns its record and the number of sanitised
/// commands.
fn run_episode(
    controller: &mut dyn Controller,
    env: &mut NavEnv,
    cfg: &EvalConfig,
    index: u64,
    clock: &mut Clock,
) -> (EpisodeRecord, u64) {
    let seed = episode_seed(cfg.seed, index);
    let mut truth = env.reset(seed);
    controller.reset();
    let mut firmware = Firmware::new(
        env.action_space(),
        cfg.sensor,
        cfg.actuator,
        cfg.faults.dropout,
        cfg.faults.stuck,
        cfg.seed,
        index,
    );
    let changed_walls = cfg.faults.changed_walls(env.scenario());
    let mut meter = EpisodeMeter::new(
        seed,
        env.position(),
        2,
        env.scenario(),
        cfg.record_trajectories,
    );
    for tick in 0..env.scenario().time_limit {
        if let (Some(walls), Some(change)) = (&changed_walls, cfg.faults.wall) {
            if change.at_tick == tick {
                env.set_walls(walls.iter().map(|w| w.segment()).collect());
            }
        }
        let action = firmware.control(tick, &truth, controller, clock, &mut meter.saturated);
        let step = env.step(action);
        let command = f64::from(action[0]).hypot(f64::from(action[1]));
        let touched = step.info.margin_touched;
        meter.push(Tick {
            position: env.position(),
            touched,
            command,
        });
        truth = step.observation;
        if step.terminated {
            meter.left_arena = env.outside();
            break;
        }
    }
    (meter.record(), firmware.sanitized())
}

/// Running totals over the episodes, in episode order (the sums are those a pass over all the
/// records would make, so the report is the same bit for bit).
#[derive(Debug, Default)]
struct Totals {
    episodes: u64,
    success: u64,
    reached: u64,
    near_pass: u64,
    stuck: u64,
    left_arena: u64,
    error_sum: f64,
    steps: u64,
    contact_steps: u64,
    saturated_steps: [u64; 2],
    goal_reached: u64,
    goal_steps_sum: f64,
    sanitized: u64,
}

impl Totals {
    fn add(&mut self, e: &EpisodeRecord, sanitized: u64) {
        self.episodes += 1;
        self.success += u64::from(e.success);
        self.reached += u64::from(e.reached);
        self.near_pass += u64::from(e.near_pass);
        self.stuck += u64::from(e.stuck);
        self.left_arena += u64::from(e.left_arena);
        self.error_sum += e.error;
        self.steps += u64::from(e.steps);
        self.contact_steps += u64::from(e.contact_steps);
        for (total, n) in self.saturated_steps.iter_mut().zip(&e.saturated_steps) {
            *total += u64::from(*n);
        }
        if let Some(steps) = e.steps_to_goal {
            self.goal_reached += 1;
            self.goal_steps_sum += f64::from(steps);
        }
        self.sanitized += sanitized;
    }

    fn report(
        &self,
        controller: String,
        scenario: &Scenario,
        cfg: &EvalConfig,
        timing: Timing,
    ) -> Report {
        // At least one: a run that stopped in its first episode has rates of 0, not NaN.
        let n = self.episodes.max(1) as f64;
        let per_step = |count: u64| count as f64 / self.steps.max(1) as f64;
        let mut report = Report {
            scenario: scenario.name.clone(),
            controller,
            boot_error: None,
            config: cfg.clone(),
            success_rate: self.success as f64 / n,
            mean_error: self.error_sum / n,
            strict_reach_rate: self.reached as f64 / n,
            near_pass_rate: self.near_pass as f64 / n,
            mean_steps_to_goal: (self.goal_reached > 0)
                .then(|| self.goal_steps_sum / self.goal_reached as f64),
            stuck_rate: self.stuck as f64 / n,
            left_arena_rate: self.left_arena as f64 / n,
            contact_fraction: per_step(self.contact_steps),
            saturation_fraction: self.saturated_steps.map(per_step).to_vec(),
            sanitized_commands: self.sanitized,
            total_steps: self.steps,
            timing,
            pass: PassOutcome {
                passed: true,
                failures: Vec::new(),
            },
            stopped: None,
            chip: None,
            episodes: Vec::new(),
        };
        report.pass = judge(&report, scenario);
        report
    }
}

fn judge(r: &Report, s: &Scenario) -> PassOutcome {
    let mut failures = Vec::new();
    if r.success_rate < s.pass.min_success_rate {
        failures.push(format!(
            "success rate {:.3} is below the minimum {:.3}",
            r.success_rate, s.pass.min_success_rate
        ));
    }
    if r.stuck_rate > s.pass.max_stuck_rate {
        failures.push(format!(
            "stuck-at-margin rate {:.3} is above the maximum {:.3}",
            r.stuck_rate, s.pass.max_stuck_rate
        ));
    }
    PassOutcome {
        passed: failures.is_empty(),
        failures,
    }
}

#[cfg(test)]
mod tests {
    use super::super::straight::Straight;
    use super::*;

    /// Regression: `episodes = usize::MAX` panicked (`capacity overflow`) and
    /// 10^12 aborted on a 152 TB allocation. Counts above `MAX_EPISODES` are refused by
    /// `validate`, before anything is allocated or run.
    #[test]
    fn an_episode_count_beyond_the_maximum_is_refused_before_any_work() {
        let s = Scenario::builtin("nav-open").expect("builtin");
        for episodes in [usize::MAX, 1_000_000_000_000, MAX_EPISODES + 1] {
            let cfg = EvalConfig {
                episodes,
                ..EvalConfig::default()
            };
            let e = evaluate_controller(&mut Straight { max_step: 0.25 }, &s, &cfg)
                .expect_err("must be refused");
            assert_eq!(
                e.to_string(),
                format!("episodes: must be in 1..=1000000, found {episodes}")
            );
        }
    }

    #[test]
    fn an_error_from_the_episode_callback_stops_the_run() {
        let s = Scenario::builtin("nav-open").expect("builtin");
        let cfg = EvalConfig::default();
        let mut seen = 0;
        let result = evaluate_streaming(&mut Straight { max_step: 0.25 }, &s, &cfg, |_| {
            seen += 1;
            if seen == 3 {
                Err(Error::Config {
                    field: "test",
                    message: "stop".into(),
                })
            } else {
                Ok(())
            }
        });
        assert_eq!(result.expect_err("stopped").to_string(), "test: stop");
        assert_eq!(seen, 3);
    }
}
