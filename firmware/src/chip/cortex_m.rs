//! The Cortex-M (QEMU's mps2-an385/an386): cortex-m-rt's reset and exceptions, SysTick.

use cortex_m::peripheral::{syst::SystClkSource, SYST};
use cortex_m_rt::{entry, exception, ExceptionFrame};
use policy_core::model::Scratch;

use crate::console::{exit_failure, fail, Line};
use crate::W;

#[entry]
fn main() -> ! {
    // cortex-m-rt turns a `static mut` declared here into a `&'static mut`: `main` runs once and
    // nothing else can name it, so this is the only reference and no `unsafe` is needed. The
    // scratch is all zeros, so it sits in .bss (RAM) and costs no flash.
    static mut SCRATCH: Scratch<W> = Scratch::new();
    crate::run(SCRATCH)
}

/// The stack pointer of the caller (inlined into it).
#[inline(always)]
pub fn stack_pointer() -> usize {
    cortex_m::register::msp::read() as usize
}

/// Starts SysTick from the core clock, counting down over its full 24 bits.
pub fn start_clock() {
    let Some(mut core) = cortex_m::Peripherals::take() else {
        fail("core peripherals already taken")
    };
    let syst = &mut core.SYST;
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(0x00FF_FFFF);
    syst.clear_current();
    syst.enable_counter();
}

pub fn ticks() -> u32 {
    SYST::get_current()
}

/// SysTick ticks since `t0` (it counts down, 24 bits).
pub fn elapsed(t0: u32) -> u32 {
    t0.wrapping_sub(ticks()) & 0x00FF_FFFF
}

/// Runs a loop of known length (2 instructions per turn) and returns (instructions, ticks): under
/// QEMU's `-icount` this converts SysTick ticks into instructions when the plugin is unavailable.
pub fn calibrate() -> (u32, u32) {
    const TURNS: u32 = 100_000;
    let t0 = ticks();
    // SAFETY: a register-only countdown loop; touches no memory and no stack.
    unsafe {
        core::arch::asm!("1:", "subs {0}, {0}, #1", "bne 1b", inout(reg) TURNS => _, options(nomem, nostack));
    }
    (2 * TURNS, elapsed(t0))
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    Line::new("FAIL HardFault at pc").hex(frame.pc()).emit();
    exit_failure()
}

#[exception]
unsafe fn DefaultHandler(irqn: i16) -> ! {
    Line::new("FAIL unexpected exception or interrupt")
        .dec(irqn as u16 as u32)
        .emit();
    exit_failure()
}
