//! The blob region: two flash slots that memory.x places after the firmware.
//!
//! The linker script defines `_slot_a`, `_slot_b` and `_slot_size`; their *addresses* are the
//! values (a symbol defined in a linker script has an address and no storage). A flasher writes
//! policies there (host-trainer `export --image`), never the firmware's build.

extern "C" {
    static _slot_a: u8;
    static _slot_b: u8;
    static _slot_size: u8;
    #[cfg(feature = "refine")]
    static _critic: u8;
    #[cfg(feature = "refine")]
    static _critic_size: u8;
}

/// Slots A and B as byte slices of flash.
pub fn slots() -> (&'static [u8], &'static [u8]) {
    // SAFETY: memory.x places SLOTS inside the part's flash, after FLASH, so both ranges are
    // readable memory that no Rust object occupies and nothing writes while the firmware runs
    // (a flasher writes them with the core halted). `_slot_size` is a length, not storage.
    unsafe {
        let size = core::ptr::addr_of!(_slot_size) as usize;
        (
            core::slice::from_raw_parts(core::ptr::addr_of!(_slot_a), size),
            core::slice::from_raw_parts(core::ptr::addr_of!(_slot_b), size),
        )
    }
}

/// The critic region (feature `refine`) as a byte slice of flash.
#[cfg(feature = "refine")]
pub fn critic_region() -> &'static [u8] {
    // SAFETY: as in `slots`: memory.x places CRITIC in flash, outside every Rust object, and
    // nothing writes it while the firmware runs.
    unsafe {
        let size = core::ptr::addr_of!(_critic_size) as usize;
        core::slice::from_raw_parts(core::ptr::addr_of!(_critic), size)
    }
}
