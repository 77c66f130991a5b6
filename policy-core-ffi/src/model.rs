//! `dcp_model`: a verified model in caller-provided storage, and running it.
//!
//! The storage is an opaque, 8-aligned byte array the C side allocates where it likes (a
//! `static`, the stack). Inside it: a tag word, the [`Model`] (a header and a view of the
//! blob's payload) and the blob's bytes as a slice. The tag is written last by a successful load
//! and cleared first by every load, so a zeroed storage, or one whose last load failed, is
//! `DCP_ERR_NOT_LOADED`, never a model built from garbage.

use policy_core::model::Model;
use policy_core::{Error, ModelKind};

use crate::buffers::{one, Raw};
use crate::header::DcpHeader;
use crate::status::{finish, DcpError, Failure, DCP_ERR_NOT_LOADED};

/// Bytes of a `dcp_model`'s storage: room for the model on 32- and 64-bit targets with a
/// margin (a compile-time assertion checks it on every target built).
pub const DCP_MODEL_BYTES: usize = 256;

/// Storage for one loaded model. Zero it before first use (`dcp_model m = {0};` or a `static`),
/// then fill it with `dcp_model_load` or `dcp_model_for_policy`. It may be copied with `memcpy`
/// (the copy is the same model); it holds no pointer to itself.
#[repr(C, align(8))]
#[derive(Debug)]
pub struct DcpModel {
    /// Opaque: only this library reads or writes it.
    pub opaque: [u8; DCP_MODEL_BYTES],
}

/// What the storage holds after a successful load.
#[repr(C)]
struct Stored {
    tag: u64,
    model: Model<'static>,
    blob: &'static [u8],
}

/// "DCPMODEL": the tag of a loaded storage.
const TAG: u64 = u64::from_le_bytes(*b"DCPMODEL");

const _: () = assert!(
    size_of::<Stored>() <= DCP_MODEL_BYTES && align_of::<Stored>() <= align_of::<DcpModel>(),
    "DCP_MODEL_BYTES is too small for this target: raise it (the C header changes with it)"
);

/// Verifies the `len` bytes at `blob` (as `dcp_verify`) and fills `*model` with a model that
/// reads its weights from those bytes. Any kind loads (actor, critic, discrete policy).
///
/// The blob's bytes must stay where they are, unchanged, for as long as the model is used (a
/// blob in flash does). On failure `*model` holds no model (`DCP_ERR_NOT_LOADED` afterwards).
///
/// # Safety
/// `blob` is NULL or points to `len` readable bytes that outlive every use of `*model` and do
/// not change; `model` is NULL or points to a writable `dcp_model`; `err` is NULL or points to
/// a writable `dcp_error`.
#[no_mangle]
pub unsafe extern "C" fn dcp_model_load(
    blob: *const u8,
    len: usize,
    model: *mut DcpModel,
    err: *mut DcpError,
) -> i32 {
    // SAFETY: forwarded contract (see above).
    unsafe { load(blob, len, model, err, Model::from_blob) }
}

/// As `dcp_model_load`, for a policy this firmware can run: an actor or a discrete policy (not
/// a critic) with `observations` inputs and `actions` outputs whose widest layer fits a scratch
/// of `scratch_width` floats per half (`2 * scratch_width` floats in all). policy-core's
/// `Model::for_policy`: the check the Rust example firmware runs at boot.
///
/// # Safety
/// As `dcp_model_load`.
#[no_mangle]
pub unsafe extern "C" fn dcp_model_for_policy(
    blob: *const u8,
    len: usize,
    observations: usize,
    actions: usize,
    scratch_width: usize,
    model: *mut DcpModel,
    err: *mut DcpError,
) -> i32 {
    // SAFETY: forwarded contract (see above).
    unsafe {
        load(blob, len, model, err, |b| {
            Model::for_policy(b, observations, actions, scratch_width)
        })
    }
}

