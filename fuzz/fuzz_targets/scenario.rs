//! Any UTF-8 text through `Scenario::from_toml_str`, the TOML round trip and the plant.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| {
    if let Ok(text) = std::str::from_utf8(bytes) {
        tests::scenario_checks::check(text);
    }
});
