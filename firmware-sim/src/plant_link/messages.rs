//! The plant link's messages and their frames: what the host (the trainer, `firmware-sim run`)
//! and a plant process say to each other over the plant's standard input and output.
//!
//! Every frame is the project's one framing, hil-protocol's
//! [`frame_body`](hil_protocol::frame_body): a postcard envelope (the protocol [`VERSION`],
//! then the message's postcard bytes), its CRC-32 (ISO-HDLC,
//! little-endian), the whole COBS-encoded and ended by a `0x00` byte. The chip link and the
//! plant link differ only in their messages, which here are the plant's sizes (any number of
//! values, names of any length), so they are allocated and a frame may be up to
//! [`MAX_FRAME`] bytes. docs/own-plant.md walks through an exchange byte by byte.
//!
//! The conversation is strictly one answer per request, in order:
//!
//! | host sends | plant answers |
//! |---|---|
//! | [`ToPlant::Hello`] | [`FromPlant::Hello`]: its name and the boxes of its one agent |
//! | [`ToPlant::Reset`] `{ seed }` | [`FromPlant::Reset`] `{ observation }` |
//! | [`ToPlant::Step`] `{ action }` | [`FromPlant::Step`]: observation, reward, flags, margin |
//! | [`ToPlant::Close`] | nothing: the plant exits |
//!
//! A plant may answer any request with [`FromPlant::Error`] (an action of the wrong size, say);
//! the host then stops with that message. A plant also exits when its standard input ends, so
//! a host that dies (even by `kill -9`) leaves no plant behind.
//!
//! ```
//! use firmware_sim::plant_link::messages::{decode, encode, FromPlant, StepReply};
//! let reply = FromPlant::Step(StepReply {
//!     observation: vec![0.5, -1.0],
//!     reward: -0.25,
//!     terminated: false,
//!     truncated: false,
//!     margin_touched: true,
//!     applied: vec![0.0],
//!     success: None,
//! });
//! let frame = encode(&reply).unwrap();
//! assert_eq!(frame.last(), Some(&0)); // the delimiter, and no other zero byte
//! assert!(!frame[..frame.len() - 1].contains(&0));
//! let mut wire = frame[..frame.len() - 1].to_vec();
//! assert_eq!(decode::<FromPlant>(&mut wire).unwrap(), reply);
//! ```

use std::fmt;

use serde::{Deserialize, Serialize};

/// The plant protocol's version, carried by every frame. Raised whenever a message changes.
pub const VERSION: u16 = 1;

/// The longest frame either side accepts, delimiter included (1 MiB: an observation of about
/// 200,000 values). A longer frame is refused as [`LinkError::TooLong`].
pub const MAX_FRAME: usize = 1 << 20;

/// What the host sends.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum ToPlant {
    /// Say who you are: answered by [`FromPlant::Hello`].
    Hello,
    /// Start an episode; the same seed must give the same start.
    Reset {
        /// The episode's seed.
        seed: u64,
    },
    /// Apply one action (always finite: the host replaces NaN and infinities by 0).
    Step {
        /// One value per action dimension.
        action: Vec<f32>,
    },
    /// The host is done: exit.
    Close,
}

/// What the plant sends.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum FromPlant {
    /// Who the plant is.
    Hello(Hello),
    /// The first observation of an episode.
    Reset {
        /// The observation.
        observation: Vec<f32>,
    },
    /// What one action did.
    Step(StepReply),
    /// The plant cannot answer the request: one line saying why.
    Error {
        /// What went wrong.
        message: String,
    },
}

/// A plant's name and its agents.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Hello {
    /// The plant's name, used in reports and run folders (e.g. `Pendulum-v1`).
    pub name: String,
    /// Its agents. This version of the protocol runs plants of exactly one agent.
    pub agents: Vec<Agent>,
}

/// One agent's boxes: `low[i] <= x[i] <= high[i]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Agent {
    /// The agent's name.
    pub name: String,
    /// Lower bounds of the observation (may be `-inf`, as Gymnasium's MuJoCo tasks declare).
    pub observation_low: Vec<f32>,
    /// Upper bounds of the observation (may be `+inf`).
    pub observation_high: Vec<f32>,
    /// Lower bounds of the action: finite, below `action_high`.
    pub action_low: Vec<f32>,
    /// Upper bounds of the action.
    pub action_high: Vec<f32>,
}

/// What one action did, as Gymnasium's `step` says it, with the margin made explicit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StepReply {
    /// The next observation.
    pub observation: Vec<f32>,
    /// The reward for this step.
    pub reward: f32,
    /// The episode ended in a terminal state.
    pub terminated: bool,
    /// The episode was cut by a time limit (not terminal for bootstrapping).
    pub truncated: bool,
    /// The step touched a hard margin (a joint limit, a wall, the action clipped at its box).
    pub margin_touched: bool,
    /// The motion the plant carried out, in action units, one value per action dimension (the
    /// action itself where the plant knows no better).
    pub applied: Vec<f32>,
    /// The plant's own verdict on the episode so far, if it has one (a goal reached).
    pub success: Option<bool>,
}

