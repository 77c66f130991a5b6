//! Lines over semihosting and the two ways a run ends, in a few instructions of `bkpt 0xAB`
//! each: no core::fmt, no division (the Cortex-M0 has no divide instruction), so the flash figure
//! shows the policy and the slots, not the printing.
//!
//! Semihosting needs a debugger, or QEMU's `-semihosting-config enable=on,target=native`; a
//! product's console is its UART.

/// One output line, written as it is assembled: each piece goes to the host at once, so there is
/// no buffer to clear or copy (a 96-byte one cost about 0.4 KB of flash in copies).
pub struct Line;

impl Line {
    /// A line starting with `tag`.
    pub fn new(tag: &str) -> Self {
        write(tag.as_bytes());
        Line
    }

    /// Appends text.
    pub fn push(&mut self, text: &str) -> &mut Self {
        write(text.as_bytes());
        self
    }

    /// Appends ` ` and `value`'s bits as two hex digits (an int8 code).
    pub fn hex8(&mut self, value: u8) -> &mut Self {
        let digit = |d: u8| b"0123456789abcdef"[usize::from(d & 0xF)];
        write(&[b' ', digit(value >> 4), digit(value)]);
        self
    }

    /// Appends ` ` and `value` in decimal, by subtracting powers of ten.
    pub fn dec(&mut self, mut value: u32) -> &mut Self {
        let mut text = [b' '; 11];
        let mut len = 1;
        for power in [
            1_000_000_000,
            100_000_000,
            10_000_000,
            1_000_000,
            100_000,
            10_000,
            1000,
            100,
            10,
            1,
        ] {
            let mut digit = b'0';
            while value >= power {
                value -= power;
                digit += 1;
            }
            if len > 1 || digit != b'0' || power == 1 {
                if let Some(slot) = text.get_mut(len) {
                    *slot = digit;
                }
                len += 1;
            }
        }
        write(text.get(..len).unwrap_or_default());
        self
    }

    /// Ends the line.
    pub fn emit(&mut self) {
        write(b"\n");
    }
}

/// `SYS_OPEN`, `SYS_WRITE`, `SYS_EXIT`: the semihosting operations used.
const SYS_OPEN: u32 = 0x01;
const SYS_WRITE: u32 = 0x05;
const SYS_EXIT: u32 = 0x18;

/// One semihosting call: `op` in r0, the address of its argument block in r1, the result in r0.
fn call(op: u32, args: &[usize]) -> isize {
    let result: isize;
    // SAFETY: `bkpt 0xAB` is the semihosting trap; the host reads `args` (a live slice) and
    // writes only r0. Without a debugger attached the core faults here instead (HardFault).
    unsafe {
        core::arch::asm!("bkpt 0xAB", inout("r0") op as isize => result, in("r1") args.as_ptr(),
            options(nostack, readonly));
    }
    result
}

/// Writes `bytes` to the host's stdout (":tt" opened for writing, as cortex-m-semihosting does).
fn write(bytes: &[u8]) {
    let name = b":tt\0";
    let handle = call(SYS_OPEN, &[name.as_ptr() as usize, 4, name.len() - 1]);
    if handle >= 0 {
        call(
            SYS_WRITE,
            &[handle as usize, bytes.as_ptr() as usize, bytes.len()],
        );
    }
}

/// Ends the run: QEMU exits with status 0 (`success`) or 1.
pub fn exit(success: bool) -> ! {
    // ADP_Stopped_ApplicationExit, ADP_Stopped_RunTimeErrorUnknown.
    let reason: usize = if success { 0x20026 } else { 0x20023 };
    // On ARMv6-M (32-bit semihosting) r1 holds the reason itself, not a block's address.
    let result: isize;
    // SAFETY: the semihosting exit trap; it does not return under QEMU.
    unsafe {
        core::arch::asm!("bkpt 0xAB", inout("r0") SYS_EXIT as isize => result, in("r1") reason,
            options(nostack, nomem));
    }
    let _ = result;
    loop {
        // Reached only without a debugger: park the core.
        core::hint::spin_loop();
    }
}

/// Prints `FAIL <what>` and ends the run with a failure status.
pub fn fail(what: &str) -> ! {
    Line::new("FAIL ").push(what).emit();
    exit(false)
}
