//! What differs between the chips the firmware runs on: the reset entry and fault handlers (each
//! runtime crate's), the cycle counter the SysTick-style fallback count reads, and the stack
//! pointer. Everything else (boot, the control step, the report) is the same code on every
//! chip; the output goes over semihosting on both (console.rs).
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

#[cfg(all(feature = "hil", not(target_arch = "arm")))]
compile_error!("feature `hil` serves over the MPS2's UART0 (src/uart.rs): Cortex-M only");
