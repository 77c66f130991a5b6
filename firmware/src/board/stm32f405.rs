//! The STM32F405RG (feature `stm32f405`), on an Olimex STM32-H405 board or QEMU's model of it
//! (`-M olimex-stm32-h405`; `netduinoplus2` has the same chip and runs the same image). The
//! console and the HIL link are USART1 on PB6 (TX) and PB7 (RX), 115200 baud 8N1: a board needs
//! no debugger attached to run, report or serve the host, only a 3.3 V USB-serial adapter.
//!
//! **The vendor HAL (stm32f4xx-hal) sets up the clocks and the pins and enables USART1's clock;
//! the USART's own registers are written through the HAL's PAC** (`stm32f4xx_hal::pac`). The
//! HAL's `Serial::new` pulses USART1's reset bit in the RCC, and QEMU 10.0.2's model of the
//! F405's RCC crashes (a segmentation fault) when that reset is released, so CI could not run
//! it. After a power-on reset the USART is in its reset state anyway; four registers (BRR, CR1,
//! SR, DR) are the whole driver.
//!
//! **Clocks: the reset clock.** The core runs on the 16 MHz HSI the chip starts on, through the
//! HAL's default configuration (no HSE, no PLL), so the HAL waits on no ready flag. QEMU models
//! only the RCC's enable and reset bits (its ready flags never rise), and a configuration with
//! the board's 8 MHz crystal and the PLL (`Config::hse(8.MHz()).sysclk(168.MHz())`) spins
//! forever under QEMU waiting for HSERDY, where CI runs this firmware. On a board that
//! configuration is the one to use for speed (10.5 times the clock; the HAL sets the flash wait
//! states and the USART divider follows the HAL's clocks); the figures here are instructions,
//! not cycles, and do not change with the clock. QEMU's SysTick counts at its own fixed 168 MHz
//! whatever the RCC says; the firmware calibrates SysTick against a loop of known length either
//! way.
//!
//! **Pins.** PB6/PB7 (alternate function 7) rather than PA9/PA10, the chip's other USART1 pins:
//! PA9 to PA12 are the USB OTG FS pins (VBUS, ID, DM, DP), which the H405's USB connector uses.
//! RX has the internal pull-up, so an unplugged adapter reads as an idle line, not noise. QEMU
//! models no GPIO on this chip (the pin set-up writes are ignored there).

use core::cell::RefCell;

use cortex_m::interrupt::{self, Mutex};
#[cfg(feature = "hil")]
use cortex_m::peripheral::NVIC;
#[cfg(feature = "hil")]
use stm32f4xx_hal::pac::Interrupt;
use stm32f4xx_hal::pac::{self, USART1};
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::{BusClock, Config, Enable};

/// The serial line's rate, both directions (firmware-sim `--baud`).
pub const BAUD: u32 = 115_200;

/// USART1 once [`init`] has set it up: the console writes through it until the HIL [`Link`]
/// takes it.
static USART: Mutex<RefCell<Option<USART1>>> = Mutex::new(RefCell::new(None));

/// Sets the clocks (the HAL's default: HSI, 16 MHz), PB6/PB7 as USART1's pins, and USART1 at
/// [`BAUD`], 8 data bits, no parity, 1 stop bit. Called once, first thing in `main`; a second
/// call finds the peripherals taken and changes nothing.
pub fn init() {
    let Some(dp) = pac::Peripherals::take() else {
        return;
    };
    let mut rcc = dp.RCC.freeze(Config::hsi());
    let gpiob = dp.GPIOB.split(&mut rcc);
    // The pins keep their mode when these handles go: the USART owns them from here on.
    let _tx = gpiob.pb6.into_alternate::<7>();
    let _rx = gpiob.pb7.into_alternate::<7>().internal_pull_up(true);
    USART1::enable(&mut rcc);
    let usart = dp.USART1;
    // Oversampling by 16: BRR is the bus clock over the rate, rounded (16 MHz / 115200: 139,
    // 115,108 baud, 0.08 % slow, well within the 2 % a UART tolerates).
    let clock = USART1::clock(&rcc.clocks).raw();
    let divider = (clock + BAUD / 2) / BAUD;
    usart.brr().write(|w| {
        w.div_mantissa().set((divider >> 4) as u16);
        w.div_fraction().set((divider & 0xF) as u8)
    });
    // Reset values elsewhere: 8 data bits, no parity (CR1), 1 stop bit (CR2), no flow control.
    usart
        .cr1()
        .write(|w| w.ue().set_bit().te().set_bit().re().set_bit());
    interrupt::free(|cs| USART.borrow(cs).replace(Some(usart)));
}

