//! # hil-protocol
//!
//! The messages between firmware-sim (the host: plant, sensor and actuator models) and the HIL
//! firmware (`firmware/`, feature `hil`: the chip computes every action), and how they travel.
//! One `no_std`, allocation-free crate that both sides compile, so the two can never disagree on
//! a message's layout.
//!
//! ## Frames
//!
//! A frame is a postcard envelope — the protocol [`VERSION`] and the message, itself
//! postcard bytes — followed by the CRC-32 (ISO-HDLC, little-endian) of those bytes, the whole
//! COBS-encoded and ended by a `0x00` byte. postcard's own flavors build it (`CrcModifier`
//! inside `Cobs`), and [`decode`] undoes it: COBS, then the CRC, then the version, then the
//! message. The version sits in the envelope rather than in the message so that it can always be
//! read, whatever a later version does to the messages: a frame of another version is refused
//! as [`Error::Version`], not misread.
//!
//! ## Conversation
//!
//! At boot the chip sends [`FromChip::Hello`]: which slot runs (or the safe state and both
//! slots' reasons), its sequence, the blob's CRC, shape and weight encoding, and the SysTick
//! calibration. The host sends [`ToChip::Observe`] for each tick; the chip answers
//! [`FromChip::Action`] with the same tick number, the action and the SysTick ticks `act` took,
//! or [`FromChip::Refused`] (an observation of the wrong size). Both sizes are the running
//! blob's, as the hello reports them. [`ToChip::Hello`] asks for the
//! hello again (a board that booted before the host opened the port). A hello that arrives
//! unasked means the chip reset.
//!
//! ```
//! use hil_protocol::{decode, encode, FromChip, Values, MAX_FRAME};
//! let sent = FromChip::Action { tick: 7, action: Values::from_slice(&[0.25, f32::NAN]).unwrap(), ticks: 93 };
//! let mut buf = [0u8; MAX_FRAME];
//! let frame = encode(&sent, &mut buf).unwrap();
//! assert_eq!(frame.last(), Some(&0)); // the delimiter; no other zero byte
//! assert!(!frame[..frame.len() - 1].contains(&0));
//! let mut wire = frame[..frame.len() - 1].to_vec();
//! let got: FromChip = decode(&mut wire).unwrap();
//! // Bit for bit, NaN included.
//! match got {
//!     FromChip::Action { tick: 7, action, ticks: 93 } => {
//!         assert_eq!(action[0].to_bits(), 0.25f32.to_bits());
//!         assert_eq!(action[1].to_bits(), f32::NAN.to_bits());
//!     }
//!     other => panic!("{other:?}"),
//! }
//! ```
#![no_std]
#![deny(missing_docs)]

use postcard::ser_flavors::{crc::CrcModifier, Cobs, Slice};
use serde::{Deserialize, Serialize};

/// The protocol version every frame carries. Raised whenever a message changes.
pub const VERSION: u16 = 1;
/// The most values an observation or action holds (the example firmware's most observations).
pub const MAX_VALUES: usize = 16;
/// The longest encoded frame, delimiter included (a hello with two long reasons is about 200).
pub const MAX_FRAME: usize = 256;
/// The most bytes of a slot's failure reason (policy-core's one-line errors; longer is cut).
pub const REASON_CAPACITY: usize = 80;

/// An observation or an action.
pub type Values = heapless::Vec<f32, MAX_VALUES>;
/// A slot's failure reason.
pub type Reason = heapless::String<REASON_CAPACITY>;

/// What the host sends.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum ToChip {
    /// Send the hello again.
    Hello,
    /// Run `act` on this observation.
    Observe {
        /// The host's tick number, echoed in the answer.
        tick: u32,
        /// The sensor reading, as the firmware's sensors would give it.
        observation: Values,
    },
}

/// What the chip sends.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum FromChip {
    /// At boot, and when asked: what runs.
    Hello(Hello),
    /// The answer to [`ToChip::Observe`].
    Action {
        /// The tick number of the observation.
        tick: u32,
        /// The action, of the running blob's size; empty if no slot runs (the safe state: the
        /// chip has no blob, so no action size, and the host applies the zero action).
        action: Values,
        /// SysTick ticks the call took (instructions: see [`Calibration`]).
        ticks: u32,
    },
    /// An observation the chip cannot run (wrong size).
    Refused {
        /// The tick number of the observation.
        tick: u32,
        /// Why.
        reason: Reason,
    },
}

