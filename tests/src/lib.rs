//! End-to-end tests across the workspace live in `tests/`; this library holds what both the
//! tests and the fuzzer (`fuzz/`) check about the project's parsers.
//!
//! `tests/end_to_end.rs` is what a user of the project cares about: train a small DCP policy with
//! host-trainer, export its blob, boot those exact bytes in firmware-sim and run the closed loop.
//!
//! The parsers that read outside input (blob bytes, navigation and badminton scenario TOML,
//! `--faults` strings, host-trainer's config files, the plant link's frames) each have a
//! `check` function here that panics when a property breaks. The coverage-guided targets in
//! `fuzz/` and the structured proptests in `tests/*_mutations.rs` call the same functions, so
//! the two harnesses cannot drift apart.
#![deny(missing_docs)]

pub mod badminton_checks;
pub mod blob_checks;
pub mod config_checks;
pub mod fault_checks;
pub mod plant_link_checks;
pub mod scenario_checks;

/// Errors reach users as one line (STYLE: a CLI error is one line on stderr).
fn assert_one_line(message: &str) {
    assert!(
        !message.contains('\n'),
        "error message spans lines: {message:?}"
    );
    assert!(!message.is_empty(), "empty error message");
}
