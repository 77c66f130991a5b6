//! The C API's ABI version and the sizes a firmware needs at compile time: a header from one
//! release linked against a library from another is refused with its own status instead of
//! misreading a struct, and a `static` scratch can be declared for a shape before anything runs.

use policy_core::blob::{MAX_ACTIONS, MAX_CHOICES, MAX_OBSERVATIONS, MAX_WIDTH};

use crate::status::{finish, DcpError, Failure};

/// The ABI version of this header and library. It changes when a change would make a program
/// compiled against one header misbehave with another library: a struct's layout, a function's
/// parameters or meaning, a status code's or constant's value. New functions and new codes for
/// new failures keep it. Check it once at boot with `DCP_ABI_CHECK(err)`.
pub const DCP_ABI_VERSION: u32 = 1;

/// The largest scratch width any blob the format allows needs: a critic's first layer reads the
/// most observations plus the most actions (a literal, for cbindgen).
pub const DCP_MAX_SCRATCH_WIDTH: usize = 1280;
const _: () = assert!(
    DCP_MAX_SCRATCH_WIDTH == MAX_OBSERVATIONS + MAX_ACTIONS
        && DCP_MAX_SCRATCH_WIDTH >= MAX_WIDTH
        && DCP_MAX_SCRATCH_WIDTH >= MAX_CHOICES
);

/// The ABI version the library was built with (`DCP_ABI_VERSION` of its own header).
#[no_mangle]
pub extern "C" fn dcp_abi_version() -> u32 {
    DCP_ABI_VERSION
}

/// Refuses a header whose ABI version is not the library's: `DCP_OK` when `header_version`
/// (pass `DCP_ABI_VERSION`, as the macro `DCP_ABI_CHECK(err)` does) is the library's, else
/// `DCP_ERR_ABI_MISMATCH` (`expected`: the library's version, `found`: the header's).
///
/// # Safety
/// `err` is NULL or points to a writable `dcp_error`.
#[no_mangle]
pub unsafe extern "C" fn dcp_abi_check(header_version: u32, err: *mut DcpError) -> i32 {
    let run = || {
        if header_version == DCP_ABI_VERSION {
            Ok(())
        } else {
            Err(Failure::AbiMismatch {
                library: DCP_ABI_VERSION,
                header: header_version,
            })
        }
    };
    // SAFETY: `err` is NULL or writable, by the caller's contract.
    unsafe { finish(err, run) }
}
