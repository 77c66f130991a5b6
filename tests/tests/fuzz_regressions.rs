//! Every reproducer the fuzzer found (`fuzz/regressions/<target>/`) holds the properties now.
//!
//! A file listed in [`OPEN`] reproduces a bug not fixed yet; it is replayed only by the ignored
//! test, which passes once the bug is fixed (then the file leaves the list).

use std::path::{Path, PathBuf};

use tests::{blob_checks, fault_checks, scenario_checks};

/// Reproducers of open bugs, with the bug.
const OPEN: &[(&str, &str)] = &[
    (
        "scenario/arena-beyond-f32.toml",
        "firmware-sim: arena_half_size above f32::MAX validates, and the plant observes [inf, inf]",
    ),
    (
        "scenario/newline-in-name.toml",
        "firmware-sim: a name with a newline makes a validation error span two lines",
    ),
];

/// Every reproducer, as (target, path).
fn reproducers() -> Vec<(String, PathBuf)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/regressions");
    let mut out = Vec::new();
    for target in ["blob", "scenario", "faults"] {
        let Ok(dir) = std::fs::read_dir(root.join(target)) else {
            continue;
        };
        out.extend(dir.flatten().map(|e| (target.to_string(), e.path())));
    }
    out.sort();
    out
}

fn is_open(target: &str, path: &Path) -> bool {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
    OPEN.iter()
        .any(|(file, _)| *file == format!("{target}/{name}"))
}

/// Runs `target`'s checks on the file's bytes, as the fuzz target does.
fn replay(target: &str, path: &Path) {
    let bytes = std::fs::read(path).expect("a reproducer reads");
    let text = std::str::from_utf8(&bytes);
    match (target, text) {
        ("blob", _) => blob_checks::check(&bytes),
        ("scenario", Ok(text)) => scenario_checks::check(text),
        ("faults", Ok(text)) => fault_checks::check(text),
        _ => {}
    }
}

#[test]
fn fixed_findings_stay_fixed() {
    for (target, path) in reproducers() {
        if !is_open(&target, &path) {
            replay(&target, &path);
        }
    }
}

#[test]
#[ignore = "open firmware-sim bug, see OPEN"]
fn open_findings_are_fixed() {
    let still_open: Vec<String> = reproducers()
        .into_iter()
        .filter(|(target, path)| is_open(target, path))
        .filter(|(target, path)| std::panic::catch_unwind(|| replay(target, path)).is_err())
        .map(|(_, path)| path.display().to_string())
        .collect();
    assert!(still_open.is_empty(), "still failing: {still_open:?}");
}
