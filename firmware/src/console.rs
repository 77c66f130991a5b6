//! Line output over semihosting, and the two ways the firmware ends.
//!
//! Lines are assembled by hand (hex and decimal integers, text) rather than with `core::fmt`, so
//! the success path does not link the formatting machinery: the flash figures then show the
//! policy, not `Display`. Only the failure paths use `core::fmt`.

// The two crates have the same API: semihosting through `bkpt` on the Cortex-M, through the
// `slli x0; ebreak; srai x0` sequence on RISC-V (QEMU's -semihosting-config for both).
#[cfg(target_arch = "arm")]
use cortex_m::asm::wfi;
#[cfg(target_arch = "arm")]
use cortex_m_semihosting::{debug, hio};
#[cfg(target_arch = "riscv32")]
use riscv::asm::wfi;
#[cfg(target_arch = "riscv32")]
use riscv_semihosting::{debug, hio};

/// One output line of at most 256 bytes; longer text is cut (the newline is always kept).
pub struct Line {
    buf: [u8; 256],
    len: usize,
}

impl Line {
    /// A line starting with `tag`.
    pub fn new(tag: &str) -> Self {
        let mut line = Self {
            buf: [0; 256],
            len: 0,
        };
        line.push(tag);
        line
    }

    /// Appends text.
    pub fn push(&mut self, text: &str) -> &mut Self {
        for &b in text.as_bytes() {
            if self.len < self.buf.len() {
                self.buf[self.len] = b;
                self.len += 1;
            }
        }
        self
    }

    /// Appends ` ` and `value` as eight hex digits (how f32 bits are printed).
    pub fn hex(&mut self, value: u32) -> &mut Self {
        let mut digits = [b' '; 9];
        for (i, d) in digits[1..].iter_mut().enumerate() {
            *d = b"0123456789abcdef"[((value >> (28 - 4 * i)) & 0xF) as usize];
        }
        self.push(core::str::from_utf8(&digits).unwrap_or(" ?"))
    }

    /// Appends ` ` and `value` in decimal.
    pub fn dec(&mut self, mut value: u32) -> &mut Self {
        let mut digits = [0u8; 10];
        let mut at = digits.len();
        loop {
            at -= 1;
            digits[at] = b'0' + (value % 10) as u8;
            value /= 10;
            if value == 0 {
                break;
            }
        }
        self.push(" ");
        self.push(core::str::from_utf8(&digits[at..]).unwrap_or("?"))
    }

    /// Writes the line and a newline to the host's stdout.
    pub fn emit(&mut self) {
        self.len = self.len.min(self.buf.len() - 1);
        self.push("\n");
        if let Ok(mut out) = hio::hstdout() {
            // Nothing better to do if the host stops listening: the exit status still reports.
            let _ = out.write_all(&self.buf[..self.len]);
        }
    }
}

impl core::fmt::Write for Line {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        self.push(s);
        Ok(())
    }
}

/// Ends the run successfully (QEMU exits with status 0).
pub fn exit_ok() -> ! {
    debug::exit(debug::EXIT_SUCCESS);
    // Reached only on a board without a debugger attached: stop here.
    loop {
        wfi();
    }
}

/// Prints `FAIL <what>` and ends the run with a failure status (QEMU exits with status 1).
pub fn fail(what: &str) -> ! {
    Line::new("FAIL ").push(what).emit();
    exit_failure()
}

/// Ends the run with a failure status.
pub fn exit_failure() -> ! {
    debug::exit(debug::EXIT_FAILURE);
    loop {
        wfi();
    }
}