/// Why a frame could not be written or read.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LinkError {
    /// The frame is longer than [`MAX_FRAME`].
    TooLong,
    /// The frame's COBS, CRC or length is wrong (hil-protocol's reason).
    Garbled(hil_protocol::Error),
    /// The frame is of another protocol version.
    Version {
        /// The version the frame carries.
        found: u16,
    },
    /// The frame is intact and of this version but holds no message of it.
    Malformed,
}

impl fmt::Display for LinkError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LinkError::TooLong => write!(f, "a frame longer than {MAX_FRAME} bytes"),
            LinkError::Garbled(e) => write!(f, "{e}"),
            LinkError::Version { found } => write!(
                f,
                "a frame of plant protocol version {found}; this side speaks version {VERSION}"
            ),
            LinkError::Malformed => write!(
                f,
                "a frame holding no message of plant protocol version {VERSION}"
            ),
        }
    }
}

/// One message as a frame, its `0x00` delimiter included.
pub fn encode<M: Serialize>(message: &M) -> Result<Vec<u8>, LinkError> {
    encode_version(message, VERSION)
}

/// [`encode`] under another version number (for tests of the version check).
#[doc(hidden)]
pub fn encode_version<M: Serialize>(message: &M, version: u16) -> Result<Vec<u8>, LinkError> {
    let body = postcard::to_allocvec(message).map_err(|_| LinkError::TooLong)?;
    // The envelope adds the version (3 bytes at most), the body's length (5) and the CRC (4);
    // COBS adds a byte per 254 and the delimiter.
    let framed = body.len() + 12;
    let mut out = vec![0u8; framed + framed / 254 + 2];
    let frame = hil_protocol::frame_body(&body, version, &mut out).map_err(LinkError::Garbled)?;
    if frame.len() > MAX_FRAME {
        return Err(LinkError::TooLong);
    }
    let n = frame.len();
    out.truncate(n);
    Ok(out)
}

/// Reads the message of one frame: `frame` holds the bytes before the delimiter (decoded in
/// place).
pub fn decode<M: for<'de> Deserialize<'de>>(frame: &mut [u8]) -> Result<M, LinkError> {
    if frame.len() >= MAX_FRAME {
        return Err(LinkError::TooLong);
    }
    let (version, body) = hil_protocol::unframe(frame).map_err(LinkError::Garbled)?;
    if version != VERSION {
        return Err(LinkError::Version { found: version });
    }
    // The message must fill the body: a shorter reading is another message misread.
    match postcard::take_from_bytes(body) {
        Ok((message, [])) => Ok(message),
        _ => Err(LinkError::Malformed),
    }
}

impl ToPlant {
    /// The request's name, for error messages (`step`, `reset`, ...).
    pub fn name(&self) -> &'static str {
        match self {
            ToPlant::Hello => "hello",
            ToPlant::Reset { .. } => "reset",
            ToPlant::Step { .. } => "step",
            ToPlant::Close => "close",
        }
    }
}

impl FromPlant {
    /// The answer's name, for error messages.
    pub fn name(&self) -> &'static str {
        match self {
            FromPlant::Hello(_) => "hello",
            FromPlant::Reset { .. } => "reset",
            FromPlant::Step(_) => "step",
            FromPlant::Error { .. } => "error",
        }
    }
}

/// Reads the next frame from a byte stream: the bytes before the next `0x00` (empty frames are
/// skipped). `Ok(None)` at the end of the stream; a frame longer than [`MAX_FRAME`] is read to
/// its delimiter and refused as [`LinkError::TooLong`], so memory stays bounded.
pub fn read_frame(
    input: &mut impl std::io::BufRead,
) -> std::io::Result<Option<Result<Vec<u8>, LinkError>>> {
    let mut frame = Vec::new();
    let mut too_long = false;
    loop {
        let buf = input.fill_buf()?;
        if buf.is_empty() {
            // The stream ended; a half frame before the end is not a frame.
            return Ok(None);
        }
        let (chunk, end) = match buf.iter().position(|&b| b == 0) {
            Some(at) => (&buf[..at], Some(at + 1)),
            None => (buf, None),
        };
        if frame.len() + chunk.len() < MAX_FRAME {
            frame.extend_from_slice(chunk);
        } else {
            too_long = true;
            frame.clear();
        }
        let used = end.unwrap_or(buf.len());
        input.consume(used);
        if end.is_some() {
            if too_long {
                return Ok(Some(Err(LinkError::TooLong)));
            }
            if !frame.is_empty() {
                return Ok(Some(Ok(frame)));
            }
        }
    }
}
