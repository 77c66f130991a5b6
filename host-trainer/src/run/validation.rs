//! Validation while training: every few episodes the actor is exported as the blob it would
//! be, booted as the chip boots it, and run through firmware-sim's test protocol on starts of
//! its own; the best policy by one rule is kept, and the run can end once the gate holds.
//!
//! Three decisions live here, each in one function:
//! - **which starts** ([`validation_seed`]): a stream of the run's seed named `validation`,
//!   never the test's seed, so the test starts play no part in any choice the run makes;
//! - **which policy is kept** ([`Round::better_than`]): the one that meets the validation
//!   criteria, then the one that passes the scenario's own gate, then the lower mean settled
//!   error (a plant of the user's: the higher mean return), then the earlier;
//! - **when to stop** ([`ValidationConfig::stops_after`]): `in_a_row` rounds in a row meet the
//!   criteria.
//!
//! Validation draws from no training stream, so it changes no bit of what the run learns: a
//! run with validation trains the same networks, episode for episode, as one without.
//!
//! Why these defaults (docs/training.md, "Validation while training"): the criteria are the
//! scenario's gate with a margin (success ≥ 0.9 where nav-walls asks 0.8, stuck ≤ 0.1 where it
//! allows 0.2) and a mean settled error below 0.4, because the main job's aim on the test
//! starts is success ≥ 0.9 and settled error < 0.5, and a policy parked at the pinwheel's inner
//! ring settles about 1 from the centre on the starts it parks on (0.67 to 1.2 in the margin
//! study) while one that goes round settles within 0.35: the margin keeps a validation pass
//! from being a test fail by the sampling of 100 starts. A round every 10 episodes, and the first
//! that meets the criteria ends the run, because the settled error is where a policy comes to
//! rest and that resting point moves from round to round: rounds close together catch a policy
//! within 0.4 sooner, for about 3 % of the training's time. The main job's study measured it
//! against rounds every 100 episodes with two in a row (docs/results/main-job.md, "Second
//! amendment"): every one of 20 base seeds still delivers, in less than half the time.

use serde::{Deserialize, Serialize};

use firmware_sim::boot::{self, PlantSizes};
use firmware_sim::controller::Controller;
use firmware_sim::env::Plant;
use firmware_sim::heads::HeadsPolicy;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::{self, EvalConfig, MAX_EPISODES};
use firmware_sim::plant_test::{evaluate_plant, PlantTestConfig};
use firmware_sim::seed::training_stream;
use rand_core::Rng as _;

use crate::Error;

/// The seed of the end-of-training test's starts (`train` tests on seed 0, as `eval` and
/// `firmware-sim run` do by default); validation never uses it.
pub const TEST_SEED: u64 = 0;

/// The `[validation]` section of a run's configuration.
///
/// A config without the section trains as runs did before validation existed: to its budget,
/// keeping the last networks (what `sweep` and `reproduce` do, their protocols say so).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ValidationConfig {
    /// Validate every this many episodes, and once more at the end of the budget.
    pub every: usize,
    /// Validation starts per round.
    pub starts: usize,
    /// End the run when `in_a_row` rounds in a row meet the criteria; off: train to the budget
    /// and keep the best.
    pub stop: bool,
    /// Rounds in a row that must meet the criteria before the run stops.
    pub in_a_row: usize,
    /// Least success rate of a round that meets the criteria.
    pub min_success: f64,
    /// Largest stuck-at-margin rate of a round that meets the criteria.
    pub max_stuck: f64,
    /// Largest mean settled error of a round that meets the criteria (scenarios only: a plant
    /// of the user's reports no settled error).
    pub max_error: f64,
}

impl Default for ValidationConfig {
    fn default() -> Self {
        ValidationConfig {
            every: 10,
            starts: 100,
            stop: true,
            in_a_row: 1,
            min_success: 0.9,
            max_stuck: 0.1,
            max_error: 0.4,
        }
    }
}

