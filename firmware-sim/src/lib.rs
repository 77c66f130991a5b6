//! # firmware-sim
//!
//! Runs the exact bytes that would be flashed, through policy-core, in a closed loop against
//! plants with hard margins, and measures how the policy behaves there.
#![deny(missing_docs)]

pub mod env;
