//! # host-trainer
//!
//! Trains Deep Comparative Policy (DCP) and its baselines on firmware-sim's plants, and exports
//! the result as a postcard blob that policy-core runs bit for bit as the trainer evaluated it.
//!
//! Why a trainer of its own rather than PyTorch: the exported policy must act *exactly* as the
//! trainer evaluated it, down to the bit, on the same arithmetic the microcontroller runs; and a
//! 4×48 network on batches of 64 is far too small for a deep-learning framework to pay off.
//!
//! The pieces, in the order data flows:
//! - [`seed`]: one seed, one named random stream per component (same seed ⇒ same bytes).
//! - [`net`], [`adam`], [`normalize`], [`replay`], [`rollout`]: the MLP with back-propagation,
//!   its optimiser, the running observation normaliser, the replay buffer and the on-policy
//!   rollout buffer with GAE.
//! - [`algo`]: the algorithm plug-in (what the training loop asks of an algorithm, and the list
//!   of algorithms).
//! - [`agent`]: the actor-critic machinery DDPG and DCP share (critic Bellman update, targets,
//!   exploration in the unit action box) and [`noise`] (the exploration process);
//!   [`actor_critic`]: the two as a plug-in.
//! - [`ddpg`] and [`dcp`]: the two actor updates; [`ppo`] and [`dqn`]: the paper's other two
//!   agents; one file each, config first.
//! - [`train`]: the episode loop on a firmware-sim plant, metrics, checkpoints, divergence stop.
//! - [`export`]: actor and critic blobs of any shape for policy-core's runtime model;
//!   [`inspect`]: what a blob holds; [`checkpoint`], [`run_dir`], [`plot`]: the files of a run
//!   folder `{task}__{algo}__{seed}/`.
//! - [`sweep`]: many seeds and algorithms as parallel `train` processes, with a summary whose
//!   intervals [`stats`] computes; [`progress`]: the progress bar `train` and `sweep` share.
//!
//! ```no_run
//! use host_trainer::{run_dir::RunDir, train::{self, TrainConfig, Trainer}};
//! let mut trainer = Trainer::new(TrainConfig::default())?; // nav-walls, DCP, 4x48, GR, 3000 episodes
//! let run = RunDir::create("runs".as_ref(), &trainer.config.run_name())?;
//! train::run(&mut trainer, &run, &mut |_, _| std::ops::ControlFlow::Continue(()))?;
//! let blob = trainer.export(&run)?; // policy.postcard: flash it, or run it in firmware-sim
//! # Ok::<(), host_trainer::Error>(())
//! ```
#![deny(missing_docs)]

// Network machinery (shared by every algorithm).
pub mod adam;
pub mod export;
pub mod net;
pub mod noise;
pub mod normalize;
pub mod replay;
pub mod rollout;
pub mod seed;

// Algorithms, training loop and CLI support.
pub mod actor_critic;
pub mod agent;
pub mod algo;
pub mod checkpoint;
pub mod crash_test;
pub mod dcp;
pub mod ddpg;
pub mod dqn;
pub mod error;
pub mod inspect;
pub mod plot;
pub mod ppo;
pub mod progress;
pub mod run_dir;
pub mod stats;
pub mod sweep;
pub mod train;

pub use error::Error;
