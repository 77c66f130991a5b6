//! Each load check returns its own typed error, and a failed load leaves the slot untouched.

use policy_core::blob::{self, Header};
use policy_core::{Activation, Critic, Error, ModelKind, Policy, Shape};

use crate::support::{blob_of, nav_critic, nav_policy, reseal};

type Actor = Policy<2, 32, 1, 2>;

/// A loaded, non-zero slot: "untouched" must mean something.
fn occupied_slot() -> Actor {
    nav_policy(0x5107, Activation::Relu)
}

/// Loads into an occupied slot and checks the slot is unchanged, bit for bit, on error.
fn load_error(bytes: &[u8]) -> Error {
    let mut slot = occupied_slot();
    let before = blob_of(&slot, "");
    let err = slot
        .load_into(bytes)
        .expect_err("this blob must be rejected");
    assert_eq!(
        blob_of(&slot, ""),
        before,
        "slot changed by a failed load ({err})"
    );
    err
}

fn good() -> Vec<u8> {
    blob_of(&nav_policy::<2, 32, 1, 2>(1, Activation::Tanh), "good")
}

/// Rebuilds a blob around an edited header (CRC recomputed, so only the edit is wrong).
fn with_header(edit: impl FnOnce(&mut Header)) -> Vec<u8> {
    let bytes = good();
    let (mut header, rest): (Header, &[u8]) = postcard::take_from_bytes(&bytes).expect("header");
    let pad = (bytes.len() - rest.len()).next_multiple_of(4) - (bytes.len() - rest.len());
    edit(&mut header);
    let mut out = postcard::to_stdvec(&header).expect("postcard");
    out.resize(out.len().next_multiple_of(4), 0);
    out.extend_from_slice(&rest[pad..]);
    reseal(&mut out);
    out
}

#[test]
fn good_blob_loads_and_replaces_the_slot() {
    let mut slot = occupied_slot();
    slot.load_into(&good()).expect("good blob");
    assert_eq!(slot, nav_policy(1, Activation::Tanh));
}

#[test]
fn empty_and_short_inputs_are_truncated() {
    assert_eq!(
        load_error(&[]),
        Error::Truncated {
            needed: 4,
            found: 0
        }
    );
    assert_eq!(
        load_error(b"DCP"),
        Error::Truncated {
            needed: 4,
            found: 3
        }
    );
    assert!(matches!(load_error(b"DCPB"), Error::Malformed { .. }));
}

#[test]
fn wrong_magic() {
    let mut b = good();
    b[..4].copy_from_slice(b"PNG\0");
    assert_eq!(load_error(&b), Error::WrongMagic { found: *b"PNG\0" });
}

#[test]
fn unsupported_version() {
    let b = with_header(|h| h.version = 5);
    assert_eq!(
        load_error(&b),
        Error::UnsupportedVersion {
            supported: 4,
            found: 5
        }
    );
}

/// An f32 blob is version 2, an f16 or int8 one version 3 and an integer one version 4: a header
/// that pairs them otherwise is malformed (one encoding, one byte form).
#[test]
fn encoding_and_version_must_agree() {
    for version in [3, 4] {
        let b = with_header(|h| h.version = version);
        assert!(
            matches!(load_error(&b), Error::Malformed { what } if what.contains("encoding")),
            "{:?}",
            load_error(&b)
        );
    }
}

#[test]
fn wrong_kind() {
    let critic = blob_of(&nav_critic::<2, 32, 1, 2>(2, Activation::Tanh), "critic");
    let err = load_error(&critic);
    assert_eq!(
        err,
        Error::WrongKind {
            expected: ModelKind::Actor,
            found: ModelKind::Critic
        }
    );
    assert_eq!(
        err.to_string(),
        "wrong model kind: expected actor, found critic"
    );
    let mut c = Critic::<2, 32, 1, 2>::ZERO;
    assert!(matches!(c.load_into(&good()), Err(Error::WrongKind { .. })));
    assert_eq!(c, Critic::ZERO);
}

