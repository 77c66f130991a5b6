//! Any UTF-8 text through the badminton scenario parser; an accepted scenario plays a few points.
#![no_main]

libfuzzer_sys::fuzz_target!(|bytes: &[u8]| {
    if let Ok(text) = std::str::from_utf8(bytes) {
        tests::badminton_checks::check(text);
    }
});
