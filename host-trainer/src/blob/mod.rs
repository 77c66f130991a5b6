//! Policy blobs: writing the trainer's networks in policy-core's format, and reading back what
//! a blob holds.

pub mod export;
pub mod inspect;
