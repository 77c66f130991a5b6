//! Any UTF-8 text through the `--faults` parser, its canonical form and `Faults::validate`.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| {
    if let Ok(text) = std::str::from_utf8(bytes) {
        tests::fault_checks::check(text);
    }
});
