//! The smallest whole Cortex-M0 firmware: boots the newer of two flash slots whose blob passes
//! full verification ([`slot::choose`] with [`Model::for_policy_within`]: header, CRC-32, every
//! parameter, the sizes and the scratch width), falls back to the other slot, runs the safe state
//! if neither verifies, and runs an integer actor ([`Model::act_codes_in`]: input codes in, unit
//! codes out) with no float arithmetic anywhere in the image. policy-core is built with its
//! `integer` feature alone, so a blob in any other encoding is refused at boot like any bad slot.
//!
//! Everything beyond that is what scripts/cortex-m.sh needs to check and measure it, kept small
//! so the flash figure is the firmware's: ten fixed observation codes ([`codes`]; 20 bytes of
//! flash, not a table of float observations), the actions printed as codes for the host to
//! recompute bit for bit, [`fw_mark`] calls around each span a QEMU plugin counts, and the
//! stack painted to find its peak. Lines are assembled by hand ([`console`]); nothing links
//! core::fmt. A slot's failure is printed as `failed` without policy-core's one-line reason,
//! whose `Display` would link the formatting machinery.
#![no_std]
#![no_main]

mod codes;
mod console;
// The example firmware's stack painting, the same file: both link with cortex-m-rt's link.x.
#[path = "../../firmware/src/stack.rs"]
mod stack;

use core::hint::black_box;

use cortex_m_rt::{entry, exception};
use policy_core::model::Model;
use policy_core::slot::{self, SlotId, Status};

use codes::CASES;
use console::{exit, fail, Line};

/// Width of the activation scratch: the widest layer a blob may have to run here. Two vectors
/// of `W` int32 values, 512 B of RAM for 64; a wider blob is refused at boot (safe state).
const W: usize = 64;
/// The most observations and actions a blob may have (the lengths of the code buffers).
const MAX_OBS: usize = 8;
const MAX_ACT: usize = 8;

/// A call the QEMU plugin (firmware/qemu-plugin/icount.c) watches: it prints the running
/// instruction count each time this function is entered. Never inlined, and `black_box` is an
/// opaque memory barrier, so the measured work cannot move across a mark.
#[inline(never)]
#[no_mangle]
pub extern "C" fn fw_mark(id: u32) {
    black_box(id);
}

/// Slots A and B as byte slices of flash (nrf51/memory.x's `_slot_a`, `_slot_b`, `_slot_size`:
/// symbols whose addresses are the values).
fn slots() -> (&'static [u8], &'static [u8]) {
    extern "C" {
        static _slot_a: u8;
        static _slot_b: u8;
        static _slot_size: u8;
    }
    // SAFETY: memory.x places SLOTS inside the part's flash, after FLASH, so both ranges are
    // readable memory that no Rust object occupies and nothing writes while the firmware runs.
    unsafe {
        let size = core::ptr::addr_of!(_slot_size) as usize;
        (
            core::slice::from_raw_parts(core::ptr::addr_of!(_slot_a), size),
            core::slice::from_raw_parts(core::ptr::addr_of!(_slot_b), size),
        )
    }
}

/// Picks the slot to run and verifies its blob completely, as an actor or discrete policy of at
/// most [`MAX_OBS`] observations and [`MAX_ACT`] actions whose widest layer fits the scratch.
fn boot(slot_a: &'static [u8], slot_b: &'static [u8]) -> slot::Boot<Model<'static>> {
    slot::choose(slot_a, slot_b, |blob| {
        Model::for_policy_within(blob, MAX_OBS, MAX_ACT, W)
    })
}

/// One control step: the policy's unit codes (`u = code / 127` of the unit box) into `action`,
/// or the safe state (zeros) without a model or on any error.
fn control_step(model: Option<&Model<'_>>, codes: &[i8], scratch: &mut [i32], action: &mut [i8]) {
    if !model.is_some_and(|m| m.act_codes_in(codes, scratch, action).is_ok()) {
        action.fill(0);
    }
}

/// The stack pointer of the caller (inlined into it); read with one instruction, as this
/// firmware links no `cortex-m` crate.
#[inline(always)]
fn stack_pointer() -> usize {
    let sp: usize;
    // SAFETY: reads the stack pointer into a register; touches no memory.
    unsafe {
        core::arch::asm!("mov {}, sp", out(reg) sp, options(nomem, nostack, preserves_flags))
    };
    sp
}

