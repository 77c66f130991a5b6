//! Line output, and the two ways the firmware ends. Where a line goes and what ending means are
//! the board's ([`crate::board`]): semihosting and QEMU's exit status on the MPS2 boards and the
//! FE310, USART1 and a parked core on the STM32F405.
//!
//! Lines are assembled by hand (hex and decimal integers, text) rather than with `core::fmt`, so
//! the success path does not link the formatting machinery: the flash figures then show the
//! policy, not `Display`. Only the failure paths use `core::fmt`.

use crate::board;

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

    /// Writes the line and a newline to the board's console.
    pub fn emit(&mut self) {
        self.len = self.len.min(self.buf.len() - 1);
        self.push("\n");
        board::write(&self.buf[..self.len]);
    }
}

impl core::fmt::Write for Line {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        self.push(s);
        Ok(())
    }
}

/// Ends the run successfully (under QEMU's MPS2 boards: exit status 0).
pub fn exit_ok() -> ! {
    board::exit(true)
}

/// Prints `FAIL <what>` and ends the run with a failure status (under QEMU's MPS2 boards: exit
/// status 1).
pub fn fail(what: &str) -> ! {
    Line::new("FAIL ").push(what).emit();
    exit_failure()
}

/// Ends the run with a failure status.
pub fn exit_failure() -> ! {
    board::exit(false)
}
