//! A team folder `{scenario}__{algo}__{seed}/`: its config and plant, the checkpoint, the
//! metrics per block of points, and the exported players.
//!
//! ```text
//! badminton__dcp-t16__0/
//!   config.toml  scenario.toml  checkpoint.postcard  metrics.csv
//!   players/p00/player.toml  catch.postcard  serve.postcard  reset.postcard
//!               catch-critic.postcard  serve-critic.postcard  reset-critic.postcard  scenario.toml
//!   players/p01/...
//! ```
//!
//! `player.toml` is the manifest `firmware-sim match` reads (format 1): a label, the scenario
//! the player trained on, and which blob is which agent, every path inside the player's folder.

use std::ops::ControlFlow;

use serde::{Deserialize, Serialize};

use firmware_sim::badminton::blob_player::{Manifest, PerRole, FORMAT};
use firmware_sim::badminton::game::{Badminton, Role};
use firmware_sim::badminton::{self};

use super::config::TeamConfig;
use super::training::{plant_error, Tally, Team};
use crate::run::checkpoint::{seal, unseal, write_in_halves};
use crate::run::folder::{self, blob_label, RunDir};
use crate::run::plot::{self, Panel, Series};
use crate::Error;

/// Player `p`'s folder name in a team of `players`: `p00`, `p01`, ... (wider for teams over 100).
pub fn player_name(p: usize, players: usize) -> String {
    let width = players.saturating_sub(1).to_string().len().max(2);
    format!("p{p:0width$}")
}

/// Whether the team folder `dir` holds every player of `config` exported: the export writes
/// the players in order, each manifest last, so the last player's manifest is the mark.
pub fn exported(dir: &std::path::Path, config: &TeamConfig) -> bool {
    let last = player_name(config.players.saturating_sub(1), config.players);
    dir.join(PLAYERS).join(last).join(MANIFEST).is_file()
}

/// Magic and format version of a team checkpoint.
pub const MAGIC: &[u8; 8] = b"DCPTEAM1";
/// The folder of the exported players, inside the team folder.
pub const PLAYERS: &str = "players";
/// Where an export writes the players before they replace [`PLAYERS`].
pub const PARTIAL_PLAYERS: &str = ".players.partial";
pub use firmware_sim::badminton::blob_player::MANIFEST;

/// Everything needed to continue a team's training.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TeamCheckpoint {
    /// The team's config, as TOML text.
    pub config_toml: String,
    /// The badminton scenario, as TOML text.
    pub scenario_toml: String,
    /// The players' learners, the team's stream and its metrics.
    pub team: Team,
}

impl TeamCheckpoint {
    /// Reads a team checkpoint file (magic, CRC-32, contents).
    pub fn load(path: &std::path::Path) -> Result<TeamCheckpoint, Error> {
        let bytes = std::fs::read(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let message = |message| Error::Checkpoint {
            path: path.to_path_buf(),
            message,
        };
        let Some(rest) = bytes.strip_prefix(MAGIC.as_slice()) else {
            let found = String::from_utf8_lossy(&bytes[..bytes.len().min(8)]).into_owned();
            return Err(message(format!(
                "not a team checkpoint: expected the magic \"DCPTEAM1\", found {found:?}"
            )));
        };
        unseal(rest, &bytes).map_err(message)
    }

    /// Writes it atomically.
    pub fn save(&self, path: &std::path::Path) -> Result<(), Error> {
        let bytes = seal(MAGIC, self).map_err(|message| Error::Checkpoint {
            path: path.to_path_buf(),
            message,
        })?;
        write_in_halves(path, &bytes)
    }
}

/// A team being trained, with its plant and folder.
#[derive(Debug)]
pub struct TeamRun {
    /// Its settings.
    pub config: TeamConfig,
    /// The badminton scenario.
    pub plant: badminton::Config,
    /// The training state.
    pub team: Team,
    /// The folder.
    pub dir: RunDir,
    game: Badminton,
}

/// How a call of [`TeamRun::train`] ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Every point of the budget is played.
    Finished,
    /// Stopped on request after this many points; the checkpoint holds them.
    Stopped(usize),
}

impl TeamRun {
    /// A new team in `out/{team_name}`; a folder that already holds a team is refused.
    pub fn create(config: TeamConfig, out: &std::path::Path) -> Result<TeamRun, Error> {
        config.validate()?;
        let plant = badminton::Config::resolve(&config.scenario).map_err(plant_error)?;
        let team = Team::new(&config, &plant)?;
        let dir = RunDir::create(out, &config.team_name())?;
        TeamRun::with(config, plant, team, dir)
    }