/// Writes bytes to USART1, waiting while its transmit register is full. Before [`init`] and
/// after the HIL link took the USART, the bytes go nowhere.
pub fn write(bytes: &[u8]) {
    interrupt::free(|cs| {
        if let Some(usart) = USART.borrow(cs).borrow().as_ref() {
            for &b in bytes {
                send(usart, b);
            }
        }
    });
}

/// Ends the run: waits until the last byte has left (so the `DONE` or `FAIL` line reaches the
/// host whole), then parks the core. There is no one to hand an exit status to: the host reads
/// the last line (scripts/cortex-m.sh stops QEMU when it sees it).
pub fn exit(_success: bool) -> ! {
    interrupt::free(|cs| {
        if let Some(usart) = USART.borrow(cs).borrow().as_ref() {
            while usart.sr().read().tc().bit_is_clear() {}
        }
    });
    loop {
        cortex_m::asm::wfi();
    }
}

fn send(usart: &USART1, byte: u8) {
    while usart.sr().read().txe().bit_is_clear() {}
    usart.dr().write(|w| w.dr().set(byte.into()));
}

/// The HIL link (feature `hil`): USART1, taken from the console.
///
/// Waiting for a byte sleeps (WFI) rather than spins, as on the MPS2 boards: the receive
/// interrupt (RXNE) is enabled in the USART and the NVIC but masked by PRIMASK, so it wakes the
/// core without running a handler.
#[cfg(feature = "hil")]
pub struct Link {
    usart: USART1,
}

#[cfg(feature = "hil")]
impl Link {
    /// Takes USART1 from the console and enables its receive interrupt as a wake-up source.
    /// `None` if [`init`] did not set it up. From here on the console's lines (a `FAIL` from a
    /// panic) go nowhere: they would garble the link's frames, and the host reports the silence.
    pub fn take() -> Option<Self> {
        interrupt::disable();
        let usart = interrupt::free(|cs| USART.borrow(cs).take())?;
        usart.cr1().modify(|_, w| w.rxneie().set_bit());
        // SAFETY: PRIMASK is set above and never cleared on this path, so no handler runs for
        // USART1 (none is defined): the interrupt only ends WFI. Nothing is preempted.
        unsafe { NVIC::unmask(Interrupt::USART1) };
        Some(Link { usart })
    }

    /// Sends one byte, waiting while the transmit register is full.
    pub fn send(&mut self, byte: u8) {
        send(&self.usart, byte);
    }

    /// Waits (asleep) for one byte and returns it.
    pub fn receive(&mut self) -> u8 {
        loop {
            // A byte that lands between the check and WFI leaves its interrupt pending, and a
            // pending interrupt ends WFI at once: no byte is slept through.
            let status = self.usart.sr().read();
            if status.rxne().bit_is_set() {
                // Reading DR clears RXNE and any overrun, framing or noise flag with it; a
                // byte lost or damaged that way shows as a bad frame CRC on the host.
                let byte = self.usart.dr().read().dr().bits() as u8;
                NVIC::unpend(Interrupt::USART1);
                return byte;
            }
            if status.ore().bit_is_set() {
                // An overrun without data: the SR-then-DR read sequence clears it.
                let _ = self.usart.dr().read();
                continue;
            }
            cortex_m::asm::wfi();
        }
    }
}
