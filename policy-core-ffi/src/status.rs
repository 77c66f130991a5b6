//! Status codes, the `dcp_error` out-struct and the code names: the C side of policy-core's one
//! error enum, plus the few misuses only a C caller can make.

use core::ffi::c_char;
use core::fmt::{self, Write};

use policy_core::{Encoding, Error, ModelKind};

/// Success.
pub const DCP_OK: i32 = 0;
/// policy-core `Error::WrongMagic`: not a blob (`found`: the first four bytes, little-endian).
pub const DCP_ERR_WRONG_MAGIC: i32 = -1;
/// `Error::UnsupportedVersion` (`expected`: the version read, `found`: the blob's).
pub const DCP_ERR_UNSUPPORTED_VERSION: i32 = -2;
/// `Error::WrongKind` (`expected`, `found`: `DCP_KIND_*`), e.g. `dcp_act` on a critic.
pub const DCP_ERR_WRONG_KIND: i32 = -3;
/// `Error::WrongEncoding` (`expected`, `found`: `DCP_ENCODING_*`).
pub const DCP_ERR_WRONG_ENCODING: i32 = -4;
/// `Error::EncodingNotCompiled` (`found`: `DCP_ENCODING_*`).
pub const DCP_ERR_ENCODING_NOT_COMPILED: i32 = -5;
/// `Error::ShapeMismatch` (the shapes are in the message).
pub const DCP_ERR_SHAPE_MISMATCH: i32 = -6;
/// `Error::Truncated` (`needed`, `found`: bytes).
pub const DCP_ERR_TRUNCATED: i32 = -7;
/// `Error::TrailingBytes` (`expected`, `found`: bytes).
pub const DCP_ERR_TRAILING_BYTES: i32 = -8;
/// `Error::Malformed` (`what`: which part of the header).
pub const DCP_ERR_MALFORMED: i32 = -9;
/// `Error::ChecksumMismatch` (`expected`: the stored CRC-32, `found`: the computed one).
pub const DCP_ERR_CHECKSUM_MISMATCH: i32 = -10;
/// `Error::NonFiniteParameter` (`index`: the parameter's index in the payload).
pub const DCP_ERR_NON_FINITE_PARAMETER: i32 = -11;
/// `Error::InvalidParameter` (`what`: the rule, `index`: the dimension).
pub const DCP_ERR_INVALID_PARAMETER: i32 = -12;
/// `Error::ShapeBeyondLimits` (`what`, `min`, `max`, `found`).
pub const DCP_ERR_SHAPE_BEYOND_LIMITS: i32 = -13;
/// `Error::SizeMismatch` (`what`, `expected`: the caller's size, `found`: the blob's).
pub const DCP_ERR_SIZE_MISMATCH: i32 = -14;
/// `Error::ScratchTooSmall` (`needed`: the width the blob needs, `found`: the scratch's width,
/// half its floats).
pub const DCP_ERR_SCRATCH_TOO_SMALL: i32 = -15;
/// `Error::BufferTooSmall` (`needed`, `found`: bytes).
pub const DCP_ERR_BUFFER_TOO_SMALL: i32 = -16;
/// `Error::SlotEmpty`: erased or blank flash.
pub const DCP_ERR_SLOT_EMPTY: i32 = -17;
/// `Error::SlotMagic` (`found`: the first four bytes, little-endian).
pub const DCP_ERR_SLOT_MAGIC: i32 = -18;
/// `Error::SlotHeaderChecksum` (`expected`: stored, `found`: computed).
pub const DCP_ERR_SLOT_HEADER_CHECKSUM: i32 = -19;
/// `Error::SlotOverflow` (`needed`: bytes, `found`: the slot's capacity).
pub const DCP_ERR_SLOT_OVERFLOW: i32 = -20;
/// A policy-core error this version of the C API has no code for (policy-core's `Error` is
/// `#[non_exhaustive]`: a variant added later maps here until it gets its own code). The
/// message still says what went wrong.
pub const DCP_ERR_OTHER: i32 = -99;
/// A pointer argument is NULL (`what`: the argument's name).
pub const DCP_ERR_NULL_POINTER: i32 = -100;
/// A pointer argument is not aligned for its type (`what`: the argument's name; a misaligned
/// `err` itself gets the code alone, since nothing can be written through it).
pub const DCP_ERR_MISALIGNED: i32 = -101;
/// A length runs past the end of the address space (`what`: the argument's name).
pub const DCP_ERR_BAD_LENGTH: i32 = -102;
/// Two buffers that must be distinct overlap (`what`: the two arguments).
pub const DCP_ERR_OVERLAP: i32 = -103;
/// A `dcp_model` that holds no model: never loaded (zeroed), or its last load failed.
pub const DCP_ERR_NOT_LOADED: i32 = -104;
/// `dcp_slot_choose`: neither slot holds a policy that runs here (each slot's reason is in the
/// `dcp_boot`); run the safe state.
pub const DCP_ERR_NO_SLOT: i32 = -105;
/// `dcp_abi_check`: the header the caller was compiled with is not this library's ABI version
/// (`expected`: the library's, `found`: the header's).
pub const DCP_ERR_ABI_MISMATCH: i32 = -106;

