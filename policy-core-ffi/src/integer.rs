//! The integer entry of an integer-encoded actor (`DCP_ENCODING_INTEGER`): observation codes in,
//! unit codes out, integer arithmetic only, so a chip without an FPU calls no software float.
//! `dcp_act` runs the same actor from floats (it quantises the observation and dequantises the
//! action with a few float operations per component); these two functions split that into the
//! float-to-code step a sensor pipeline may do itself, and the integer forward pass.

use crate::buffers::Raw;
use crate::model::{loaded, DcpModel};
use crate::status::{finish, DcpError, Failure};

/// An integer actor's input codes for an observation: each component's int8 code in the blob's
/// input quantisation (the normaliser and the first layer's input scale folded into one
/// `round(x * scale + offset)`, clamped to int8; a NaN or infinite component gets the code of a
/// normalised 0), into `codes`. `obs_len` and `codes_len` must both be the blob's observation
/// size (`DCP_ERR_SIZE_MISMATCH`). On a model of another encoding: `DCP_ERR_WRONG_ENCODING`;
/// on a critic or discrete policy: `DCP_ERR_WRONG_KIND`. `codes` is written only on success.
///
/// # Safety
/// `model` is NULL or a zeroed or loaded `dcp_model` whose blob is still in place; `obs` is NULL
/// or `obs_len` readable floats; `codes` is NULL or `codes_len` writable bytes; `err` is NULL or
/// a writable `dcp_error`.
#[no_mangle]
pub unsafe extern "C" fn dcp_observation_codes(
    model: *const DcpModel,
    obs: *const f32,
    obs_len: usize,
    codes: *mut i8,
    codes_len: usize,
    err: *mut DcpError,
) -> i32 {
    let run = || -> Result<(), Failure> {
        // SAFETY: forwarded contract.
        let (m, blob, storage) = unsafe { loaded(model) }?;
        let obs = Raw::new(obs, obs_len, "obs")?;
        let codes = Raw::new(codes.cast_const(), codes_len, "codes")?;
        let blob = Raw::new(blob.as_ptr(), blob.len(), "model")?;
        codes.disjoint(&obs)?;
        codes.disjoint(&storage)?;
        codes.disjoint(&blob)?;
        // SAFETY: readable by contract; only read.
        let obs = unsafe { obs.slice() };
        // SAFETY: writable by contract; disjoint from every other buffer of the call (checked).
        let codes = unsafe { codes.slice_mut() };
        m.observation_codes(obs, codes)?;
        Ok(())
    };
    // SAFETY: `err` is NULL or writable, by the caller's contract.
    unsafe { finish(err, run) }
}

/// The integer forward pass of an integer actor: input `codes` (from `dcp_observation_codes`,
/// or a pipeline that produces them directly) to one unit code per action dimension in
/// `unit_codes`, each in -127..=127: the actuator's command `code / 127` of the unit box, which
/// `dcp_act` maps onto the blob's bounds. The same integers `dcp_act` computes.
///
/// `scratch` holds `scratch_len` `int32_t`, at least `dcp_scratch_floats` of them (the same
/// count as `dcp_act`'s floats; `DCP_ERR_SCRATCH_TOO_SMALL`). `codes_len` and `action_len`
/// must be the blob's sizes (`DCP_ERR_SIZE_MISMATCH`). On a model of another encoding:
/// `DCP_ERR_WRONG_ENCODING`; on a critic or discrete policy: `DCP_ERR_WRONG_KIND`. The buffers
/// must not overlap (`DCP_ERR_OVERLAP`); `unit_codes` is written only on success.
///
/// # Safety
/// `model` as `dcp_observation_codes`; `codes` is NULL or `codes_len` readable bytes; `scratch`
/// is NULL or `scratch_len` writable `int32_t`; `unit_codes` is NULL or `action_len` writable
/// bytes; `err` is NULL or a writable `dcp_error`.
#[no_mangle]
pub unsafe extern "C" fn dcp_act_codes(
    model: *const DcpModel,
    codes: *const i8,
    codes_len: usize,
    scratch: *mut i32,
    scratch_len: usize,
    unit_codes: *mut i8,
    action_len: usize,
    err: *mut DcpError,
) -> i32 {
    let run = || -> Result<(), Failure> {
        // SAFETY: forwarded contract.
        let (m, blob, storage) = unsafe { loaded(model) }?;
        let codes = Raw::new(codes, codes_len, "codes")?;
        let scratch = Raw::new(scratch.cast_const(), scratch_len, "scratch")?;
        let unit = Raw::new(unit_codes.cast_const(), action_len, "unit_codes")?;
        let blob = Raw::new(blob.as_ptr(), blob.len(), "model")?;
        scratch.disjoint(&codes)?;
        scratch.disjoint(&storage)?;
        scratch.disjoint(&blob)?;
        unit.disjoint(&codes)?;
        unit.disjoint(&storage)?;
        unit.disjoint(&blob)?;
        scratch.disjoint(&unit)?;
        // SAFETY: readable by contract; only read.
        let codes = unsafe { codes.slice() };
        // SAFETY: writable by contract; disjoint from every other buffer of the call (checked).
        let (scratch, unit) = unsafe { (scratch.slice_mut(), unit.slice_mut()) };
        m.act_codes_in(codes, scratch, unit)?;
        Ok(())
    };
    // SAFETY: `err` is NULL or writable, by the caller's contract.
    unsafe { finish(err, run) }
}