#[entry]
fn main() -> ! {
    // cortex-m-rt turns a `static mut` declared here into a `&'static mut`: the only reference.
    // All zeros, so it sits in .bss and costs no flash.
    static mut SCRATCH: [i32; 2 * W] = [0; 2 * W];
    let sp = stack_pointer();
    stack::paint(sp);

    fw_mark(0); // span "overhead": two marks back to back
    fw_mark(1);
    let (slot_a, slot_b) = slots();
    fw_mark(2);
    let booted = boot(black_box(slot_a), black_box(slot_b));
    fw_mark(3);
    let boot_stack = stack::used_below(sp);
    let model = booted.running.as_ref().map(|(_, model)| model);

    stack::paint(sp);
    let (n_obs, n_act) = model.map_or((0, 0), |m| {
        let shape = m.header().shape;
        (usize::from(shape.observations), usize::from(shape.actions))
    });
    let mut actions = [[0i8; MAX_ACT]; CASES];
    let mut obs = [0i8; MAX_OBS];
    let obs = obs.get_mut(..n_obs).unwrap_or_default();
    for (k, action) in actions.iter_mut().enumerate() {
        let action = action.get_mut(..n_act).unwrap_or_default();
        codes::fill(k, obs);
        fw_mark(4);
        control_step(model, black_box(obs), SCRATCH, action);
        fw_mark(5);
    }
    let act_stack = stack::used_below(sp);

    report_slots(&booted);
    if let Some(model) = model {
        let shape = model.header().shape;
        Line::new("SHAPE")
            .dec(shape.depth.into())
            .dec(shape.width.into())
            .dec(shape.observations.into())
            .dec(shape.actions.into())
            .emit();
        let running = match booted.running {
            Some((SlotId::B, _)) => slot_b,
            _ => slot_a,
        };
        let blob_bytes = slot::read(running).map_or(0, |r| r.blob.len());
        Line::new("BLOB_BYTES").dec(blob_bytes as u32).emit();
    }
    Line::new("SCRATCH_BYTES")
        .dec(core::mem::size_of_val(SCRATCH) as u32)
        .emit();
    for (k, action) in actions.iter().enumerate() {
        codes::fill(k, obs);
        codes_line(Line::new("OBS_CODES").dec(k as u32), obs);
        codes_line(
            Line::new("ACT_CODES").dec(k as u32),
            action.get(..n_act).unwrap_or_default(),
        );
    }
    Line::new("SPAN overhead 1").emit();
    Line::new("SPAN boot 1").emit();
    for k in 0..CASES {
        Line::new("SPAN act").dec(k as u32).emit();
    }
    Line::new("STACK_MAIN")
        .dec((stack::top() - sp) as u32)
        .emit();
    Line::new("STACK_PHASE boot").dec(boot_stack as u32).emit();
    Line::new("STACK_PHASE act").dec(act_stack as u32).emit();
    if model.is_none() {
        fail("boot: no slot holds a policy this firmware can run (safe state)");
    }
    // `act_codes_in` promises codes in -127..=127 for every input.
    if actions.iter().flatten().any(|&c| c == i8::MIN) {
        fail("an action code is outside -127..=127");
    }
    Line::new("DONE").emit();
    exit(true)
}

/// Emits `line` with each code's bits appended as two hex digits.
#[inline(never)]
fn codes_line(line: &mut Line, codes: &[i8]) {
    for &c in codes {
        line.hex8(c as u8);
    }
    line.emit();
}

/// Prints what became of each slot (`SLOT A running 3`, `SLOT B failed`) and which one runs
/// (`RUNNING A`, `RUNNING B` or `RUNNING safe`).
fn report_slots(booted: &slot::Boot<Model<'_>>) {
    for (name, status) in [("SLOT A", booted.a), ("SLOT B", booted.b)] {
        let mut line = Line::new(name);
        match status {
            Status::Running { sequence } => line.push(" running").dec(sequence),
            Status::Standby { sequence } => line.push(" standby").dec(sequence),
            Status::Failed(_) => line.push(" failed"),
        };
        line.emit();
    }
    let running = match booted.running {
        Some((SlotId::A, _)) => "A",
        Some((SlotId::B, _)) => "B",
        None => "safe",
    };
    Line::new("RUNNING ").push(running).emit();
}

#[exception]
unsafe fn HardFault(_frame: &cortex_m_rt::ExceptionFrame) -> ! {
    fail("HardFault")
}

#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    fail("panic")
}
