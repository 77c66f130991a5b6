//! What must hold for any bytes that reach the plant link's reader: a plant's output as the
//! host reads it ([`FromPlant`]), or a host's requests as a plant served from Rust reads them
//! ([`ToPlant`]).
//!
//! Shared by the fuzz target `fuzz/fuzz_targets/plant_link.rs` and the proptests in
//! `tests/tests/plant_link_mutations.rs`.

use std::fmt::Debug;

use firmware_sim::plant_link::messages::{self, FromPlant, LinkError, ToPlant};

/// Reads `bytes` as one frame and as a stream of frames, decoding every frame as both message
/// kinds: each is an error of one line, or a message that re-encodes to a frame decoding to
/// the same message, bit for bit.
pub fn check(bytes: &[u8]) {
    check_frame(bytes);
    let mut input = bytes;
    while let Some(frame) = messages::read_frame(&mut input).expect("a slice reads") {
        match frame {
            Ok(frame) => {
                assert!(!frame.is_empty(), "read_frame skips empty frames");
                assert!(!frame.contains(&0), "a frame holds no delimiter");
                check_frame(&frame);
            }
            Err(e) => crate::assert_one_line(&e.to_string()),
        }
    }
}

/// The bytes before a delimiter, decoded as each message kind.
fn check_frame(bytes: &[u8]) {
    round_trip::<FromPlant>(bytes, messages::decode, messages::encode);
    round_trip::<ToPlant>(bytes, messages::decode, messages::encode);
}

/// Decoding `bytes` gives an error of one line or a message `M` that survives a second trip.
fn round_trip<M: Debug>(
    bytes: &[u8],
    decode: fn(&mut [u8]) -> Result<M, LinkError>,
    encode: fn(&M) -> Result<Vec<u8>, LinkError>,
) {
    let message = match decode(&mut bytes.to_vec()) {
        Ok(message) => message,
        Err(e) => return crate::assert_one_line(&e.to_string()),
    };
    // The frame read was under the size limit; its canonical form is no longer.
    let frame = encode(&message).unwrap_or_else(|e| panic!("{message:?} does not encode: {e}"));
    let (delimiter, wire) = frame.split_last().expect("a frame is never empty");
    assert_eq!(*delimiter, 0, "a frame ends with its delimiter");
    assert!(!wire.contains(&0), "a frame holds no other zero");
    let again = decode(&mut wire.to_vec())
        .unwrap_or_else(|e| panic!("{message:?} re-encoded does not decode: {e}"));
    // Equal frames are equal messages bit for bit: postcard writes every f32's bits as they
    // are, so NaN payloads compare too (PartialEq would call two NaNs different).
    assert_eq!(
        encode(&again).expect("encodes once"),
        frame,
        "{message:?} changed on a second trip"
    );
}
