//! Example firmware: a DCP policy running on a Cortex-M.
//!
//! The part a user copies is short: the blob sits in flash (`include_bytes!`), is checked and
//! copied once into a `static` slot with [`Policy::load_into`](policy_core::Policy::load_into),
//! and [`act`](policy_core::Policy::act) turns each observation into a bounded action.
//!
//! Everything else measures what that costs, for scripts/cortex-m.sh: it prints the observations
//! and actions as `f32` bits (the host recomputes them), calls [`fw_mark`] around each span whose
//! instructions a QEMU plugin counts, times the same spans with SysTick (the fallback count),
//! and paints the stack to find its peak. The run ends with QEMU's exit status: 0 only if the
//! blob loaded and every action is finite and inside the bounds; panics and faults exit too.
#![no_std]
#![no_main]

mod console;
mod observations;
mod shape;
mod stack;

use core::hint::black_box;

use cortex_m::peripheral::{syst::SystClkSource, SYST};
use cortex_m_rt::{entry, exception, ExceptionFrame};
use policy_core::blob::Model;

use console::{exit_failure, exit_ok, fail, Line};
use observations::OBSERVATIONS;
use shape::Actor;

/// The policy blob in flash; build.rs picks the file (`POLICY_BLOB`).
static BLOB: &[u8] = include_bytes!(env!("POLICY_BLOB_PATH"));

/// Arguments for the tanhf timing span: 64 points spread over [-3, 3], where hidden
/// pre-activations of a trained actor mostly fall.
const TANH_POINTS: usize = 64;

/// A call the QEMU plugin (firmware/qemu-plugin/icount.c) watches: it prints the running
/// instruction count each time this function is entered. Never inlined, and `black_box` is an
/// opaque memory barrier, so the measured work cannot move across a mark.
#[inline(never)]
#[no_mangle]
pub extern "C" fn fw_mark(id: u32) {
    black_box(id);
}

#[entry]
fn main() -> ! {
    // cortex-m-rt turns a `static mut` declared here into a `&'static mut`: `main` runs once and
    // nothing else can name it, so this is the only reference and no `unsafe` is needed. The slot
    // is all zeros, so it sits in .bss (RAM) and costs no flash; `load_into` copies the weights
    // into it in place, so no model-sized value ever passes through the stack.
    static mut POLICY: Actor = Actor::ZERO;

    let sp = cortex_m::register::msp::read() as usize;
    stack::paint(sp);
    let Some(mut core) = cortex_m::Peripherals::take() else {
        fail("core peripherals already taken")
    };
    start_systick(&mut core.SYST);
    let (cal_insns, cal_ticks) = calibrate();

    fw_mark(0); // span "overhead": two marks back to back
    fw_mark(1);

    let t0 = ticks();
    fw_mark(2);
    let loaded = POLICY.load_into(black_box(BLOB));
    fw_mark(3);
    let load_ticks = elapsed(t0);
    let load_stack = stack::used_below(sp);
    if let Err(e) = loaded {
        fail_load(e)
    }
    let policy: &Actor = POLICY;

    stack::paint(sp);
    let mut actions = [[0.0f32; 2]; OBSERVATIONS.len()];
    let t0 = ticks();
    for (obs, action) in OBSERVATIONS.iter().zip(&mut actions) {
        fw_mark(4);
        *action = policy.act(black_box(obs));
        fw_mark(5);
    }
    let act_ticks = elapsed(t0);
    let act_stack = stack::used_below(sp);

    let tanh_sum = time_tanhf();

    report(&actions, sp, [load_stack, act_stack]);
    Line::new("TICKS_CAL").dec(cal_insns).dec(cal_ticks).emit();
    Line::new("TICKS load_into 1").dec(load_ticks).emit();
    Line::new("TICKS act")
        .dec(OBSERVATIONS.len() as u32)
        .dec(act_ticks)
        .emit();
    black_box(tanh_sum);
    check_bounds(policy, &actions);
    Line::new("DONE").emit();
    exit_ok()
}

