//! Puts nrf51/memory.x where cortex-m-rt's link.x finds it (OUT_DIR, on the link search path).
//! None may sit in this folder itself: the linker looks in its working directory first.

use std::{env, fs, path::PathBuf, process::exit};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let manifest =
        PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    if let Err(e) = fs::copy(manifest.join("nrf51/memory.x"), out.join("memory.x")) {
        eprintln!("cannot copy nrf51/memory.x into OUT_DIR: {e}");
        exit(1);
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=nrf51/memory.x");
}