#[test]
fn shape_mismatch_names_both_shapes() {
    let big = blob_of(&nav_policy::<2, 48, 3, 2>(3, Activation::Tanh), "4x48");
    let err = load_error(&big);
    let found = Shape {
        observations: 2,
        actions: 2,
        width: 48,
        depth: 4,
        choices: 0,
    };
    let expected = Shape {
        observations: 2,
        actions: 2,
        width: 32,
        depth: 2,
        choices: 0,
    };
    assert_eq!(err, Error::ShapeMismatch { expected, found });
    assert_eq!(
        err.to_string(),
        "shape mismatch: compiled for 2x32 hidden, 2 observations, 2 actions, \
         blob holds 4x48 hidden, 2 observations, 2 actions"
    );
}

#[test]
fn header_contradictions_are_malformed() {
    let zero_depth = with_header(|h| h.shape.depth = 0);
    assert!(matches!(
        load_error(&zero_depth),
        Error::ShapeBeyondLimits { what: "depth", .. }
    ));
    let zero_width = with_header(|h| h.shape.width = 0);
    assert!(matches!(
        load_error(&zero_width),
        Error::ShapeBeyondLimits { what: "width", .. }
    ));
    let long = with_header(|h| h.payload_len += 4);
    assert!(matches!(load_error(&long), Error::Malformed { .. }));
    // A shape whose size overflows: 65535² × 254 parameters.
    let huge = with_header(|h| {
        h.shape = Shape {
            observations: 1,
            actions: 1,
            width: u16::MAX,
            depth: 255,
            choices: 0,
        };
        h.payload_len = u32::MAX;
    });
    assert!(matches!(load_error(&huge), Error::ShapeBeyondLimits { .. }));
}

/// The good blob with the one-byte varint at header offset `at` written `extra` bytes longer
/// (`v` as `v | 0x80, 0x80, ..., 0x00`: the same value to a lenient decoder), re-padded and
/// resealed, so that only the encoding is wrong.
fn widened(at: usize, extra: usize) -> Vec<u8> {
    let bytes = good();
    let (_, rest): (Header, &[u8]) = postcard::take_from_bytes(&bytes).expect("header");
    let header_len = bytes.len() - rest.len();
    let payload = &bytes[header_len.next_multiple_of(4)..];
    let v = bytes[at];
    assert!(v < 0x80, "offset {at} holds a one-byte varint");
    let mut out = bytes[..at].to_vec();
    out.push(v | 0x80);
    out.extend(std::iter::repeat_n(0x80, extra - 1));
    out.push(0);
    out.extend_from_slice(&bytes[at + 1..header_len]);
    out.resize(out.len().next_multiple_of(4), 0);
    out.extend_from_slice(payload);
    reseal(&mut out);
    out
}

#[test]
fn a_varint_longer_than_its_shortest_form_is_malformed() {
    // Offsets in the good blob's header: 4 version, 5 kind, 6 encoding, 9 width, 12 activation,
    // 13 label length (docs/blob-format.md, the header table).
    for (at, extra) in [(4, 1), (5, 4), (6, 1), (9, 2), (12, 4), (13, 1)] {
        let wide = widened(at, extra);
        match load_error(&wide) {
            Error::Malformed { what } => assert!(what.contains("canonical"), "{what}"),
            other => panic!("offset {at} + {extra} bytes: {other}"),
        }
        assert!(policy_core::model::Model::from_blob(&wide).is_err());
    }
    // A version written long is refused for its form, not taken for an unknown version, and a
    // varint too long for its type is refused as undecodable.
    let mut too_long = good();
    too_long.splice(4..5, [0x82, 0x80, 0x80, 0x00]);
    reseal(&mut too_long);
    assert!(matches!(load_error(&too_long), Error::Malformed { .. }));
}

