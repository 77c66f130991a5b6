//! The blob format is exactly postcard, the spec's worked example is what the code writes, and
//! the CRC is the standard CRC-32.

use policy_core::blob::{self, Compiled, Header, MAGIC, MAX_HEADER_LEN, VERSION};
use policy_core::{crc32, Activation, Critic, Encoding, ModelKind, Policy, Shape};
use serde::ser::{Serialize, SerializeTuple, Serializer};

use crate::support::{blob_of, nav_critic, nav_policy, tiny_policy, TINY_LABEL};

/// A run of f32s as a serde tuple: postcard writes tuples with no length prefix, each f32 as 4
/// little-endian bytes.
struct Floats(Vec<f32>);

impl Serialize for Floats {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(self.0.len())?;
        for v in &self.0 {
            t.serialize_element(v)?;
        }
        t.end()
    }
}

fn params_of<M: Compiled>(model: &M) -> Vec<f32> {
    let mut all = Vec::new();
    model.params(&mut |s| all.extend_from_slice(s));
    all
}

/// What serde + postcard produce for the blob's logical content: the header, zero padding to a
/// multiple of 4, the floats, then the CRC as a `[u8; 4]` (a tuple, so raw bytes rather than a
/// varint).
fn postcard_blob<M: Compiled>(model: &M, label: &str) -> Vec<u8> {
    let params = params_of(model);
    let header = Header {
        magic: MAGIC,
        version: VERSION,
        kind: M::KIND,
        encoding: Encoding::F32,
        shape: M::SHAPE,
        activation: model.activation(),
        label: label.try_into().expect("short label"),
        payload_len: 4 * params.len() as u32,
    };
    let mut body = postcard::to_stdvec(&header).expect("postcard");
    body.resize(body.len().next_multiple_of(4), 0);
    body.extend(postcard::to_stdvec(&Floats(params)).expect("postcard"));
    let crc = crc32(&body).to_le_bytes();
    body.extend(postcard::to_stdvec(&crc).expect("postcard"));
    body
}

#[test]
fn actor_blob_is_postcard_of_header_and_floats() {
    let p = nav_policy::<2, 48, 3, 2>(7, Activation::Tanh);
    assert_eq!(
        blob_of(&p, "nav dcp seed 7"),
        postcard_blob(&p, "nav dcp seed 7")
    );
    let r = nav_policy::<3, 8, 0, 1>(8, Activation::Relu);
    assert_eq!(blob_of(&r, ""), postcard_blob(&r, ""));
}

#[test]
fn critic_blob_is_postcard_of_header_and_floats() {
    let c = nav_critic::<2, 32, 1, 2>(9, Activation::Relu);
    assert_eq!(blob_of(&c, "critic"), postcard_blob(&c, "critic"));
}

#[test]
fn postcard_decodes_what_the_writer_wrote() {
    let p = nav_policy::<2, 32, 1, 2>(10, Activation::Tanh);
    let bytes = blob_of(&p, "decode me");
    let (header, rest): (Header, &[u8]) = postcard::take_from_bytes(&bytes).expect("header");
    assert_eq!(
        header.shape,
        Shape {
            observations: 2,
            actions: 2,
            width: 32,
            depth: 2,
            choices: 0,
        }
    );
    assert_eq!(header.label.as_str(), "decode me");
    let pad = (4 - (bytes.len() - rest.len()) % 4) % 4;
    assert!(rest[..pad].iter().all(|&b| b == 0));
    let floats: Vec<f32> = rest[pad..pad + header.payload_len as usize]
        .chunks_exact(4)
        .map(|c| postcard::from_bytes::<f32>(c).expect("f32"))
        .collect();
    assert_eq!(floats, params_of(&p));
}

#[test]
fn param_count_agrees_with_the_types() {
    fn check<M: Compiled>(m: &M) {
        assert_eq!(
            Some(params_of(m).len()),
            M::SHAPE.param_count(M::KIND),
            "{}",
            M::SHAPE
        );
    }
    check(&Policy::<1, 2, 0, 1>::ZERO);
    check(&Policy::<2, 32, 1, 2>::ZERO);
    check(&Policy::<2, 48, 3, 2>::ZERO);
    check(&Policy::<5, 7, 4, 3>::ZERO);
    check(&Critic::<2, 32, 1, 2>::ZERO);
    check(&Critic::<3, 4, 0, 1>::ZERO);
    check(&Critic::<6, 9, 2, 4>::ZERO);
}

