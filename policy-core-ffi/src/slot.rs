//! The A/B flash slot rule for C: `dcp_slot_choose` runs policy-core's `slot::choose` with
//! `Model::for_policy`, exactly what the Rust example firmware's `boot` does, and reports each
//! slot's fate; `dcp_slot_read` reads one slot record's header.

use policy_core::model::Model;
use policy_core::slot::{self, SlotId, Status};

use crate::buffers::{one, Raw};
use crate::model::{store, DcpModel};
use crate::status::{describe, finish, DcpError, Failure, DCP_ERR_NO_SLOT, DCP_OK};

/// `dcp_boot.running`: no slot runs (the safe state).
pub const DCP_SLOT_NONE: u32 = 0;
/// Slot A runs.
pub const DCP_SLOT_A: u32 = 1;
/// Slot B runs.
pub const DCP_SLOT_B: u32 = 2;
/// `dcp_slot_status.state`: the slot's blob verified and runs.
pub const DCP_SLOT_RUNNING: u32 = 1;
/// Its header is intact but the other, newer slot runs; its blob was not verified.
pub const DCP_SLOT_STANDBY: u32 = 2;
/// It cannot run: `error` says why.
pub const DCP_SLOT_FAILED: u32 = 3;

/// What became of one slot at boot.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct DcpSlotStatus {
    /// `DCP_SLOT_RUNNING`, `DCP_SLOT_STANDBY` or `DCP_SLOT_FAILED`.
    pub state: u32,
    /// The slot record's sequence number (running and standby; 0 when failed).
    pub sequence: u32,
    /// Why it failed (`code` is `DCP_OK` otherwise), with policy-core's message.
    pub error: DcpError,
}

/// The outcome of `dcp_slot_choose`.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct DcpBoot {
    /// `DCP_SLOT_A`, `DCP_SLOT_B` or `DCP_SLOT_NONE`.
    pub running: u32,
    /// Zero: the four bytes that align `a` on 64-bit targets (present on every target, so that
    /// no byte of the struct is padding the library leaves unwritten).
    pub reserved: u32,
    /// Slot A's fate.
    pub a: DcpSlotStatus,
    /// Slot B's fate.
    pub b: DcpSlotStatus,
}

fn status(s: Status) -> DcpSlotStatus {
    let (state, sequence, error) = match s {
        Status::Running { sequence } => (DCP_SLOT_RUNNING, sequence, describe(DCP_OK, None)),
        Status::Standby { sequence } => (DCP_SLOT_STANDBY, sequence, describe(DCP_OK, None)),
        Status::Failed(e) => {
            let f = Failure::Core(e);
            (DCP_SLOT_FAILED, 0, describe(f.code(), Some(f)))
        }
    };
    DcpSlotStatus {
        state,
        sequence,
        error,
    }
}

