//! The two-joint planar arm as a plant of the toolkit (`firmware_sim::env::Env`): what a user's
//! own crate adds to train, export and check a policy for its system. `src/main.rs` is the
//! command line around it.

pub mod arm;