/// What the chip booted.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Hello {
    /// The slot that runs, or `None`: the safe state (zero action).
    pub running: Option<Running>,
    /// What became of slot A.
    pub a: SlotState,
    /// What became of slot B.
    pub b: SlotState,
    /// SysTick against instructions, measured at boot.
    pub calibration: Calibration,
}

/// The slot that runs and its blob.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Running {
    /// Slot A or B.
    pub slot: Slot,
    /// The slot record's sequence number.
    pub sequence: u32,
    /// The blob's own CRC-32 (its last four bytes).
    pub blob_crc: u32,
    /// The blob's length in bytes.
    pub blob_len: u32,
    /// Hidden layers.
    pub depth: u8,
    /// Hidden width.
    pub width: u16,
    /// Observations.
    pub observations: u16,
    /// Actions.
    pub actions: u16,
    /// Weight encoding.
    pub encoding: Encoding,
}

/// A flash slot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Slot {
    /// Slot A.
    A,
    /// Slot B.
    B,
}

/// What became of a slot at boot (policy-core's `slot::Status`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum SlotState {
    /// It runs.
    Running {
        /// Its sequence number.
        sequence: u32,
    },
    /// It verified but the other slot is newer.
    Standby {
        /// Its sequence number.
        sequence: u32,
    },
    /// It did not verify.
    Failed {
        /// policy-core's one-line reason.
        reason: Reason,
    },
}

/// A blob's weight encoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Encoding {
    /// f32 weights.
    F32,
    /// f16 weights.
    F16,
    /// int8 weights with per-output scales.
    Int8,
    /// Integer arithmetic throughout (format version 4): int8 weights and activations.
    Integer,
}

/// A loop of `instructions` instructions took `ticks` SysTick ticks: under QEMU's
/// `-icount shift=0` SysTick ticks are virtual time, so `ticks x instructions / ticks` is an
/// instruction count (to one tick's worth); on a board they are core clock cycles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Calibration {
    /// Instructions in the calibration loop.
    pub instructions: u32,
    /// SysTick ticks it took.
    pub ticks: u32,
}

impl Calibration {
    /// `ticks` converted to instructions (rounded down); `ticks` itself if uncalibrated.
    ///
    /// ```
    /// let cal = hil_protocol::Calibration { instructions: 200_000, ticks: 5_000 };
    /// assert_eq!(cal.instructions(93), 3720);
    /// ```
    pub fn instructions(&self, ticks: u32) -> u64 {
        if self.ticks == 0 {
            return u64::from(ticks);
        }
        u64::from(ticks) * u64::from(self.instructions) / u64::from(self.ticks)
    }
}

/// The frame around every message: the version, then the message's postcard bytes.
#[derive(Debug, Serialize, Deserialize)]
struct Envelope<'a> {
    version: u16,
    body: &'a [u8],
}

/// Why a frame could not be written or read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error {
    /// The message does not fit [`MAX_FRAME`].
    TooLong,
    /// The bytes between two delimiters are not valid COBS.
    Framing,
    /// The CRC-32 does not match: bytes were changed on the way.
    Crc,
    /// The frame ends before its message does.
    Truncated,
    /// The frame is of another protocol version.
    Version {
        /// The version the frame carries.
        found: u16,
    },
    /// The frame's CRC and version are right but its message is not one of this version's.
    Malformed,
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Error::TooLong => write!(f, "a frame longer than {MAX_FRAME} bytes"),
            Error::Framing => write!(f, "a garbled frame (invalid COBS)"),
            Error::Crc => write!(f, "a garbled frame (CRC-32 mismatch)"),
            Error::Truncated => write!(f, "a truncated frame"),
            Error::Version { found } => write!(
                f,
                "a frame of protocol version {found}; this side speaks version {VERSION}"
            ),
            Error::Malformed => write!(
                f,
                "a frame holding no message of protocol version {VERSION}"
            ),
        }
    }
}

/// The 32-bit CRC of every frame: ISO-HDLC, the polynomial of policy-core's blob CRC.
const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// Writes `message` as one frame into `buf`; returns the frame, its `0x00` delimiter included.
pub fn encode<'b, M: Serialize>(
    message: &M,
    buf: &'b mut [u8; MAX_FRAME],
) -> Result<&'b [u8], Error> {
    encode_version(message, VERSION, buf)
}

