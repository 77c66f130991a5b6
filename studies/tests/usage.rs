use crate::study;

/// Each study with no arguments: a failing exit code and its usage, naming the binary.
#[test]
fn no_arguments_is_a_usage_error() {
    for (binary, name) in [
        (env!("CARGO_BIN_EXE_margin-study"), "margin-study"),
        (env!("CARGO_BIN_EXE_margin-diagnosis"), "margin-diagnosis"),
        (env!("CARGO_BIN_EXE_stuck-critic"), "stuck-critic"),
        (env!("CARGO_BIN_EXE_quantisation-cost"), "quantisation-cost"),
        (env!("CARGO_BIN_EXE_integer-cost"), "integer-cost"),
        (env!("CARGO_BIN_EXE_compare-in-loop"), "compare-in-loop"),
        (env!("CARGO_BIN_EXE_restat"), "restat"),
        (env!("CARGO_BIN_EXE_cmsis-nn-header"), "cmsis-nn-header"),
        (env!("CARGO_BIN_EXE_main-job"), "main-job"),
        (env!("CARGO_BIN_EXE_race-rounds"), "race-rounds"),
    ] {
        let out = study(binary, &[]);
        assert!(!out.status.success(), "{name}");
        let err = String::from_utf8_lossy(&out.stderr);
        // The clap-parsed studies (main-job, race-rounds) say "Usage:".
        assert!(
            err.to_lowercase().contains("usage") && err.contains(name),
            "{name}: {err}"
        );
    }
}

/// A run folder that does not exist: one line naming it, no panic.
#[test]
fn a_missing_run_folder_is_named() {
    for (binary, name) in [
        (env!("CARGO_BIN_EXE_quantisation-cost"), "quantisation-cost"),
        (env!("CARGO_BIN_EXE_integer-cost"), "integer-cost"),
        (env!("CARGO_BIN_EXE_compare-in-loop"), "compare-in-loop"),
        (env!("CARGO_BIN_EXE_stuck-critic"), "stuck-critic"),
    ] {
        let out = study(binary, &["no-such-run"]);
        assert!(!out.status.success(), "{name}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.starts_with(&format!("{name}: ")), "{name}: {err}");
        assert!(err.contains("no-such-run"), "{name}: {err}");
        assert_eq!(err.lines().count(), 1, "{name}: {err}");
    }
}
