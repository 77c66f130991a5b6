//! The studies behind `docs/results/`: each turns the runs a study recorded into its page, with
//! the statistics of `host_trainer::stats`. They live apart from the library's examples, which
//! show a user how to use the library (`examples/planar-arm/`, the worked example outside the
//! workspace).
//!
//! The studies are the crate's binaries (`src/bin/`, run as `cargo run --release -p studies
//! --bin NAME`); the library holds what two of them share.

#![deny(missing_docs)]

pub mod hybrid;
pub mod main_job;
pub mod paired;
pub mod race_rounds;
pub mod restat;
pub mod run_folder;
pub mod standard_tasks;
pub mod walls;
