//! Peak stack measurement by painting, as firmware/src/stack.rs does: fill the free stack with a
//! pattern, run, and find the lowest word the pattern no longer holds.

const PAINT: u32 = 0x5AFE_C0DE;

extern "C" {
    /// End of the statics: the lowest address the stack may grow to (cortex-m-rt's link.x).
    static __sheap: u32;
    /// The initial stack pointer, the top of RAM (cortex-m-rt's link.x).
    static _stack_start: u32;
}

fn limit() -> usize {
    core::ptr::addr_of!(__sheap) as usize
}

/// The address the stack starts at.
pub fn top() -> usize {
    core::ptr::addr_of!(_stack_start) as usize
}

/// The stack pointer of the caller (inlined into it).
#[inline(always)]
pub fn pointer() -> usize {
    let sp: usize;
    // SAFETY: reads the stack pointer into a register; touches no memory.
    unsafe {
        core::arch::asm!("mov {}, sp", out(reg) sp, options(nomem, nostack, preserves_flags))
    };
    sp
}

/// Paints `[limit(), sp)` where `sp` is the caller's stack pointer. Always inlined and free of
/// calls, so it runs in the caller's frame: nothing below `sp` is live while it writes.
#[inline(always)]
pub fn paint(sp: usize) {
    let mut at = limit();
    while at + 4 <= sp {
        // SAFETY: `[limit(), sp)` is unused stack (below the live frames, above the statics) and
        // word-aligned (`__sheap` is 4-aligned by link.x); no interrupt is enabled to use it.
        unsafe { core::ptr::write_volatile(at as *mut u32, PAINT) };
        at += 4;
    }
}

/// Bytes of stack used below `sp` since the last [`paint`]. Inlined for the same reason.
#[inline(always)]
pub fn used_below(sp: usize) -> usize {
    let mut at = limit();
    // SAFETY: the same painted, word-aligned region as in `paint`; reads only.
    while at + 4 <= sp && unsafe { core::ptr::read_volatile(at as *const u32) } == PAINT {
        at += 4;
    }
    sp - at
}