/// The loads' common path: clear the tag, verify, store.
///
/// # Safety
/// As `dcp_model_load`.
unsafe fn load(
    blob: *const u8,
    len: usize,
    model: *mut DcpModel,
    err: *mut DcpError,
    verify: impl FnOnce(&'static [u8]) -> Result<Model<'static>, Error>,
) -> i32 {
    let run = || -> Result<(), Failure> {
        let storage = one(model.cast_const(), "model")?;
        // SAFETY: `storage` is non-NULL and aligned (checked), writable by the caller's
        // contract; clearing the tag first means a failed load leaves no model behind.
        unsafe { clear(model) };
        let raw = Raw::new(blob, len, "blob")?;
        storage.disjoint(&raw)?;
        // SAFETY: the caller's contract: `len` readable bytes that outlive every use of the
        // model and do not change, hence 'static for the model's purposes.
        let bytes: &'static [u8] = unsafe { raw.slice() };
        let loaded = verify(bytes)?;
        // SAFETY: checked non-NULL and aligned above; writable by contract.
        unsafe { put(model, bytes, loaded) };
        Ok(())
    };
    // SAFETY: `err` is NULL or writable, by the caller's contract.
    unsafe { finish(err, run) }
}

/// Writes a zero tag into a storage.
///
/// # Safety
/// `model` is non-NULL, aligned and writable.
unsafe fn clear(model: *mut DcpModel) {
    // SAFETY: the tag is the first 8 bytes of an 8-aligned storage of DCP_MODEL_BYTES >= 8.
    unsafe { model.cast::<u64>().write(0) };
}

/// Stores a loaded model, tag last.
///
/// # Safety
/// `model` is non-NULL, aligned and writable.
unsafe fn put(model: *mut DcpModel, blob: &'static [u8], loaded: Model<'static>) {
    let stored = Stored {
        tag: TAG,
        model: loaded,
        blob,
    };
    // SAFETY: `model` is non-NULL, aligned (8, which Stored's alignment does not exceed,
    // asserted at compile time, as its size fits DCP_MODEL_BYTES) and writable (this function's
    // contract); `write` does not drop the old bytes (a Stored has no destructor).
    unsafe { model.cast::<Stored>().write(stored) };
}

/// The model in a storage, after checking the pointer and the tag.
///
/// # Safety
/// `model` is NULL or points to a readable `dcp_model` that was zeroed or loaded, and that
/// nothing writes while the returned references live.
pub(crate) unsafe fn loaded<'a>(
    model: *const DcpModel,
) -> Result<(&'a Model<'static>, &'static [u8], Raw<DcpModel>), Failure> {
    let storage = one(model, "model")?;
    // SAFETY: non-NULL and aligned (checked); readable and initialised (zeroed or loaded) by
    // the caller's contract; the tag is the first 8 bytes.
    let tag = unsafe { model.cast::<u64>().read() };
    if tag != TAG {
        return Err(Failure::api(DCP_ERR_NOT_LOADED, "model"));
    }
    // SAFETY: the tag is written only by `put`, after a whole valid `Stored`, and cleared before
    // any other write, so a tagged storage holds a valid Stored; nothing writes it while the
    // reference lives (the caller's contract).
    let stored = unsafe { &*model.cast::<Stored>() };
    Ok((&stored.model, stored.blob, storage))
}

/// Writes the loaded model's header (as `dcp_verify` gives it) to `*out`.
///
/// # Safety
/// `model` is NULL or points to a zeroed or loaded `dcp_model`; `out` is NULL or points to a
/// writable `dcp_header`; `err` is NULL or points to a writable `dcp_error`.
#[no_mangle]
pub unsafe extern "C" fn dcp_model_header(
    model: *const DcpModel,
    out: *mut DcpHeader,
    err: *mut DcpError,
) -> i32 {
    let run = || -> Result<(), Failure> {
        // SAFETY: forwarded contract.
        let (m, blob, storage) = unsafe { loaded(model) }?;
        let out = one(out.cast_const(), "out")?;
        out.disjoint(&storage)?;
        let header = DcpHeader::of(m, blob);
        // SAFETY: non-NULL, aligned, disjoint from the model; writable by contract.
        unsafe { out.put(header) };
        Ok(())
    };
    // SAFETY: `err` is NULL or writable, by the caller's contract.
    unsafe { finish(err, run) }
}

