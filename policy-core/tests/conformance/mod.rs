//! The conformance vectors of `policy-core/conformance/`, run against policy-core.
//!
//! `vectors.txt` is the manifest another implementation runs too (docs/blob-format.md,
//! "Conformance vectors"); the runner below is the reference for what each line asks. The
//! second test regenerates the folder from `generate.rs` and requires the committed files to
//! be exactly that (`UPDATE_GOLDEN=1` rewrites them), so the vectors, the generator and the
//! reader cannot drift apart.

mod generate;
mod integer_cases;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use policy_core::model::{Model, Scratch};
use policy_core::slot::{self, SlotId};
use policy_core::Error;

/// Wide enough for every valid vector (the widest is 16).
pub type Scratch64 = Scratch<64>;

fn folder() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("conformance")
}

/// The error's class: its variant name, which is also the C API's status name without the
/// `DCP_ERR_` prefix and in CamelCase.
pub fn class(err: &Error) -> String {
    let debug = format!("{err:?}");
    debug
        .split([' ', '{', '('])
        .next()
        .unwrap_or_default()
        .to_string()
}

/// f32 values as their bits, 8 hex digits each, comma-separated.
pub fn hex_bits(values: &[f32]) -> String {
    let words: Vec<String> = values
        .iter()
        .map(|v| format!("{:08x}", v.to_bits()))
        .collect();
    words.join(",")
}

fn parse_bits(list: &str) -> Vec<f32> {
    list.split(',')
        .map(|w| f32::from_bits(u32::from_str_radix(w, 16).expect("8 hex digits")))
        .collect()
}

/// One manifest line: the command, its positional words and its `key=value` fields.
struct Line<'a> {
    words: Vec<&'a str>,
    fields: BTreeMap<&'a str, &'a str>,
}

impl<'a> Line<'a> {
    fn parse(line: &'a str) -> Line<'a> {
        let (mut words, mut fields) = (Vec::new(), BTreeMap::new());
        for token in line.split_whitespace() {
            match token.split_once('=') {
                Some((k, v)) => {
                    fields.insert(k, v);
                }
                None => words.push(token),
            }
        }
        Line { words, fields }
    }

    fn field(&self, key: &str) -> &'a str {
        self.fields
            .get(key)
            .copied()
            .unwrap_or_else(|| panic!("{:?}: no {key}=", self.words))
    }

    fn number(&self, key: &str) -> usize {
        self.field(key).parse().expect("a decimal number")
    }
}

