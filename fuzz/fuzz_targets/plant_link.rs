//! Any bytes through the plant link's frame reader and decoder as both sides' messages; what
//! decodes re-encodes and decodes again to the same message, bit for bit.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| {
    tests::plant_link_checks::check(bytes);
});
