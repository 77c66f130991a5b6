//! Example firmware: a DCP policy running on a microcontroller (a Cortex-M, or a RISC-V
//! RV32IMAC), straight from flash.
//!
//! The part a user copies is short ([`boot`] and [`control_step`]). The firmware holds no blob:
//! policies are flashed into two slots of their own (memory.x, [`slots`]), so a new policy never
//! means a new firmware build. At boot [`slot::choose`] picks the newer slot whose blob passes
//! [`Model::for_policy_within`] (CRC, header, every parameter; an actor or discrete policy of at
//! most [`MAX_OBS`] observations and [`MAX_ACT`] actions, narrow enough for its scratch width
//! [`W`]) and falls back to the other slot; then [`act`](Model::act) reads the weights from flash
//! on every call, at the blob's own observation and action sizes ([`sizes`]). A policy for
//! another plant (a cart of 3 observations and 1 action, an arm of 6 and 2) runs on the same
//! build. Nothing model-sized is copied to RAM: the only RAM the policy uses is a
//! [`Scratch<W>`] (2 x `W` floats) for the activations.
//! One build runs a blob of any shape up to `W` wide: there is no table of compiled shapes. On
//! any error (neither slot holds a blob that verifies, is within the maxima and fits) the firmware
//! runs the safe state, the zero action, and prints each slot's reason.
//!
//! There is no compile-time fast path, because it was not faster: the const-generic
//! `Policy<2, 48, 3, 2>` (weights copied into 29 KB of RAM) ran the trained 4x48 ReLU actor at
//! 3.40 instructions per multiply-accumulate on the M4F and a tanh 4x48 at 4.74; `Model` straight
//! from flash runs them at 3.03 and 4.79 (scripts/cortex-m.sh, QEMU instruction counts), in 1.8
//! KB of RAM in all.
//!
//! Everything else measures what that costs, for scripts/cortex-m.sh: it acts on ten fixed
//! observations of the blob's size ([`observations::fill`]), prints the observations and actions
//! as `f32` bits (the host recomputes them), which slot runs and why, calls
//! [`fw_mark`] around each span whose instructions a QEMU plugin counts, times the same spans
//! with SysTick or `mcycle` (the fallback count, [`chip`]), and paints the stack to find its
//! peak. The run ends with QEMU's exit status: 0 only if a slot's blob was accepted at boot and
//! every action is finite and inside the bounds; panics and faults exit too.
#![no_std]
#![no_main]

mod board;
mod chip;
mod console;
#[cfg(feature = "hil")]
mod hil;
mod observations;
#[cfg(feature = "refine")]
mod proposals;
#[cfg(feature = "refine")]
mod refine;
mod sizes;
mod slots;
mod stack;

use core::hint::black_box;

use policy_core::model::{Model, Scratch};
use policy_core::slot::{self, SlotId, Status};

use chip::{calibrate, elapsed, start_clock, ticks};
use console::{exit_failure, exit_ok, fail, Line};
use observations::CASES;
pub(crate) use sizes::{MAX_ACT, MAX_OBS};
use slots::slots;

/// Width of the activation scratch: the widest layer a blob may have to run here. It costs
/// 2 x `W` x 4 bytes of RAM (512 B for 64); a wider blob is refused at boot (safe state).
pub(crate) const W: usize = 64;

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

/// Picks the slot to run (the newer one that verifies, else the other) and verifies its blob as
/// a policy this firmware can run: an actor or discrete policy of at most [`MAX_OBS`]
/// observations and [`MAX_ACT`] actions whose widest layer fits the scratch. `running` is
/// `None`: the safe state.
pub fn boot(slot_a: &'static [u8], slot_b: &'static [u8]) -> slot::Boot<Model<'static>> {
    slot::choose(slot_a, slot_b, |blob| {
        Model::for_policy_within(blob, MAX_OBS, MAX_ACT, W)
    })
}

/// The running blob's (observations, actions): the sizes the firmware reads its sensors into and
/// drives its actuators with. The safe state has no blob and no sizes: (0, 0).
pub fn sizes(model: Option<&Model<'_>>) -> (usize, usize) {
    model.map_or((0, 0), |m| {
        let shape = m.header().shape;
        (shape.observations.into(), shape.actions.into())
    })
}

