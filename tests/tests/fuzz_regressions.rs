//! Every reproducer the fuzzer harness found (`fuzz/regressions/<target>/`) holds the properties
//! now. Both scenario findings (an `arena_half_size` above `f32::MAX` that validated, a name with
//! a newline that split an error over two lines) are fixed in firmware-sim.

use std::path::{Path, PathBuf};

use tests::{
    badminton_checks, blob_checks, config_checks, fault_checks, plant_link_checks, scenario_checks,
};

/// Every reproducer, as (target, path).
fn reproducers() -> Vec<(String, PathBuf)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/regressions");
    let mut out = Vec::new();
    for target in [
        "blob",
        "scenario",
        "faults",
        "badminton",
        "train_config",
        "plant_link",
    ] {
        let Ok(dir) = std::fs::read_dir(root.join(target)) else {
            continue;
        };
        out.extend(dir.flatten().map(|e| (target.to_string(), e.path())));
    }
    out.sort();
    out
}

/// Runs `target`'s checks on the file's bytes, as the fuzz target does.
fn replay(target: &str, path: &Path) {
    let bytes = std::fs::read(path).expect("a reproducer reads");
    let text = std::str::from_utf8(&bytes);
    match (target, text) {
        ("blob", _) => blob_checks::check(&bytes),
        ("plant_link", _) => plant_link_checks::check(&bytes),
        ("scenario", Ok(text)) => scenario_checks::check(text),
        ("faults", Ok(text)) => fault_checks::check(text),
        ("badminton", Ok(text)) => badminton_checks::check(text),
        ("train_config", Ok(text)) => config_checks::check(text),
        _ => {}
    }
}

#[test]
fn fixed_findings_stay_fixed() {
    let all = reproducers();
    assert!(
        !all.is_empty(),
        "no reproducers found: the test would prove nothing"
    );
    for (target, path) in all {
        replay(&target, &path);
    }
}
