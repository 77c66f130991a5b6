//! A team's training settings: the plant, the algorithm and its sections, the team's size, its
//! budget of points and the range of the per-game exploration σ.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::algorithms::agent_config::AgentConfig;
use crate::algorithms::{dcp, ddpg, ppo, Algo, Learner, Sections};
use crate::run::config::{one_line, read_text};
use crate::Error;

/// The most players a team may have.
pub const MAX_PLAYERS: usize = 1024;
/// The most points a team may train for.
pub const MAX_POINTS: usize = 10_000_000;

/// Everything a team's training reads; `config.toml` of a team folder.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TeamConfig {
    /// The badminton scenario: `badminton` (built in) or a scenario TOML file.
    pub scenario: String,
    /// The algorithm every agent of every player learns with (dcp, ddpg, td3 or ppo).
    pub algo: Algo,
    /// The one seed of the team: initial weights, pairings, σ draws, every learner's streams.
    pub seed: u64,
    /// Players in the team [paper: 16].
    pub players: usize,
    /// Points (episodes) of training, over the whole team [paper: 20,000].
    pub points: usize,
    /// Each game's exploration σ is drawn from U[sigma_min, sigma_max] [paper: 0.02].
    pub sigma_min: f32,
    /// [paper: 0.2].
    pub sigma_max: f32,
    /// Points between checkpoints; each is also one row of `metrics.csv`.
    pub checkpoint_every: usize,
    /// Settings every learner shares (networks, learning rates, batch, γ, normalisation)
    /// [paper: 4×48, learning rate 1/4096, L2 1e-4, batch 64 for badminton as for navigation;
    /// ours: updates start after 64 transitions, one batch, not navigation's 1,000: a learner
    /// sees one to a few transitions per point it plays, about 3,000 in a 20,000-point team
    /// of 16].
    pub agent: AgentConfig,
    /// DCP settings (when `algo = "dcp"`).
    pub dcp: dcp::Config,
    /// DDPG settings (`ddpg` and `td3`).
    pub ddpg: ddpg::Config,
    /// TD3 settings (`td3`; DCP's target smoothing takes its σ and clip).
    pub td3: ddpg::Td3Config,
    /// PPO settings (`ppo`).
    pub ppo: ppo::Config,
}

impl Default for TeamConfig {
    fn default() -> Self {
        TeamConfig {
            scenario: "badminton".into(),
            algo: Algo::Dcp,
            seed: 0,
            players: 16,
            points: 20_000,
            sigma_min: 0.02,
            sigma_max: 0.2,
            checkpoint_every: 500,
            agent: AgentConfig {
                warmup_steps: 64,
                ..AgentConfig::default()
            },
            dcp: dcp::Config::default(),
            ddpg: ddpg::Config::default(),
            td3: ddpg::Td3Config::default(),
            ppo: ppo::Config::default(),
        }
    }
}

impl TeamConfig {
    /// Parses a team config file (TOML). Unknown keys are errors; missing keys take their
    /// defaults.
    pub fn from_file(path: &Path) -> Result<TeamConfig, Error> {
        TeamConfig::parse(&read_text(path)?, path)
    }

    /// Parses the text of the config file `path` (named in errors).
    pub fn parse(text: &str, path: &Path) -> Result<TeamConfig, Error> {
        toml::from_str(text).map_err(|e| Error::ConfigFile {
            path: path.to_path_buf(),
            message: one_line(&e.to_string()),
        })
    }

    /// The config as TOML text.
    pub fn to_toml(&self) -> String {
        toml::to_string(self)
            .unwrap_or_else(|e| format!("# could not serialise config: {e}\n# {self:?}\n"))
    }

    /// Checks what the types do not: a team of at least two players (a pairing needs two), a
    /// budget of at least one point, σ bounds with 0 ≤ min ≤ max, an algorithm that acts in a
    /// continuous box (not DQN), and the algorithm's own sections.
    pub fn validate(&self) -> Result<(), Error> {
        let invalid = |what: &str, expected: &str, found: String| Error::InvalidConfig {
            what: what.into(),
            expected: expected.into(),
            found,
        };
        if !(2..=MAX_PLAYERS).contains(&self.players) {
            let expected = format!("an integer in [2, {MAX_PLAYERS}] (a game pairs two players)");
            return Err(invalid("players", &expected, self.players.to_string()));
        }
        if !(1..=MAX_POINTS).contains(&self.points) {
            let expected = format!("an integer in [1, {MAX_POINTS}]");
            return Err(invalid("points", &expected, self.points.to_string()));
        }
        if self.checkpoint_every == 0 {
            let found = "0".to_string();
            return Err(invalid("checkpoint_every", "a positive integer", found));
        }
        let sigma_ok = |s: f32| s.is_finite() && s >= 0.0;
        if !(sigma_ok(self.sigma_min)
            && sigma_ok(self.sigma_max)
            && self.sigma_min <= self.sigma_max)
        {
            return Err(invalid(
                "sigma_min, sigma_max",
                "finite, 0 <= sigma_min <= sigma_max",
                format!("{}, {}", self.sigma_min, self.sigma_max),
            ));
        }
        if self.algo == Algo::Dqn {
            let expected = "dcp, ddpg, td3 or ppo (badminton's actions are continuous)";
            return Err(invalid("algo", expected, "dqn".into()));
        }
        self.agent.validate()?;
        Learner::validate(&self.sections(self.seed))
    }

    /// The sections a learner of this team reads, with its own seed.
    pub fn sections(&self, seed: u64) -> Sections<'_> {
        Sections {
            algo: self.algo,
            seed,
            agent: &self.agent,
            dcp: &self.dcp,
            ddpg: &self.ddpg,
            td3: &self.td3,
            ppo: &self.ppo,
            dqn: &NO_DQN,
        }
    }

    /// The team folder's name: `{scenario}__{algo}[-t{T}]__{seed}` (DCP names its T, since
    /// teams of several T train side by side).
    pub fn team_name(&self) -> String {
        let scenario = Path::new(&self.scenario).file_stem().map_or_else(
            || self.scenario.clone(),
            |s| s.to_string_lossy().into_owned(),
        );
        let algo = match self.algo {
            Algo::Dcp => format!("dcp-t{}", self.dcp.t),
            other => other.to_string(),
        };
        format!("{scenario}__{algo}__{}", self.seed)
    }
}

/// A team never trains DQN (refused by [`TeamConfig::validate`]); its section is a constant.
static NO_DQN: std::sync::LazyLock<crate::algorithms::dqn::Config> =
    std::sync::LazyLock::new(Default::default);
