//! QEMU's MPS2 boards (mps2-an386, a Cortex-M4F; mps2-an385, a Cortex-M3): the console is
//! semihosting and a run ends with QEMU's exit status, which is what scripts/cortex-m.sh reads.
//! Semihosting needs a debugger (or QEMU) on the other end: on a real chip without one, its
//! `bkpt` faults. A firmware for a board without a debugger attached uses a board module with a
//! serial console instead (the STM32F405's).

#[cfg(feature = "hil")]
mod uart;

pub use super::semihosting::{exit, init, write};

#[cfg(feature = "hil")]
pub use uart::Uart0 as Link;
