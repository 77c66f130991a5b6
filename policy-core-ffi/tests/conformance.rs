//! policy-core's conformance vectors (`policy-core/conformance/vectors.txt`) through the C API:
//! every blob accepted with the header the manifest lists or refused with its error class (and
//! index), every `act`, `q` and `choose` line's bits (and an integer actor's input codes and
//! integer-entry unit codes), and every slot case's running slot and statuses. A C firmware
//! calling these functions meets the same vectors as policy-core.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::ptr::null_mut;

use policy_core_ffi::*;

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../policy-core/conformance")
}

/// A file's bytes in 8-aligned storage (a blob's payload is read as 4-byte words).
struct Bytes {
    words: Vec<u64>,
    len: usize,
}

impl Bytes {
    fn read(path: &Path) -> Bytes {
        let raw = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let mut words = vec![0u64; raw.len() / 8 + 1];
        for (i, b) in raw.iter().enumerate() {
            words[i / 8] |= u64::from(*b) << (8 * (i % 8));
        }
        Bytes {
            words,
            len: raw.len(),
        }
    }

    fn ptr(&self) -> *const u8 {
        self.words.as_ptr().cast()
    }
}

fn fields<'a>(tokens: &[&'a str]) -> BTreeMap<&'a str, &'a str> {
    tokens.iter().filter_map(|t| t.split_once('=')).collect()
}

fn floats(list: &str) -> Vec<f32> {
    list.split(',')
        .map(|h| f32::from_bits(u32::from_str_radix(h, 16).expect("hex")))
        .collect()
}

fn bits(list: &str) -> Vec<u32> {
    list.split(',')
        .map(|h| u32::from_str_radix(h, 16).expect("hex"))
        .collect()
}

fn name(code: i32) -> String {
    // SAFETY: dcp_status_name returns a static NUL-terminated string.
    unsafe { std::ffi::CStr::from_ptr(dcp_status_name(code)) }
        .to_string_lossy()
        .into_owned()
}

fn new_model() -> DcpModel {
    DcpModel {
        opaque: [0; DCP_MODEL_BYTES],
    }
}

fn zeroed<T>() -> T {
    // SAFETY: used only for the API's plain-data structs (integers and char arrays).
    unsafe { std::mem::zeroed() }
}

fn label_hex(h: &DcpHeader) -> String {
    h.label[..h.label_len as usize]
        .iter()
        .map(|&c| format!("{:02x}", c as u8))
        .collect()
}

fn kind(code: u32) -> &'static str {
    match code {
        DCP_KIND_ACTOR => "actor",
        DCP_KIND_CRITIC => "critic",
        DCP_KIND_DISCRETE => "discrete",
        _ => "?",
    }
}

fn encoding(code: u32) -> &'static str {
    match code {
        DCP_ENCODING_F32 => "f32",
        DCP_ENCODING_F16 => "f16",
        DCP_ENCODING_INT8 => "int8",
        DCP_ENCODING_INTEGER => "integer",
        _ => "?",
    }
}

fn status(s: &DcpSlotStatus) -> String {
    match s.state {
        DCP_SLOT_RUNNING => format!("running:{}", s.sequence),
        DCP_SLOT_STANDBY => format!("standby:{}", s.sequence),
        _ => format!("failed:{}", name(s.error.code)),
    }
}

/// Integers in decimal, comma-separated, as the manifest writes codes.
fn decimal(values: &[i8]) -> String {
    let words: Vec<String> = values.iter().map(i8::to_string).collect();
    words.join(",")
}

