//! The C API called from Rust: every misuse a C caller can make gives its code (NULL for every
//! pointer argument of every function, misaligned and overlapping buffers, wrong lengths, an
//! unloaded storage, the wrong kind), every policy-core error maps to its own code, and a loaded
//! model gives the bits `Model` gives (policy-core's golden vectors).

use core::ffi::CStr;
use core::ptr::{null, null_mut};

use policy_core::model::{Model, Scratch};
use policy_core::slot;
use policy_core::{Encoding, Error, ModelKind, Shape};
use policy_core_ffi::*;

fn golden(name: &str) -> Vec<u8> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../policy-core/tests/golden/");
    std::fs::read(format!("{path}{name}")).expect("golden blob")
}

fn new_error() -> DcpError {
    // SAFETY: DcpError is plain data (integers and char arrays); all zeros is a valid value.
    unsafe { core::mem::zeroed() }
}

fn new_model() -> DcpModel {
    DcpModel {
        opaque: [0; DCP_MODEL_BYTES],
    }
}

fn text(chars: &[core::ffi::c_char]) -> String {
    let bytes: Vec<u8> = chars
        .iter()
        .take_while(|&&c| c != 0)
        .map(|&c| c as u8)
        .collect();
    String::from_utf8(bytes).expect("utf-8")
}

fn name(code: i32) -> String {
    // SAFETY: dcp_status_name returns a static NUL-terminated string, never NULL.
    unsafe { CStr::from_ptr(dcp_status_name(code)) }
        .to_str()
        .expect("ascii")
        .to_string()
}

/// Loads `blob` into a fresh storage.
fn load(blob: &[u8]) -> DcpModel {
    let mut m = new_model();
    // SAFETY: valid buffers; the blob outlives the model in every test that uses it.
    let code = unsafe { dcp_model_load(blob.as_ptr(), blob.len(), &mut m, null_mut()) };
    assert_eq!(code, DCP_OK, "{}", name(code));
    m
}

/// One of every policy-core error variant known today, with its code.
fn every_error() -> Vec<(Error, i32)> {
    let shape = Shape {
        observations: 2,
        actions: 2,
        width: 8,
        depth: 1,
        choices: 0,
    };
    vec![
        (Error::WrongMagic { found: *b"ABCD" }, DCP_ERR_WRONG_MAGIC),
        (
            Error::UnsupportedVersion {
                supported: 2,
                found: 9,
            },
            DCP_ERR_UNSUPPORTED_VERSION,
        ),
        (
            Error::WrongKind {
                expected: ModelKind::Actor,
                found: ModelKind::Critic,
            },
            DCP_ERR_WRONG_KIND,
        ),
        (
            Error::WrongEncoding {
                expected: Encoding::F32,
                found: Encoding::Int8,
            },
            DCP_ERR_WRONG_ENCODING,
        ),
        (
            Error::EncodingNotCompiled {
                found: Encoding::F16,
            },
            DCP_ERR_ENCODING_NOT_COMPILED,
        ),
        (
            Error::ShapeMismatch {
                expected: shape,
                found: shape,
            },
            DCP_ERR_SHAPE_MISMATCH,
        ),
        (
            Error::Truncated {
                needed: 10,
                found: 3,
            },
            DCP_ERR_TRUNCATED,
        ),
        (
            Error::TrailingBytes {
                expected: 10,
                found: 12,
            },
            DCP_ERR_TRAILING_BYTES,
        ),
        (Error::Malformed { what: "header" }, DCP_ERR_MALFORMED),
        (
            Error::ChecksumMismatch {
                stored: 1,
                computed: 2,
            },
            DCP_ERR_CHECKSUM_MISMATCH,
        ),
        (
            Error::NonFiniteParameter { index: 7 },
            DCP_ERR_NON_FINITE_PARAMETER,
        ),
        (
            Error::InvalidParameter {
                what: "low > high",
                index: 1,
            },
            DCP_ERR_INVALID_PARAMETER,
        ),
        (
            Error::ShapeBeyondLimits {
                what: "width",
                min: 1,
                max: 512,
                found: 999,
            },
            DCP_ERR_SHAPE_BEYOND_LIMITS,
        ),
        (
            Error::SizeMismatch {
                what: "action size",
                expected: 2,
                found: 3,
            },
            DCP_ERR_SIZE_MISMATCH,
        ),
        (
            Error::ScratchTooSmall {
                needed: 48,
                found: 32,
            },
            DCP_ERR_SCRATCH_TOO_SMALL,
        ),
        (
            Error::BufferTooSmall {
                needed: 100,
                found: 10,
            },
            DCP_ERR_BUFFER_TOO_SMALL,
        ),
        (Error::SlotEmpty, DCP_ERR_SLOT_EMPTY),
        (Error::SlotMagic { found: *b"XXXX" }, DCP_ERR_SLOT_MAGIC),
        (
            Error::SlotHeaderChecksum {
                stored: 3,
                computed: 4,
            },
            DCP_ERR_SLOT_HEADER_CHECKSUM,
        ),
        (
            Error::SlotOverflow {
                needed: 300,
                capacity: 200,
            },
            DCP_ERR_SLOT_OVERFLOW,
        ),
    ]
}

/// The mapping from policy-core's errors to codes, as a table: every variant known today has
/// its own negative code and a name equal to the variant's (the `_ =>` arm, `DCP_ERR_OTHER`,
/// is for variants added later and is never one of these).
#[test]
fn every_policy_core_error_has_its_own_code_and_name() {
    let table = every_error();
    assert_eq!(table.len(), 20, "one row per Error variant");
    let mut codes: Vec<i32> = Vec::new();
    for (e, want) in &table {
        let code = code_of(e);
        assert_eq!(code, *want, "{e:?}");
        assert!(code < 0 && code != DCP_ERR_OTHER, "{e:?}");
        let variant = format!("{e:?}");
        let variant = variant
            .split([' ', '{'])
            .next()
            .expect("variant name")
            .to_string();
        assert_eq!(name(code), variant);
        codes.push(code);
    }
    codes.sort_unstable();
    codes.dedup();
    assert_eq!(codes.len(), table.len(), "codes are distinct");
    for c in [
        DCP_ERR_OTHER,
        DCP_ERR_NULL_POINTER,
        DCP_ERR_MISALIGNED,
        DCP_ERR_BAD_LENGTH,
        DCP_ERR_OVERLAP,
        DCP_ERR_NOT_LOADED,
        DCP_ERR_NO_SLOT,
    ] {
        assert!(!codes.contains(&c));
        assert_ne!(name(c), "Unknown");
    }
    assert_eq!(name(DCP_OK), "Ok");
    assert_eq!(name(12345), "Unknown");
}

