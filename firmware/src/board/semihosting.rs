//! A console over semihosting, for the boards QEMU runs with a debugger's view of the chip (the
//! MPS2 boards, the FE310): lines go to the host's stdout and a run ends with QEMU's exit status,
//! which is what scripts/cortex-m.sh reads. The two crates have the same API: semihosting through
//! `bkpt` on the Cortex-M, through the `slli x0; ebreak; srai x0` sequence on RISC-V.

#[cfg(target_arch = "arm")]
use cortex_m::asm::wfi;
#[cfg(target_arch = "arm")]
use cortex_m_semihosting::{debug, hio};
#[cfg(target_arch = "riscv32")]
use riscv::asm::wfi;
#[cfg(target_arch = "riscv32")]
use riscv_semihosting::{debug, hio};

/// Nothing to set up: QEMU starts these boards at their clock, and semihosting needs no
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
        wfi();
    }
}