#[test]
fn max_header_len_is_the_widest_header() {
    let widest = Header {
        magic: MAGIC,
        version: u16::MAX,
        kind: ModelKind::Discrete,
        encoding: Encoding::F32,
        shape: Shape {
            observations: u16::MAX,
            actions: u16::MAX,
            width: u16::MAX,
            depth: 255,
            choices: u16::MAX,
        },
        activation: Activation::Relu,
        label: "x"
            .repeat(blob::LABEL_CAPACITY)
            .as_str()
            .try_into()
            .expect("32 bytes"),
        payload_len: u32::MAX,
    };
    assert_eq!(
        postcard::to_stdvec(&widest)
            .expect("postcard")
            .len()
            .next_multiple_of(4),
        MAX_HEADER_LEN
    );
}

/// Standard CRC-32/ISO-HDLC check values (the catalogue's "check" and a common text).
#[test]
fn crc32_test_vectors() {
    assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    assert_eq!(
        crc32(b"The quick brown fox jumps over the lazy dog"),
        0x414F_A339
    );
    assert_eq!(crc32(b""), 0);
    assert_eq!(crc32(&[0u8; 32]), 0x190A_55AD);
}

/// The hex dump in `docs/blob-format.md` (between the `tiny-blob` markers), parsed.
fn doc_hex() -> Vec<u8> {
    doc_hex_of("tiny-blob")
}

/// The hex dump between the `<!-- NAME:begin -->` and `<!-- NAME:end -->` markers, parsed.
fn doc_hex_of(name: &str) -> Vec<u8> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/blob-format.md");
    let doc = std::fs::read_to_string(path).expect("docs/blob-format.md");
    let start = doc
        .find(&format!("<!-- {name}:begin -->"))
        .expect("begin marker");
    let end = doc
        .find(&format!("<!-- {name}:end -->"))
        .expect("end marker");
    let mut bytes = Vec::new();
    for line in doc[start..end].lines().filter(|l| l.contains('|')) {
        let hexes = line.split('|').next().unwrap_or("");
        let mut tokens = hexes.split_whitespace();
        let offset: usize = tokens
            .next()
            .expect("offset")
            .parse()
            .expect("decimal offset");
        assert_eq!(offset, bytes.len(), "offset column in the doc: {line}");
        bytes.extend(tokens.map(|t| u8::from_str_radix(t, 16).expect("hex byte")));
    }
    bytes
}

