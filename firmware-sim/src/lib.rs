//! # firmware-sim
//!
//! Runs the exact bytes that would be flashed, through policy-core, in a closed loop against
//! plants with hard margins, and measures how the policy behaves there: does it slide along a
//! wall to the gap, or push against it forever?
//!
//! - [`mod@env`]: the Gymnasium-style plant interface shared with the trainer.
//! - [`badminton`]: the badminton plant of experiment 2 (two players of three agents), its
//!   reference players and the paper's measures.
//! - [`nav`]: the navigation plant of experiment 1; [`scenario`]: its layouts as TOML data;
//!   [`geometry`]: exact sliding motion among zero-thickness walls.
//! - [`harness`]: the firmware loop (boot from a blob, sensor, actuator, faults) and its margin
//!   metrics; [`controller`]: blob policies of any shape (policy-core's runtime model) and
//!   reference controllers.
//! - [`slots`]: booting from the A/B flash slots with the firmware's own rule (policy-core's
//!   `slot::choose`).
//! - [`files`]: atomic output files, output paths checked before work, bounded blob reads;
//!   [`json_report`] and [`svg`]: the CLI's report and plot, streamed episode by episode.
#![deny(missing_docs)]

pub mod actuator;
pub mod badminton;
pub mod controller;
pub mod env;
pub mod error;
pub mod faults;
pub mod files;
pub mod geometry;
pub mod harness;
pub mod json_report;
pub mod metrics;
pub mod nav;
pub mod oracle;
pub mod refine;
pub mod scenario;
pub mod seed;
pub mod sensor;
pub mod slots;
pub mod svg;

pub use error::Error;
