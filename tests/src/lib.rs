//! End-to-end tests across the workspace live in `tests/` (this library is empty on purpose).
//!
//! `tests/end_to_end.rs` is what a user of the project cares about: train a small DCP policy with
//! host-trainer, export its blob, boot those exact bytes in firmware-sim and run the closed loop.
#![deny(missing_docs)]
