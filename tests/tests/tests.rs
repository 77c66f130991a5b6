//! The workspace's integration tests: one binary, one module per concern (ripgrep's layout).

// Train a tiny DCP policy, export it, boot the bytes in firmware-sim and run the closed loop.
mod end_to_end;
// Valid blobs mutated field by field (header, lengths, payload values, label, CRC) through the
// blob loader and the boot path, checked by `tests::blob_checks` as the `blob` fuzz target is.
mod blob_mutations;
// The `key = value` line edits the mutation tests below share.
mod line_edits;
// Scenario TOML assembled from valid fragments with values, types and keys mutated, checked by
// `tests::scenario_checks` as the `scenario` fuzz target is.
mod scenario_mutations;
// The shipped badminton scenario with values, types and keys mutated line by line, checked by
// `tests::badminton_checks` as the `badminton` fuzz target is.
mod badminton_mutations;
// host-trainer's config files (every algorithm's section) mutated line by line, checked by
// `tests::config_checks` as the `train_config` fuzz target is.
mod config_mutations;
// Fault strings assembled from the `--faults` grammar with numbers and separators mutated,
// checked by `tests::fault_checks` as the `faults` fuzz target is.
mod fault_mutations;
// The plant link's frames: messages of either side round-trip bit for bit, changed bytes are a
// message or a one-line error, one bit flipped is refused; checked by `tests::plant_link_checks`
// as the `plant_link` fuzz target is.
mod plant_link_mutations;
// Every reproducer the fuzzer found (`fuzz/regressions/`) is replayed through the same checks.
mod fuzz_regressions;
