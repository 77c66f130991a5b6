//! The most observations and actions a blob may declare to run on this firmware: the lengths of
//! its observation and action buffers. Within them the firmware runs the blob's own sizes (boot
//! verifies with `Model::for_policy_within`), so a policy for another plant needs no rebuild.
//! firmware/host-check includes this same file (`#[path]`), so the host refuses what the chip
//! would.
//!
//! 16 observations and 8 actions, within the most values a HIL frame carries
//! (`hil_protocol::MAX_VALUES`, asserted where the `hil` feature builds): enough for a cart (3
//! observations, 1 action), a two-joint arm (6, 2) or MuJoCo's reacher (10, 2). A larger plant
//! means larger buffers here, 4 bytes of RAM per value and buffer, and a HIL protocol of more
//! values.

/// The most observations a blob may declare.
pub const MAX_OBS: usize = 16;
/// The most actions a blob may declare.
pub const MAX_ACT: usize = 8;
