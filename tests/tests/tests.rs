//! The workspace's integration tests: one binary, one module per concern (ripgrep's layout).

// Train a tiny DCP policy, export it, boot the bytes in firmware-sim and run the closed loop.
mod end_to_end;
// The blob, scenario and fault parsers on structured, mutated inputs (proptest), checked with
// the same properties as the fuzz targets in `fuzz/`.
mod parser_properties;