impl ValidationConfig {
    /// Checks the settings. An interval above the episode budget is allowed here (the round at
    /// the end of the budget is then the only one); `train --validate-every` refuses it, since
    /// a user who asks for rounds expects more than one.
    ///
    /// ```
    /// use host_trainer::run::validation::ValidationConfig;
    /// let v = ValidationConfig { every: 0, ..ValidationConfig::default() };
    /// let err = v.check().unwrap_err().to_string();
    /// assert!(err.contains("validation.every"), "{err}");
    /// assert!(ValidationConfig::default().check().is_ok());
    /// ```
    pub fn check(&self) -> Result<(), Error> {
        let bad = |what: &str, expected: String, found: String| {
            Err(Error::InvalidConfig {
                what: format!("validation.{what}"),
                expected,
                found,
            })
        };
        if self.every == 0 {
            return bad(
                "every",
                "at least 1 episode between rounds".into(),
                "0".into(),
            );
        }
        if !(1..=MAX_EPISODES).contains(&self.starts) {
            return bad(
                "starts",
                format!("1 to {MAX_EPISODES} validation starts"),
                self.starts.to_string(),
            );
        }
        if self.in_a_row == 0 {
            return bad("in_a_row", "at least 1 round".into(), "0".into());
        }
        for (what, v) in [
            ("min_success", self.min_success),
            ("max_stuck", self.max_stuck),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return bad(what, "a rate in [0, 1]".into(), v.to_string());
            }
        }
        if !(self.max_error.is_finite() && self.max_error >= 0.0) {
            return bad(
                "max_error",
                "a finite distance, 0 or more".into(),
                self.max_error.to_string(),
            );
        }
        Ok(())
    }

    /// How a report names the stop: "met the criteria" for one round, "met the criteria N
    /// rounds in a row" for more.
    ///
    /// ```
    /// use host_trainer::run::validation::ValidationConfig;
    /// let v = |in_a_row| ValidationConfig { in_a_row, ..ValidationConfig::default() };
    /// assert_eq!(v(1).met_the_criteria(), "met the criteria");
    /// assert_eq!(v(2).met_the_criteria(), "met the criteria 2 rounds in a row");
    /// ```
    pub fn met_the_criteria(&self) -> String {
        match self.in_a_row {
            1 => "met the criteria".to_string(),
            n => format!("met the criteria {n} rounds in a row"),
        }
    }

    /// Whether `rounds` (a run's validation history, oldest first) ends the run: stopping is on
    /// and the last `in_a_row` rounds all meet the criteria.
    ///
    /// ```
    /// use host_trainer::run::validation::{Round, ValidationConfig};
    /// let v = ValidationConfig { in_a_row: 2, ..ValidationConfig::default() };
    /// let round = |episode, meets| Round { episode, meets, ..Round::default() };
    /// assert!(!v.stops_after(&[round(100, true)]));
    /// assert!(!v.stops_after(&[round(100, true), round(200, false)]));
    /// assert!(v.stops_after(&[round(100, false), round(200, true), round(300, true)]));
    /// ```
    pub fn stops_after(&self, rounds: &[Round]) -> bool {
        self.stop
            && rounds.len() >= self.in_a_row
            && rounds[rounds.len() - self.in_a_row..]
                .iter()
                .all(|r| r.meets)
    }
}

/// One validation round's figures.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Round {
    /// Completed episodes when the round ran.
    pub episode: usize,
    /// Environment steps by then.
    pub total_steps: u64,
    /// Success rate over the validation starts.
    pub success: f64,
    /// Stuck-at-margin rate.
    pub stuck: f64,
    /// Mean settled error (a scenario; `None` on a plant of the user's).
    pub error: Option<f64>,
    /// Mean return (a plant of the user's; `None` on a scenario, whose return is the
    /// training reward's and not what the gate judges).
    pub mean_return: Option<f64>,
    /// The scenario's (or plant test's) own pass criteria hold.
    pub gate: bool,
    /// The validation criteria hold: the gate, and the margins of [`ValidationConfig`].
    pub meets: bool,
}

impl Round {
    /// The rule that keeps the best policy: meeting the criteria first, then passing the gate,
    /// then the lower mean settled error (or the higher mean return), then the earlier round.
    ///
    /// ```
    /// use host_trainer::run::validation::Round;
    /// let r = |episode, meets, error| Round { episode, meets, gate: meets, error: Some(error), ..Round::default() };
    /// assert!(r(200, true, 0.3).better_than(&r(100, false, 0.1)));
    /// assert!(r(200, true, 0.1).better_than(&r(100, true, 0.3)));
    /// assert!(!r(200, true, 0.3).better_than(&r(100, true, 0.3))); // a tie keeps the earlier
    /// ```
    pub fn better_than(&self, other: &Round) -> bool {
        use std::cmp::Ordering::{Equal, Greater, Less};
        let by_flags = (self.meets, self.gate).cmp(&(other.meets, other.gate));
        let by_figure = match (self.error, other.error, self.mean_return, other.mean_return) {
            (Some(a), Some(b), ..) => b.total_cmp(&a),
            (_, _, Some(a), Some(b)) => a.total_cmp(&b),
            _ => Equal,
        };
        match by_flags.then(by_figure) {
            Greater => true,
            Less | Equal => false,
        }
    }