/// The floats a scratch for this model must hold (`2 * scratch width`), into `*out`.
///
/// # Safety
/// `model` is NULL or points to a zeroed or loaded `dcp_model`; `out` is NULL or points to a
/// writable `size_t`; `err` is NULL or points to a writable `dcp_error`.
#[no_mangle]
pub unsafe extern "C" fn dcp_scratch_floats(
    model: *const DcpModel,
    out: *mut usize,
    err: *mut DcpError,
) -> i32 {
    let run = || -> Result<(), Failure> {
        // SAFETY: forwarded contract.
        let (m, _, _) = unsafe { loaded(model) }?;
        let out = one(out.cast_const(), "out")?;
        // SAFETY: non-NULL and aligned (checked); writable by contract.
        unsafe { out.put(m.scratch_floats()) };
        Ok(())
    };
    // SAFETY: `err` is NULL or writable, by the caller's contract.
    unsafe { finish(err, run) }
}

/// The buffers of one forward pass, checked: the observation, the scratch, and the model with
/// its blob, all pairwise disjoint from the scratch.
struct Pass<'a> {
    model: &'a Model<'static>,
    obs: &'a [f32],
    scratch: &'a mut [f32],
}

/// Checks a pass's pointers; `outputs` are the other buffers the pass writes (disjoint from all).
///
/// # Safety
/// The pointers as the public functions' contracts say.
unsafe fn pass<'a>(
    model: *const DcpModel,
    obs: *const f32,
    obs_len: usize,
    scratch: *mut f32,
    scratch_len: usize,
    outputs: &[Raw<f32>],
) -> Result<Pass<'a>, Failure> {
    // SAFETY: forwarded contract.
    let (m, blob, storage) = unsafe { loaded(model) }?;
    let obs = Raw::new(obs, obs_len, "obs")?;
    let scratch = Raw::new(scratch.cast_const(), scratch_len, "scratch")?;
    let blob = Raw::new(blob.as_ptr(), blob.len(), "model")?;
    for out in outputs.iter().chain([&scratch]) {
        out.disjoint(&storage)?;
        out.disjoint(&blob)?;
        out.disjoint(&obs)?;
    }
    for (i, a) in outputs.iter().enumerate() {
        scratch.disjoint(a)?;
        for b in outputs.iter().skip(i + 1) {
            a.disjoint(b)?;
        }
    }
    Ok(Pass {
        model: m,
        // SAFETY: readable by contract; only read.
        obs: unsafe { obs.slice() },
        // SAFETY: writable by contract; disjoint from every other buffer of the call (checked).
        scratch: unsafe { scratch.slice_mut() },
    })
}

