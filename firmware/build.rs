//! Puts memory.x where cortex-m-rt's link.x finds it. The RISC-V's layout, fe310/memory.x, goes
//! to the linker by path (.cargo/config.toml): riscv-rt's `INCLUDE memory.x` would find this
//! folder's Cortex-M memory.x first (the linker runs here). The firmware holds no blob: policies
//! are flashed into the slots memory.x declares, separately from the firmware.

use std::{env, fs, path::PathBuf, process::exit};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let manifest =
        PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    if let Err(e) = fs::copy(manifest.join("memory.x"), out.join("memory.x")) {
        eprintln!("cannot copy memory.x into OUT_DIR: {e}");
        exit(1);
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=fe310/memory.x");

    // Feature `refine`: the number of proposals per tick, a build input like memory.x.
    println!("cargo:rerun-if-env-changed=REFINE_T");
    let t = env::var("REFINE_T").unwrap_or_else(|_| "16".into());
    if t.parse::<u16>().is_err() {
        eprintln!("REFINE_T={t}: expected a number of proposals, 0..=65535");
        exit(1);
    }
    println!("cargo:rustc-env=REFINE_T={t}");
}