/// The header check as it was first written, kept as the reference the reader must agree
/// with: postcard decodes the header (version 1's fields for a version-1 blob), then the
/// decoded values are re-encoded and must give the stored bytes. `None`: the header is accepted
/// with this encoded length; `Some(what)`: refused as `Malformed { what }` or as the unsupported
/// version (`what` = "version").
fn reference_header_check(bytes: &[u8]) -> Result<(Header, usize), &'static str> {
    #[derive(serde::Serialize, serde::Deserialize)]
    struct HeaderV1 {
        magic: [u8; 4],
        version: u16,
        kind: ModelKind,
        shape: (u16, u16, u16, u8),
        activation: Activation,
        label: heapless::String<32>,
        payload_len: u32,
    }
    fn what(e: postcard::Error) -> &'static str {
        match e {
            postcard::Error::DeserializeUnexpectedEnd => "header ends early (truncated blob)",
            postcard::Error::DeserializeBadEnum => "unknown kind or activation",
            postcard::Error::DeserializeBadUtf8 => "label is not UTF-8",
            _ => "header fields cannot be decoded",
        }
    }
    fn canonical<T: serde::Serialize>(value: &T, stored: &[u8]) -> Result<(), &'static str> {
        let again = postcard::to_stdvec(value).expect("a decoded header re-encodes");
        match again == stored {
            true => Ok(()),
            false => {
                Err("header is not in canonical form (a varint longer than its shortest encoding)")
            }
        }
    }
    let (version, _) = postcard::take_from_bytes::<u16>(&bytes[4..]).map_err(what)?;
    match version {
        1 => {
            let (v1, rest) = postcard::take_from_bytes::<HeaderV1>(bytes).map_err(what)?;
            let len = bytes.len() - rest.len();
            canonical(&v1, &bytes[..len])?;
            if v1.kind == ModelKind::Discrete {
                return Err("unknown kind or activation");
            }
            let (observations, actions, width, depth) = v1.shape;
            let header = Header {
                magic: v1.magic,
                version: 1,
                kind: v1.kind,
                encoding: blob::Encoding::F32,
                shape: Shape {
                    observations,
                    actions,
                    width,
                    depth,
                    choices: 0,
                },
                activation: v1.activation,
                label: v1.label,
                payload_len: v1.payload_len,
            };
            Ok((header, len))
        }
        2..=4 => {
            let (header, rest) = postcard::take_from_bytes::<Header>(bytes).map_err(what)?;
            let len = bytes.len() - rest.len();
            canonical(&header, &bytes[..len])?;
            Ok((header, len))
        }
        _ => Err("version"),
    }
}

/// `blob::verify` agrees with the reference header check on `bytes`: the same refusal, or an
/// accepted header whose later checks (limits, length, CRC) may still refuse the blob.
fn agrees_with_reference(bytes: &[u8]) {
    let got = blob::verify(bytes);
    match (reference_header_check(bytes), got) {
        (Err("version"), Err(Error::UnsupportedVersion { .. })) => {}
        (Err(want), Err(Error::Malformed { what })) => assert_eq!(what, want, "{bytes:02x?}"),
        (Err(want), other) => {
            panic!("reference refuses ({want}), verify gives {other:?}: {bytes:02x?}")
        }
        (Ok((header, _)), Ok(v)) => assert_eq!(v.header, header),
        (Ok(_), Err(Error::Malformed { what })) => assert!(
            !what.starts_with("header")
                && !what.contains("kind or activation")
                && !what.starts_with("label"),
            "reference accepts the header, verify refuses it: {what}: {bytes:02x?}"
        ),
        (Ok(_), Err(Error::UnsupportedVersion { .. })) => {
            panic!("reference accepts the version: {bytes:02x?}")
        }
        (Ok(_), Err(_)) => {}
    }
}

/// Regression: the canonical-header rule once re-encoded the whole header with postcard to
/// compare it with the stored bytes, which cost the int8-only firmware about 1.5 KB of flash;
/// the reader now compares each varint's length as it reads it. A non-canonical varint in any
/// field, of any length, is still refused, with the same error as the re-encoding check gives
/// for every header below (padded, edited byte by byte, truncated), versions 1 to 3.
#[test]
fn a_non_canonical_varint_header_is_still_refused() {
    let golden = |name: &str| {
        std::fs::read(format!(
            "{}/tests/golden/v1/{name}",
            env!("CARGO_MANIFEST_DIR")
        ))
        .expect("golden v1 blob")
    };
    let blobs = [
        good(),
        blob_of(&nav_critic::<2, 32, 1, 2>(3, Activation::Relu), "critic"),
        golden("actor_2x32.postcard"),
    ];
    let mut checked = 0;
    for bytes in &blobs {
        let (_, header_len) = reference_header_check(bytes).expect("a good header");
        // Every varint padded by 1 to 9 groups: each byte below 0x80 that ends a varint.
        for at in 4..header_len {
            for extra in 1..10 {
                let mut wide = bytes[..at].to_vec();
                wide.push(bytes[at] | 0x80);
                wide.extend(std::iter::repeat_n(0x80, extra - 1));
                wide.push(0);
                wide.extend_from_slice(&bytes[at + 1..]);
                reseal(&mut wide);
                agrees_with_reference(&wide);
                checked += 1;
            }
        }
        // Every header byte set to every value; every truncation inside the header.
        for at in 4..header_len {
            for value in 0..=255u8 {
                let mut edited = bytes.clone();
                edited[at] = value;
                reseal(&mut edited);
                agrees_with_reference(&edited);
                checked += 1;
            }
        }
        for len in 5..header_len {
            agrees_with_reference(&bytes[..len]);
        }
    }
    assert!(checked > 10_000, "{checked} headers");
}

