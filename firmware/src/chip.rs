//! What differs between the chips the firmware runs on: the reset entry and fault handlers (each
//! runtime crate's), the cycle counter the SysTick-style fallback count reads, and the stack
//! pointer. Everything else (boot, the control step, the report) is the same code on every
//! chip; where the output goes is the board's (board/).
//!
//! Each entry hands [`crate::run`] the activation scratch as a `&'static mut` in `.bss`, so the
//! scratch counts as static RAM on every chip alike.

#[cfg(target_arch = "arm")]
mod cortex_m;
#[cfg(target_arch = "arm")]
pub use self::cortex_m::{calibrate, elapsed, stack_pointer, start_clock, ticks};

#[cfg(target_arch = "riscv32")]
mod riscv;
#[cfg(target_arch = "riscv32")]
pub use self::riscv::{calibrate, elapsed, stack_pointer, start_clock, ticks};

#[cfg(all(any(feature = "hil", feature = "stm32f405"), not(target_arch = "arm")))]
compile_error!(
    "features `hil` and `stm32f405` are for Cortex-M boards (src/board/): not on a RISC-V"
);