#[test]
fn a_verify_failure_fills_the_error_struct() {
    let mut blob = golden("actor_2x32.postcard");
    let n = blob.len();
    blob[n - 1] ^= 0x40; // the stored CRC
    let (mut h, mut e) = (
        // SAFETY: DcpHeader is plain data; all zeros is a valid value.
        unsafe { core::mem::zeroed::<DcpHeader>() },
        new_error(),
    );
    // SAFETY: valid buffers.
    let code = unsafe { dcp_verify(blob.as_ptr(), blob.len(), &mut h, &mut e) };
    assert_eq!(code, DCP_ERR_CHECKSUM_MISMATCH);
    assert_eq!(e.code, code);
    let Err(Error::ChecksumMismatch { stored, computed }) = Model::from_blob(&blob) else {
        panic!("the flipped blob fails its checksum");
    };
    assert_eq!((e.expected, e.found), (stored as usize, computed as usize));
    assert_eq!(
        text(&e.message),
        Error::ChecksumMismatch { stored, computed }.to_string()
    );
    // A NonFiniteParameter carries its index; a SizeMismatch its sizes and what.
    let ok = golden("actor_2x32.postcard");
    // SAFETY: valid buffers.
    let code =
        unsafe { dcp_model_for_policy(ok.as_ptr(), ok.len(), 3, 2, 64, &mut new_model(), &mut e) };
    assert_eq!(code, DCP_ERR_SIZE_MISMATCH);
    assert_eq!((e.expected, e.found), (3, 2));
    assert_eq!(text(&e.what), "observation size");
}

#[test]
fn verify_reports_the_header() {
    let blob = golden("actor_4x48.postcard");
    // SAFETY: DcpHeader is plain data; all zeros is a valid value.
    let mut h: DcpHeader = unsafe { core::mem::zeroed() };
    // SAFETY: valid buffers.
    let code = unsafe { dcp_verify(blob.as_ptr(), blob.len(), &mut h, null_mut()) };
    assert_eq!(code, DCP_OK);
    let m = Model::from_blob(&blob).expect("golden");
    let header = m.header();
    assert_eq!(h.version, u32::from(header.version));
    assert_eq!(h.kind, DCP_KIND_ACTOR);
    assert_eq!(h.encoding, DCP_ENCODING_F32);
    let s = header.shape;
    assert_eq!(
        (h.observations, h.actions, h.width, h.depth, h.choices),
        (2, 2, 48, u32::from(s.depth), 0)
    );
    assert_eq!(h.scratch_width, 48);
    assert_eq!(text(&h.label), header.label.as_str());
    assert_eq!(h.label_len as usize, header.label.len());
    assert_eq!(h.payload_len, header.payload_len);
    let crc = u32::from_le_bytes(blob[blob.len() - 4..].try_into().expect("4 bytes"));
    assert_eq!(h.crc, crc);
    assert_eq!(h.crc, policy_core::crc32(&blob[..blob.len() - 4]));
    assert_eq!(h.blob_len as usize, blob.len());
    let loaded = load(&blob);
    // SAFETY: DcpHeader is plain data; all zeros is a valid value.
    let mut h2: DcpHeader = unsafe { core::mem::zeroed() };
    // SAFETY: valid buffers.
    let code = unsafe { dcp_model_header(&loaded, &mut h2, null_mut()) };
    assert_eq!(code, DCP_OK);
    assert_eq!(h2.crc, h.crc);
    assert_eq!(h2.blob_len, h.blob_len);
}