/// An integer actor's input codes for `obs` (`dcp_observation_codes`) and the unit codes the
/// integer entry returns for them (`dcp_act_codes`), both in decimal.
fn integer_entry(m: &DcpModel, obs: &[f32], actions: usize) -> (String, String) {
    let mut codes = vec![0i8; obs.len()];
    // SAFETY: every buffer is valid for its length and distinct.
    let code = unsafe {
        dcp_observation_codes(
            m,
            obs.as_ptr(),
            obs.len(),
            codes.as_mut_ptr(),
            codes.len(),
            null_mut(),
        )
    };
    assert_eq!(code, DCP_OK, "{}", name(code));
    let mut scratch = vec![0i32; 4096];
    let mut units = vec![0i8; actions];
    // SAFETY: every buffer is valid for its length and distinct.
    let code = unsafe {
        dcp_act_codes(
            m,
            codes.as_ptr(),
            codes.len(),
            scratch.as_mut_ptr(),
            scratch.len(),
            units.as_mut_ptr(),
            units.len(),
            null_mut(),
        )
    };
    assert_eq!(code, DCP_OK, "{}", name(code));
    (decimal(&codes), decimal(&units))
}

#[test]
fn every_conformance_vector_passes_through_the_c_api() {
    let manifest = std::fs::read_to_string(dir().join("vectors.txt")).expect("vectors.txt");
    let blob = |n: &str| Bytes::read(&dir().join("blobs").join(format!("{n}.blob")));
    let mut models: BTreeMap<String, (Bytes, DcpModel)> = BTreeMap::new();
    let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
    let mut scratch = vec![0.0f32; 4096];
    for line in manifest.lines() {
        let tokens: Vec<&str> = line.split_whitespace().collect();
        let (Some(&what), Some(&subject)) = (tokens.first(), tokens.get(1)) else {
            continue;
        };
        if what.starts_with('#') {
            continue;
        }
        let f = fields(&tokens[2..]);
        *counts.entry(what).or_default() += 1;
        match what {
            "blob" => {
                let bytes = blob(subject);
                let mut h: DcpHeader = zeroed();
                let mut e: DcpError = zeroed();
                // SAFETY: `bytes` holds `len` readable bytes; `h` and `e` are writable.
                let code = unsafe { dcp_verify(bytes.ptr(), bytes.len, &mut h, &mut e) };
                match tokens[2] {
                    "accept" => {
                        assert_eq!(code, DCP_OK, "{line}: {}", name(code));
                        let got = [
                            ("version", h.version.to_string()),
                            ("kind", kind(h.kind).to_string()),
                            ("encoding", encoding(h.encoding).to_string()),
                            ("observations", h.observations.to_string()),
                            ("actions", h.actions.to_string()),
                            ("width", h.width.to_string()),
                            ("depth", h.depth.to_string()),
                            ("choices", h.choices.to_string()),
                            (
                                "activation",
                                if h.activation == DCP_ACTIVATION_TANH {
                                    "tanh"
                                } else {
                                    "relu"
                                }
                                .to_string(),
                            ),
                            ("label", label_hex(&h)),
                            ("payload_len", h.payload_len.to_string()),
                            ("crc", format!("{:08x}", h.crc)),
                        ];
                        for (key, value) in got {
                            assert_eq!(f.get(key).copied(), Some(value.as_str()), "{line}: {key}");
                        }
                        let mut m = new_model();
                        // SAFETY: as above; `m` is writable and outlives none of `bytes`' uses.
                        let code =
                            unsafe { dcp_model_load(bytes.ptr(), bytes.len, &mut m, null_mut()) };
                        assert_eq!(code, DCP_OK, "{line}");
                        models.insert(subject.to_string(), (bytes, m));
                    }
                    "reject" => {
                        assert_eq!(name(code), tokens[3], "{line}");
                        assert_eq!(e.code, code, "{line}");
                        if let Some(index) = f.get("index") {
                            assert_eq!(e.index.to_string(), *index, "{line}");
                        }
                    }
                    other => panic!("{line}: unknown outcome {other}"),
                }
            }
            "act" | "q" | "choose" => {
                let (_, m) = models
                    .get(subject)
                    .unwrap_or_else(|| panic!("{line}: no accepted blob {subject}"));
                let obs = floats(f["obs"]);
                let s = scratch.as_mut_ptr();
                let n = scratch.len();
                if what == "q" {
                    let unit = floats(f["action"]);
                    let mut q = 0.0f32;
                    // SAFETY: every buffer is valid for its length and distinct.
                    let code = unsafe {
                        dcp_q(
                            m,
                            obs.as_ptr(),
                            obs.len(),
                            unit.as_ptr(),
                            unit.len(),
                            s,
                            n,
                            &mut q,
                            null_mut(),
                        )
                    };
                    assert_eq!(code, DCP_OK, "{line}: {}", name(code));
                    assert_eq!(vec![q.to_bits()], bits(f["q"]), "{line}");
                    continue;
                }
                let want = bits(f["action"]);
                let mut action = vec![0.0f32; want.len()];
                // SAFETY: every buffer is valid for its length and distinct.
                let code = unsafe {
                    dcp_act(
                        m,
                        obs.as_ptr(),
                        obs.len(),
                        s,
                        n,
                        action.as_mut_ptr(),
                        action.len(),
                        null_mut(),
                    )
                };
                assert_eq!(code, DCP_OK, "{line}: {}", name(code));
                let got: Vec<u32> = action.iter().map(|a| a.to_bits()).collect();
                assert_eq!(got, want, "{line}");
                if let Some(codes) = f.get("codes") {
                    let (found, units) = integer_entry(m, &obs, want.len());
                    assert_eq!(found, *codes, "{line}: codes");
                    assert_eq!(units, f["units"], "{line}: units");
                }
                if what == "choose" {
                    let mut index = u32::MAX;
                    // SAFETY: every buffer is valid for its length and distinct.
                    let code = unsafe {
                        dcp_choose(m, obs.as_ptr(), obs.len(), s, n, &mut index, null_mut())
                    };
                    assert_eq!(code, DCP_OK, "{line}");
                    assert_eq!(index.to_string(), f["index"], "{line}");
                    // Every row's Q value; a NaN matches any NaN (its bits are the CPU's).
                    let want = floats(f["q"]);
                    let mut q = vec![0.0f32; want.len()];
                    // SAFETY: every buffer is valid for its length and distinct.
                    let code = unsafe {
                        dcp_choice_q(
                            m,
                            obs.as_ptr(),
                            obs.len(),
                            s,
                            n,
                            q.as_mut_ptr(),
                            q.len(),
                            null_mut(),
                        )
                    };
                    assert_eq!(code, DCP_OK, "{line}: {}", name(code));
                    for (k, (g, w)) in q.iter().zip(&want).enumerate() {
                        assert!(
                            g.to_bits() == w.to_bits() || (g.is_nan() && w.is_nan()),
                            "{line}: row {k}: {g} against {w}"
                        );
                    }
                }
            }
            "slot" => {
                let slot = |n: &str| Bytes::read(&dir().join("slots").join(format!("{n}.slot")));
                let (a, b) = (slot(f["slot_a"]), slot(f["slot_b"]));
                let number = |k: &str| f[k].parse::<usize>().expect("number");
                let mut boot: DcpBoot = zeroed();
                let mut m = new_model();
                // SAFETY: both slots hold their lengths; `boot` and `m` are writable.
                let code = unsafe {
                    dcp_slot_choose(
                        a.ptr(),
                        a.len,
                        b.ptr(),
                        b.len,
                        number("observations"),
                        number("actions"),
                        number("width"),
                        &mut boot,
                        &mut m,
                        null_mut(),
                    )
                };
                let runs = match boot.running {
                    DCP_SLOT_A => "A",
                    DCP_SLOT_B => "B",
                    _ => "none",
                };
                assert_eq!(runs, f["runs"], "{line}");
                assert_eq!(code == DCP_OK, runs != "none", "{line}: {}", name(code));
                assert_eq!(status(&boot.a), f["status_a"], "{line}");
                assert_eq!(status(&boot.b), f["status_b"], "{line}");
            }
            other => panic!("unknown manifest line kind {other}: {line}"),
        }
    }
    // The manifest is not empty or cut short: every kind of line was seen.
    for kind in ["blob", "act", "q", "choose", "slot"] {
        assert!(
            counts.get(kind).copied().unwrap_or(0) > 0,
            "no {kind} line in {counts:?}"
        );
    }
}
