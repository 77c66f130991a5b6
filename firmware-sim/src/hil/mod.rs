//! Hardware in the loop: the chip computes every action. `firmware-sim run --hil` keeps the
//! plant, the sensor and actuator models, the faults and the metrics on the host, and asks the
//! HIL firmware (`firmware/`, feature `hil`) for each action over a serial link, in
//! hil-protocol's frames. The chip is a [`Controller`](crate::controller::Controller)
//! ([`HilChip`]), so the whole test protocol runs unchanged; what fails on the chip's side
//! (silence, a garbled frame, a reset) stops the run after the episodes that completed.
//!
//! - [`chip`]: the chip as a controller, and its report (slot, boot, instructions per tick);
//! - [`link`]: the byte link (QEMU's UART on a Unix socket, or a serial port);
//! - [`qemu`]: finding the HIL firmware, reading its slot addresses, starting QEMU.

pub mod chip;
pub mod link;
pub mod qemu;

pub use chip::{ChipReport, HilChip};
