//! The `host-trainer` binary's commands, one file each (the library lives beside them in
//! `src/`, under `lib.rs`; these files belong to `main.rs` alone). Each file holds its
//! command's flags and the function that runs it; the work itself is the library's.

pub(crate) mod act;
pub(crate) mod eval;
pub(crate) mod export;
pub(crate) mod inspect;
pub(crate) mod race;
pub(crate) mod reproduce;
pub(crate) mod signals;
pub(crate) mod sweep;
pub(crate) mod team;
pub(crate) mod train;

/// The cores this process may use (1 if the system cannot say).
pub(crate) fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}
