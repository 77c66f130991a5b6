//! # firmware-sim
//!
//! Runs the exact bytes that would be flashed, through policy-core, in a closed loop against
//! plants with hard margins, and measures how the policy behaves there: does it slide along a
//! wall to the gap, or push against it forever?
//!
//! The top-level modules hold what does not depend on the plant; each plant has its folder.
//!
//! - [`mod@env`]: the Gymnasium-style plant interface shared with the trainer.
//! - [`controller`]: blob policies of any shape (policy-core's runtime model) and the safe
//!   state; [`boot`]: booting a blob against a plant's sizes; [`slots`]: booting from the A/B
//!   flash slots with the firmware's own rule (policy-core's `slot::choose`); [`refine`]: DCP's
//!   compare step on the device; [`heads`]: an actor of several heads with the critic choosing
//!   among them.
//! - [`firmware`]: the firmware's side of each tick, around the controller: the [`sensor`]
//!   (noise, delay, dropouts) and the [`actuator`] (saturation, rate limit, a stuck dimension);
//!   [`mod@pass`]: a run's verdict.
//! - [`files`]: atomic output files, output paths checked before work, bounded blob reads;
//!   [`seed`]: the random streams; [`error`]: the crate's one error type.
//! - [`plant_test`]: the test protocol for any plant: the firmware loop with its faults, the
//!   margin figures every plant gives, and criteria the user declares.
//! - [`plant_link`]: a plant in another process, any language, over its standard input and
//!   output: the host's side ([`plant_link::child`]) and the plant's ([`plant_link::serve`]).
//! - [`hil`]: hardware in the loop: the HIL firmware (under QEMU or on a board) computes
//!   every action, as a [`controller::Controller`] the test protocol runs unchanged.
//! - [`nav`]: the navigation plant of experiment 1, its layouts, reference controllers and test
//!   protocol (margin metrics, JSON report, SVG plot).
//! - [`badminton`]: the badminton plant of experiment 2 (two players of three agents), its
//!   reference players and the paper's measures.
#![deny(missing_docs)]

pub mod actuator;
pub mod badminton;
pub mod boot;
pub mod controller;
pub mod env;
pub mod error;
pub mod files;
pub mod firmware;
pub mod heads;
pub mod hil;
pub mod nav;
pub mod pass;
pub mod plant_link;
pub mod plant_test;
pub(crate) mod process;
pub mod refine;
pub mod seed;
pub mod sensor;
pub mod slots;

pub use error::Error;