/// NULL for each pointer argument of each function, one at a time: DCP_ERR_NULL_POINTER with
/// the argument's name, and `err` NULL is allowed everywhere.
#[test]
fn null_for_every_pointer_argument_is_an_error_code() {
    let actor = golden("actor_4x48.postcard");
    let critic = golden("critic_2x32.postcard");
    let model = load(&actor);
    let critic_model = load(&critic);
    let record = [&slot::header(1, actor.len()).expect("header")[..], &actor].concat();
    let obs = [0.5f32, -0.5];
    let mut scratch = [0.0f32; 128];
    let mut action = [0.0f32; 2];
    let (mut q, mut index, mut floats, mut seq, mut blob_len) = (0.0f32, 0u32, 0usize, 0u32, 0);
    let mut blob_at: *const u8 = null();
    let (mut low, mut high) = ([0.0f32; 2], [0.0f32; 2]);
    // SAFETY: plain data; all zeros is a valid value.
    let mut header: DcpHeader = unsafe { core::mem::zeroed() };
    // SAFETY: plain data; all zeros is a valid value.
    let mut boot: DcpBoot = unsafe { core::mem::zeroed() };
    let mut out_model = new_model();
    let mut e = new_error();
    let b = actor.as_ptr();
    let n = actor.len();

    let check = |what: &str, code: i32, e: &DcpError| {
        assert_eq!(code, DCP_ERR_NULL_POINTER, "{what}: {}", name(code));
        assert_eq!(e.code, code, "{what}");
        assert_eq!(text(&e.what), what);
    };
    // SAFETY: every pointer below is NULL or valid for its length.
    unsafe {
        check("blob", dcp_verify(null(), n, &mut header, &mut e), &e);
        check("out", dcp_verify(b, n, null_mut(), &mut e), &e);
        check(
            "blob",
            dcp_model_load(null(), n, &mut out_model, &mut e),
            &e,
        );
        check("model", dcp_model_load(b, n, null_mut(), &mut e), &e);
        check(
            "blob",
            dcp_model_for_policy(null(), n, 2, 2, 64, &mut out_model, &mut e),
            &e,
        );
        check(
            "model",
            dcp_model_for_policy(b, n, 2, 2, 64, null_mut(), &mut e),
            &e,
        );
        check("model", dcp_model_header(null(), &mut header, &mut e), &e);
        check("out", dcp_model_header(&model, null_mut(), &mut e), &e);
        check("model", dcp_scratch_floats(null(), &mut floats, &mut e), &e);
        check("out", dcp_scratch_floats(&model, null_mut(), &mut e), &e);

        let (o, s, a) = (obs.as_ptr(), scratch.as_mut_ptr(), action.as_mut_ptr());
        check("model", dcp_act(null(), o, 2, s, 128, a, 2, &mut e), &e);
        check("obs", dcp_act(&model, null(), 2, s, 128, a, 2, &mut e), &e);
        check(
            "scratch",
            dcp_act(&model, o, 2, null_mut(), 128, a, 2, &mut e),
            &e,
        );
        check(
            "action",
            dcp_act(&model, o, 2, s, 128, null_mut(), 2, &mut e),
            &e,
        );

        let c = &critic_model;
        let u = [0.1f32, 0.2];
        let up = u.as_ptr();
        check(
            "model",
            dcp_q(null(), o, 2, up, 2, s, 128, &mut q, &mut e),
            &e,
        );
        check(
            "obs",
            dcp_q(c, null(), 2, up, 2, s, 128, &mut q, &mut e),
            &e,
        );
        check(
            "unit_action",
            dcp_q(c, o, 2, null(), 2, s, 128, &mut q, &mut e),
            &e,
        );
        check(
            "scratch",
            dcp_q(c, o, 2, up, 2, null_mut(), 128, &mut q, &mut e),
            &e,
        );
        check("q", dcp_q(c, o, 2, up, 2, s, 128, null_mut(), &mut e), &e);

        check(
            "model",
            dcp_choose(null(), o, 2, s, 128, &mut index, &mut e),
            &e,
        );
        check(
            "obs",
            dcp_choose(&model, null(), 2, s, 128, &mut index, &mut e),
            &e,
        );
        check(
            "scratch",
            dcp_choose(&model, o, 2, null_mut(), 128, &mut index, &mut e),
            &e,
        );
        check(
            "index",
            dcp_choose(&model, o, 2, s, 128, null_mut(), &mut e),
            &e,
        );
        let mut rows = [0.0f32; 4];
        let r = rows.as_mut_ptr();
        check(
            "model",
            dcp_choice_q(null(), o, 2, s, 128, r, 4, &mut e),
            &e,
        );
        check(
            "obs",
            dcp_choice_q(&model, null(), 2, s, 128, r, 4, &mut e),
            &e,
        );
        check(
            "scratch",
            dcp_choice_q(&model, o, 2, null_mut(), 128, r, 4, &mut e),
            &e,
        );
        check(
            "q",
            dcp_choice_q(&model, o, 2, s, 128, null_mut(), 4, &mut e),
            &e,
        );

        let (lo, hi) = (low.as_mut_ptr(), high.as_mut_ptr());
        check("model", dcp_action_bounds(null(), lo, hi, 2, &mut e), &e);
        check(
            "low",
            dcp_action_bounds(&model, null_mut(), hi, 2, &mut e),
            &e,
        );
        check(
            "high",
            dcp_action_bounds(&model, lo, null_mut(), 2, &mut e),
            &e,
        );

        let (r, rn) = (record.as_ptr(), record.len());
        check(
            "slot_a",
            dcp_slot_choose(
                null(),
                rn,
                r,
                rn,
                2,
                2,
                64,
                &mut boot,
                &mut out_model,
                &mut e,
            ),
            &e,
        );
        check(
            "slot_b",
            dcp_slot_choose(
                r,
                rn,
                null(),
                rn,
                2,
                2,
                64,
                &mut boot,
                &mut out_model,
                &mut e,
            ),
            &e,
        );
        check(
            "out",
            dcp_slot_choose(r, rn, r, rn, 2, 2, 64, null_mut(), &mut out_model, &mut e),
            &e,
        );
        check(
            "model",
            dcp_slot_choose(r, rn, r, rn, 2, 2, 64, &mut boot, null_mut(), &mut e),
            &e,
        );
        check(
            "slot",
            dcp_slot_read(null(), rn, &mut seq, &mut blob_at, &mut blob_len, &mut e),
            &e,
        );
        check(
            "sequence",
            dcp_slot_read(r, rn, null_mut(), &mut blob_at, &mut blob_len, &mut e),
            &e,
        );
        check(
            "blob",
            dcp_slot_read(r, rn, &mut seq, null_mut(), &mut blob_len, &mut e),
            &e,
        );
        check(
            "blob_len",
            dcp_slot_read(r, rn, &mut seq, &mut blob_at, null_mut(), &mut e),
            &e,
        );
        // The integer entry (on the f32 model: NULL is checked before the encoding).
        let (mut codes, mut unit_codes, mut ints) = ([0i8; 2], [0i8; 2], [0i32; 128]);
        let (c, uc, is) = (
            codes.as_mut_ptr(),
            unit_codes.as_mut_ptr(),
            ints.as_mut_ptr(),
        );
        check(
            "model",
            dcp_observation_codes(null(), o, 2, c, 2, &mut e),
            &e,
        );
        check(
            "obs",
            dcp_observation_codes(&model, null(), 2, c, 2, &mut e),
            &e,
        );
        check(
            "codes",
            dcp_observation_codes(&model, o, 2, null_mut(), 2, &mut e),
            &e,
        );
        check(
            "model",
            dcp_act_codes(null(), c, 2, is, 128, uc, 2, &mut e),
            &e,
        );
        check(
            "codes",
            dcp_act_codes(&model, null(), 2, is, 128, uc, 2, &mut e),
            &e,
        );
        check(
            "scratch",
            dcp_act_codes(&model, c, 2, null_mut(), 128, uc, 2, &mut e),
            &e,
        );
        check(
            "unit_codes",
            dcp_act_codes(&model, c, 2, is, 128, null_mut(), 2, &mut e),
            &e,
        );
        // `err` may always be NULL: the code still comes back.
        assert_eq!(
            dcp_verify(null(), n, &mut header, null_mut()),
            DCP_ERR_NULL_POINTER
        );
        // And a success with NULL err.
        assert_eq!(dcp_act(&model, o, 2, s, 128, a, 2, null_mut()), DCP_OK);
        assert_eq!(
            dcp_slot_read(r, rn, &mut seq, &mut blob_at, &mut blob_len, null_mut()),
            DCP_OK
        );
        assert_eq!((seq, blob_len), (1, actor.len()));
        assert_eq!(blob_at, r.add(slot::HEADER_LEN));
    }
}