/// One control step: the policy's action into `action` (the blob's action size), or the safe
/// state (zeros) without a model or on any error.
pub fn control_step(
    model: Option<&Model<'_>>,
    obs: &[f32],
    scratch: &mut Scratch<W>,
    action: &mut [f32],
) {
    if !model.is_some_and(|m| m.act(obs, scratch, action).is_ok()) {
        action.fill(0.0);
    }
}

/// The first `n` values of a buffer (`n` is a blob's size, within the buffer's by [`boot`]; the
/// whole buffer otherwise, never a panic).
pub(crate) fn first(buffer: &mut [f32], n: usize) -> &mut [f32] {
    let n = n.min(buffer.len());
    buffer.get_mut(..n).unwrap_or_default()
}

/// The run, from the chip's reset entry ([`chip`]), with the activation scratch in `.bss`.
fn run(scratch: &'static mut Scratch<W>) -> ! {
    let sp = chip::stack_pointer();
    stack::paint(sp);
    // Clocks and the console's serial port before anything prints; after the paint, so that
    // its stack counts in the boot phase's.
    board::init();
    start_clock();
    let (cal_insns, cal_ticks) = calibrate();

    fw_mark(0); // span "overhead": two marks back to back
    fw_mark(1);

    let (slot_a, slot_b) = slots();
    let t0 = ticks();
    fw_mark(2);
    let booted = boot(black_box(slot_a), black_box(slot_b));
    fw_mark(3);
    let boot_ticks = elapsed(t0);
    let boot_stack = stack::used_below(sp);
    let model = booted.running.as_ref().map(|(_, model)| model);

    // Hardware in the loop: from here on the host sends the observations. `serve` never
    // returns; the constant `if` keeps the code below compiled (and free of warnings) in this
    // build too, and the optimiser drops it.
    #[cfg(feature = "hil")]
    if hil::SERVE {
        hil::serve(&booted, (slot_a, slot_b), (cal_insns, cal_ticks), scratch);
    }

    #[cfg(feature = "refine")]
    let mut refiner = match refine::Refiner::boot(slots::critic_region(), model) {
        Ok(r) => r,
        Err(e) => fail_critic(&e),
    };
    #[cfg(feature = "refine")]
    Line::new("REFINE").dec(refine::T as u32).emit();

    stack::paint(sp);
    let (n_obs, n_act) = sizes(model);
    let mut actions = [[0.0f32; MAX_ACT]; CASES];
    let mut obs = [0.0f32; MAX_OBS];
    let mut act_ticks = 0;
    for (k, action) in actions.iter_mut().enumerate() {
        let (obs, action) = (first(&mut obs, n_obs), first(action, n_act));
        observations::fill(k, obs);
        // Timed per observation, so the clock's figure leaves out the filling, as the marks do.
        let t0 = ticks();
        fw_mark(4);
        control_step(model, black_box(obs), scratch, action);
        #[cfg(feature = "refine")]
        if let Some(refined) = model.and_then(|m| refiner.step(m, obs, scratch)) {
            action.iter_mut().zip(refined).for_each(|(a, r)| *a = r);
        }
        fw_mark(5);
        act_ticks += elapsed(t0);
    }
    let act_stack = stack::used_below(sp);

    let tanh_sum = time_tanhf();

    report_slots(&booted);
    let running_slot = match booted.running {
        Some((SlotId::A, _)) => Some(slot_a),
        Some((SlotId::B, _)) => Some(slot_b),
        None => None,
    };
    let blob_bytes = running_slot
        .and_then(|s| slot::read(s).ok())
        .map_or(0, |r| r.blob.len());
    report(model, blob_bytes, &mut actions, sp, [boot_stack, act_stack]);
    Line::new("TICKS_CAL").dec(cal_insns).dec(cal_ticks).emit();
    Line::new("TICKS boot 1").dec(boot_ticks).emit();
    Line::new("TICKS act")
        .dec(CASES as u32)
        .dec(act_ticks)
        .emit();
    black_box(tanh_sum);
    match model {
        Some(model) => check_bounds(model, &actions),
        None => fail_boot(),
    }
    Line::new("DONE").emit();
    exit_ok()
}