    /// Continues the team in `path` from its checkpoint, with the config it recorded; `points`
    /// may raise the budget.
    pub fn resume(path: &std::path::Path, points: Option<usize>) -> Result<TeamRun, Error> {
        let dir = RunDir::open(path)?;
        let file = dir.file(folder::CHECKPOINT);
        let checkpoint = TeamCheckpoint::load(&file)?;
        let recorded = std::path::Path::new(folder::CONFIG);
        let mut config = TeamConfig::parse(&checkpoint.config_toml, recorded)?;
        if let Some(points) = points {
            // The budget can grow, not shrink below what is played, as train's --episodes: a
            // smaller one would mark the team finished with more points than its budget says.
            if points < checkpoint.team.points {
                return Err(Error::invalid(
                    "--points",
                    format!(
                        "at least the {} points the checkpoint has played",
                        checkpoint.team.points
                    ),
                    points,
                ));
            }
            config.points = points;
        }
        config.validate()?;
        let plant = badminton::Config::from_toml_str(&checkpoint.scenario_toml, "scenario.toml")
            .map_err(plant_error)?;
        let mut team = checkpoint.team;
        team.configure(&config)
            .map_err(|message| Error::Checkpoint {
                path: file.clone(),
                message,
            })?;
        TeamRun::with(config, plant, team, dir)
    }

    fn with(
        config: TeamConfig,
        plant: badminton::Config,
        team: Team,
        dir: RunDir,
    ) -> Result<TeamRun, Error> {
        let game = Badminton::new(&plant).map_err(plant_error)?;
        Ok(TeamRun {
            config,
            plant,
            team,
            dir,
            game,
        })
    }

    /// Trains until the budget is played or `on_point` breaks (then a checkpoint is written at
    /// once); a checkpoint and a metrics row every `checkpoint_every` points.
    pub fn train(
        &mut self,
        on_point: &mut dyn FnMut(&Team) -> ControlFlow<()>,
    ) -> Result<Outcome, Error> {
        if self.team.points == 0 {
            self.dir
                .write(folder::CONFIG, self.config.to_toml().as_bytes())?;
            self.dir
                .write(folder::SCENARIO, self.plant.to_toml().as_bytes())?;
            self.save()?;
        }
        while self.team.points < self.config.points {
            self.team.play_point(&self.config, &mut self.game)?;
            let end = self.team.points % self.config.checkpoint_every == 0
                || self.team.points == self.config.points;
            if end {
                self.team.close_block();
            }
            if !self.team.is_finite() {
                return Err(Error::Diverged {
                    episode: self.team.points,
                    what: "a network weight".into(),
                    checkpoint: Some(self.dir.file(folder::CHECKPOINT)),
                });
            }
            if on_point(&self.team).is_break() {
                self.save()?;
                return Ok(Outcome::Stopped(self.team.points));
            }
            if end {
                self.save()?;
            }
        }
        Ok(Outcome::Finished)
    }

    /// Writes the checkpoint and the metrics.
    pub fn save(&self) -> Result<(), Error> {
        let checkpoint = TeamCheckpoint {
            config_toml: self.config.to_toml(),
            scenario_toml: self.plant.to_toml(),
            team: self.team.clone(),
        };
        checkpoint.save(&self.dir.file(folder::CHECKPOINT))?;
        self.dir
            .write(folder::METRICS, self.metrics_csv().as_bytes())?;
        self.dir
            .write(folder::CURVE, self.learning_curve().as_bytes())
    }