#[test]
fn a_zeroed_or_failed_storage_is_not_loaded() {
    let zeroed = new_model();
    let obs = [0.0f32; 2];
    let mut scratch = [0.0f32; 128];
    let mut action = [0.0f32; 2];
    let mut floats = 0usize;
    let mut e = new_error();
    // SAFETY: valid buffers.
    unsafe {
        let act = |m: &DcpModel, e: &mut DcpError, s: &mut [f32], a: &mut [f32]| {
            dcp_act(
                m,
                obs.as_ptr(),
                2,
                s.as_mut_ptr(),
                s.len(),
                a.as_mut_ptr(),
                2,
                e,
            )
        };
        assert_eq!(
            act(&zeroed, &mut e, &mut scratch, &mut action),
            DCP_ERR_NOT_LOADED
        );
        assert_eq!(
            dcp_scratch_floats(&zeroed, &mut floats, &mut e),
            DCP_ERR_NOT_LOADED
        );
        // A good load, then a failed one into the same storage: no model is left behind.
        let good = golden("actor_4x48.postcard");
        let mut m = load(&good);
        assert_eq!(act(&m, &mut e, &mut scratch, &mut action), DCP_OK);
        let mut bad = good.clone();
        bad[0] = b'X';
        assert_eq!(
            dcp_model_load(bad.as_ptr(), bad.len(), &mut m, &mut e),
            DCP_ERR_WRONG_MAGIC
        );
        assert_eq!(e.found, u32::from_le_bytes(*b"XCPB") as usize);
        assert_eq!(
            act(&m, &mut e, &mut scratch, &mut action),
            DCP_ERR_NOT_LOADED
        );
        assert_eq!(text(&e.what), "model");
    }
}

#[test]
fn wrong_lengths_and_kinds_are_error_codes() {
    let actor = golden("actor_4x48.postcard");
    let critic = golden("critic_2x32.postcard");
    let (m, c) = (load(&actor), load(&critic));
    let obs = [0.5f32, -0.5, 9.0];
    let mut scratch = vec![0.0f32; 200];
    let mut action = [0.0f32; 3];
    let mut e = new_error();
    let mut floats = 0;
    // SAFETY: valid buffers, each at least as long as the length passed.
    unsafe {
        assert_eq!(dcp_scratch_floats(&m, &mut floats, &mut e), DCP_OK);
        assert_eq!(floats, 96);
        let s = scratch.as_mut_ptr();
        let a = action.as_mut_ptr();
        // Observation and action sizes.
        assert_eq!(
            dcp_act(&m, obs.as_ptr(), 3, s, 96, a, 2, &mut e),
            DCP_ERR_SIZE_MISMATCH
        );
        assert_eq!((e.expected, e.found), (3, 2));
        assert_eq!(
            dcp_act(&m, obs.as_ptr(), 1, s, 96, a, 2, &mut e),
            DCP_ERR_SIZE_MISMATCH
        );
        assert_eq!(
            dcp_act(&m, obs.as_ptr(), 2, s, 96, a, 3, &mut e),
            DCP_ERR_SIZE_MISMATCH
        );
        assert_eq!(text(&e.what), "action size");
        // Scratch one float short, and empty; a longer one is fine.
        assert_eq!(
            dcp_act(&m, obs.as_ptr(), 2, s, 95, a, 2, &mut e),
            DCP_ERR_SCRATCH_TOO_SMALL
        );
        assert_eq!((e.needed, e.found), (48, 47));
        assert_eq!(
            dcp_act(&m, obs.as_ptr(), 2, s, 0, a, 2, &mut e),
            DCP_ERR_SCRATCH_TOO_SMALL
        );
        assert_eq!(dcp_act(&m, obs.as_ptr(), 2, s, 200, a, 2, &mut e), DCP_OK);
        assert_eq!(e.code, DCP_OK);
        // A length past the address space.
        assert_eq!(
            dcp_act(&m, obs.as_ptr(), usize::MAX / 2, s, 96, a, 2, &mut e),
            DCP_ERR_BAD_LENGTH
        );
        assert_eq!(text(&e.what), "obs");
        assert_eq!(
            dcp_verify(actor.as_ptr(), usize::MAX, &mut core::mem::zeroed(), &mut e),
            DCP_ERR_BAD_LENGTH
        );
        // Blob lengths one short and one long.
        let mut other = new_model();
        assert_eq!(
            dcp_model_load(actor.as_ptr(), actor.len() - 1, &mut other, &mut e),
            DCP_ERR_TRUNCATED
        );
        let mut longer = actor.clone();
        longer.push(0);
        assert_eq!(
            dcp_model_load(longer.as_ptr(), longer.len(), &mut other, &mut e),
            DCP_ERR_TRAILING_BYTES
        );
        // The wrong kind: act on a critic, q on an actor, choose on either.
        assert_eq!(
            dcp_act(&c, obs.as_ptr(), 2, s, 96, a, 2, &mut e),
            DCP_ERR_WRONG_KIND
        );
        assert_eq!(
            (e.expected, e.found),
            (DCP_KIND_ACTOR as usize, DCP_KIND_CRITIC as usize)
        );
        let mut q = 0.0;
        let u = [0.0f32; 2];
        assert_eq!(
            dcp_q(&m, obs.as_ptr(), 2, u.as_ptr(), 2, s, 96, &mut q, &mut e),
            DCP_ERR_WRONG_KIND
        );
        let mut index = 0;
        assert_eq!(
            dcp_choose(&m, obs.as_ptr(), 2, s, 96, &mut index, &mut e),
            DCP_ERR_WRONG_KIND
        );
        let mut rows = [0.0f32; 2];
        assert_eq!(
            dcp_choice_q(&m, obs.as_ptr(), 2, s, 96, rows.as_mut_ptr(), 2, &mut e),
            DCP_ERR_WRONG_KIND
        );
        assert_eq!(
            dcp_action_bounds(&c, a, a.add(2), 1, &mut e),
            DCP_ERR_WRONG_KIND
        );
        // for_policy refuses a critic and a scratch too narrow.
        assert_eq!(
            dcp_model_for_policy(critic.as_ptr(), critic.len(), 2, 2, 64, &mut other, &mut e),
            DCP_ERR_WRONG_KIND
        );
        assert_eq!(
            dcp_model_for_policy(actor.as_ptr(), actor.len(), 2, 2, 32, &mut other, &mut e),
            DCP_ERR_SCRATCH_TOO_SMALL
        );
        assert_eq!((e.needed, e.found), (48, 32));
    }
}

