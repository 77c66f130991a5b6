//! The run's configuration: everything that defines a run, saved as its `config.toml`.
//!
//! It composes the algorithms' config sections (each defined at the top of its algorithm's file)
//! with the run's own settings (task, reward, seed, budget), and hands the algorithms only their
//! sections ([`Sections`]).

use std::path::Path;

use firmware_sim::nav::Reward;
use serde::{Deserialize, Serialize};

use crate::algorithms::agent_config::AgentConfig;
use crate::algorithms::{dcp, ddpg, dqn, ppo, Algo, Learner, Sections};
use crate::nn::hidden::Hidden;
use crate::run::folder;
use crate::run::validation::ValidationConfig;
use crate::Error;

/// Everything that defines a run (saved as the run's `config.toml`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrainConfig {
    /// Built-in scenario name (`nav-walls`, `nav-open`) or a scenario TOML file; for a plant
    /// of the user's (`plant_cmd`, or a plant given to `Trainer::with_plant`), the plant's name.
    pub task: String,
    /// A plant process instead of a scenario: the command that starts it, speaking the plant
    /// link on its standard input and output (docs/own-plant.md).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plant_cmd: Option<String>,
    /// The learning algorithm.
    pub algo: Algo,
    /// The reward, overriding the scenario's [paper: GR for the headline results].
    pub reward: RewardKind,
    /// The one seed of the run.
    pub seed: u64,
    /// Training episodes [paper: 3,000 for navigation].
    pub episodes: usize,
    /// A budget in environment steps as well: the run ends with the episode in which its
    /// steps reach this many (a step budget is how Stable-Baselines3 and the RL Zoo count;
    /// `episodes` stays an upper bound). Unset: episodes alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub env_steps: Option<u64>,
    /// Write a checkpoint (and metrics, plot) every this many episodes.
    pub checkpoint_every: usize,
    /// Test starts for the final firmware-sim evaluation [paper: 100].
    pub eval_episodes: usize,
    /// Validation while training, the best policy kept and the stop when the gate holds
    /// ([`ValidationConfig`]). A config without this section has none: it trains to its budget
    /// and keeps the last networks, as runs did before validation existed (and as `sweep` and
    /// `reproduce` do); `train`'s defaults have it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub validation: Option<ValidationConfig>,
    /// Settings every algorithm shares (networks, learning rates, γ, normalisation; each
    /// algorithm's file says which it reads).
    pub agent: AgentConfig,
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
    /// steps in minibatches of 8 over 2 epochs, validation every 2 episodes on 5 starts (two rounds
    /// in a row stop it). Smoke tests and the end-to-end test use it; it
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
        c.agent.hidden = Hidden {
            depth: 2,
            width: 32,
        };
        c.agent.batch = 16;
        c.agent.warmup_steps = 16;
        c.dcp.t = 4;
        c.ppo.rollout = 32;
        c.ppo.minibatch = 8;
        c.ppo.epochs = 2;
        // Two rounds in a row, so the tests see the rule at work that `in_a_row` sets.
        c.validation = Some(ValidationConfig {
            every: 2,
            starts: 5,
            in_a_row: 2,
            ..ValidationConfig::default()
        });
        // Only what `algo` reads: a config file holding another algorithm's settings is refused.
        // Built from constants, which read back (every test that trains starts here).
        c.for_algo(algo)
            .expect("the smoke config reads back through TOML")
    }
}