/// `DCP_KIND_*`: what a blob holds (`dcp_header.kind`, `DCP_ERR_WRONG_KIND`'s numbers).
pub const DCP_KIND_ACTOR: u32 = 0;
/// A critic Q(s, a).
pub const DCP_KIND_CRITIC: u32 = 1;
/// A discrete policy (an action table and a Q network).
pub const DCP_KIND_DISCRETE: u32 = 2;
/// `DCP_ENCODING_*`: how a blob stores its weights.
pub const DCP_ENCODING_F32: u32 = 0;
/// Half precision.
pub const DCP_ENCODING_F16: u32 = 1;
/// Signed bytes with an f32 scale per output.
pub const DCP_ENCODING_INT8: u32 = 2;
/// Integer arithmetic throughout (format version 4, actors only); loaded and run through the
/// float entry, `dcp_act`.
pub const DCP_ENCODING_INTEGER: u32 = 3;

/// Bytes of `dcp_error.what` (NUL included; longer text is cut).
pub const DCP_WHAT_LEN: usize = 80;
/// Bytes of `dcp_error.message` (NUL included; longer text is cut).
pub const DCP_MESSAGE_LEN: usize = 160;

/// What went wrong, for a caller that passes a non-NULL `dcp_error *`: the code the function
/// returned, the numbers of the error (the fields a variant does not have are 0), and policy-core's
/// one-line message. `what` and `message` are copied into the struct (policy-core's texts are
/// Rust strings, not NUL-terminated), always NUL-terminated, so the struct can outlive anything.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct DcpError {
    /// The status the function returned (`DCP_OK` on success).
    pub code: i32,
    /// Zero: the four bytes that align the `size_t` fields on 64-bit targets (present on every
    /// target, so that no byte of the struct is padding the library leaves unwritten).
    pub reserved: u32,
    /// `DCP_ERR_NON_FINITE_PARAMETER`: the parameter; `DCP_ERR_INVALID_PARAMETER`: the
    /// dimension.
    pub index: usize,
    /// What the caller (or the format) expected; see each code.
    pub expected: usize,
    /// What was found; see each code.
    pub found: usize,
    /// What was needed; see each code.
    pub needed: usize,
    /// `DCP_ERR_SHAPE_BEYOND_LIMITS`: the smallest allowed value.
    pub min: usize,
    /// `DCP_ERR_SHAPE_BEYOND_LIMITS`: the largest allowed value.
    pub max: usize,
    /// Which part, rule, size or argument (empty when the variant names none).
    pub what: [c_char; DCP_WHAT_LEN],
    /// policy-core's message, as the Rust firmware prints it.
    pub message: [c_char; DCP_MESSAGE_LEN],
}