    /// `learning-curve.svg`: serve error and catch success per block of points, and the hits
    /// per point (the rallies lengthen as the team learns).
    pub fn learning_curve(&self) -> String {
        let rows = &self.team.rows;
        let line = |name: &str, color: &'static str, y: &dyn Fn(&Tally) -> Option<f64>| Series {
            name: name.into(),
            color,
            opacity: 1.0,
            points: (rows.iter())
                .filter_map(|r| y(&r.tally).map(|y| (r.points as f64, y)))
                .collect(),
        };
        let ratio = |a: u64, b: u64| (b > 0).then(|| a as f64 / b as f64);
        let rates = Panel {
            y_label: "rate".into(),
            y_range: Some((0.0, 1.0)),
            series: vec![
                line("serve error", "#d62728", &|t| ratio(t.faults, t.hits)),
                line("catch success", "#2ca02c", &|t| ratio(t.caught, t.in_balls)),
            ],
        };
        let hits = Panel {
            y_label: "hits per point".into(),
            y_range: None,
            series: vec![line("hits per point", "#1f77b4", &|t| {
                ratio(t.hits, t.points)
            })],
        };
        plot::svg(&self.config.team_name(), "points", &[rates, hits])
    }

    /// `metrics.csv`: one row per block of points: hits per point, lets, serve error (out and
    /// net over hits), catch success (caught over balls landing in), and per role the mean
    /// reward per transition and the mean of each learner statistic.
    pub fn metrics_csv(&self) -> String {
        let stat_names = self.team.players[0].agents[0].get().stat_names();
        let mut header = vec![
            "points".to_string(),
            "hits_per_point".into(),
            "lets".into(),
            "serve_error".into(),
            "catch_success".into(),
        ];
        for role in Role::ALL {
            header.push(format!("{}_reward", role.name()));
            header.extend(stat_names.iter().map(|s| format!("{}_{s}", role.name())));
        }
        let mut out = header.join(",") + "\n";
        for row in &self.team.rows {
            let t = &row.tally;
            let ratio = |a: u64, b: u64| {
                if b == 0 {
                    f64::NAN
                } else {
                    a as f64 / b as f64
                }
            };
            let mut cells = vec![
                row.points.to_string(),
                format!("{:.3}", ratio(t.hits, t.points)),
                format!("{:.4}", ratio(t.lets, t.points)),
                format!("{:.4}", ratio(t.faults, t.hits)),
                format!("{:.4}", ratio(t.caught, t.in_balls)),
            ];
            for r in 0..3 {
                cells.push(format!(
                    "{:.4}",
                    t.reward[r] / t.transitions[r].max(1) as f64
                ));
                for k in 0..stat_names.len() {
                    let (sum, n) = t.stats[r].get(k).copied().unwrap_or((0.0, 0));
                    cells.push(format!(
                        "{:.6}",
                        if n == 0 { f64::NAN } else { sum / n as f64 }
                    ));
                }
            }
            out += &(cells.join(",") + "\n");
        }
        out
    }

    /// Exports every player into `players/pNN/`: its three actor blobs, its critics (where the
    /// algorithm has one), the scenario and the manifest. Returns the player folders.
    ///
    /// All or nothing: the players are written into a hidden sibling, `.players.partial`, which
    /// then takes the place of `players/`, so an export killed mid-way leaves the last complete
    /// `players/` (or none), never a smaller team that `firmware-sim teams` would play.
    pub fn export(&self) -> Result<Vec<std::path::PathBuf>, Error> {
        let algo = self.config.team_name();
        let algo = algo.split("__").nth(1).unwrap_or("team");
        let players = self.dir.path().join(PLAYERS);
        let partial = self.dir.path().join(PARTIAL_PLAYERS);
        let io = |path: &std::path::Path| {
            let path = path.to_path_buf();
            move |source| Error::Io { path, source }
        };
        if partial.exists() {
            std::fs::remove_dir_all(&partial).map_err(io(&partial))?;
        }
        std::fs::create_dir_all(&partial).map_err(io(&partial))?;
        let mut folders = Vec::new();
        for (p, player) in self.team.players.iter().enumerate() {
            let name = player_name(p, self.team.players.len());
            let dir = partial.join(&name);
            std::fs::create_dir_all(&dir).map_err(io(&dir))?;
            let dir = RunDir::open(&dir)?;
            let file = |role: Role, suffix: &str| format!("{}{suffix}.postcard", role.name());
            let per_role = |suffix: &str| PerRole {
                catch: file(Role::Catch, suffix),
                serve: file(Role::Serve, suffix),
                reset: file(Role::Reset, suffix),
            };
            let mut critics = false;
            for (role, learner) in Role::ALL.iter().zip(&player.agents) {
                let label = blob_label(&format!("{name}.{}", role.name()), algo, self.config.seed);
                dir.write(&file(*role, ""), &learner.get().policy_blob(&label)?)?;
                if let Some(critic) = learner.get().critic_blob(&label) {
                    dir.write(&file(*role, "-critic"), &critic?)?;
                    critics = true;
                }
            }
            dir.write(folder::SCENARIO, self.plant.to_toml().as_bytes())?;
            let manifest = Manifest {
                format: FORMAT,
                label: blob_label(&name, algo, self.config.seed),
                scenario: Some(folder::SCENARIO.into()),
                actors: per_role(""),
                critics: critics.then(|| per_role("-critic")),
            };
            let text = toml::to_string(&manifest).map_err(|e| Error::Io {
                path: dir.file(MANIFEST),
                source: std::io::Error::other(e),
            })?;
            let header = format!(
                "# A badminton player of three agents, written by host-trainer team; played by\n# firmware-sim match --p0 {}\n",
                players.join(&name).display()
            );
            dir.write(MANIFEST, (header + &text).as_bytes())?;
            folders.push(players.join(&name));
        }
        if players.exists() {
            std::fs::remove_dir_all(&players).map_err(io(&players))?;
        }
        std::fs::rename(&partial, &players).map_err(io(&players))?;
        Ok(folders)
    }
}