    /// The round as one line of `validation.csv`.
    pub fn csv(&self) -> String {
        let opt = |v: Option<f64>| v.map_or_else(String::new, |v| format!("{v}"));
        format!(
            "{},{},{},{},{},{},{},{}",
            self.episode,
            self.total_steps,
            self.success,
            self.stuck,
            opt(self.error),
            opt(self.mean_return),
            u8::from(self.gate),
            u8::from(self.meets)
        )
    }
}

/// The header of `validation.csv`.
pub const CSV_HEADER: &str =
    "episode,total_steps,success,stuck,settled_error,mean_return,gate,meets";

/// A run's validation history as `validation.csv`.
pub fn csv(rounds: &[Round]) -> String {
    let mut out = format!("{CSV_HEADER}\n");
    for r in rounds {
        out.push_str(&r.csv());
        out.push('\n');
    }
    out
}

/// The policy a run keeps: the best round's blobs, exactly as they were validated.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Kept {
    /// The round that chose it.
    pub round: Round,
    /// The actor blob (`policy.postcard`).
    pub policy: Vec<u8>,
    /// The critic blob (`critic.postcard`), for algorithms with a Q(s, a) critic.
    pub critic: Option<Vec<u8>>,
}

/// The seed of a run's validation starts: the first draw of its `validation` stream that is not
/// the test's seed, so validation and the test never share a start's seed.
///
/// ```
/// use host_trainer::run::validation::{validation_seed, TEST_SEED};
/// assert_ne!(validation_seed(0), TEST_SEED);
/// assert_eq!(validation_seed(7), validation_seed(7));
/// assert_ne!(validation_seed(7), validation_seed(8));
/// ```
pub fn validation_seed(run_seed: u64) -> u64 {
    let mut stream = training_stream(run_seed, "validation");
    loop {
        let seed = stream.next_u64();
        if seed != TEST_SEED {
            return seed;
        }
    }
}

/// Where a round runs: the run's scenario (through firmware-sim's navigation test protocol)
/// or its plant (through the test protocol for any plant).
pub(crate) enum Ground<'a> {
    /// A scenario, as the end-of-training test runs it.
    Scenario(&'a Scenario),
    /// A plant of the user's (a plant process or a plant given in process).
    Plant(&'a mut dyn Plant, &'a str),
}

/// Runs one validation round of `policy` (with its `critic` choosing among heads when it has
/// several) on `ground`, judged by `config`.
pub(crate) fn round(
    config: &ValidationConfig,
    ground: Ground<'_>,
    (policy, critic): (&[u8], Option<&[u8]>),
    seed: u64,
    (episode, total_steps): (usize, u64),
) -> Result<Round, Error> {
    let sim = |e: firmware_sim::Error| Error::Sim {
        context: format!("validation after episode {episode}"),
        message: e.to_string(),
    };
    let mut round = Round {
        episode,
        total_steps,
        ..Round::default()
    };
    match ground {
        Ground::Scenario(scenario) => {
            let sizes = PlantSizes::of(scenario).map_err(sim)?;
            let mut controller: Box<dyn Controller> = match critic {
                Some(critic) => Box::new(HeadsPolicy::boot(policy, critic, &sizes).map_err(sim)?),
                None => Box::new(boot::boot(policy, &sizes).map_err(sim)?),
            };
            let eval = EvalConfig {
                episodes: config.starts,
                seed,
                ..EvalConfig::default()
            };
            let report = test_protocol::evaluate_controller(controller.as_mut(), scenario, &eval)
                .map_err(sim)?;
            round.success = report.success_rate;
            round.stuck = report.stuck_rate;
            round.error = Some(report.mean_error);
            round.gate = report.pass.passed;
        }
        Ground::Plant(plant, name) => {
            let sizes = {
                let agents = plant.agents();
                let agent = agents.first().ok_or_else(|| Error::Sim {
                    context: format!("plant {name:?}"),
                    message: "the plant declares no agent".into(),
                })?;
                PlantSizes {
                    observations: agent.observation_space.dim(),
                    actions: agent.action_space.dim(),
                }
            };
            let mut controller = boot::boot(policy, &sizes).map_err(sim)?;
            let test = PlantTestConfig {
                episodes: config.starts,
                seed,
                ..PlantTestConfig::default()
            };
            let report = evaluate_plant(&mut controller, plant, name, &test).map_err(sim)?;
            round.success = report.success_rate;
            round.stuck = report.stuck_rate;
            round.mean_return = Some(report.mean_return);
            round.gate = report.pass.passed;
        }
    }
    round.meets = round.gate
        && round.success >= config.min_success
        && round.stuck <= config.max_stuck
        && round.error.is_none_or(|e| e < config.max_error);
    Ok(round)
}
