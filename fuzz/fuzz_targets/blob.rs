//! Any bytes through `blob::verify`, every `load_into` shape and firmware-sim's boot path.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| tests::blob_checks::check(bytes));
