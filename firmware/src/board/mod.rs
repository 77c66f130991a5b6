//! What differs between the boards this firmware runs on: setting the chip up, where the
//! console's lines go, how a run ends, and the serial link of the HIL build (feature `hil`).
//! Everything else (the boot from the slots, the control step, the measurements, the HIL
//! protocol) is the same code on every board.
//!
//! Each board module provides `init`, `write`, `exit` and, with feature `hil`, `Link` (`take`,
//! `send`, `receive`). One is compiled: on a Cortex-M, QEMU's MPS2 boards by default and the
//! STM32F405 with feature `stm32f405` (which also picks its memory map, `stm32f405/memory.x`,
//! in build.rs); on a RISC-V, QEMU's sifive_e (the FE310). The chip's own concerns (reset entry,
//! faults, counter, stack pointer) are [`crate::chip`]'s.

#[cfg(all(target_arch = "arm", not(feature = "stm32f405")))]
mod mps2;
#[cfg(all(target_arch = "arm", not(feature = "stm32f405")))]
pub use mps2::*;

// The FE310 (QEMU's sifive_e) is a semihosting console and nothing else; no HIL link (chip.rs
// refuses feature `hil` on a RISC-V at compile time).
#[cfg(target_arch = "riscv32")]
pub use semihosting::*;

#[cfg(not(feature = "stm32f405"))]
mod semihosting;

#[cfg(feature = "stm32f405")]
mod stm32f405;
#[cfg(feature = "stm32f405")]
pub use stm32f405::*;
