//! Hardware in the loop (feature `hil`): the firmware serves `act` over the board's serial link
//! (UART0 on the MPS2 boards, USART1 on the STM32F405; [`crate::board`]) to firmware-sim, which
//! runs the plant, the sensor and the actuator models on the host (firmware-sim's `run --hil`).
//! The messages and their frames are hil-protocol's, the crate the host compiles too.
//!
//! At boot it sends a hello (which slot runs, or the safe state and both slots' reasons; the
//! blob's sequence, CRC, shape and encoding; the SysTick calibration), then answers each
//! observation with the action [`control_step`] computes from flash and the SysTick ticks the
//! call took. It never ends: the host stops QEMU (or the board) when the run is over.
//!
//! The sizes are the running blob's (the hello's `observations` and `actions`): an observation
//! of another size is refused with both sizes in the reason. In the safe state there is no blob
//! and so no action size: every observation is answered with an empty action, which the host
//! applies as the zero action of its plant's size.

use core::fmt::Write;
use core::hint::black_box;

use hil_protocol::{
    decode, encode, Calibration, Encoding, FromChip, Hello, Reason, Receiver, Running, Slot,
    SlotState, ToChip, Values, MAX_FRAME,
};
use policy_core::model::{Model, Scratch};
use policy_core::slot::{self, Boot, SlotId, Status};

use crate::board::Link;
use crate::chip::{elapsed, ticks};
use crate::console::fail;
use crate::{control_step, first, fw_mark, sizes, MAX_ACT, MAX_OBS, W};

/// Always true: `main` serves the host instead of running the fixed observations.
pub const SERVE: bool = true;

/// Serves the host forever.
pub fn serve(
    booted: &Boot<Model<'static>>,
    slots: (&'static [u8], &'static [u8]),
    calibration: (u32, u32),
    scratch: &mut Scratch<W>,
) -> ! {
    let Some(mut uart) = Link::take() else {
        fail("no serial link to the host (the board's set-up did not finish)")
    };
    let hello = FromChip::Hello(hello(booted, slots, calibration));
    // A delimiter first: whatever half frame the host holds from before a reset ends here, so
    // the hello arrives whole and reads as the reset it is.
    uart.send(0);
    send(&mut uart, &hello);
    let model = booted.running.as_ref().map(|(_, model)| model);
    let mut rx = Receiver::new();
    loop {
        let byte = uart.receive();
        let Some(frame) = rx.push(byte) else {
            continue;
        };
        let answer = match frame.and_then(decode::<ToChip>) {
            Ok(ToChip::Hello) => hello.clone(),
            Ok(ToChip::Observe { tick, observation }) => {
                let (n_obs, n_act) = sizes(model);
                if model.is_some() && observation.len() != n_obs {
                    refused(
                        tick,
                        format_args!(
                            "observation size: the blob reads {n_obs}, found {}",
                            observation.len()
                        ),
                    )
                } else {
                    let mut action = [0.0; MAX_ACT];
                    let action = first(&mut action, n_act);
                    let t0 = ticks();
                    fw_mark(4);
                    control_step(model, black_box(&observation), scratch, action);
                    fw_mark(5);
                    let ticks = elapsed(t0);
                    FromChip::Action {
                        tick,
                        action: Values::from_slice(action).unwrap_or_default(),
                        ticks,
                    }
                }
            }
            // The host learns why its frame was refused (tick unknown: u32::MAX).
            Err(e) => refused(u32::MAX, format_args!("{e}")),
        };
        send(&mut uart, &answer);
    }
}

fn refused(tick: u32, why: core::fmt::Arguments<'_>) -> FromChip {
    let mut reason = Reason::new();
    let _ = reason.write_fmt(why);
    FromChip::Refused { tick, reason }
}

fn send(uart: &mut Link, message: &FromChip) {
    let mut buf = [0u8; MAX_FRAME];
    // Every message this firmware sends fits MAX_FRAME (reasons are capped); nothing to send
    // otherwise, and the host's tick timeout reports the silence.
    if let Ok(frame) = encode(message, &mut buf) {
        for &b in frame {
            uart.send(b);
        }
    }
}

fn hello(
    booted: &Boot<Model<'static>>,
    (slot_a, slot_b): (&'static [u8], &'static [u8]),
    (instructions, ticks): (u32, u32),
) -> Hello {
    let running = booted.running.as_ref().map(|(id, model)| {
        let (slot, bytes) = match id {
            SlotId::A => (Slot::A, slot_a),
            SlotId::B => (Slot::B, slot_b),
        };
        let record = slot::read(bytes).ok();
        let blob = record.as_ref().map_or(&[][..], |r| r.blob);
        let crc = blob
            .len()
            .checked_sub(4)
            .and_then(|at| blob.get(at..))
            .and_then(|b| <[u8; 4]>::try_from(b).ok())
            .map_or(0, u32::from_le_bytes);
        let header = model.header();
        Running {
            slot,
            sequence: record.map_or(0, |r| r.sequence),
            blob_crc: crc,
            blob_len: blob.len() as u32,
            depth: header.shape.depth,
            width: header.shape.width,
            observations: header.shape.observations,
            actions: header.shape.actions,
            encoding: match header.encoding {
                policy_core::Encoding::F32 => Encoding::F32,
                policy_core::Encoding::F16 => Encoding::F16,
                policy_core::Encoding::Int8 => Encoding::Int8,
                policy_core::Encoding::Integer => Encoding::Integer,
            },
        }
    });
    Hello {
        running,
        a: state(booted.a),
        b: state(booted.b),
        calibration: Calibration {
            instructions,
            ticks,
        },
    }
}

fn state(status: Status) -> SlotState {
    match status {
        Status::Running { sequence } => SlotState::Running { sequence },
        Status::Standby { sequence } => SlotState::Standby { sequence },
        Status::Failed(e) => {
            let mut reason = Reason::new();
            let _ = write!(reason, "{e}");
            SlotState::Failed { reason }
        }
    }
}

/// Every size a blob may have here fits a frame's values: checked when this builds.
const _: () = assert!(MAX_ACT <= hil_protocol::MAX_VALUES && MAX_OBS <= hil_protocol::MAX_VALUES);