/// Prints what the host needs to check and measure, in the order the spans were marked.
fn report(actions: &[[f32; 2]], sp: usize, phases: [usize; 2]) {
    let shape = Actor::SHAPE;
    Line::new("SHAPE")
        .dec(shape.depth.into())
        .dec(shape.width.into())
        .dec(shape.observations.into())
        .dec(shape.actions.into())
        .emit();
    Line::new("SLOT_BYTES")
        .dec(core::mem::size_of::<Actor>() as u32)
        .emit();
    Line::new("BLOB_BYTES").dec(BLOB.len() as u32).emit();
    for (k, (obs, act)) in OBSERVATIONS.iter().zip(actions).enumerate() {
        Line::new("OBS")
            .dec(k as u32)
            .hex(obs[0].to_bits())
            .hex(obs[1].to_bits())
            .emit();
        Line::new("ACT")
            .dec(k as u32)
            .hex(act[0].to_bits())
            .hex(act[1].to_bits())
            .emit();
    }
    Line::new("SPAN overhead 1").emit();
    Line::new("SPAN load_into 1").emit();
    for k in 0..OBSERVATIONS.len() {
        Line::new("SPAN act").dec(k as u32).emit();
    }
    Line::new("SPAN tanhf").dec(TANH_POINTS as u32).emit();
    Line::new("STACK_MAIN")
        .dec((stack::top() - sp) as u32)
        .emit();
    Line::new("STACK_PHASE load_into")
        .dec(phases[0] as u32)
        .emit();
    Line::new("STACK_PHASE act").dec(phases[1] as u32).emit();
}

/// `act` promises finite actions inside the blob's bounds for every observation; a firmware that
/// sees otherwise must not report success.
fn check_bounds(policy: &Actor, actions: &[[f32; 2]]) {
    for action in actions {
        for ((&a, &lo), &hi) in action
            .iter()
            .zip(&policy.bounds.low)
            .zip(&policy.bounds.high)
        {
            if !a.is_finite() || a < lo || a > hi {
                fail("an action is non-finite or outside the bounds");
            }
        }
    }
}

/// Runs `libm::tanhf` (the hidden activation) on [`TANH_POINTS`] arguments between two marks, so
/// the report can tell the activations' share of `act` from the multiply-accumulates'.
fn time_tanhf() -> f32 {
    let xs: [f32; TANH_POINTS] =
        core::array::from_fn(|i| -3.0 + 6.0 * i as f32 / (TANH_POINTS - 1) as f32);
    let mut sum = 0.0;
    fw_mark(6);
    for &x in &xs {
        sum += libm::tanhf(black_box(x));
    }
    fw_mark(7);
    sum
}

fn start_systick(syst: &mut SYST) {
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(0x00FF_FFFF);
    syst.clear_current();
    syst.enable_counter();
}

fn ticks() -> u32 {
    SYST::get_current()
}

/// SysTick ticks since `t0` (it counts down, 24 bits).
fn elapsed(t0: u32) -> u32 {
    t0.wrapping_sub(ticks()) & 0x00FF_FFFF
}

/// Runs a loop of known length (2 instructions per turn) and returns (instructions, ticks): under
/// QEMU's `-icount` this converts SysTick ticks into instructions when the plugin is unavailable.
fn calibrate() -> (u32, u32) {
    const TURNS: u32 = 100_000;
    let t0 = ticks();
    // SAFETY: a register-only countdown loop; touches no memory and no stack.
    unsafe {
        core::arch::asm!("1:", "subs {0}, {0}, #1", "bne 1b", inout(reg) TURNS => _, options(nomem, nostack));
    }
    (2 * TURNS, elapsed(t0))
}

/// Reports a blob the slot rejected, with policy-core's one-line reason (expected vs found).
fn fail_load(e: policy_core::Error) -> ! {
    use core::fmt::Write;
    let mut line = Line::new("FAIL load_into: ");
    let _ = write!(line, "{e}");
    line.emit();
    exit_failure()
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

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    let mut line = Line::new("FAIL panic");
    if let Some(message) = info.message().as_str() {
        line.push(": ").push(message);
    }
    if let Some(at) = info.location() {
        line.push(" at ")
            .push(at.file())
            .push(" line")
            .dec(at.line());
    }
    line.emit();
    exit_failure()
}
