//! Experiment 2's training: teams of badminton players, each player three learners (catch,
//! serve, reset) of one algorithm, trained by playing random pairings within the team.
//!
//! - [`config`]: the team's settings (`config.toml` of a team folder).
//! - [`training`]: the team and its loop over firmware-sim's multi-agent [`Plant`](firmware_sim::env::Plant).
//! - [`folder`]: the team folder: checkpoint and resume, metrics per block of points, and the
//!   export of every player as a folder `firmware-sim match` plays.

pub mod config;
pub mod folder;
pub mod training;
