//! Any UTF-8 text as a host-trainer config file; an accepted config trains a few episodes.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| {
    if let Ok(text) = std::str::from_utf8(bytes) {
        tests::config_checks::check(text);
    }
});