/// [`encode`] with another version number (for tests of the version check).
#[doc(hidden)]
pub fn encode_version<'b, M: Serialize>(
    message: &M,
    version: u16,
    buf: &'b mut [u8; MAX_FRAME],
) -> Result<&'b [u8], Error> {
    let mut body = [0u8; MAX_FRAME];
    let body = postcard::to_slice(message, &mut body).map_err(|_| Error::TooLong)?;
    frame_body(body, version, buf)
}

/// Frames a message's postcard bytes `body` under `version` into `out`: the envelope, its
/// CRC-32, COBS and the `0x00` delimiter. Returns the frame. This is the framing of every link
/// the project speaks (the chip's here; firmware-sim's plant link, whose messages are larger
/// and allocated, calls it with its own version and buffer).
///
/// ```
/// let mut out = [0u8; 32];
/// let frame = hil_protocol::frame_body(&[7, 1], 3, &mut out).unwrap();
/// let mut wire = frame[..frame.len() - 1].to_vec();
/// assert_eq!(hil_protocol::unframe(&mut wire).unwrap(), (3, &[7u8, 1][..]));
/// ```
pub fn frame_body<'b>(body: &[u8], version: u16, out: &'b mut [u8]) -> Result<&'b [u8], Error> {
    let envelope = Envelope { version, body };
    let cobs = Cobs::try_new(Slice::new(out)).map_err(|_| Error::TooLong)?;
    let frame = postcard::serialize_with_flavor(&envelope, CrcModifier::new(cobs, CRC.digest()))
        .map_err(|_| Error::TooLong)?;
    Ok(frame)
}

/// Undoes [`frame_body`] on the bytes before the delimiter (decoded in place): COBS, then the
/// CRC-32; returns the version and the message's bytes, whatever the version.
pub fn unframe(frame: &mut [u8]) -> Result<(u16, &[u8]), Error> {
    let n = cobs::decode_in_place(frame).map_err(|_| Error::Framing)?;
    let bytes: &[u8] = &frame[..n];
    let (envelope, rest): (Envelope<'_>, &[u8]) =
        postcard::de_flavors::crc::take_from_bytes_u32(bytes, CRC.digest()).map_err(
            |e| match e {
                postcard::Error::DeserializeBadCrc => Error::Crc,
                postcard::Error::DeserializeUnexpectedEnd => Error::Truncated,
                _ => Error::Crc,
            },
        )?;
    // Bytes after the CRC are no part of any frame: a frame with a tail is refused, not read
    // as if it ended at its CRC.
    if !rest.is_empty() {
        return Err(Error::Malformed);
    }
    Ok((envelope.version, envelope.body))
}

/// Reads the message of one frame: `frame` holds the bytes before the delimiter (decoded in
/// place).
pub fn decode<'a, M: Deserialize<'a>>(frame: &'a mut [u8]) -> Result<M, Error> {
    let (version, body) = unframe(frame)?;
    if version != VERSION {
        return Err(Error::Version { found: version });
    }
    // The message must fill the body: a shorter reading is another message misread.
    match postcard::take_from_bytes(body) {
        Ok((message, [])) => Ok(message),
        _ => Err(Error::Malformed),
    }
}

/// Collects bytes from a link into frames: [`push`](Receiver::push) each byte received; at a
/// delimiter it hands back the frame's bytes (for [`decode`]). Fixed size: a frame longer than
/// [`MAX_FRAME`] is dropped up to its delimiter and reported once as [`Error::TooLong`].
#[derive(Debug)]
pub struct Receiver {
    buf: [u8; MAX_FRAME],
    len: usize,
    overflow: bool,
}

impl Default for Receiver {
    fn default() -> Self {
        Self::new()
    }
}

impl Receiver {
    /// An empty receiver.
    pub const fn new() -> Self {
        Receiver {
            buf: [0; MAX_FRAME],
            len: 0,
            overflow: false,
        }
    }

    /// Takes one byte; at a delimiter returns the frame before it (empty frames are skipped).
    /// The slice stays valid until the next call.
    pub fn push(&mut self, byte: u8) -> Option<Result<&mut [u8], Error>> {
        if byte != 0 {
            if self.len < self.buf.len() {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflow = true;
            }
            return None;
        }
        let n = core::mem::take(&mut self.len);
        if core::mem::take(&mut self.overflow) {
            return Some(Err(Error::TooLong));
        }
        if n == 0 {
            return None;
        }
        Some(Ok(&mut self.buf[..n]))
    }

    /// Whether part of a frame has been received.
    pub fn is_mid_frame(&self) -> bool {
        self.len > 0 || self.overflow
    }
}
