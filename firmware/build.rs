//! Puts the board's memory.x where cortex-m-rt's link.x finds it: `mps2/memory.x` (QEMU's MPS2
//! boards), or `stm32f405/memory.x` with feature `stm32f405`. The firmware holds no blob:
//! policies are flashed into the slots memory.x declares, separately from the firmware.
//!
//! No memory.x may sit in this folder itself: the linker looks for link.x's `INCLUDE memory.x`
//! in its working directory (this folder, where cargo runs it) before the search paths, so one
//! here would be every board's layout. The RISC-V's layout, fe310/memory.x, goes to the linker
//! by path (.cargo/config.toml), before riscv-rt's link.x.

use std::{env, fs, path::PathBuf, process::exit};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let manifest =
        PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let memory = if env::var_os("CARGO_FEATURE_STM32F405").is_some() {
        "stm32f405/memory.x"
    } else {
        "mps2/memory.x"
    };
    if let Err(e) = fs::copy(manifest.join(memory), out.join("memory.x")) {
        eprintln!("cannot copy {memory} into OUT_DIR: {e}");
        exit(1);
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=mps2/memory.x");
    println!("cargo:rerun-if-changed=stm32f405/memory.x");
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