/// Why a call failed, before it becomes a `DcpError`.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Failure {
    /// policy-core refused.
    Core(Error),
    /// The C caller's misuse: a `DCP_ERR_*` code and the argument it concerns.
    Api { code: i32, what: &'static str },
    /// A header of another ABI version than the library's.
    AbiMismatch { library: u32, header: u32 },
}

impl From<Error> for Failure {
    fn from(e: Error) -> Self {
        Failure::Core(e)
    }
}

impl Failure {
    pub(crate) const fn api(code: i32, what: &'static str) -> Self {
        Failure::Api { code, what }
    }

    pub(crate) fn code(&self) -> i32 {
        match self {
            Failure::Core(e) => code_of(e),
            Failure::Api { code, .. } => *code,
            Failure::AbiMismatch { .. } => DCP_ERR_ABI_MISMATCH,
        }
    }
}

/// The status code of a policy-core error. Codes are stable: a new policy-core variant gets a
/// new code, never another's.
pub fn code_of(e: &Error) -> i32 {
    match e {
        Error::WrongMagic { .. } => DCP_ERR_WRONG_MAGIC,
        Error::UnsupportedVersion { .. } => DCP_ERR_UNSUPPORTED_VERSION,
        Error::WrongKind { .. } => DCP_ERR_WRONG_KIND,
        Error::WrongEncoding { .. } => DCP_ERR_WRONG_ENCODING,
        Error::EncodingNotCompiled { .. } => DCP_ERR_ENCODING_NOT_COMPILED,
        Error::ShapeMismatch { .. } => DCP_ERR_SHAPE_MISMATCH,
        Error::Truncated { .. } => DCP_ERR_TRUNCATED,
        Error::TrailingBytes { .. } => DCP_ERR_TRAILING_BYTES,
        Error::Malformed { .. } => DCP_ERR_MALFORMED,
        Error::ChecksumMismatch { .. } => DCP_ERR_CHECKSUM_MISMATCH,
        Error::NonFiniteParameter { .. } => DCP_ERR_NON_FINITE_PARAMETER,
        Error::InvalidParameter { .. } => DCP_ERR_INVALID_PARAMETER,
        Error::ShapeBeyondLimits { .. } => DCP_ERR_SHAPE_BEYOND_LIMITS,
        Error::SizeMismatch { .. } => DCP_ERR_SIZE_MISMATCH,
        Error::ScratchTooSmall { .. } => DCP_ERR_SCRATCH_TOO_SMALL,
        Error::BufferTooSmall { .. } => DCP_ERR_BUFFER_TOO_SMALL,
        Error::SlotEmpty => DCP_ERR_SLOT_EMPTY,
        Error::SlotMagic { .. } => DCP_ERR_SLOT_MAGIC,
        Error::SlotHeaderChecksum { .. } => DCP_ERR_SLOT_HEADER_CHECKSUM,
        Error::SlotOverflow { .. } => DCP_ERR_SLOT_OVERFLOW,
        // `Error` is #[non_exhaustive]: a variant added to policy-core after this table still
        // compiles and reports DCP_ERR_OTHER with its message (the table test in
        // tests/api.rs lists every variant known today).
        _ => DCP_ERR_OTHER,
    }
}