#[test]
fn spec_worked_example_is_what_the_writer_writes() {
    let blob = blob_of(&tiny_policy(), TINY_LABEL);
    if std::env::var_os("PRINT_TINY").is_some() {
        eprintln!(
            "{}",
            blob.iter()
                .map(|b| format!("{b:02x}"))
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
    assert_eq!(
        doc_hex(),
        blob,
        "docs/blob-format.md's hex dump is out of date"
    );
    // The doc's worked evaluation, to the digits it prints.
    let p = Policy::<1, 2, 0, 1>::from_blob(&blob).expect("tiny blob loads");
    let a = p.act(&[1.0])[0];
    assert!((a - 0.182_33).abs() < 1e-5, "{a}");
}

/// The worked examples of the quantised encodings: the tiny actor written in f16 and in int8 is
/// byte for byte the dump in the document, and evaluates to the digits it prints.
#[test]
fn quantised_worked_examples_are_what_the_writer_writes() {
    use policy_core::model::{Model, Scratch};
    use policy_core::{Encoding, ModelKind};
    let tiny = tiny_policy();
    let mut params = Vec::new();
    tiny.params(&mut |p| params.extend_from_slice(p));
    for (encoding, name, action) in [
        (Encoding::F16, "tiny-blob-f16", 0.182_33f32),
        (Encoding::Int8, "tiny-blob-int8", 0.182_43),
    ] {
        let spec = blob::Spec {
            kind: ModelKind::Actor,
            encoding,
            shape: <policy_core::Policy<1, 2, 0, 1> as Compiled>::SHAPE,
            activation: tiny.activation(),
            label: TINY_LABEL,
        };
        let bytes = crate::support::write_vec(&spec, &params).expect("quantised tiny blob");
        if std::env::var_os("PRINT_TINY").is_some() {
            let hex: Vec<String> = bytes.iter().map(|b| format!("{b:02x}")).collect();
            eprintln!("{encoding}: {}", hex.join(" "));
        }
        assert_eq!(
            doc_hex_of(name),
            bytes,
            "docs/blob-format.md's {encoding} dump is out of date"
        );
        let model = Model::from_blob(&bytes).expect("loads");
        let mut a = [0.0f32];
        model
            .act(&[1.0], &mut Scratch::<2>::new(), &mut a)
            .expect("act");
        assert!((a[0] - action).abs() < 1e-5, "{encoding}: {}", a[0]);
    }
}

/// The integer encoding's worked example: the tiny actor written by `write_integer` with the
/// ranges the document gives is byte for byte its dump, and computes the codes and the action it
/// works through.
#[test]
fn integer_worked_example_is_what_the_writer_writes() {
    use policy_core::model::{Model, Scratch};
    use policy_core::{Encoding, ModelKind};
    let tiny = tiny_policy();
    let mut params = Vec::new();
    tiny.params(&mut |p| params.extend_from_slice(p));
    let spec = blob::Spec {
        kind: ModelKind::Actor,
        encoding: Encoding::Integer,
        shape: <policy_core::Policy<1, 2, 0, 1> as Compiled>::SHAPE,
        activation: tiny.activation(),
        label: TINY_LABEL,
    };
    let ranges = [(-3.0, 3.0), (-3.0, 3.5), (-1.0, 1.0)];
    let mut bytes = vec![0u8; blob::encoded_len(&spec).expect("length")];
    let n = blob::write_integer(&spec, &ranges, &mut |sink| sink(&params), &mut bytes)
        .expect("integer tiny blob");
    assert_eq!(n, bytes.len());
    if std::env::var_os("PRINT_TINY").is_some() {
        let hex: Vec<String> = bytes.iter().map(|b| format!("{b:02x}")).collect();
        eprintln!("integer: {}", hex.join(" "));
    }
    assert_eq!(
        doc_hex_of("tiny-blob-integer"),
        bytes,
        "docs/blob-format.md's integer dump is out of date"
    );
    // The conformance vector `tiny-integer` is this blob.
    let vector = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/conformance/blobs/tiny-integer.blob"
    );
    assert_eq!(std::fs::read(vector).expect("the vector"), bytes);
    let model = Model::from_blob(&bytes).expect("loads");
    let mut codes = [0i8];
    model.observation_codes(&[1.0], &mut codes).expect("codes");
    let mut unit = [0i8];
    model
        .act_codes_in(&codes, &mut [0; 4], &mut unit)
        .expect("act codes");
    let mut a = [0.0f32];
    model
        .act(&[1.0], &mut Scratch::<2>::new(), &mut a)
        .expect("act");
    assert_eq!((codes[0], unit[0]), (INTEGER_CODE, INTEGER_UNIT), "{a:?}");
    assert!((a[0] - INTEGER_ACTION).abs() < 1e-5, "{}", a[0]);
}

/// What the integer worked example computes on the observation 1.0: the input code, the unit
/// code and the action (docs/blob-format.md).
const INTEGER_CODE: i8 = 42;
const INTEGER_UNIT: i8 = 93;
const INTEGER_ACTION: f32 = 0.183_07;

/// The slot-record example in `docs/blob-format.md` is the header policy-core writes for the
/// tiny blob with sequence number 3, and reads back.
#[test]
fn slot_header_worked_example_is_what_the_writer_writes() {
    let blob = blob_of(&tiny_policy(), TINY_LABEL);
    let header = policy_core::slot::header(3, blob.len()).expect("header");
    assert_eq!(
        doc_hex_of("tiny-slot-header"),
        header,
        "docs/blob-format.md's slot header dump is out of date"
    );
    let record = [&header[..], &blob].concat();
    let read = policy_core::slot::read(&record).expect("reads back");
    assert_eq!((read.sequence, read.blob), (3, &blob[..]));
}
