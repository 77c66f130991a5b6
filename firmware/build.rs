//! Puts memory.x where cortex-m-rt's link.x finds it, and chooses the blob `include_bytes!` embeds.

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

    // The blob is a build input like memory.x: POLICY_BLOB names it, else firmware/policy.postcard.
    println!("cargo:rerun-if-env-changed=POLICY_BLOB");
    let blob = match env::var_os("POLICY_BLOB") {
        Some(path) => PathBuf::from(path),
        None => manifest.join("policy.postcard"),
    };
    let blob = manifest.join(blob); // relative paths are taken from firmware/
    if !blob.is_file() {
        eprintln!(
            "no policy blob at {}: set POLICY_BLOB=/path/to/actor.postcard (host-trainer's export), or \
             make one with `cargo run --manifest-path firmware/host-check/Cargo.toml -- gen 4x48 firmware/policy.postcard`",
            blob.display()
        );
        exit(1);
    }
    println!("cargo:rerun-if-changed={}", blob.display());
    println!("cargo:rustc-env=POLICY_BLOB_PATH={}", blob.display());
}
