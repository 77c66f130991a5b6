//! The frame codec: every message round-trips bit for bit; a changed, cut or foreign-version
//! frame is refused with its reason, never misread.

use hil_protocol::{
    decode, encode, encode_version, Calibration, Encoding, Error, FromChip, Hello, Reason,
    Receiver, Running, Slot, SlotState, ToChip, Values, MAX_FRAME, VERSION,
};

fn hello() -> FromChip {
    FromChip::Hello(Hello {
        running: Some(Running {
            slot: Slot::B,
            sequence: u32::MAX,
            blob_crc: 0xDEAD_BEEF,
            blob_len: 12_345,
            depth: 6,
            width: 64,
            observations: 2,
            actions: 2,
            encoding: Encoding::Int8,
        }),
        a: SlotState::Failed {
            reason: Reason::try_from("x".repeat(80).as_str()).expect("fits"),
        },
        b: SlotState::Running { sequence: 3 },
        calibration: Calibration {
            instructions: 200_000,
            ticks: 5_000,
        },
    })
}

fn messages() -> Vec<Vec<u8>> {
    let values = Values::from_slice(&[-0.0, f32::NAN, f32::INFINITY, 1e-45, 0.1, -3.5, 7.0, 0.0])
        .expect("fits");
    let from_chip = [
        hello(),
        FromChip::Action {
            tick: 0,
            action: values.clone(),
            ticks: u32::MAX,
        },
        FromChip::Refused {
            tick: 9,
            reason: Reason::try_from("observation size: expected 2, found 3").expect("fits"),
        },
    ];
    let to_chip = [
        ToChip::Hello,
        ToChip::Observe {
            tick: 199,
            observation: values,
        },
    ];
    let mut frames = Vec::new();
    let mut buf = [0u8; MAX_FRAME];
    for m in &from_chip {
        frames.push(encode(m, &mut buf).expect("fits").to_vec());
    }
    for m in &to_chip {
        frames.push(encode(m, &mut buf).expect("fits").to_vec());
    }
    frames
}

/// Debug of f32 NaN compares as text, so two messages equal bit for bit print the same.
fn same_bits<T: std::fmt::Debug>(a: &T, b: &T) -> bool {
    format!("{a:?}") == format!("{b:?}")
}

