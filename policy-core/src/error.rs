//! The one error type of policy-core.

use core::fmt;

use crate::format::{Encoding, ModelKind, Shape};

/// Everything that can go wrong when loading or writing a blob.
///
/// Every variant says what was expected and what was found, so a firmware log line or a CLI
/// message is enough to diagnose a bad blob without a debugger.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Error {
    /// The first four bytes are not the blob magic `DCPB`.
    WrongMagic {
        /// The four bytes found at the start.
        found: [u8; 4],
    },
    /// The blob's format version is not one this build reads.
    UnsupportedVersion {
        /// The version this build reads.
        supported: u16,
        /// The version in the blob.
        found: u16,
    },
    /// The blob holds an actor where a critic was asked for, or the reverse.
    WrongKind {
        /// The kind the caller asked for.
        expected: ModelKind,
        /// The kind in the blob.
        found: ModelKind,
    },
    /// The blob stores its weights in an encoding the caller cannot run: the compiled types
    /// ([`Policy`](crate::Policy), [`Critic`](crate::Critic)) hold f32 weights; the runtime
    /// [`Model`](crate::model::Model) runs every encoding.
    WrongEncoding {
        /// The encoding the caller runs.
        expected: Encoding,
        /// The encoding in the blob.
        found: Encoding,
    },
    /// The blob stores its weights in an encoding this build of policy-core does not read: its
    /// cargo feature (`f32`, `f16`, `int8` or `integer`, all on by default) was left out, as a firmware
    /// that runs one encoding only does to save flash.
    EncodingNotCompiled {
        /// The encoding in the blob.
        found: Encoding,
    },
    /// The blob's network shape differs from the compiled one.
    ShapeMismatch {
        /// The shape this code was compiled for.
        expected: Shape,
        /// The shape named by the blob.
        found: Shape,
    },
    /// The bytes end before the blob does.
    Truncated {
        /// Bytes the blob needs.
        needed: usize,
        /// Bytes given.
        found: usize,
    },
    /// The bytes go on after the blob's checksum.
    TrailingBytes {
        /// Bytes the blob occupies.
        expected: usize,
        /// Bytes given.
        found: usize,
    },
    /// The header cannot be decoded or contradicts itself.
    Malformed {
        /// Which part of the header is wrong.
        what: &'static str,
    },
    /// The CRC-32 stored in the blob differs from the one computed over its bytes.
    ChecksumMismatch {
        /// CRC-32 stored in the last four bytes.
        stored: u32,
        /// CRC-32 computed over the bytes before it.
        computed: u32,
    },
    /// A parameter is NaN or infinite.
    NonFiniteParameter {
        /// Index of the parameter in the payload (0 = first `f32` after the header).
        index: usize,
    },
    /// A parameter is finite but not allowed (for example an action bound with low > high).
    InvalidParameter {
        /// Which rule the parameter breaks.
        what: &'static str,
        /// Index of the offending component (observation or action dimension).
        index: usize,
    },
    /// The calibration an integer blob is written from is missing or unusable: a NaN or
    /// infinite observation or range, a range that is empty (a layer whose outputs never
    /// vary), or ranges of the wrong count (host side; a loader never returns it).
    Calibration {
        /// What is wrong.
        what: &'static str,
        /// Which sample, range or layer: the range's index (0 = the observations, `l + 1` =
        /// layer `l`), or the observation's, as `what` says.
        index: usize,
    },
    /// A shape is outside the format's documented limits (or the kind's rules).
    ShapeBeyondLimits {
        /// Which size.
        what: &'static str,
        /// The smallest allowed value.
        min: usize,
        /// The largest allowed value.
        max: usize,
        /// The value found.
        found: usize,
    },
    /// A firmware's (or caller's) observation or action size differs from the blob's.
    SizeMismatch {
        /// Which size.
        what: &'static str,
        /// The size the caller has.
        expected: usize,
        /// The size the blob declares.
        found: usize,
    },
    /// A blob declares more observations or actions than the caller's buffers hold (a firmware
    /// that takes its sizes from the blob, up to build-time maxima).
    SizeBeyondMaximum {
        /// Which size.
        what: &'static str,
        /// The most the caller takes.
        max: usize,
        /// The size the blob declares.
        found: usize,
    },
    /// The caller's scratch buffer is narrower than the blob's widest layer.
    ScratchTooSmall {
        /// Width the blob needs.
        needed: usize,
        /// Width of the scratch buffer.
        found: usize,
    },
    /// The output buffer is too small for the blob being written.
    BufferTooSmall {
        /// Bytes the blob needs.
        needed: usize,
        /// Bytes available.
        found: usize,
    },
    /// A flash slot holds no slot record: erased (all `0xFF`) or blank (all `0x00`).
    SlotEmpty,
    /// A flash slot does not start with the slot-record magic `DCPS`.
    SlotMagic {
        /// The four bytes found at the start of the slot.
        found: [u8; 4],
    },
    /// A slot record's header (magic, sequence number, length) fails its own CRC-32.
    SlotHeaderChecksum {
        /// CRC-32 stored in the header.
        stored: u32,
        /// CRC-32 computed over the header's first 12 bytes.
        computed: u32,
    },
    /// A slot record (header and blob) is longer than its slot.
    SlotOverflow {
        /// Bytes the record needs.
        needed: usize,
        /// Bytes the slot has.
        capacity: usize,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::WrongMagic { found } => {
                f.write_str("not a policy blob: expected magic \"DCPB\", found ")?;
                hex_bytes(f, found)
            }
            Error::UnsupportedVersion { supported, found } => {
                write!(f, "unsupported blob format version {found} (this build reads version {supported})")
            }
            Error::WrongKind { expected, found } => {
                write!(f, "wrong model kind: expected {expected}, found {found}")
            }
            Error::WrongEncoding { expected, found } => write!(
                f,
                "wrong weight encoding: this loader runs {expected} weights, the blob holds {found} (load it with the runtime Model)"
            ),
            Error::EncodingNotCompiled { found } => write!(
                f,
                "blob holds {found} weights, which this build does not read (policy-core built without its feature \"{}\")",
                found.feature()
            ),
            Error::ShapeMismatch { expected, found } => {
                write!(
                    f,
                    "shape mismatch: compiled for {expected}, blob holds {found}"
                )
            }
            Error::Truncated { needed, found } => {
                write!(f, "blob truncated: needs {needed} bytes, found {found}")
            }
            Error::TrailingBytes { expected, found } => {
                write!(
                    f,
                    "trailing bytes after the blob: expected {expected} bytes, found {found}"
                )
            }
            Error::Malformed { what } => write!(f, "malformed blob header: {what}"),
            Error::ChecksumMismatch { stored, computed } => write!(
                f,
                "checksum mismatch: stored CRC-32 {stored:#010x}, computed {computed:#010x}"
            ),
            Error::NonFiniteParameter { index } => {
                write!(f, "parameter {index} of the payload is NaN or infinite")
            }
            Error::InvalidParameter { what, index } => {
                write!(f, "invalid parameter in dimension {index}: {what}")
            }
            Error::Calibration { what, index } => {
                write!(f, "cannot calibrate (at {index}): {what}")
            }
            Error::ShapeBeyondLimits {
                what,
                min,
                max,
                found,
            } => write!(
                f,
                "shape beyond the format's limits: {what} must be in {min}..={max}, found {found}"
            ),
            Error::SizeMismatch {
                what,
                expected,
                found,
            } => write!(
                f,
                "{what} mismatch: the firmware has {expected}, the blob declares {found}"
            ),
            // Short enough for the HIL hello's 80-byte reason.
            Error::SizeBeyondMaximum { what, max, found } => write!(
                f,
                "{what} {found} beyond the firmware's maximum of {max}"
            ),
            Error::ScratchTooSmall { needed, found } => write!(
                f,
                "scratch buffer too small: the blob needs width {needed}, the buffer has {found}"
            ),
            Error::BufferTooSmall { needed, found } => {
                write!(
                    f,
                    "output buffer too small: needs {needed} bytes, found {found}"
                )
            }
            Error::SlotEmpty => write!(f, "empty slot: no slot record (erased or blank flash)"),
            Error::SlotMagic { found } => {
                f.write_str("not a slot record: expected magic \"DCPS\", found ")?;
                hex_bytes(f, found)
            }
            Error::SlotHeaderChecksum { stored, computed } => write!(
                f,
                "slot record header corrupted: stored CRC-32 {stored:#010x}, computed {computed:#010x}"
            ),
            Error::SlotOverflow { needed, capacity } => write!(
                f,
                "slot record does not fit its slot: needs {needed} bytes, the slot has {capacity}"
            ),
        }
    }
}

