//! What the algorithms learn from: the off-policy replay buffer and the on-policy rollout
//! buffer with GAE.

pub mod replay;
pub mod rollout;