#[test]
fn misaligned_and_overlapping_buffers_are_error_codes() {
    let actor = golden("actor_4x48.postcard");
    let m = load(&actor);
    let mut floats = vec![0.0f32; 300];
    let mut e = new_error();
    let base = floats.as_mut_ptr();
    // SAFETY: every pointer points into `floats` with room for its length.
    unsafe {
        let odd = base.cast::<u8>().add(1).cast::<f32>();
        assert_eq!(
            dcp_act(&m, odd, 2, base.add(10), 96, base.add(200), 2, &mut e),
            DCP_ERR_MISALIGNED
        );
        assert_eq!(text(&e.what), "obs");
        // Scratch over the observation, the action inside the scratch.
        assert_eq!(
            dcp_act(&m, base.add(5), 2, base, 96, base.add(200), 2, &mut e),
            DCP_ERR_OVERLAP
        );
        assert_eq!(
            dcp_act(&m, base.add(250), 2, base, 96, base.add(95), 2, &mut e),
            DCP_ERR_OVERLAP
        );
        // Adjacent is not overlapping.
        assert_eq!(
            dcp_act(&m, base.add(96), 2, base, 96, base.add(98), 2, &mut e),
            DCP_OK
        );
        // A storage misaligned for dcp_model.
        let mut raw = vec![0u64; 64];
        let bad = raw.as_mut_ptr().cast::<u8>().add(4).cast::<DcpModel>();
        assert_eq!(
            dcp_model_load(actor.as_ptr(), actor.len(), bad, &mut e),
            DCP_ERR_MISALIGNED
        );
        // The model's storage inside the blob it is loaded from.
        let mut copy = vec![0u64; actor.len() / 8 + 64];
        let bytes = copy.as_mut_ptr().cast::<u8>();
        core::ptr::copy_nonoverlapping(actor.as_ptr(), bytes, actor.len());
        assert_eq!(
            dcp_model_load(bytes, actor.len(), bytes.cast::<DcpModel>(), &mut e),
            DCP_ERR_OVERLAP
        );
        // A scratch over the model's blob.
        assert_eq!(
            dcp_act(
                &m,
                base,
                2,
                actor.as_ptr().cast_mut().cast::<f32>(),
                96,
                base.add(4),
                2,
                &mut e
            ),
            DCP_ERR_OVERLAP
        );
    }
}

/// Regression: a misaligned `dcp_error *` was taken for NULL (the call ran and reported
/// success with nothing written), while every other misaligned pointer is an error. It is now
/// refused the same way, before the call does anything: a model storage stays unloaded.
#[test]
fn a_misaligned_error_pointer_is_refused_like_every_other_pointer() {
    let actor = golden("actor_4x48.postcard");
    let mut raw = vec![0u64; size_of::<DcpError>() / 8 + 2];
    // SAFETY: one byte into a buffer with room for a DcpError after it.
    let odd = unsafe { raw.as_mut_ptr().cast::<u8>().add(1).cast::<DcpError>() };
    let mut m = new_model();
    // SAFETY: every pointer is valid for its length; `odd` is writable.
    unsafe {
        assert_eq!(
            dcp_model_load(actor.as_ptr(), actor.len(), &mut m, odd),
            DCP_ERR_MISALIGNED
        );
        let (mut floats, mut scratch) = (0usize, [0.0f32; 96]);
        assert_eq!(
            dcp_scratch_floats(&m, &mut floats, null_mut()),
            DCP_ERR_NOT_LOADED
        );
        let (obs, mut action) = ([0.5f32, -0.25], [7.0f32; 2]);
        let loaded = load(&actor);
        assert_eq!(
            dcp_act(
                &loaded,
                obs.as_ptr(),
                2,
                scratch.as_mut_ptr(),
                96,
                action.as_mut_ptr(),
                2,
                odd
            ),
            DCP_ERR_MISALIGNED
        );
        assert_eq!(action, [7.0; 2], "nothing is written");
        assert_eq!(
            dcp_verify(actor.as_ptr(), actor.len(), null_mut(), odd),
            DCP_ERR_MISALIGNED
        );
    }
    assert!(
        raw.iter().all(|&w| w == 0),
        "nothing was written through err"
    );
}

/// `obs` and `action` may not be the same buffer (nor overlap): `action` is written while the
/// forward pass may still read `obs`, so the call refuses it with `DCP_ERR_OVERLAP`.
#[test]
fn an_action_written_over_its_observation_is_an_overlap() {
    let actor = golden("actor_4x48.postcard");
    let m = load(&actor);
    let (mut buf, mut scratch, mut e) = ([0.5f32, -0.25], [0.0f32; 96], new_error());
    // SAFETY: both pointers are `buf`, valid for two floats.
    let status = unsafe {
        dcp_act(
            &m,
            buf.as_ptr(),
            2,
            scratch.as_mut_ptr(),
            96,
            buf.as_mut_ptr(),
            2,
            &mut e,
        )
    };
    assert_eq!(status, DCP_ERR_OVERLAP);
    assert_eq!(text(&e.what), "action and obs");
    assert_eq!(buf, [0.5, -0.25], "the observation is left as it was");
}

/// No struct of the API has padding: every byte is a named field the library writes (zero for
/// the `reserved` ones), so a caller that copies or hashes a struct reads no stale stack bytes.
#[test]
fn the_api_structs_have_no_padding() {
    let word = size_of::<usize>();
    assert_eq!(size_of::<DcpHeader>(), 10 * 4 + DCP_LABEL_LEN + 3 + 4 * 4);
    assert_eq!(
        size_of::<DcpError>(),
        4 + 4 + 6 * word + DCP_WHAT_LEN + DCP_MESSAGE_LEN
    );
    assert_eq!(size_of::<DcpSlotStatus>(), 4 + 4 + size_of::<DcpError>());
    assert_eq!(size_of::<DcpBoot>(), 4 + 4 + 2 * size_of::<DcpSlotStatus>());
}

/// Regression: a board with one slot had to pass a dummy second region, as
/// `dcp_slot_choose(a, len, NULL, 0, ...)` failed the boot with `DCP_ERR_NULL_POINTER`. NULL
/// with length 0 is now an absent slot, reported empty; NULL with a length is still an error.
#[test]
fn a_board_with_one_slot_passes_null_for_the_other() {
    let actor = golden("actor_4x48.postcard");
    let image = [&slot::header(3, actor.len()).expect("header")[..], &actor].concat();
    for a_is_present in [true, false] {
        let (mut boot, mut m, mut e) = (
            core::mem::MaybeUninit::<DcpBoot>::zeroed(),
            new_model(),
            new_error(),
        );
        let (a, a_len, b, b_len) = if a_is_present {
            (image.as_ptr(), image.len(), null(), 0)
        } else {
            (null(), 0, image.as_ptr(), image.len())
        };
        // SAFETY: the present slot is `image`; the absent one is NULL with length 0.
        let code = unsafe {
            dcp_slot_choose(
                a,
                a_len,
                b,
                b_len,
                2,
                2,
                64,
                boot.as_mut_ptr(),
                &mut m,
                &mut e,
            )
        };
        assert_eq!(code, DCP_OK, "{}", text(&e.message));
        // SAFETY: written by the successful call.
        let boot = unsafe { boot.assume_init() };
        let (present, absent) = if a_is_present {
            (boot.a, boot.b)
        } else {
            (boot.b, boot.a)
        };
        assert_eq!(
            boot.running,
            if a_is_present { DCP_SLOT_A } else { DCP_SLOT_B }
        );
        assert_eq!((present.state, present.sequence), (DCP_SLOT_RUNNING, 3));
        assert_eq!(
            (absent.state, absent.error.code),
            (DCP_SLOT_FAILED, DCP_ERR_SLOT_EMPTY)
        );
    }
    let (mut boot, mut m, mut e) = (
        core::mem::MaybeUninit::<DcpBoot>::zeroed(),
        new_model(),
        new_error(),
    );
    // SAFETY: slot B is NULL with a length: refused before anything is read.
    let code = unsafe {
        dcp_slot_choose(
            image.as_ptr(),
            image.len(),
            null(),
            64,
            2,
            2,
            64,
            boot.as_mut_ptr(),
            &mut m,
            &mut e,
        )
    };
    assert_eq!(
        (code, text(&e.what).as_str()),
        (DCP_ERR_NULL_POINTER, "slot_b")
    );
}

