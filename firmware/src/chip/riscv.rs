//! The RISC-V RV32IMAC (QEMU's sifive_e, a SiFive FE310): riscv-rt's reset and trap entry, the
//! `mcycle` counter.

use policy_core::model::Scratch;
use riscv::register::{mcause, mcycle, mepc, mtval};

use crate::console::{exit_failure, Line};
use crate::W;

#[riscv_rt::entry]
fn main() -> ! {
    static mut SCRATCH: Scratch<W> = Scratch::new();
    // SAFETY: riscv-rt calls `main` once, after reset, and nothing else names SCRATCH, so this is
    // the only reference to it for the rest of the run (what cortex-m-rt's `#[entry]` does for
    // a `static mut` declared in `main`; riscv-rt's does not). All zeros: .bss, no flash.
    let scratch = unsafe { &mut *core::ptr::addr_of_mut!(SCRATCH) };
    crate::run(scratch)
}

/// The stack pointer of the caller (inlined into it).
#[inline(always)]
pub fn stack_pointer() -> usize {
    let sp: usize;
    // SAFETY: reads a register into another; no memory, no stack.
    unsafe { core::arch::asm!("mv {}, sp", out(reg) sp, options(nomem, nostack)) };
    sp
}

/// `mcycle` runs from reset (the FE310 and QEMU start it); nothing to set up.
pub fn start_clock() {}

pub fn ticks() -> u32 {
    mcycle::read() as u32
}

/// `mcycle` ticks since `t0` (it counts up; the low 32 bits suffice for the spans measured).
pub fn elapsed(t0: u32) -> u32 {
    ticks().wrapping_sub(t0)
}

/// Runs a loop of known length (2 instructions per turn) and returns (instructions, ticks): under
/// QEMU's `-icount` `mcycle` counts instructions, the fallback when the plugin is unavailable.
pub fn calibrate() -> (u32, u32) {
    const TURNS: u32 = 100_000;
    let t0 = ticks();
    // SAFETY: a register-only countdown loop; touches no memory and no stack.
    unsafe {
        core::arch::asm!("1:", "addi {0}, {0}, -1", "bnez {0}, 1b", inout(reg) TURNS => _, options(nomem, nostack));
    }
    (2 * TURNS, elapsed(t0))
}

/// Any exception (an access fault, an illegal instruction): the Cortex-M's HardFault.
#[export_name = "ExceptionHandler"]
fn exception_handler(_frame: &riscv_rt::TrapFrame) -> ! {
    Line::new("FAIL exception")
        .dec(mcause::read().bits() as u32)
        .push(" at pc")
        .hex(mepc::read() as u32)
        .push(" mtval")
        .hex(mtval::read() as u32)
        .emit();
    exit_failure()
}

/// No interrupt is enabled: one that arrives is a fault.
#[export_name = "DefaultHandler"]
fn default_handler() -> ! {
    Line::new("FAIL unexpected interrupt")
        .dec(mcause::read().bits() as u32)
        .emit();
    exit_failure()
}
