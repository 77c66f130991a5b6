//! UART0 of QEMU's mps2-an385/an386 (the CMSDK APB UART): the HIL firmware's link to the host
//! (feature `hil`). The only `unsafe` of the HIL path is the two volatile accesses below;
//! everything else goes through [`Uart0`]'s safe methods.
//!
//! Registers (ARM CMSDK APB UART, as QEMU's `cmsdk-apb-uart` models it): DATA +0x0, STATE +0x4
//! (bit 0 TX buffer full, bit 1 RX buffer full), CTRL +0x8 (bit 0 TX enable, bit 1 RX enable,
//! bit 3 RX interrupt enable), INTCLEAR +0xC, BAUDDIV +0x10. Another board brings its own link
//! in its board module (the STM32F405's USART1: `board/stm32f405.rs`).
//!
//! Waiting for a byte sleeps (WFI) rather than spins: the receive interrupt is enabled in the
//! UART and the NVIC but masked by PRIMASK, so it wakes the core without running a handler.
//! Under QEMU a sleeping core hands the emulator's I/O thread the lock it needs to deliver the
//! next byte, and burns no host CPU while the host computes the plant.

/// UART0's base address on the MPS2 boards.
const BASE: usize = 0x4000_4000;
const DATA: usize = 0x0;
const STATE: usize = 0x4;
const CTRL: usize = 0x8;
const INTCLEAR: usize = 0xC;
const BAUDDIV: usize = 0x10;
const RX_INTERRUPT: u32 = 1 << 3;
const RX_CLEAR: u32 = 1 << 1;
/// NVIC set-enable and clear-pending registers of IRQs 0-31.
const NVIC_ISER0: usize = 0xE000_E100;
const NVIC_ICPR0: usize = 0xE000_E280;
/// UART0's receive interrupt is IRQ 0 on the MPS2 boards (QEMU's hw/arm/mps2.c).
const UART0_RX_IRQ_BIT: u32 = 1 << 0;
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
    /// Sets the divider and enables the transmitter and receiver. Always `Some`: UART0 is
    /// there on every MPS2 board (the `Option` is the board modules' common form).
    pub fn take() -> Option<Self> {
        let uart = Uart0 { _only: () };
        // Masked: the receive interrupt only wakes WFI, no handler ever runs.
        cortex_m::interrupt::disable();
        uart.write_reg(CTRL, 0);
        uart.write_reg(BAUDDIV, DIVIDER);
        uart.write_reg(CTRL, TX_RX_ENABLE | RX_INTERRUPT);
        uart.write(NVIC_ISER0, UART0_RX_IRQ_BIT);
        // A read of DATA is what tells QEMU's model to take input again: without it, input
        // that the host sent while the receiver was off waits for QEMU's next timer event (the
        // SysTick wrap, hundreds of millions of instructions away under -icount). On a board
        // it reads an empty buffer, which changes nothing.
        let _ = uart.read_reg(DATA);
        Some(uart)
    }

    /// Sends one byte, waiting while the transmit buffer is full.
    pub fn send(&mut self, byte: u8) {
        while self.read_reg(STATE) & TX_FULL != 0 {}
        self.write_reg(DATA, u32::from(byte));
    }

    /// Waits (asleep) for one byte and returns it.
    pub fn receive(&mut self) -> u8 {
        // A byte that lands between the check and WFI leaves its interrupt pending, and a
        // pending interrupt ends WFI at once: no byte is slept through.
        while self.read_reg(STATE) & RX_FULL == 0 {
            cortex_m::asm::wfi();
        }
        let byte = self.read_reg(DATA) as u8;
        self.write_reg(INTCLEAR, RX_CLEAR);
        self.write(NVIC_ICPR0, UART0_RX_IRQ_BIT);
        byte
    }

    fn read_reg(&self, offset: usize) -> u32 {
        // SAFETY: BASE + offset is one of UART0's 32-bit registers (offsets above), a device
        // register that is always mapped on the MPS2 boards and aligned; a volatile read has no
        // effect on Rust-visible memory (reading DATA pops the receive buffer, which is why only
        // `receive` and `take` read it).
        unsafe { core::ptr::read_volatile((BASE + offset) as *const u32) }
    }

    fn write_reg(&self, offset: usize, value: u32) {
        self.write(BASE + offset, value);
    }

    fn write(&self, address: usize, value: u32) {
        // SAFETY: `address` is one of UART0's registers (`write_reg`) or the NVIC's ISER0 or
        // ICPR0 (`take`, `receive`): aligned 32-bit device registers every Cortex-M3/M4 and the
        // MPS2 boards map; writing them touches no Rust-visible memory. Enabling UART0's IRQ
        // is sound because PRIMASK masks it (`take`): no handler runs, nothing is preempted.
        unsafe { core::ptr::write_volatile(address as *mut u32, value) }
    }
}
