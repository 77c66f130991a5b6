//! QEMU's MPS2 boards (mps2-an386, a Cortex-M4F; mps2-an385, a Cortex-M3): the console is
//! semihosting and a run ends with QEMU's exit status, which is what scripts/cortex-m.sh reads.
//! Semihosting needs a debugger (or QEMU) on the other end: on a real chip without one, its
//! `bkpt` faults. A firmware for a board without a debugger attached uses a board module with a
//! serial console instead (the STM32F405's).

#[cfg(feature = "hil")]
mod uart;

use cortex_m_semihosting::{debug, hio};

#[cfg(feature = "hil")]
pub use uart::Uart0 as Link;

/// Nothing to set up: QEMU starts the MPS2 boards at their clock, and semihosting needs no
/// peripheral.
pub fn init() {}

/// Writes bytes to the host's stdout.
pub fn write(bytes: &[u8]) {
    if let Ok(mut out) = hio::hstdout() {
        // Nothing better to do if the host stops listening: the exit status still reports.
        let _ = out.write_all(bytes);
    }
}

/// Ends the run: QEMU exits with status 0 (`success`) or 1.
pub fn exit(success: bool) -> ! {
    debug::exit(if success {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    // Reached only on a board without a debugger attached: stop here.
    loop {
        cortex_m::asm::wfi();
    }
}
