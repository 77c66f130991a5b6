//! `dcp_verify` and the `dcp_header` it fills: what a blob holds, after every check passed.

use core::ffi::c_char;

use policy_core::blob::LABEL_CAPACITY;
use policy_core::model::Model;
use policy_core::Activation;

use crate::buffers::{one, Raw};
use crate::status::{encoding_code, finish, kind_code, DcpError, Failure};

/// `DCP_ACTIVATION_*`: the hidden layers' activation.
pub const DCP_ACTIVATION_TANH: u32 = 0;
/// Rectified linear unit.
pub const DCP_ACTIVATION_RELU: u32 = 1;
/// Bytes of `dcp_header.label`: the format's 32-byte label and a NUL (a literal, for cbindgen).
pub const DCP_LABEL_LEN: usize = 33;
const _: () = assert!(DCP_LABEL_LEN == LABEL_CAPACITY + 1);

/// What a verified blob holds (`dcp_verify`, `dcp_model_header`).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct DcpHeader {
    /// Format version (1, 2 or 3).
    pub version: u32,
    /// `DCP_KIND_*`.
    pub kind: u32,
    /// `DCP_ENCODING_*`.
    pub encoding: u32,
    /// `DCP_ACTIVATION_*`.
    pub activation: u32,
    /// Observation size.
    pub observations: u32,
    /// Action size.
    pub actions: u32,
    /// Hidden layer width.
    pub width: u32,
    /// Hidden layers.
    pub depth: u32,
    /// Action-table rows of a discrete policy (0 otherwise).
    pub choices: u32,
    /// The scratch width the blob needs (its widest layer); a scratch holds twice as many floats.
    pub scratch_width: u32,
    /// The label's bytes (UTF-8), NUL-terminated.
    pub label: [c_char; DCP_LABEL_LEN],
    /// Zero: the three bytes that align `label_len`, named so that no byte of the struct is
    /// padding the library leaves unwritten.
    pub reserved: [u8; 3],
    /// The label's length in bytes, NUL excluded.
    pub label_len: u32,
    /// Payload bytes.
    pub payload_len: u32,
    /// The CRC-32 stored in the blob's last four bytes (checked equal to the computed one).
    pub crc: u32,
    /// Bytes of the whole blob: header, padding, payload, CRC.
    pub blob_len: u32,
}

impl DcpHeader {
    /// The header of `model`, loaded from exactly `blob`.
    pub(crate) fn of(model: &Model<'_>, blob: &[u8]) -> DcpHeader {
        let h = model.header();
        let s = &h.shape;
        let mut label = [0; DCP_LABEL_LEN];
        for (d, &b) in label.iter_mut().zip(h.label.as_bytes()) {
            *d = b as c_char;
        }
        let crc = blob.last_chunk::<4>().map_or(0, |c| u32::from_le_bytes(*c));
        DcpHeader {
            version: h.version.into(),
            kind: kind_code(h.kind),
            encoding: encoding_code(h.encoding),
            activation: match h.activation {
                Activation::Tanh => DCP_ACTIVATION_TANH,
                Activation::Relu => DCP_ACTIVATION_RELU,
            },
            observations: s.observations.into(),
            actions: s.actions.into(),
            width: s.width.into(),
            depth: s.depth.into(),
            choices: s.choices.into(),
            scratch_width: u32::try_from(model.scratch_width()).unwrap_or(u32::MAX),
            label,
            reserved: [0; 3],
            label_len: h.label.len() as u32,
            payload_len: h.payload_len,
            crc,
            blob_len: u32::try_from(blob.len()).unwrap_or(u32::MAX),
        }
    }
}

/// Verifies the `len` bytes at `blob` completely (what `dcp_model_load` checks: magic, version,
/// header, limits, length, CRC, every parameter) and writes what they hold to `*out`.
/// Returns `DCP_OK` or the first check that failed; `*out` is written only on success. `out`
/// is required: NULL gives `DCP_ERR_NULL_POINTER` without verifying (`dcp_model_load` verifies
/// as completely and keeps the model).
///
/// # Safety
/// `blob` is NULL or points to `len` readable bytes; `out` is NULL or points to a writable
/// `dcp_header`; `err` is NULL or points to a writable `dcp_error`.
#[no_mangle]
pub unsafe extern "C" fn dcp_verify(
    blob: *const u8,
    len: usize,
    out: *mut DcpHeader,
    err: *mut DcpError,
) -> i32 {
    let run = || -> Result<(), Failure> {
        let raw = Raw::new(blob, len, "blob")?;
        let out = one(out.cast_const(), "out")?;
        out.disjoint(&raw)?;
        // SAFETY: the caller's contract: `blob` points to `len` readable bytes, unchanged
        // during the call.
        let bytes = unsafe { raw.slice() };
        let model = Model::from_blob(bytes)?;
        let header = DcpHeader::of(&model, bytes);
        // SAFETY: checked non-NULL, aligned and disjoint from the blob; writable by contract.
        unsafe { out.put(header) };
        Ok(())
    };
    // SAFETY: `err` is NULL or writable, by the caller's contract.
    unsafe { finish(err, run) }
}
