//! What a run trains on, and how its folder and checkpoint record it: one of firmware-sim's
//! scenarios, a plant process started from a command (`--plant-cmd`, the plant link), or a
//! plant the caller's own code built ([`crate::run::trainer::Trainer::with_plant`]).
//!
//! A scenario is recorded as its TOML, as before. The other two are recorded by their hello
//! (name and boxes) and, for a process, its command: a run resumed on a plant whose hello has
//! changed is refused, since the networks were shaped and normalised for the old one.

use firmware_sim::env::{BoxSpace, Plant};
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::plant_link::child::{ChildPlant, Timeouts};
use firmware_sim::plant_link::messages::{Agent, Hello};
use serde::{Deserialize, Serialize};

use crate::Error;

/// What a run trains on.
#[derive(Clone, Debug, PartialEq)]
pub enum RunPlant {
    /// A firmware-sim scenario (resolved, before the run's reward and γ overrides).
    Scenario(Scenario),
    /// A plant process: its command and the hello it sent when the run started.
    Process {
        /// The command, as given to `--plant-cmd`.
        command: String,
        /// Its hello.
        hello: Hello,
    },
    /// A plant the caller's code built: the boxes it declared when the run started.
    Given {
        /// Its name and boxes.
        hello: Hello,
    },
}

/// How a run folder records a plant that is not a scenario (the `[plant_link]` table).
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Record {
    plant_link: LinkRecord,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct LinkRecord {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    command: Option<String>,
    hello: Hello,
}

impl RunPlant {
    /// The record's TOML text (a run folder's `scenario.toml`, a checkpoint's plant).
    pub fn to_toml(&self) -> String {
        let record = |command: Option<&String>, hello: &Hello| Record {
            plant_link: LinkRecord {
                command: command.cloned(),
                hello: hello.clone(),
            },
        };
        let text = match self {
            RunPlant::Scenario(s) => return crate::run::trainer::scenario_toml(s),
            RunPlant::Process { command, hello } => toml::to_string(&record(Some(command), hello)),
            RunPlant::Given { hello } => toml::to_string(&record(None, hello)),
        };
        text.unwrap_or_else(|e| format!("# could not serialise the plant: {e}\n# {self:?}\n"))
    }

    /// Reads a record written by [`RunPlant::to_toml`].
    pub fn from_toml(text: &str) -> Result<RunPlant, String> {
        if let Ok(Record { plant_link }) = toml::from_str::<Record>(text) {
            return Ok(match plant_link.command {
                Some(command) => RunPlant::Process {
                    command,
                    hello: plant_link.hello,
                },
                None => RunPlant::Given {
                    hello: plant_link.hello,
                },
            });
        }
        Scenario::from_toml_str(text)
            .map(RunPlant::Scenario)
            .map_err(|e| e.to_string())
    }

    /// The scenario, for a scenario run.
    pub fn scenario(&self) -> Option<&Scenario> {
        match self {
            RunPlant::Scenario(s) => Some(s),
            _ => None,
        }
    }

    /// The plant's name as reports give it.
    pub fn name(&self) -> String {
        match self {
            RunPlant::Scenario(s) => s.name.clone(),
            RunPlant::Process { hello, .. } | RunPlant::Given { hello } => hello.name.clone(),
        }
    }

    /// Starts the plant process of a `Process` record and checks it still says the same hello.
    pub fn start_process(command: &str, timeouts: Timeouts) -> Result<(ChildPlant, Hello), Error> {
        let plant = ChildPlant::spawn(command, timeouts).map_err(plant_error)?;
        let hello = plant.hello().clone();
        Ok((plant, hello))
    }
}

/// The hello of a plant given in process: its one agent's boxes under `name`.
pub fn hello_of(name: &str, plant: &dyn Plant) -> Hello {
    let agents = plant
        .agents()
        .into_iter()
        .map(|a| Agent {
            name: a.name,
            observation_low: a.observation_space.low,
            observation_high: a.observation_space.high,
            action_low: a.action_space.low,
            action_high: a.action_space.high,
        })
        .collect();
    Hello {
        name: name.to_string(),
        agents,
    }
}

/// Refuses a plant whose hello differs from the one the run recorded.
pub fn check_same_hello(recorded: &Hello, now: &Hello, plant: &str) -> Result<(), Error> {
    if recorded == now {
        return Ok(());
    }
    let boxes = |h: &Hello| {
        h.agents
            .iter()
            .map(|a| {
                let o = BoxSpace {
                    low: a.observation_low.clone(),
                    high: a.observation_high.clone(),
                };
                format!(
                    "{} observations in {:?}..{:?}, actions in {:?}..{:?}",
                    o.dim(),
                    a.observation_low,
                    a.observation_high,
                    a.action_low,
                    a.action_high
                )
            })
            .collect::<Vec<_>>()
            .join("; ")
    };
    Err(Error::Sim {
        context: format!("plant {plant:?}"),
        message: format!(
            "its hello has changed since the run started (recorded {:?}: {}; now {:?}: {}): a \
             run goes on only on the plant it started with",
            recorded.name,
            boxes(recorded),
            now.name,
            boxes(now)
        ),
    })
}

/// A plant's error as the trainer's.
pub fn plant_error(e: firmware_sim::Error) -> Error {
    match e {
        firmware_sim::Error::Plant { plant, message } => Error::Sim {
            context: format!("plant {plant:?}"),
            message,
        },
        other => Error::Sim {
            context: "plant".into(),
            message: other.to_string(),
        },
    }
}

/// A plant's name as a run folder may carry it: letters, digits, `.`, `_` and `-`; anything
/// else becomes `-`.
///
/// ```
/// use host_trainer::run::plant::folder_safe;
/// assert_eq!(folder_safe("Pendulum-v1"), "Pendulum-v1");
/// assert_eq!(folder_safe("my plant/v2"), "my-plant-v2");
/// assert_eq!(folder_safe(""), "plant");
/// ```
pub fn folder_safe(name: &str) -> String {
    let safe: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-') {
                c
            } else {
                '-'
            }
        })
        .collect();
    let safe = safe.trim_start_matches('.').to_string();
    if safe.is_empty() {
        "plant".into()
    } else {
        safe
    }
}