#[test]
fn truncated_and_trailing() {
    let b = good();
    let n = b.len();
    assert_eq!(
        load_error(&b[..n - 1]),
        Error::Truncated {
            needed: n,
            found: n - 1
        }
    );
    let mut longer = b.clone();
    longer.push(0);
    assert_eq!(
        load_error(&longer),
        Error::TrailingBytes {
            expected: n,
            found: n + 1
        }
    );
}

#[test]
fn checksum_mismatch_reports_both_values() {
    let mut b = good();
    let n = b.len();
    b[n - 10] ^= 0x01;
    let err = load_error(&b);
    let Error::ChecksumMismatch { stored, computed } = err else {
        panic!("{err:?}")
    };
    assert_ne!(stored, computed);
    assert!(err
        .to_string()
        .starts_with("checksum mismatch: stored CRC-32 0x"));
}

#[test]
fn non_finite_parameter_reports_its_index() {
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let mut p = nav_policy::<2, 32, 1, 2>(4, Activation::Tanh);
        p.input.w[(3, 1)] = bad; // column 1, row 3: after mean 2, inv_std 2, clip, bounds 4
        let err = load_error(&blob_of(&p, "nan"));
        assert_eq!(err, Error::NonFiniteParameter { index: 9 + 32 + 3 });
    }
}

#[test]
fn invalid_parameters_are_rejected() {
    type Edit = fn(&mut Actor);
    let cases: [(Edit, usize); 5] = [
        (|p| p.normalizer.inv_std[1] = -1.0, 1),
        (|p| p.normalizer.clip = 0.0, 0),
        (|p| p.normalizer.clip = -3.0, 0),
        (|p| (p.bounds.low[1], p.bounds.high[1]) = (0.5, -0.5), 1),
        (|p| (p.bounds.low[0], p.bounds.high[0]) = (-3e38, 3e38), 0),
    ];
    for (edit, dim) in cases {
        let mut p = nav_policy::<2, 32, 1, 2>(5, Activation::Tanh);
        edit(&mut p);
        let err = load_error(&blob_of(&p, "invalid"));
        assert!(
            matches!(err, Error::InvalidParameter { index, .. } if index == dim),
            "{err:?}"
        );
    }
    let mut c = nav_critic::<2, 32, 1, 2>(6, Activation::Tanh);
    c.normalizer.clip = 0.0;
    let mut slot = Critic::<2, 32, 1, 2>::ZERO;
    let err = slot.load_into(&blob_of(&c, "")).expect_err("clip 0");
    assert!(matches!(err, Error::InvalidParameter { .. }));
}

#[test]
fn writer_rejects_long_labels_and_small_buffers() {
    let p = nav_policy::<2, 32, 1, 2>(7, Activation::Tanh);
    let mut buf = vec![0u8; 8192];
    let label = "x".repeat(33);
    assert!(matches!(
        p.write_blob(&label, &mut buf),
        Err(Error::Malformed { .. })
    ));
    let needed = blob::blob_len(&p, "ok").expect("len");
    let err = p
        .write_blob("ok", &mut buf[..needed - 1])
        .expect_err("too small");
    assert_eq!(
        err,
        Error::BufferTooSmall {
            needed,
            found: needed - 1
        }
    );
    assert_eq!(p.write_blob("ok", &mut buf), Ok(needed));
}

#[test]
fn every_error_displays_one_line() {
    let errors = [
        load_error(&[]),
        load_error(b"XXXXXXXX"),
        load_error(&with_header(|h| h.version = 9)),
        load_error(&with_header(|h| h.shape.depth = 0)),
    ];
    for e in errors {
        let text = e.to_string();
        assert!(!text.is_empty() && !text.contains('\n'), "{text:?}");
    }
}