/// Reentrancy, as docs/c-api.md states it: calls share no state, so a call may be preempted
/// by another (an interrupt, a thread) on the same model or another one, each with its own
/// scratch and outputs, and both give the bits they give alone. Two threads act on one shared
/// model and a third on a second model, interleaved at whatever points the scheduler picks.
#[test]
fn calls_on_one_model_or_two_at_once_give_the_bits_they_give_alone() {
    let actor = golden("actor_4x48.postcard");
    let critic = golden("critic_2x32.postcard");
    let (shared, other) = (load(&actor), load(&critic));
    let observations: Vec<[f32; 2]> = (0..2000)
        .map(|k| [k as f32 * 0.013 - 9.0, 4.0 - k as f32 * 0.007])
        .collect();
    let alone_act = |o: &[f32; 2]| {
        let (mut scratch, mut action) = ([0.0f32; 96], [0.0f32; 2]);
        // SAFETY: every pointer is a live local or the shared model, with room for its length.
        let code = unsafe {
            dcp_act(
                &shared,
                o.as_ptr(),
                2,
                scratch.as_mut_ptr(),
                96,
                action.as_mut_ptr(),
                2,
                null_mut(),
            )
        };
        assert_eq!(code, DCP_OK);
        action.map(f32::to_bits)
    };
    let alone_q = |o: &[f32; 2]| {
        let (mut scratch, mut q) = ([0.0f32; 64], 0.0f32);
        let unit = [o[0] / 10.0, o[1] / 10.0];
        // SAFETY: as above, with the second model.
        let code = unsafe {
            dcp_q(
                &other,
                o.as_ptr(),
                2,
                unit.as_ptr(),
                2,
                scratch.as_mut_ptr(),
                64,
                &mut q,
                null_mut(),
            )
        };
        assert_eq!(code, DCP_OK);
        q.to_bits()
    };
    let want_act: Vec<[u32; 2]> = observations.iter().map(alone_act).collect();
    let want_q: Vec<u32> = observations.iter().map(alone_q).collect();
    std::thread::scope(|s| {
        let acting = [
            s.spawn(|| observations.iter().map(alone_act).collect::<Vec<_>>()),
            s.spawn(|| {
                observations
                    .iter()
                    .rev()
                    .map(alone_act)
                    .rev()
                    .collect::<Vec<_>>()
            }),
        ];
        let scoring = s.spawn(|| observations.iter().map(alone_q).collect::<Vec<_>>());
        for t in acting {
            assert_eq!(t.join().expect("thread"), want_act);
        }
        assert_eq!(scoring.join().expect("thread"), want_q);
    });
}

fn hex(t: &str) -> u32 {
    u32::from_str_radix(t, 16).expect("hex")
}

/// policy-core's golden vectors through the C API: the committed output bits.
#[test]
fn the_c_api_reproduces_the_golden_vectors() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../policy-core/tests/golden/vectors.txt"
    ))
    .expect("vectors");
    let blobs = [
        golden("actor_2x32.postcard"),
        golden("actor_4x48.postcard"),
        golden("critic_2x32.postcard"),
    ];
    let models = [load(&blobs[0]), load(&blobs[1]), load(&blobs[2])];
    let mut scratch = [0.0f32; 128];
    let mut checked = 0;
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        let Some((lhs, rhs)) = line.split_once("->") else {
            continue;
        };
        let mut f = lhs.split_whitespace();
        let tag = f.next().expect("tag");
        let input: Vec<f32> = f.map(|t| f32::from_bits(hex(t))).collect();
        let want: Vec<u32> = rhs.split_whitespace().map(hex).collect();
        let s = scratch.as_mut_ptr();
        let got: Vec<u32> = match tag {
            "act2x32" | "act4x48" => {
                let m = &models[usize::from(tag == "act4x48")];
                let mut a = [0.0f32; 2];
                // SAFETY: valid buffers.
                let code =
                    unsafe { dcp_act(m, input.as_ptr(), 2, s, 128, a.as_mut_ptr(), 2, null_mut()) };
                assert_eq!(code, DCP_OK);
                a.iter().map(|v| v.to_bits()).collect()
            }
            "q2x32" => {
                let mut q = 0.0f32;
                // SAFETY: valid buffers.
                let code = unsafe {
                    dcp_q(
                        &models[2],
                        input.as_ptr(),
                        2,
                        input[2..].as_ptr(),
                        2,
                        s,
                        128,
                        &mut q,
                        null_mut(),
                    )
                };
                assert_eq!(code, DCP_OK);
                vec![q.to_bits()]
            }
            _ => continue,
        };
        assert_eq!(got, want, "{line}");
        checked += 1;
    }
    assert!(checked > 50, "only {checked} vectors");
}

