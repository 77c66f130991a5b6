//! QEMU's sifive_e (a SiFive FE310, RISC-V RV32IMAC): the console is semihosting through the
//! `slli x0; ebreak; srai x0` sequence and a run ends with QEMU's exit status, as on the MPS2
//! boards. No HIL link: the `hil` build is Cortex-M only (chip.rs says so at compile time).

use riscv_semihosting::{debug, hio};

/// Nothing to set up: QEMU starts the FE310 at its clock, and semihosting needs no peripheral.
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
        riscv::asm::wfi();
    }
}
