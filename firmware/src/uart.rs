//! UART0 of QEMU's mps2-an385/an386 (the CMSDK APB UART), polled: the HIL firmware's link to
//! the host (feature `hil`). The only `unsafe` of the HIL path is the two volatile accesses
//! below; everything else goes through [`Uart0`]'s safe methods.
//!
//! Registers (ARM CMSDK APB UART, as QEMU's `cmsdk-apb-uart` models it): DATA +0x0, STATE +0x4
//! (bit 0 TX buffer full, bit 1 RX buffer full), CTRL +0x8 (bit 0 TX enable, bit 1 RX enable),
//! BAUDDIV +0x10. On a board with another UART, this file is the one to replace.

/// UART0's base address on the MPS2 boards.
const BASE: usize = 0x4000_4000;
const DATA: usize = 0x0;
const STATE: usize = 0x4;
const CTRL: usize = 0x8;
const BAUDDIV: usize = 0x10;
const TX_FULL: u32 = 1 << 0;
const RX_FULL: u32 = 1 << 1;
const TX_RX_ENABLE: u32 = 0b11;
/// The MPS2's 25 MHz peripheral clock over 115200 baud (QEMU ignores the rate, a board does not;
/// the CMSDK UART needs at least 16).
const DIVIDER: u32 = 25_000_000 / 115_200;

/// UART0, enabled for transmit and receive. One value exists: [`Uart0::take`] hands it out once.
pub struct Uart0 {
    _only: (),
}

impl Uart0 {
    /// Sets the divider and enables the transmitter and receiver.
    pub fn take() -> Self {
        let uart = Uart0 { _only: () };
        uart.write_reg(CTRL, 0);
        uart.write_reg(BAUDDIV, DIVIDER);
        uart.write_reg(CTRL, TX_RX_ENABLE);
        // A read of DATA is what tells QEMU's model to take input again: without it, input
        // that the host sent while the receiver was off waits for QEMU's next timer event (the
        // SysTick wrap, hundreds of millions of instructions away under -icount). On a board
        // it reads an empty buffer, which changes nothing.
        let _ = uart.read_reg(DATA);
        uart
    }

    /// Sends one byte, waiting while the transmit buffer is full.
    pub fn write(&mut self, byte: u8) {
        while self.read_reg(STATE) & TX_FULL != 0 {}
        self.write_reg(DATA, u32::from(byte));
    }

    /// Waits for one byte and returns it.
    pub fn read(&mut self) -> u8 {
        while self.read_reg(STATE) & RX_FULL == 0 {}
        self.read_reg(DATA) as u8
    }

    fn read_reg(&self, offset: usize) -> u32 {
        // SAFETY: BASE + offset is one of UART0's 32-bit registers (offsets above), a device
        // register that is always mapped on the MPS2 boards and aligned; a volatile read has no
        // effect on Rust-visible memory (reading DATA pops the receive buffer, which is why only
        // `read` reads it).
        unsafe { core::ptr::read_volatile((BASE + offset) as *const u32) }
    }

    fn write_reg(&self, offset: usize, value: u32) {
        // SAFETY: as in `read_reg`; writing a UART register touches no Rust-visible memory.
        unsafe { core::ptr::write_volatile((BASE + offset) as *mut u32, value) }
    }
}