/// Every code and its name, as `dcp_status_name` returns them.
const NAMES: [(i32, &core::ffi::CStr); 29] = [
    (DCP_OK, c"Ok"),
    (DCP_ERR_WRONG_MAGIC, c"WrongMagic"),
    (DCP_ERR_UNSUPPORTED_VERSION, c"UnsupportedVersion"),
    (DCP_ERR_WRONG_KIND, c"WrongKind"),
    (DCP_ERR_WRONG_ENCODING, c"WrongEncoding"),
    (DCP_ERR_ENCODING_NOT_COMPILED, c"EncodingNotCompiled"),
    (DCP_ERR_SHAPE_MISMATCH, c"ShapeMismatch"),
    (DCP_ERR_TRUNCATED, c"Truncated"),
    (DCP_ERR_TRAILING_BYTES, c"TrailingBytes"),
    (DCP_ERR_MALFORMED, c"Malformed"),
    (DCP_ERR_CHECKSUM_MISMATCH, c"ChecksumMismatch"),
    (DCP_ERR_NON_FINITE_PARAMETER, c"NonFiniteParameter"),
    (DCP_ERR_INVALID_PARAMETER, c"InvalidParameter"),
    (DCP_ERR_SHAPE_BEYOND_LIMITS, c"ShapeBeyondLimits"),
    (DCP_ERR_SIZE_MISMATCH, c"SizeMismatch"),
    (DCP_ERR_SCRATCH_TOO_SMALL, c"ScratchTooSmall"),
    (DCP_ERR_BUFFER_TOO_SMALL, c"BufferTooSmall"),
    (DCP_ERR_SLOT_EMPTY, c"SlotEmpty"),
    (DCP_ERR_SLOT_MAGIC, c"SlotMagic"),
    (DCP_ERR_SLOT_HEADER_CHECKSUM, c"SlotHeaderChecksum"),
    (DCP_ERR_SLOT_OVERFLOW, c"SlotOverflow"),
    (DCP_ERR_OTHER, c"Other"),
    (DCP_ERR_NULL_POINTER, c"NullPointer"),
    (DCP_ERR_MISALIGNED, c"Misaligned"),
    (DCP_ERR_BAD_LENGTH, c"BadLength"),
    (DCP_ERR_OVERLAP, c"Overlap"),
    (DCP_ERR_NOT_LOADED, c"NotLoaded"),
    (DCP_ERR_NO_SLOT, c"NoSlot"),
    (DCP_ERR_ABI_MISMATCH, c"AbiMismatch"),
];

/// The name of a status code, as policy-core names its error variants (`"ChecksumMismatch"`,
/// `"NullPointer"`, `"Ok"` for `DCP_OK`), or `"Unknown"`: a static NUL-terminated string, never
/// NULL.
#[no_mangle]
pub extern "C" fn dcp_status_name(code: i32) -> *const c_char {
    NAMES
        .iter()
        .find(|(c, _)| *c == code)
        .map_or(c"Unknown", |(_, name)| *name)
        .as_ptr()
}

/// Runs a call and writes its outcome into `*err` (unless `err` is NULL); returns its code. A
/// misaligned `err` is refused like every other misaligned pointer: `DCP_ERR_MISALIGNED`
/// before anything runs (nothing is written anywhere).
///
/// # Safety
/// `err` is NULL or points to memory writable as a `DcpError`.
pub(crate) unsafe fn finish(err: *mut DcpError, run: impl FnOnce() -> Result<(), Failure>) -> i32 {
    if !err.is_aligned() {
        return DCP_ERR_MISALIGNED;
    }
    let result = run();
    let code = match &result {
        Ok(()) => DCP_OK,
        Err(f) => f.code(),
    };
    if !err.is_null() {
        let out = describe(code, result.err());
        // SAFETY: `err` is non-NULL and aligned (checked above) and, by the caller's contract,
        // writable as a DcpError; `write` does not read the old (possibly uninitialised) value.
        unsafe { err.write(out) };
    }
    code
}

/// A `DcpError` for `code` and its failure.
pub(crate) fn describe(code: i32, failure: Option<Failure>) -> DcpError {
    let mut out = DcpError {
        code,
        reserved: 0,
        index: 0,
        expected: 0,
        found: 0,
        needed: 0,
        min: 0,
        max: 0,
        what: [0; DCP_WHAT_LEN],
        message: [0; DCP_MESSAGE_LEN],
    };
    let what = match failure {
        None => "",
        Some(Failure::Api { what, .. }) => {
            let name = NAMES.iter().find(|(c, _)| *c == code).map(|(_, n)| *n);
            let mut m = CText::new(&mut out.message);
            let _ = write!(
                m,
                "{}: {what}",
                name.and_then(|n| n.to_str().ok()).unwrap_or("error")
            );
            what
        }
        Some(Failure::AbiMismatch { library, header }) => {
            let _ = write!(
                CText::new(&mut out.message),
                "ABI mismatch: the library is ABI version {library}, the header {header}"
            );
            (out.expected, out.found) = (library as usize, header as usize);
            "ABI version"
        }
        Some(Failure::Core(e)) => {
            let _ = write!(CText::new(&mut out.message), "{e}");
            numbers(&e, &mut out)
        }
    };
    let _ = CText::new(&mut out.what).write_str(what);
    out
}

