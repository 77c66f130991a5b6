//! Link flags for a program with no C start-up code.
//!
//! - `-nostartfiles`: the binary's own `_start` is the entry point, so nothing of libc's or
//!   std's start-up runs before policy-core does.
//! - `-lc`: rustc links `no_std` binaries with `-nodefaultlibs`, but the compiler still emits
//!   calls to `memcpy`, `memset`, `memcmp` and `bcmp`. On a chip `compiler_builtins` provides
//!   them; on the host they come from libc (only those routines: libc is never initialised).
fn main() {
    println!("cargo:rustc-link-arg-bins=-nostartfiles");
    println!("cargo:rustc-link-arg-bins=-lc");
}