/// The action for an observation (an actor, or a discrete policy's table row): finite and
/// inside the blob's bounds for every input, NaN and infinities included. `obs_len` and
/// `action_len` must be the blob's sizes (`DCP_ERR_SIZE_MISMATCH`); `scratch` holds
/// `scratch_len` floats, at least `dcp_scratch_floats` (`DCP_ERR_SCRATCH_TOO_SMALL`); on a
/// critic: `DCP_ERR_WRONG_KIND`. `action` is written only on success. `obs`, `scratch` and
/// `action` must not overlap one another, so an action cannot be written over its own
/// observation (`DCP_ERR_OVERLAP`; copy the observation first).
///
/// # Safety
/// `model` is NULL or a zeroed or loaded `dcp_model` whose blob is still in place; `obs` is NULL
/// or `obs_len` readable floats; `scratch` and `action` are NULL or `scratch_len` and
/// `action_len` writable floats; `err` is NULL or a writable `dcp_error`.
#[no_mangle]
pub unsafe extern "C" fn dcp_act(
    model: *const DcpModel,
    obs: *const f32,
    obs_len: usize,
    scratch: *mut f32,
    scratch_len: usize,
    action: *mut f32,
    action_len: usize,
    err: *mut DcpError,
) -> i32 {
    let run = || -> Result<(), Failure> {
        let action = Raw::new(action.cast_const(), action_len, "action")?;
        // SAFETY: forwarded contract.
        let p = unsafe { pass(model, obs, obs_len, scratch, scratch_len, &[action]) }?;
        // SAFETY: writable by contract; disjoint from every other buffer (checked in `pass`).
        let action = unsafe { action.slice_mut() };
        p.model.act_in(p.obs, p.scratch, action)?;
        Ok(())
    };
    // SAFETY: `err` is NULL or writable, by the caller's contract.
    unsafe { finish(err, run) }
}

/// A critic's Q(s, a) for an observation and a unit-box action (clamped into the box; a
/// non-finite component reads as 0), into `*q`. On an actor or discrete policy:
/// `DCP_ERR_WRONG_KIND`. Sizes and scratch as `dcp_act`.
///
/// # Safety
/// As `dcp_act`; `unit_action` is NULL or `action_len` readable floats; `q` is NULL or a
/// writable float.
#[no_mangle]
pub unsafe extern "C" fn dcp_q(
    model: *const DcpModel,
    obs: *const f32,
    obs_len: usize,
    unit_action: *const f32,
    action_len: usize,
    scratch: *mut f32,
    scratch_len: usize,
    q: *mut f32,
    err: *mut DcpError,
) -> i32 {
    let run = || -> Result<(), Failure> {
        let unit = Raw::new(unit_action, action_len, "unit_action")?;
        let q = one(q.cast_const(), "q")?;
        // SAFETY: forwarded contract.
        let p = unsafe { pass(model, obs, obs_len, scratch, scratch_len, &[q]) }?;
        let scratch_raw = Raw::new(p.scratch.as_ptr(), p.scratch.len(), "scratch")?;
        unit.disjoint(&scratch_raw)?;
        unit.disjoint(&q)?;
        // SAFETY: readable by contract; disjoint from the buffers written (checked).
        let unit = unsafe { unit.slice() };
        let value = p.model.q_in(p.obs, unit, p.scratch)?;
        // SAFETY: writable by contract; disjoint from every other buffer (checked).
        unsafe { q.put(value) };
        Ok(())
    };
    // SAFETY: `err` is NULL or writable, by the caller's contract.
    unsafe { finish(err, run) }
}

/// A discrete policy's choice, the row index of the largest Q value (ties and NaN: the lowest
/// index), into `*index`. On an actor or critic: `DCP_ERR_WRONG_KIND`.
///
/// # Safety
/// As `dcp_act`; `index` is NULL or a writable `uint32_t`.
#[no_mangle]
pub unsafe extern "C" fn dcp_choose(
    model: *const DcpModel,
    obs: *const f32,
    obs_len: usize,
    scratch: *mut f32,
    scratch_len: usize,
    index: *mut u32,
    err: *mut DcpError,
) -> i32 {
    let run = || -> Result<(), Failure> {
        let index = one(index.cast_const(), "index")?;
        let as_floats = Raw::new(index.ptr().cast::<f32>(), 1, "index")?;
        // SAFETY: forwarded contract.
        let p = unsafe { pass(model, obs, obs_len, scratch, scratch_len, &[as_floats]) }?;
        let row = p.model.choose_in(p.obs, p.scratch)?;
        // SAFETY: writable by contract; disjoint from every other buffer (checked).
        unsafe { index.put(u32::try_from(row).unwrap_or(u32::MAX)) };
        Ok(())
    };
    // SAFETY: `err` is NULL or writable, by the caller's contract.
    unsafe { finish(err, run) }
}