/// Fills the numbers a variant carries; returns its `what`.
fn numbers(e: &Error, out: &mut DcpError) -> &'static str {
    match *e {
        Error::WrongMagic { found } | Error::SlotMagic { found } => {
            out.found = u32::from_le_bytes(found) as usize;
        }
        Error::UnsupportedVersion { supported, found } => {
            (out.expected, out.found) = (supported.into(), found.into());
        }
        Error::WrongKind { expected, found } => {
            (out.expected, out.found) = (kind_code(expected) as usize, kind_code(found) as usize);
        }
        Error::WrongEncoding { expected, found } => {
            out.expected = encoding_code(expected) as usize;
            out.found = encoding_code(found) as usize;
        }
        Error::EncodingNotCompiled { found } => out.found = encoding_code(found) as usize,
        Error::Truncated { needed, found }
        | Error::ScratchTooSmall { needed, found }
        | Error::BufferTooSmall { needed, found } => (out.needed, out.found) = (needed, found),
        Error::SlotOverflow { needed, capacity } => (out.needed, out.found) = (needed, capacity),
        Error::TrailingBytes { expected, found } => (out.expected, out.found) = (expected, found),
        Error::ChecksumMismatch { stored, computed }
        | Error::SlotHeaderChecksum { stored, computed } => {
            (out.expected, out.found) = (stored as usize, computed as usize);
        }
        Error::NonFiniteParameter { index } => out.index = index,
        Error::InvalidParameter { what, index } => {
            out.index = index;
            return what;
        }
        Error::Malformed { what } => return what,
        Error::ShapeBeyondLimits {
            what,
            min,
            max,
            found,
        } => {
            (out.min, out.max, out.found) = (min, max, found);
            return what;
        }
        Error::SizeMismatch {
            what,
            expected,
            found,
        } => {
            (out.expected, out.found) = (expected, found);
            return what;
        }
        _ => {}
    }
    ""
}

/// `DCP_KIND_*` of a kind.
pub(crate) fn kind_code(kind: ModelKind) -> u32 {
    match kind {
        ModelKind::Actor => DCP_KIND_ACTOR,
        ModelKind::Critic => DCP_KIND_CRITIC,
        ModelKind::Discrete => DCP_KIND_DISCRETE,
    }
}

/// `DCP_ENCODING_*` of an encoding.
pub(crate) fn encoding_code(encoding: Encoding) -> u32 {
    match encoding {
        Encoding::F32 => DCP_ENCODING_F32,
        Encoding::F16 => DCP_ENCODING_F16,
        Encoding::Int8 => DCP_ENCODING_INT8,
        Encoding::Integer => DCP_ENCODING_INTEGER,
    }
}

/// Text into a fixed C char array: cut to fit, always NUL-terminated.
pub(crate) struct CText<'a> {
    buf: &'a mut [c_char],
    len: usize,
}

impl<'a> CText<'a> {
    pub(crate) fn new(buf: &'a mut [c_char]) -> Self {
        if let Some(first) = buf.first_mut() {
            *first = 0;
        }
        CText { buf, len: 0 }
    }
}

impl Write for CText<'_> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        let room = self.buf.len().saturating_sub(1);
        for &b in s.as_bytes() {
            if self.len >= room {
                break;
            }
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = b as c_char;
                self.len += 1;
            }
        }
        if let Some(end) = self.buf.get_mut(self.len) {
            *end = 0;
        }
        Ok(())
    }
}