/// Picks the slot to run from the two slot regions (each a slot record: a 16-byte header, then
/// the blob; the region may be longer than the record): the newer slot whose blob passes
/// `dcp_model_for_policy(observations, actions, scratch_width)`, else the other, else none.
/// Writes each slot's fate to `*out` and the running slot's model to `*model`. Returns
/// `DCP_OK` when a slot runs, `DCP_ERR_NO_SLOT` when none does (`*model` then holds no model;
/// run the safe state), or a pointer error (then `*out` is not written).
///
/// A board with one slot passes NULL and 0 for the other: an absent slot is an empty one
/// (`DCP_ERR_SLOT_EMPTY` in its status), and the present slot runs if it verifies. NULL with a
/// non-zero length is `DCP_ERR_NULL_POINTER`.
///
/// # Safety
/// `slot_a` and `slot_b` are NULL or point to `a_len` and `b_len` readable bytes that outlive
/// every use of `*model` and do not change; `out` is NULL or a writable `dcp_boot`; `model` is
/// NULL or a writable `dcp_model`; `err` is NULL or a writable `dcp_error`.
#[no_mangle]
pub unsafe extern "C" fn dcp_slot_choose(
    slot_a: *const u8,
    a_len: usize,
    slot_b: *const u8,
    b_len: usize,
    observations: usize,
    actions: usize,
    scratch_width: usize,
    out: *mut DcpBoot,
    model: *mut DcpModel,
    err: *mut DcpError,
) -> i32 {
    let run = || -> Result<(), Failure> {
        let a = Raw::optional(slot_a, a_len, "slot_a")?;
        let b = Raw::optional(slot_b, b_len, "slot_b")?;
        let boot = one(out.cast_const(), "out")?;
        let storage = one(model.cast_const(), "model")?;
        for r in [&a, &b] {
            boot.disjoint(r)?;
            storage.disjoint(r)?;
        }
        boot.disjoint(&storage)?;
        // SAFETY: readable by contract, outliving the model and unchanged (hence 'static for
        // it).
        let (a, b): (&'static [u8], &'static [u8]) = unsafe { (a.slice(), b.slice()) };
        let chosen = slot::choose(a, b, |blob| {
            Model::for_policy(blob, observations, actions, scratch_width).map(|m| (blob, m))
        });
        let result = DcpBoot {
            running: match chosen.running {
                Some((SlotId::A, _)) => DCP_SLOT_A,
                Some((SlotId::B, _)) => DCP_SLOT_B,
                None => DCP_SLOT_NONE,
            },
            reserved: 0,
            a: status(chosen.a),
            b: status(chosen.b),
        };
        let runs = chosen.running.is_some();
        // SAFETY: `model` checked non-NULL and aligned; writable by contract.
        unsafe { store(model, chosen.running.map(|(_, loaded)| loaded)) };
        // SAFETY: checked non-NULL, aligned and disjoint from the other buffers; writable by
        // contract.
        unsafe { boot.put(result) };
        if runs {
            Ok(())
        } else {
            Err(Failure::api(
                DCP_ERR_NO_SLOT,
                "neither slot holds a policy that runs here",
            ))
        }
    };
    // SAFETY: `err` is NULL or writable, by the caller's contract.
    unsafe { finish(err, run) }
}

/// Reads one slot record's header (magic, header CRC, length): its sequence number into
/// `*sequence`, and where its blob is (`*blob`, inside the slot) and how long (`*blob_len`).
/// The blob itself is not verified (`dcp_verify` does that).
///
/// # Safety
/// `slot` is NULL or `len` readable bytes; `sequence`, `blob` and `blob_len` are NULL or
/// writable; `err` is NULL or a writable `dcp_error`.
#[no_mangle]
pub unsafe extern "C" fn dcp_slot_read(
    slot: *const u8,
    len: usize,
    sequence: *mut u32,
    blob: *mut *const u8,
    blob_len: *mut usize,
    err: *mut DcpError,
) -> i32 {
    let run = || -> Result<(), Failure> {
        let region = Raw::new(slot, len, "slot")?;
        let seq = one(sequence.cast_const(), "sequence")?;
        let at = one(blob.cast_const(), "blob")?;
        let n = one(blob_len.cast_const(), "blob_len")?;
        seq.disjoint(&region)?;
        at.disjoint(&region)?;
        n.disjoint(&region)?;
        seq.disjoint(&at)?;
        seq.disjoint(&n)?;
        at.disjoint(&n)?;
        // SAFETY: readable by contract; only read during the call.
        let record = slot::read(unsafe { region.slice() })?;
        // SAFETY: each checked non-NULL, aligned and disjoint from the others and the slot;
        // writable by contract.
        unsafe {
            seq.put(record.sequence);
            at.put(record.blob.as_ptr());
            n.put(record.blob.len());
        }
        Ok(())
    };
    // SAFETY: `err` is NULL or writable, by the caller's contract.
    unsafe { finish(err, run) }
}
