//! The reference players of docs/design.md §3, for tests and gates: `random` (uniform actions)
//! and `scripted` (good but not perfect). Both act on their observation alone, like a trained
//! player would; `scripted` knows the physics and predicts the shuttle from what it sees. The
//! players a command line names ([`PlayerKind`]) add player folders, whose blobs play through
//! [`BlobPlayer`].
//!
//! ```
//! use firmware_sim::badminton::reference::{PlayerKind, Player};
//! use firmware_sim::badminton::{Config, Role};
//! let config = Config::builtin();
//! let kind: PlayerKind = "scripted".parse().unwrap();
//! let mut p = kind.build(&config, 7, 0);
//! let mut target = [0.0f32; 2];
//! p.act(Role::Reset, &[0.0; 10], &mut target); // back to (-3, 0) of its own frame
//! assert!((target[0] - (1.0 - 6.0 / 6.7)).abs() < 1e-6 && target[1] == 0.0);
//! let err = "smash".parse::<PlayerKind>().unwrap_err().to_string();
//! assert_eq!(
//!     err,
//!     "player \"smash\": expected scripted or random, or a player folder (a directory holding player.toml)"
//! );
//! ```

use std::fmt;
use std::path::Path;
use std::str::FromStr;
use std::sync::Arc;

pub use super::agent::Player;
use super::blob_player::{BlobPlayer, PlayerFolder, MANIFEST};
use super::clear::ClearSolver;
use super::config::Config;
use super::court::{Court, Vec2};
use super::game::Role;
use super::player::{action_for_hit, action_for_target};
use super::shuttle::{Physics, Shuttle};
use crate::seed::{normal, stream, uniform, SimRng};
use crate::Error;

/// A player named on the command line: `scripted`, `random`, or a player folder (a directory
/// holding `player.toml`: three blobs, one per agent; [`super::blob_player`]).
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum PlayerKind {
    /// Uniform actions.
    Random,
    /// The scripted reference player.
    Scripted,
    /// The blobs of a player folder, loaded and checked.
    Folder(Arc<PlayerFolder>),
}

/// `scripted`, `random`, or the path of a player folder, loaded and checked (the words come
/// first: name a folder called `random` as `./random`).
impl FromStr for PlayerKind {
    type Err = Error;

    fn from_str(s: &str) -> Result<PlayerKind, Error> {
        match s {
            "random" => Ok(PlayerKind::Random),
            "scripted" => Ok(PlayerKind::Scripted),
            other if Path::new(other).is_dir() => Ok(PlayerKind::Folder(Arc::new(
                PlayerFolder::load(Path::new(other))?,
            ))),
            other => Err(Error::Player {
                player: other.to_string(),
                message: format!(
                    "expected scripted or random, or a player folder (a directory holding {MANIFEST}){}",
                    if Path::new(other).exists() { ", found a file" } else { "" }
                ),
            }),
        }
    }
}

/// The name in reports: `scripted`, `random`, or the folder's label.
impl fmt::Display for PlayerKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            PlayerKind::Random => "random",
            PlayerKind::Scripted => "scripted",
            PlayerKind::Folder(folder) => &folder.label,
        })
    }
}

impl PlayerKind {
    /// The player, its random stream drawn from `seed` and its seat (0 or 1). A folder's player
    /// runs from the bytes the kind holds, so it borrows the kind.
    pub fn build<'a>(&'a self, config: &Config, seed: u64, seat: usize) -> Box<dyn Player + 'a> {
        let rng = stream(seed, "badminton-player", seat as u64);
        match self {
            PlayerKind::Random => Box::new(Random { rng }),
            PlayerKind::Scripted => Box::new(Scripted::new(config, rng)),
            PlayerKind::Folder(folder) => Box::new(BlobPlayer::boot(folder)),
        }
    }

    /// Whether the scenario's pass criteria apply to this player (not to `random`, the
    /// baseline).
    pub fn is_judged(&self) -> bool {
        !matches!(self, PlayerKind::Random)
    }

    /// The agents that play the safe state because their blob does not boot, and why (none
    /// for `scripted` and `random`).
    pub fn boot_errors(&self) -> Vec<(Role, String)> {
        match self {
            PlayerKind::Folder(folder) => folder
                .boot_errors()
                .map(|(role, e)| (role, e.to_string()))
                .collect(),
            PlayerKind::Random | PlayerKind::Scripted => Vec::new(),
        }
    }
}

/// Uniform actions in the unit box.
#[derive(Clone, Debug)]
pub struct Random {
    /// Its random stream.
    pub rng: SimRng,
}