/// A discrete policy's Q value of every action-table row, `q[k]` for row `k`, as computed (NaN
/// as it comes): the values `dcp_choose` takes its argmax of, for a port or a log to compare.
/// `q_len` must be the blob's `choices` (`DCP_ERR_SIZE_MISMATCH`, `what` = `"choice count"`).
/// On an actor or critic: `DCP_ERR_WRONG_KIND`. Sizes and scratch as `dcp_act`; `q` is written
/// only on success and must not overlap `obs` or `scratch`.
///
/// # Safety
/// As `dcp_act`; `q` is NULL or `q_len` writable floats.
#[no_mangle]
pub unsafe extern "C" fn dcp_choice_q(
    model: *const DcpModel,
    obs: *const f32,
    obs_len: usize,
    scratch: *mut f32,
    scratch_len: usize,
    q: *mut f32,
    q_len: usize,
    err: *mut DcpError,
) -> i32 {
    let run = || -> Result<(), Failure> {
        let q = Raw::new(q.cast_const(), q_len, "q")?;
        // SAFETY: forwarded contract.
        let p = unsafe { pass(model, obs, obs_len, scratch, scratch_len, &[q]) }?;
        // SAFETY: writable by contract; disjoint from every other buffer (checked in `pass`).
        let q = unsafe { q.slice_mut() };
        p.model.choice_values_in(p.obs, p.scratch, q)?;
        Ok(())
    };
    // SAFETY: `err` is NULL or writable, by the caller's contract.
    unsafe { finish(err, run) }
}

/// The action bounds of an actor or discrete policy, `low[i]` and `high[i]` for each of its
/// `len` action dimensions (`len` must be the blob's action size). On a critic:
/// `DCP_ERR_WRONG_KIND`.
///
/// # Safety
/// `model` as `dcp_act`; `low` and `high` are NULL or `len` writable floats each; `err` is NULL
/// or a writable `dcp_error`.
#[no_mangle]
pub unsafe extern "C" fn dcp_action_bounds(
    model: *const DcpModel,
    low: *mut f32,
    high: *mut f32,
    len: usize,
    err: *mut DcpError,
) -> i32 {
    let run = || -> Result<(), Failure> {
        // SAFETY: forwarded contract.
        let (m, _, storage) = unsafe { loaded(model) }?;
        let (lo, hi) = (
            Raw::new(low.cast_const(), len, "low")?,
            Raw::new(high.cast_const(), len, "high")?,
        );
        lo.disjoint(&hi)?;
        lo.disjoint(&storage)?;
        hi.disjoint(&storage)?;
        let kind = m.header().kind;
        if kind == ModelKind::Critic {
            return Err(Error::WrongKind {
                expected: ModelKind::Actor,
                found: kind,
            }
            .into());
        }
        m.expect_sizes(m.header().shape.observations.into(), len)?;
        // SAFETY: writable by contract; disjoint from each other and the model (checked).
        let (lo, hi) = unsafe { (lo.slice_mut(), hi.slice_mut()) };
        for ((l, h), (bl, bh)) in lo.iter_mut().zip(hi.iter_mut()).zip(m.action_bounds()) {
            (*l, *h) = (bl, bh);
        }
        Ok(())
    };
    // SAFETY: `err` is NULL or writable, by the caller's contract.
    unsafe { finish(err, run) }
}

/// For the slot rule: stores a model loaded elsewhere (`dcp_slot_choose`), or clears.
///
/// # Safety
/// `model` is non-NULL, aligned and writable (checked by the caller with `one`).
pub(crate) unsafe fn store(model: *mut DcpModel, value: Option<(&'static [u8], Model<'static>)>) {
    // SAFETY: forwarded contract.
    unsafe { clear(model) };
    if let Some((blob, m)) = value {
        // SAFETY: forwarded contract.
        unsafe { put(model, blob, m) };
    }
}