impl core::error::Error for Error {}

/// Writes bytes as `{:02x?}` does (`[44, 43, 50, 42]`) without the `Debug` builders, whose
/// padding adapter and list machinery cost a firmware about 0.4 KB of flash for two messages.
fn hex_bytes(f: &mut fmt::Formatter<'_>, bytes: &[u8]) -> fmt::Result {
    f.write_str("[")?;
    for (i, b) in bytes.iter().enumerate() {
        if i > 0 {
            f.write_str(", ")?;
        }
        write!(f, "{b:02x}")?;
    }
    f.write_str("]")
}

#[cfg(test)]
mod tests {
    use super::*;

    // The magic messages are read by people and matched by scripts: the hand-written hex must
    // print exactly what `{:02x?}` printed.
    #[test]
    fn magic_bytes_print_as_debug_hex_did() {
        for found in [*b"DCPB", [0, 0xff, 0x0a, 0x80], [0; 4]] {
            assert_eq!(
                Error::WrongMagic { found }.to_string(),
                format!("not a policy blob: expected magic \"DCPB\", found {found:02x?}")
            );
            assert_eq!(
                Error::SlotMagic { found }.to_string(),
                format!("not a slot record: expected magic \"DCPS\", found {found:02x?}")
            );
        }
    }

    #[test]
    fn a_size_beyond_the_maximum_fits_the_hil_reason() {
        let e = Error::SizeBeyondMaximum {
            what: "observation size",
            max: 8,
            found: 65535,
        };
        assert_eq!(
            e.to_string(),
            "observation size 65535 beyond the firmware's maximum of 8"
        );
        assert!(e.to_string().len() <= 80);
    }

    #[test]
    fn an_encoding_not_compiled_in_names_its_feature() {
        let e = Error::EncodingNotCompiled {
            found: Encoding::F16,
        };
        assert!(e.to_string().contains("f16 weights"), "{e}");
        assert!(e.to_string().contains("feature \"f16\""), "{e}");
    }
}