/// A discrete policy through dcp_choose and dcp_act: the same index and row as `Model`.
#[test]
fn a_discrete_policy_chooses_as_the_model_does() {
    let shape = Shape {
        observations: 2,
        actions: 2,
        width: 16,
        depth: 2,
        choices: 5,
    };
    let spec = policy_core::blob::Spec {
        kind: ModelKind::Discrete,
        encoding: Encoding::F32,
        shape,
        activation: policy_core::Activation::Relu,
        label: "discrete",
    };
    let count = shape.param_count(ModelKind::Discrete).expect("count");
    let prefix = shape.prefix_count(ModelKind::Discrete);
    let mut params: Vec<f32> = (0..count)
        .map(|i| ((i * 37 % 101) as f32 / 101.0 - 0.5) * 0.8)
        .collect();
    // Normaliser: mean 0, inverse std 1, clip 5; bounds [-1, 1]; a table inside them.
    for i in 0..2 {
        params[i] = 0.0;
        params[2 + i] = 1.0;
    }
    params[4] = 5.0;
    for i in 0..2 {
        params[5 + i] = -1.0;
        params[7 + i] = 1.0;
    }
    for v in &mut params[9..prefix] {
        *v = v.clamp(-1.0, 1.0);
    }
    let mut blob = vec![0u8; 4096];
    let len = policy_core::blob::write(
        &spec,
        &mut |sink: &mut dyn FnMut(&[f32])| sink(&params),
        &mut blob,
    )
    .expect("a discrete blob");
    blob.truncate(len);
    let model = Model::from_blob(&blob).expect("loads");
    let m = load(&blob);
    for k in 0..20 {
        let obs = [k as f32 * 0.3 - 3.0, 1.5 - k as f32 * 0.2];
        let mut scratch = [0.0f32; 64];
        let mut index = u32::MAX;
        let mut a = [0.0f32; 2];
        // SAFETY: valid buffers.
        unsafe {
            let s = scratch.as_mut_ptr();
            assert_eq!(
                dcp_choose(&m, obs.as_ptr(), 2, s, 64, &mut index, null_mut()),
                DCP_OK
            );
            assert_eq!(
                dcp_act(&m, obs.as_ptr(), 2, s, 64, a.as_mut_ptr(), 2, null_mut()),
                DCP_OK
            );
        }
        let mut fixed = Scratch::<16>::new();
        assert_eq!(
            Some(index as usize),
            model.choose(&obs, &mut fixed).ok(),
            "{obs:?}"
        );
        let mut b = [0.0f32; 2];
        model.act(&obs, &mut fixed, &mut b).expect("act");
        assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits));
        // Every row's Q, as the model computes it, and the index is their argmax.
        let mut q = [0.0f32; 5];
        // SAFETY: valid, distinct buffers.
        let code = unsafe {
            dcp_choice_q(
                &m,
                obs.as_ptr(),
                2,
                scratch.as_mut_ptr(),
                64,
                q.as_mut_ptr(),
                5,
                null_mut(),
            )
        };
        assert_eq!(code, DCP_OK);
        let mut want = [0.0f32; 5];
        model
            .choice_values_in(&obs, fixed.as_mut_slice(), &mut want)
            .expect("values");
        assert_eq!(q.map(f32::to_bits), want.map(f32::to_bits));
        assert_eq!(policy_core::model::argmax(&q), index as usize);
    }
    // A q of another length than the blob's choices, and a q over the scratch, are codes.
    let mut e = new_error();
    let mut scratch = [0.0f32; 70];
    let obs = [0.5f32, -0.5];
    // SAFETY: valid buffers; the lengths and the overlap are what is tested.
    unsafe {
        let s = scratch.as_mut_ptr();
        let mut q = [0.0f32; 4];
        assert_eq!(
            dcp_choice_q(&m, obs.as_ptr(), 2, s, 64, q.as_mut_ptr(), 4, &mut e),
            DCP_ERR_SIZE_MISMATCH
        );
        assert_eq!((e.expected, e.found), (5, 4));
        assert_eq!(
            std::ffi::CStr::from_ptr(e.what.as_ptr()).to_str(),
            Ok("choice count")
        );
        assert_eq!(
            dcp_choice_q(&m, obs.as_ptr(), 2, s, 64, s.add(60), 5, &mut e),
            DCP_ERR_OVERLAP
        );
    }
}

fn record(seq: u32, blob: &[u8]) -> Vec<u8> {
    [&slot::header(seq, blob.len()).expect("header")[..], blob].concat()
}

fn choose(a: &[u8], b: &[u8]) -> (i32, DcpBoot, DcpModel) {
    // SAFETY: plain data; all zeros is a valid value.
    let mut boot: DcpBoot = unsafe { core::mem::zeroed() };
    let mut m = new_model();
    // SAFETY: valid buffers (an empty slot: a dangling but aligned, non-NULL pointer, length 0).
    let code = unsafe {
        dcp_slot_choose(
            a.as_ptr(),
            a.len(),
            b.as_ptr(),
            b.len(),
            2,
            2,
            64,
            &mut boot,
            &mut m,
            null_mut(),
        )
    };
    (code, boot, m)
}

/// The slot rule through C: the same slot, statuses and reasons as policy_core::slot::choose.
#[test]
fn the_slot_rule_matches_policy_core() {
    let actor = golden("actor_4x48.postcard");
    let other = golden("actor_2x32.postcard");
    let critic = golden("critic_2x32.postcard");
    let mut flipped = record(2, &other);
    flipped[100] ^= 1;
    let cases: Vec<(Vec<u8>, Vec<u8>)> = vec![
        (record(1, &actor), vec![]),
        (record(1, &actor), record(2, &other)),
        (record(1, &actor), flipped),
        (vec![0xFF; 64], record(7, &other)),
        (vec![], vec![]),
        (record(1, &actor), record(2, &critic)),
        (record(u32::MAX, &actor), record(0, &other)),
        (vec![0x55; 64], vec![0; 8]),
    ];
    for (a, b) in &cases {
        let rust = slot::choose(a, b, |blob| Model::for_policy(blob, 2, 2, 64));
        let (code, boot, m) = choose(a, b);
        let want_running = match rust.running {
            Some((slot::SlotId::A, _)) => DCP_SLOT_A,
            Some((slot::SlotId::B, _)) => DCP_SLOT_B,
            None => DCP_SLOT_NONE,
        };
        assert_eq!(boot.running, want_running);
        assert_eq!(
            code,
            if rust.running.is_some() {
                DCP_OK
            } else {
                DCP_ERR_NO_SLOT
            }
        );
        for (status, c) in [(rust.a, boot.a), (rust.b, boot.b)] {
            match status {
                slot::Status::Running { sequence } => {
                    assert_eq!((c.state, c.sequence), (DCP_SLOT_RUNNING, sequence))
                }
                slot::Status::Standby { sequence } => {
                    assert_eq!((c.state, c.sequence), (DCP_SLOT_STANDBY, sequence))
                }
                slot::Status::Failed(e) => {
                    assert_eq!(c.state, DCP_SLOT_FAILED);
                    assert_eq!(c.error.code, code_of(&e));
                    assert_eq!(text(&c.error.message), e.to_string());
                }
            }
        }
        // The model loaded is the running slot's, and runs; none loaded means none runs.
        let mut h: DcpHeader = {
            // SAFETY: plain data; all zeros is a valid value.
            unsafe { core::mem::zeroed() }
        };
        // SAFETY: valid buffers.
        let header_code = unsafe { dcp_model_header(&m, &mut h, null_mut()) };
        match rust.running {
            Some((_, model)) => {
                assert_eq!(header_code, DCP_OK);
                assert_eq!(h.width, u32::from(model.header().shape.width));
            }
            None => assert_eq!(header_code, DCP_ERR_NOT_LOADED),
        }
    }
}

