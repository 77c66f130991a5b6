//! # host-trainer
//!
//! Trains Deep Comparative Policy (DCP) and its baselines on firmware-sim's plants, and exports
//! the result as a postcard blob that policy-core runs bit for bit as the trainer evaluated it.
#![deny(missing_docs)]

// Network machinery (shared by every algorithm).
pub mod adam;
pub mod export;
pub mod net;
pub mod normalize;
pub mod replay;
pub mod seed;

// Algorithms, training loop and CLI support.
pub mod agent;
pub mod checkpoint;
pub mod dcp;
pub mod ddpg;
pub mod error;
pub mod plot;
pub mod run_dir;
pub mod train;

pub use error::Error;
