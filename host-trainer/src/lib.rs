//! # host-trainer
//!
//! Trains Deep Comparative Policy (DCP) and its baselines on firmware-sim's plants, and exports
//! the result as a postcard blob that policy-core runs bit for bit as the trainer evaluated it.
//!
//! Why a trainer of its own rather than PyTorch: the exported policy must act *exactly* as the
//! trainer evaluated it, down to the bit, on the same arithmetic the microcontroller runs; and a
//! 4×48 network on batches of 64 is far too small for a deep-learning framework to pay off.
//!
//! ## Layout
//!
//! Imports flow one way, from the bottom of this list to its top; no two modules import each
//! other.
//! - [`reproduce`]: an experiment rebuilt by one command: its grid of runs or teams (whole, or
//!   one slice for a cluster array) run through `sweep`'s machinery, and the results page and
//!   figures built from the run folders.
//! - [`sweep`]: many seeds and algorithms as parallel `train` processes: planning, supervising
//!   the processes, and the summary with its intervals; a planned run is a `train` run or a team.
//! - [`stats`]: intervals, tests, aggregates, sensitivity and power for the results pages and
//!   summaries (pure functions; checked against scipy).
//! - [`team`]: experiment 2's teams: badminton players of three learners each, trained on
//!   random pairings within the team, checkpointed, exported as player folders.
//! - [`run`]: one training run: its configuration (which composes the algorithms' sections),
//!   the episode loop, checkpoints, the run folder `{task}__{algo}__{seed}/`, metrics, plots and
//!   the progress bar.
//! - [`algorithms`]: DCP, DDPG (and TD3), PPO and DQN, one file each with its config first, the
//!   actor-critic machinery the first three share, and the one list of algorithms.
//! - [`blob`]: actor and critic blobs of any shape for policy-core's runtime model, and what a
//!   blob holds.
//! - [`buffers`]: the replay buffer and the on-policy rollout buffer with GAE.
//! - [`nn`]: the MLP with back-propagation, Adam, the running observation normaliser, and the
//!   training loop's forward pass.
//! - [`rng_state`]: a random stream's position, as checkpoints save it. The streams themselves
//!   come from firmware-sim's [`seed`](firmware_sim::seed) module: one seed, one named stream
//!   per component (same seed ⇒ same bytes).
//! - [`error`]: the crate's one error type.
//!
//! ```no_run
//! use host_trainer::run::{config::TrainConfig, folder::RunDir, trainer::{self, Trainer}};
//! let mut trainer = Trainer::new(TrainConfig::default())?; // nav-walls, DCP, 4x48, GR, 3000 episodes
//! let run = RunDir::create("runs".as_ref(), &trainer.config.run_name())?;
//! trainer::run(&mut trainer, &run, &mut |_, _| std::ops::ControlFlow::Continue(()))?;
//! let blob = trainer.export(&run)?; // policy.postcard: flash it, or run it in firmware-sim
//! # Ok::<(), host_trainer::Error>(())
//! ```
#![deny(missing_docs)]

pub mod algorithms;
pub mod blob;
pub mod buffers;
pub mod error;
pub mod nn;
pub mod reproduce;
pub mod rng_state;
pub mod run;
pub mod stats;
pub mod sweep;
pub mod team;

pub use error::Error;

/// The Rust route of docs/own-plant.md (a plant of the caller's trained through the library),
/// run as a doctest so the page cannot drift from the API.
#[cfg(doctest)]
#[doc = include_str!("../../docs/own-plant.md")]
pub struct OwnPlantPageDoctests;