fn read(relative: &str) -> Vec<u8> {
    let path = folder().join(relative);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn every_vector_holds_for_policy_core() {
    let manifest = std::fs::read_to_string(folder().join("vectors.txt")).expect("vectors.txt");
    let mut blobs: BTreeMap<String, Vec<u8>> = BTreeMap::new();
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    let scratch = &mut Scratch64::new();
    for (n, text) in manifest.lines().enumerate() {
        if text.trim().is_empty() || text.starts_with('#') {
            continue;
        }
        let line = Line::parse(text);
        let at = format!("vectors.txt:{}: {text}", n + 1);
        let (command, name) = (line.words[0], line.words[1]);
        let bytes = blobs
            .entry(name.to_string())
            .or_insert_with(|| match command {
                "slot" => Vec::new(),
                _ => read(&format!("blobs/{name}.blob")),
            })
            .clone();
        let key = match command {
            "blob" => format!("blob {}", line.words[2]),
            other => other.to_string(),
        };
        *counts.entry(key).or_default() += 1;
        match (command, line.words.get(2).copied()) {
            ("blob", Some("accept")) => {
                let model = Model::from_blob(&bytes).unwrap_or_else(|e| panic!("{at}: {e}"));
                let h = model.header();
                let label: String = h.label.bytes().map(|b| format!("{b:02x}")).collect();
                let crc = u32::from_le_bytes(*bytes.last_chunk::<4>().expect("crc"));
                let found = [
                    ("version", h.version.to_string()),
                    ("kind", generate::kind_name(h.kind).to_string()),
                    ("encoding", h.encoding.to_string()),
                    ("observations", h.shape.observations.to_string()),
                    ("actions", h.shape.actions.to_string()),
                    ("width", h.shape.width.to_string()),
                    ("depth", h.shape.depth.to_string()),
                    ("choices", h.shape.choices.to_string()),
                    ("activation", h.activation.to_string()),
                    ("label", if label.is_empty() { "-".into() } else { label }),
                    ("payload_len", h.payload_len.to_string()),
                    ("crc", format!("{crc:08x}")),
                ];
                for (key, value) in found {
                    assert_eq!(line.field(key), value, "{at}: {key}");
                }
            }
            ("blob", Some("reject")) => {
                let err = Model::from_blob(&bytes).expect_err(&at);
                let expected = line.words[3..].join(" ");
                let expected = match line.fields.get("index") {
                    Some(i) => format!("{expected} index={i}"),
                    None => expected,
                };
                assert_eq!(generate::reject_fields(&err), expected, "{at}: {err}");
            }
            ("act", _) => {
                let model = Model::from_blob(&bytes).expect(&at);
                let expected = parse_bits(line.field("action"));
                let mut action = vec![0.0; expected.len()];
                model
                    .act(&parse_bits(line.field("obs")), scratch, &mut action)
                    .expect(&at);
                assert_eq!(hex_bits(&action), hex_bits(&expected), "{at}");
                // An integer actor's line also gives its input codes and the integer entry's
                // unit codes for them.
                if let Some(codes) = line.fields.get("codes") {
                    *counts.entry("act codes".into()).or_default() += 1;
                    let obs = parse_bits(line.field("obs"));
                    let mut found = vec![0i8; obs.len()];
                    model.observation_codes(&obs, &mut found).expect(&at);
                    assert_eq!(generate::decimal(&found), *codes, "{at}: codes");
                    let mut units = vec![0i8; expected.len()];
                    let ints = &mut vec![0i32; model.scratch_floats()];
                    model.act_codes_in(&found, ints, &mut units).expect(&at);
                    assert_eq!(generate::decimal(&units), line.field("units"), "{at}");
                }
            }
            ("q", _) => {
                let model = Model::from_blob(&bytes).expect(&at);
                let obs = parse_bits(line.field("obs"));
                let q = model
                    .q(&obs, &parse_bits(line.field("action")), scratch)
                    .expect(&at);
                // A NaN matches any NaN: the bits of a NaN that arithmetic makes differ between
                // CPUs (x86 gives ffc00000, Arm 7fc00000), and Q is returned as computed.
                let expected = parse_bits(line.field("q"))[0];
                if expected.is_nan() {
                    assert!(q.is_nan(), "{at}: {q}");
                } else {
                    assert_eq!(hex_bits(&[q]), line.field("q"), "{at}");
                }
            }
            ("choose", _) => {
                let model = Model::from_blob(&bytes).expect(&at);
                let obs = parse_bits(line.field("obs"));
                let index = model.choose(&obs, scratch).expect(&at);
                assert_eq!(index, line.number("index"), "{at}");
                let expected = parse_bits(line.field("action"));
                let mut action = vec![0.0; expected.len()];
                model.act(&obs, scratch, &mut action).expect(&at);
                assert_eq!(hex_bits(&action), hex_bits(&expected), "{at}");
                // Every row's Q value, the argmax's input; a NaN matches any NaN, as for `q`.
                let expected = parse_bits(line.field("q"));
                let mut q = vec![0.0; expected.len()];
                model
                    .choice_values_in(&obs, scratch.as_mut_slice(), &mut q)
                    .expect(&at);
                for (k, (&got, &want)) in q.iter().zip(&expected).enumerate() {
                    if want.is_nan() {
                        assert!(got.is_nan(), "{at}: row {k}: {got}");
                    } else {
                        assert_eq!(got.to_bits(), want.to_bits(), "{at}: row {k}");
                    }
                }
            }
            ("slot", _) => {
                let region = |key| read(&format!("slots/{}.slot", line.field(key)));
                let (a, b) = (region("slot_a"), region("slot_b"));
                let sizes = (
                    line.number("observations"),
                    line.number("actions"),
                    line.number("width"),
                );
                let boot = slot::choose(&a, &b, |blob| {
                    Model::for_policy(blob, sizes.0, sizes.1, sizes.2)
                });
                let runs = match boot.running {
                    Some((SlotId::A, _)) => "A",
                    Some((SlotId::B, _)) => "B",
                    None => "none",
                };
                assert_eq!(runs, line.field("runs"), "{at}");
                assert_eq!(generate::status(boot.a), line.field("status_a"), "{at}");
                assert_eq!(generate::status(boot.b), line.field("status_b"), "{at}");
            }
            _ => panic!("{at}: unknown command"),
        }
    }
    // A manifest that lost its lines must not pass: every command is present in numbers.
    for (key, min) in [
        ("blob accept", 20),
        ("blob reject", 50),
        ("act", 100),
        ("act codes", 50),
        ("q", 30),
        ("choose", 30),
        ("slot", 15),
    ] {
        let found = counts.get(key).copied().unwrap_or(0);
        assert!(
            found >= min,
            "{found} `{key}` lines, expected at least {min}"
        );
    }
}

#[test]
fn vectors_are_what_the_generator_writes() {
    let vectors = generate::generate();
    let manifest = vectors.lines.join("\n") + "\n";
    let dir = folder();
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        for sub in ["blobs", "slots"] {
            let _ = std::fs::remove_dir_all(dir.join(sub));
            std::fs::create_dir_all(dir.join(sub)).expect("create");
        }
        for (path, bytes) in &vectors.files {
            std::fs::write(dir.join(path), bytes).expect("write vector");
        }
        std::fs::write(dir.join("vectors.txt"), &manifest).expect("write manifest");
    }
    let committed = std::fs::read_to_string(dir.join("vectors.txt")).expect("vectors.txt");
    assert!(
        committed == manifest,
        "vectors.txt differs from the generator's (UPDATE_GOLDEN=1 rewrites it)"
    );
    for (path, bytes) in &vectors.files {
        assert!(read(path) == *bytes, "{path} differs from the generator's");
    }
    // No file the manifest does not name.
    for sub in ["blobs", "slots"] {
        for entry in std::fs::read_dir(dir.join(sub)).expect("folder") {
            let name = format!(
                "{sub}/{}",
                entry.expect("entry").file_name().to_string_lossy()
            );
            assert!(vectors.files.contains_key(&name), "{name} is not a vector");
        }
    }
}

/// The error classes the vectors expect are policy-core's variant names, one per rule.
#[test]
fn classes_are_variant_names() {
    assert_eq!(class(&Error::SlotEmpty), "SlotEmpty");
    assert_eq!(class(&Error::Malformed { what: "x" }), "Malformed");
    assert_eq!(
        class(&Error::NonFiniteParameter { index: 3 }),
        "NonFiniteParameter"
    );
}