/// Prints what became of each slot (`SLOT A running 3`, `SLOT B failed: <reason>`) and which
/// one runs (`RUNNING A`, `RUNNING B` or `RUNNING safe`).
fn report_slots(booted: &slot::Boot<Model<'_>>) {
    use core::fmt::Write;
    for (name, status) in [("SLOT A", booted.a), ("SLOT B", booted.b)] {
        let mut line = Line::new(name);
        match status {
            Status::Running { sequence } => line.push(" running").dec(sequence),
            Status::Standby { sequence } => line.push(" standby").dec(sequence),
            Status::Failed(e) => {
                let _ = write!(line.push(" failed: "), "{e}");
                &mut line
            }
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

/// Prints what the host needs to check and measure, in the order the spans were marked: each
/// observation and action at the blob's sizes (none in the safe state).
fn report(
    model: Option<&Model<'_>>,
    blob_bytes: usize,
    actions: &mut [[f32; MAX_ACT]],
    sp: usize,
    phases: [usize; 2],
) {
    if let Some(model) = model {
        let shape = model.header().shape;
        Line::new("SHAPE")
            .dec(shape.depth.into())
            .dec(shape.width.into())
            .dec(shape.observations.into())
            .dec(shape.actions.into())
            .emit();
    }
    Line::new("SCRATCH_BYTES")
        .dec(core::mem::size_of::<Scratch<W>>() as u32)
        .emit();
    Line::new("BLOB_BYTES").dec(blob_bytes as u32).emit();
    let (n_obs, n_act) = sizes(model);
    let mut obs = [0.0f32; MAX_OBS];
    for (k, act) in actions.iter_mut().enumerate() {
        let obs = first(&mut obs, n_obs);
        observations::fill(k, obs);
        values(Line::new("OBS").dec(k as u32), obs);
        values(Line::new("ACT").dec(k as u32), first(act, n_act));
    }
    Line::new("SPAN overhead 1").emit();
    Line::new("SPAN boot 1").emit();
    for k in 0..CASES {
        Line::new("SPAN act").dec(k as u32).emit();
    }
    Line::new("SPAN tanhf").dec(TANH_POINTS as u32).emit();
    Line::new("STACK_MAIN")
        .dec((stack::top() - sp) as u32)
        .emit();
    Line::new("STACK_PHASE boot").dec(phases[0] as u32).emit();
    Line::new("STACK_PHASE act").dec(phases[1] as u32).emit();
}

/// Emits `line` with each value's bits appended. Never inlined: unrolled for the buffers' eight
/// values at both call sites it cost about 0.8 KB of flash at opt-level 3.
#[inline(never)]
fn values(line: &mut Line, values: &[f32]) {
    for v in values {
        line.hex(v.to_bits());
    }
    line.emit();
}

/// `act` promises finite actions inside the blob's bounds for every observation; a firmware that
/// sees otherwise must not report success. ([`Model::action_bounds`] reads the bounds from the
/// payload's prefix, one pair per action the blob declares; `Model::values` would do too, but
/// links a decoding iterator of about 1 KB.)
fn check_bounds(model: &Model<'_>, actions: &[[f32; MAX_ACT]]) {
    let mut bounds = model.action_bounds();
    let bounds: [(f32, f32); MAX_ACT] =
        core::array::from_fn(|_| bounds.next().unwrap_or((f32::NAN, f32::NAN)));
    let n_act = sizes(Some(model)).1;
    for action in actions {
        let action = action.get(..n_act).unwrap_or_default();
        for (&a, &(lo, hi)) in action.iter().zip(&bounds) {
            if !a.is_finite() || !(lo..=hi).contains(&a) {
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

/// Ends a run whose critic (feature `refine`) cannot be used, with policy-core's reason.
#[cfg(feature = "refine")]
fn fail_critic(e: &policy_core::Error) -> ! {
    use core::fmt::Write;
    let mut line = Line::new("FAIL critic: ");
    let _ = write!(line, "{e}");
    line.emit();
    exit_failure()
}

/// Ends a run in which no slot could run (the `SLOT` lines above say why, with policy-core's
/// one-line reasons). The actions printed before it are the safe state's.
fn fail_boot() -> ! {
    Line::new("FAIL boot: no slot holds a policy this firmware can run (safe state)").emit();
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