/// The integer entry: codes from `dcp_observation_codes`, then `dcp_act_codes`, give the unit
/// codes whose `code / 127` is exactly the unit action the float entry computes (policy-core's
/// `act_unit`), for observations with NaN, infinities, −0, a subnormal and f32's extremes.
#[test]
fn the_integer_entry_gives_the_float_entrys_unit_action_in_integers() {
    let blob = golden("actor_4x48_integer.postcard");
    let m = load(&blob);
    let model = Model::from_blob(&blob).expect("loads");
    let specials = [
        0.0,
        -0.0,
        1.0e-40,
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::MAX,
        f32::MIN,
        4.0,
        -2.5,
    ];
    let mut scratch = [0i32; 96];
    for &a in &specials {
        for &b in &specials {
            let obs = [a, b];
            let (mut codes, mut unit) = ([0i8; 2], [0i8; 2]);
            // SAFETY: every buffer is valid for its length and distinct.
            let code = unsafe {
                dcp_observation_codes(&m, obs.as_ptr(), 2, codes.as_mut_ptr(), 2, null_mut())
            };
            assert_eq!(code, DCP_OK, "{obs:?}: {}", name(code));
            let mut expected_codes = [0i8; 2];
            model
                .observation_codes(&obs, &mut expected_codes)
                .expect("codes");
            assert_eq!(codes, expected_codes, "{obs:?}");
            // SAFETY: as above.
            let code = unsafe {
                dcp_act_codes(
                    &m,
                    codes.as_ptr(),
                    2,
                    scratch.as_mut_ptr(),
                    scratch.len(),
                    unit.as_mut_ptr(),
                    2,
                    null_mut(),
                )
            };
            assert_eq!(code, DCP_OK, "{obs:?}: {}", name(code));
            let mut float_unit = [0.0f32; 2];
            model
                .act_unit(&obs, &mut Scratch::<48>::new(), &mut float_unit)
                .expect("acts");
            let from_codes = unit.map(|c| f32::from(c) / 127.0);
            assert_eq!(
                from_codes.map(f32::to_bits),
                float_unit.map(f32::to_bits),
                "{obs:?}"
            );
        }
    }
}

/// Misuse of the integer entry: each gives its code and writes nothing.
#[test]
fn the_integer_entry_refuses_misuse_by_code() {
    let integer = golden("actor_4x48_integer.postcard");
    let f32_actor = golden("actor_4x48.postcard");
    let critic = golden("critic_2x32.postcard");
    let (m, f, c) = (load(&integer), load(&f32_actor), load(&critic));
    let zeroed = new_model();
    let obs = [0.5f32, -0.5];
    let codes = [3i8, -4];
    let mut scratch = [0i32; 96];
    let mut e = new_error();
    let act = |model: &DcpModel, codes_len, scratch: &mut [i32], unit: *mut i8, len, e| {
        // SAFETY: every non-NULL pointer is valid for its length.
        unsafe {
            dcp_act_codes(
                model,
                codes.as_ptr(),
                codes_len,
                scratch.as_mut_ptr(),
                scratch.len(),
                unit,
                len,
                e,
            )
        }
    };
    let mut unit = [99i8; 2];
    let u = unit.as_mut_ptr();
    let cases = [
        (
            "f32 blob",
            act(&f, 2, &mut scratch, u, 2, &mut e),
            DCP_ERR_WRONG_ENCODING,
        ),
        (
            "critic",
            act(&c, 2, &mut scratch, u, 2, &mut e),
            DCP_ERR_WRONG_KIND,
        ),
        (
            "not loaded",
            act(&zeroed, 2, &mut scratch, u, 2, &mut e),
            DCP_ERR_NOT_LOADED,
        ),
        (
            "codes 1",
            act(&m, 1, &mut scratch, u, 2, &mut e),
            DCP_ERR_SIZE_MISMATCH,
        ),
        (
            "actions 1",
            act(&m, 2, &mut scratch, u, 1, &mut e),
            DCP_ERR_SIZE_MISMATCH,
        ),
        (
            "scratch",
            act(&m, 2, &mut scratch[..16], u, 2, &mut e),
            DCP_ERR_SCRATCH_TOO_SMALL,
        ),
        (
            "unit NULL",
            act(&m, 2, &mut scratch, null_mut(), 2, &mut e),
            DCP_ERR_NULL_POINTER,
        ),
    ];
    for (what, code, expected) in cases {
        assert_eq!(name(code), name(expected), "{what}");
    }
    assert_eq!(unit, [99, 99], "nothing written on failure");
    // The unit codes written over the scratch: an overlap, refused before any work.
    let inside = scratch.as_mut_ptr().cast::<i8>();
    assert_eq!(
        name(act(&m, 2, &mut scratch, inside, 2, &mut e)),
        name(DCP_ERR_OVERLAP)
    );
    assert_eq!(text(&e.what), "scratch and unit_codes");
    // Observation codes: the wrong encoding, a size mismatch, codes written over the
    // observation.
    let mut out = [0i8; 2];
    // SAFETY: every pointer is valid for its length.
    unsafe {
        let code = dcp_observation_codes(&f, obs.as_ptr(), 2, out.as_mut_ptr(), 2, &mut e);
        assert_eq!(name(code), name(DCP_ERR_WRONG_ENCODING));
        let code = dcp_observation_codes(&m, obs.as_ptr(), 2, out.as_mut_ptr(), 1, &mut e);
        assert_eq!(name(code), name(DCP_ERR_SIZE_MISMATCH));
        let code = dcp_observation_codes(
            &m,
            obs.as_ptr(),
            2,
            obs.as_ptr().cast_mut().cast(),
            2,
            &mut e,
        );
        assert_eq!(name(code), name(DCP_ERR_OVERLAP));
        assert_eq!(text(&e.what), "codes and obs");
    }
    assert_eq!(out, [0, 0], "nothing written on failure");
}