#[test]
fn every_message_round_trips_bit_for_bit_and_a_frame_has_one_zero_its_delimiter() {
    let mut buf = [0u8; MAX_FRAME];
    let m = hello();
    let frame = encode(&m, &mut buf).expect("fits").to_vec();
    assert_eq!(frame.iter().filter(|&&b| b == 0).count(), 1);
    let mut body = frame[..frame.len() - 1].to_vec();
    let back: FromChip = decode(&mut body).expect("decodes");
    assert!(same_bits(&back, &m));

    let action = FromChip::Action {
        tick: 3,
        action: Values::from_slice(&[f32::from_bits(0x7FC0_1234), -0.0]).expect("fits"),
        ticks: 1,
    };
    let frame = encode(&action, &mut buf).expect("fits").to_vec();
    let mut body = frame[..frame.len() - 1].to_vec();
    match decode::<FromChip>(&mut body).expect("decodes") {
        FromChip::Action { action: a, .. } => {
            assert_eq!(a[0].to_bits(), 0x7FC0_1234);
            assert_eq!(a[1].to_bits(), (-0.0f32).to_bits());
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn the_receiver_splits_a_stream_into_frames_and_skips_empty_ones() {
    let frames = messages();
    let stream: Vec<u8> = std::iter::once(0)
        .chain(frames.iter().flatten().copied())
        .collect();
    let mut rx = Receiver::new();
    let mut got = 0;
    for &b in &stream {
        if let Some(frame) = rx.push(b) {
            let frame = frame.expect("fits");
            if got < 3 {
                decode::<FromChip>(frame).expect("a chip message");
            } else {
                decode::<ToChip>(frame).expect("a host message");
            }
            got += 1;
        }
    }
    assert_eq!(got, frames.len());
    assert!(!rx.is_mid_frame());
}

#[test]
fn a_changed_byte_anywhere_is_refused() {
    for frame in messages() {
        let body = &frame[..frame.len() - 1];
        for i in 0..body.len() {
            for flip in [0x01u8, 0x80, 0xFF] {
                let mut bad = body.to_vec();
                bad[i] ^= flip;
                if bad[i] == 0 {
                    continue; // a zero would split the frame: the receiver's case, below
                }
                let e = decode::<FromChip>(&mut bad).expect_err("changed");
                assert!(
                    matches!(e, Error::Crc | Error::Framing | Error::Truncated),
                    "byte {i} ^ {flip:#x}: {e}"
                );
            }
        }
    }
}

#[test]
fn a_cut_frame_is_refused_at_every_length() {
    for frame in messages() {
        let body = &frame[..frame.len() - 1];
        for n in 1..body.len() {
            let mut cut = body[..n].to_vec();
            let e = decode::<FromChip>(&mut cut).expect_err("cut");
            assert!(
                matches!(e, Error::Crc | Error::Framing | Error::Truncated),
                "{n}: {e}"
            );
        }
    }
}

#[test]
fn a_frame_of_another_version_is_refused_as_such() {
    let mut buf = [0u8; MAX_FRAME];
    for version in [0, VERSION + 1, u16::MAX] {
        let frame = encode_version(&ToChip::Hello, version, &mut buf).expect("fits");
        let mut body = frame[..frame.len() - 1].to_vec();
        let e = decode::<ToChip>(&mut body).expect_err("other version");
        assert_eq!(e, Error::Version { found: version });
        assert_eq!(
            e.to_string(),
            format!("a frame of protocol version {version}; this side speaks version {VERSION}")
        );
    }
}

#[test]
fn a_message_of_the_other_side_is_malformed_not_misread() {
    let mut buf = [0u8; MAX_FRAME];
    let frame = encode(&hello(), &mut buf).expect("fits");
    let mut body = frame[..frame.len() - 1].to_vec();
    assert_eq!(decode::<ToChip>(&mut body), Err(Error::Malformed));
}

#[test]
fn an_overlong_frame_is_dropped_up_to_its_delimiter_and_the_next_one_reads() {
    let mut rx = Receiver::new();
    for _ in 0..MAX_FRAME + 10 {
        assert!(rx.push(1).is_none());
    }
    assert!(matches!(rx.push(0), Some(Err(Error::TooLong))));
    let mut buf = [0u8; MAX_FRAME];
    let frame = encode(&ToChip::Hello, &mut buf).expect("fits").to_vec();
    let mut out = None;
    for &b in &frame {
        if let Some(f) = rx.push(b) {
            out = Some(decode::<ToChip>(f.expect("fits")));
        }
    }
    assert_eq!(out, Some(Ok(ToChip::Hello)));
}

/// Regression: bytes after a frame's CRC were ignored (postcard's `from_bytes_u32` drops the
/// remainder), so a frame with a tail was read as if it ended at its CRC.
#[test]
fn a_frame_with_bytes_after_its_crc_is_refused() {
    let mut plain = vec![0u8; MAX_FRAME];
    // The envelope and CRC of a Hello request, then two more bytes, framed by hand.
    let frame = hil_protocol::frame_body(&[0], VERSION, &mut plain).expect("fits");
    let mut decoded = frame[..frame.len() - 1].to_vec();
    let n = cobs::decode_in_place(&mut decoded).expect("cobs");
    decoded.truncate(n);
    decoded.extend_from_slice(&[0x2a, 0x2a]);
    let mut tailed = vec![0u8; decoded.len() + decoded.len() / 254 + 2];
    let len = cobs::encode(&decoded, &mut tailed);
    tailed.truncate(len);
    assert_eq!(decode::<ToChip>(&mut tailed), Err(Error::Malformed));
    let mut whole = frame[..frame.len() - 1].to_vec();
    assert_eq!(decode::<ToChip>(&mut whole), Ok(ToChip::Hello));
}