impl Default for TrainConfig {
    fn default() -> Self {
        TrainConfig {
            task: "nav-walls".into(),
            plant_cmd: None,
            algo: Algo::Dcp,
            reward: RewardKind::Gr,
            seed: 0,
            episodes: 3000,
            env_steps: None,
            checkpoint_every: 100,
            eval_episodes: 100,
            validation: Some(ValidationConfig::default()),
            agent: AgentConfig::default(),
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
        TrainConfig::parse(&read_text(path)?, path)
    }

    /// Parses the text of the config file `path` (named in errors; `.json` selects JSON).
    pub fn parse(text: &str, path: &Path) -> Result<TrainConfig, Error> {
        let parsed = if path.extension().is_some_and(|e| e == "json") {
            serde_json::from_str(text).map_err(|e| e.to_string())
        } else {
            toml::from_str(text).map_err(|e| e.to_string())
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

    /// The settings set away from their defaults that none of `algos` reads, as (`section`,
    /// `key`, value), in `config.toml`'s order.
    pub fn unread_settings(&self, algos: &[Algo]) -> Vec<(String, String, toml::Value)> {
        let (mine, defaults) = (self.table(), TrainConfig::default().table());
        let mut unread = Vec::new();
        for (section, value) in &mine {
            let (Some(keys), Some(default_keys)) = (
                value.as_table(),
                defaults.get(section).and_then(toml::Value::as_table),
            ) else {
                continue; // the run's own settings: every algorithm reads them
            };
            for (key, v) in keys {
                let readers = crate::algorithms::readers(section, key);
                if default_keys.get(key) != Some(v) && !algos.iter().any(|a| readers.contains(a)) {
                    unread.push((section.clone(), key.clone(), v.clone()));
                }
            }
        }
        unread
    }

    /// Refuses a setting away from its default that none of `algos` reads (a fresh `train`
    /// checks its one algorithm, a sweep all of its own), naming the algorithms that read it.
    pub fn check_read(&self, algos: &[Algo]) -> Result<(), Error> {
        match self.unread_settings(algos).into_iter().next() {
            None => Ok(()),
            Some((section, key, value)) => Err(Error::UnreadSetting {
                readers: crate::algorithms::names(crate::algorithms::readers(&section, &key)),
                key: format!("{section}.{key}"),
                value: value.to_string(),
                algos: crate::algorithms::names(algos),
            }),
        }
    }

    /// This config for `algo`, every setting that `algo` does not read at its default: what a
    /// sweep's run of `algo` records and is compared with.
    pub fn for_algo(&self, algo: Algo) -> Result<TrainConfig, Error> {
        let mut table = self.table();
        let defaults = TrainConfig::default().table();
        for (section, key, _) in self.unread_settings(&[algo]) {
            let default = defaults.get(&section).and_then(|s| s.get(&key)).cloned();
            if let Some(keys) = table.get_mut(&section).and_then(toml::Value::as_table_mut) {
                match default {
                    Some(d) => keys.insert(key, d),
                    None => keys.remove(&key), // unset by default (an `Option`)
                };
            }
        }
        // The table is this config's own, with some keys at their defaults: it always reads
        // back, and if it ever did not, the run must not go on with other settings than these.
        let mut config: TrainConfig =
            toml::Value::Table(table)
                .try_into()
                .map_err(|e: toml::de::Error| Error::InvalidConfig {
                    what: "the run's settings".into(),
                    expected: "a config that reads back after unread settings are reset".into(),
                    found: e.message().to_string(),
                })?;
        config.algo = algo;
        Ok(config)
    }

    /// The config as a TOML table (what `config.toml` holds).
    fn table(&self) -> toml::Table {
        // Plain data with string keys always serialises; an empty table would only make
        // `unread_settings` find nothing.
        toml::Table::try_from(self).unwrap_or_default()
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
        if self.env_steps == Some(0) {
            return Err(Error::InvalidConfig {
                what: "env_steps".into(),
                expected: "a positive integer (or no step budget)".into(),
                found: "0".into(),
            });
        }
        positive("checkpoint_every", self.checkpoint_every)?;
        positive("eval_episodes", self.eval_episodes)?;
        if let Some(v) = &self.validation {
            v.check()?;
        }
        Learner::validate(&self.sections())
    }

    /// The run folder's name, `{task}__{algo}__{seed}` (a scenario file contributes its stem).
    pub fn run_name(&self) -> String {
        folder::run_name(&self.task_name(), &self.algo.to_string(), self.seed)
    }

    /// The label of the run's blobs: the run name, shortened to fit the blob header.
    pub fn blob_label(&self) -> String {
        folder::blob_label(&self.task_name(), &self.algo.to_string(), self.seed)
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

impl TrainConfig {
    /// The config sections the run's algorithm reads.
    pub fn sections(&self) -> Sections<'_> {
        Sections {
            algo: self.algo,
            seed: self.seed,
            agent: &self.agent,
            dcp: &self.dcp,
            ddpg: &self.ddpg,
            td3: &self.td3,
            ppo: &self.ppo,
            dqn: &self.dqn,
        }
    }
}

/// Reads a text file the CLI was given (config, task scenario, a run's recorded plant) through
/// firmware-sim's one bounded reader ([`firmware_sim::files::read_config_text`], at most
/// [`firmware_sim::files::MAX_CONFIG_FILE`] bytes, refused from the size or one byte past the
/// limit, so `--config /dev/zero` is refused instead of filling memory).
pub fn read_text(path: &Path) -> Result<String, Error> {
    firmware_sim::files::read_config_text(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// `s` on one line (TOML and JSON errors span several).
pub(crate) fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The navigation reward (docs/design.md §2).
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
