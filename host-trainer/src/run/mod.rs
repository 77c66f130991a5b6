//! A training run: its configuration, the episode loop, checkpoints, the run folder
//! `{task}__{algo}__{seed}/` and what it holds (metrics, plots), the plant it trains on, the
//! validation rounds that keep its best policy, and the progress bar.

pub mod checkpoint;
pub mod config;
pub(crate) mod crash_test;
pub mod folder;
pub mod lock;
pub mod metrics;
pub mod plant;
pub mod plot;
pub mod progress;
pub mod race;
pub mod trainer;
pub mod validation;