impl Player for Random {
    fn name(&self) -> String {
        "random".into()
    }

    fn act(&mut self, _role: Role, _observation: &[f32], action: &mut [f32]) {
        for a in action {
            *a = (2.0 * uniform(&mut self.rng) - 1.0) as f32;
        }
    }
}

/// The scripted reference player (docs/design.md §3):
/// - catch: where the incoming shuttle falls through the hitting height on its way down (its
///   landing point if it never does), plus Gaussian noise of `catch_noise` per axis, clipped to
///   its half;
/// - serve: a clear at `serve_elevation`, azimuth and speed solved so that it lands
///   `serve_depth` inside the back line and `serve_side` inside the side line farther from the
///   opponent, then Gaussian noise of `serve_angle_noise` on both angles;
/// - reset: back to `reset` of its own frame.
#[derive(Clone, Debug)]
pub struct Scripted {
    config: Config,
    court: Court,
    physics: Physics,
    clear: ClearSolver,
    rng: SimRng,
}

impl Scripted {
    /// The scripted player of a scenario, drawing its noise from `rng`.
    pub fn new(config: &Config, rng: SimRng) -> Scripted {
        Scripted {
            court: Court::of(&config.court),
            physics: Physics::of(config),
            clear: ClearSolver::new(config),
            config: config.clone(),
            rng,
        }
    }

    /// The catch target (own frame) for an incoming shuttle seen in `observation`.
    pub fn catch_target(&mut self, observation: &[f32]) -> Vec2 {
        let (shuttle, own) = seen(observation);
        // In the own frame the opponent hits from x' > 0 toward x' < 0.
        let h = self.config.player.hit_height;
        let flight = self.physics.predict(shuttle, -1.0, &self.court, h);
        let Some(spot) = flight.descent else {
            return own; // a net ball: nothing to run for
        };
        let noise = self.config.scripted.catch_noise;
        let aim = [
            spot[0] + noise * normal(&mut self.rng),
            spot[1] + noise * normal(&mut self.rng),
        ];
        self.court.clip_to_own_half(aim).0
    }

    /// The clear's speed (m/s), elevation and azimuth (degrees) before noise, from the shuttle
    /// and opponent seen in `observation`.
    pub fn clear(&self, observation: &[f32]) -> (f64, f64, f64) {
        let (shuttle, _) = seen(observation);
        let s = &self.config.scripted;
        let (l, w) = (self.court.half_length, self.court.half_width);
        // The side line farther from the opponent (on a tie, +y').
        let side = if observation.get(9).is_some_and(|&y| y > 0.0) {
            -1.0
        } else {
            1.0
        };
        let aim = [l - s.serve_depth, side * (w - s.serve_side)];
        let (dx, dy) = (aim[0] - shuttle.p[0], aim[1] - shuttle.p[1]);
        let azimuth = dy.atan2(dx).to_degrees();
        let speed = self.clear.speed_for(dx.hypot(dy), shuttle.p[2]);
        (speed, s.serve_elevation, azimuth)
    }
}

/// Copies as many values as both sides have.
fn fill(action: &mut [f32], values: &[f32]) {
    for (a, v) in action.iter_mut().zip(values) {
        *a = *v;
    }
}

/// The shuttle and own position seen in an observation (own frame).
fn seen(observation: &[f32]) -> (Shuttle, Vec2) {
    let o = |i: usize| f64::from(observation.get(i).copied().unwrap_or(0.0));
    let shuttle = Shuttle {
        p: [o(0), o(1), o(2)],
        v: [o(3), o(4), o(5)],
    };
    (shuttle, [o(6), o(7)])
}

impl Player for Scripted {
    fn name(&self) -> String {
        "scripted".into()
    }

    fn act(&mut self, role: Role, observation: &[f32], action: &mut [f32]) {
        match role {
            Role::Catch => {
                let target = self.catch_target(observation);
                fill(action, &action_for_target(target, &self.court));
            }
            Role::Serve => {
                let (speed, elevation, azimuth) = self.clear(observation);
                let noise = self.config.scripted.serve_angle_noise;
                let elevation = elevation + noise * normal(&mut self.rng);
                let azimuth = azimuth + noise * normal(&mut self.rng);
                let hit = &self.config.hit;
                fill(action, &action_for_hit(speed, elevation, azimuth, hit));
            }
            Role::Reset => {
                let reset = self.config.scripted.reset;
                fill(action, &action_for_target(reset, &self.court));
            }
        }
    }
}
