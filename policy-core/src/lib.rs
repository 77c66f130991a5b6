//! # policy-core
//!
//! The part of margin-safe RL that runs on the microcontroller: a fixed-size MLP policy trained
//! by Deep Comparative Policy (DCP), loaded from a checked weight blob in flash, turning an
//! observation into a bounded action with no allocator and no panic.
//!
//! - [`model::Model`]: the runtime. A blob of any shape (actor, critic or discrete policy, up to
//!   the format's documented limits) is verified once and then run straight from its bytes in
//!   flash, with a caller-provided [`model::Scratch`] for the activations: no weight is copied
//!   to RAM and no crate needs a table of compiled shapes.
//! - [`Policy`] / [`Critic`]: the same models with their sizes as const generics (weights in a
//!   RAM struct), for code that wants sizes in its types; their layers compute through the
//!   runtime's kernels ([`mlp`]), so they give the same bits.
//!   [`compare::refine`] is DCP's compare step on the device.
//! - [`slot`]: two flash slots (A/B) for blobs and the one rule that picks the slot to run: the
//!   newer one that verifies, else the other, else the safe state, with a reason for each.
//! - [`blob`]: the one definition of the weight-blob format (postcard header, aligned `f32`
//!   payload, CRC-32), read on the chip and written on the host. See `docs/blob-format.md`.
//!
//! Imports flow one way, shared types at the bottom: `crc32`, `half`, `tanh`, [`normal`],
//! `clamp` and `mlp::activation`; the format's types (`blob::format`) and [`error`]; the
//! normaliser, bounds and [`mlp`] kernels and layers; reading, checking and writing blobs (the rest of [`blob`]);
//! the runtime [`model`] and the compiled [`Policy`] and [`Critic`]; [`compare`] and [`slot`]
//! on top.
//!
//! Guarantees, each backed by tests in `tests/`: loading never panics and rejects every
//! truncation and every 1- and 2-bit corruption of a blob with a typed [`Error`] (a compiled
//! slot is left untouched); `act` never panics and returns a finite, in-bounds action for any
//! observation; the forward pass's arithmetic (summation order, `libm::tanhf`, no fused
//! multiply-add) is fixed, so the committed golden vectors (`tests/golden/vectors.txt`) hold
//! bit for bit, and a trainer that follows [`mlp::accumulate`]'s order reproduces them.
//!
//! ```
//! use policy_core::model::{Model, Scratch};
//!
//! /// The blob exported by the trainer, linked into flash (or a slice of flash).
//! static BLOB: &[u8] = include_bytes!("../tests/golden/actor_4x48.postcard");
//!
//! let model = Model::from_blob(BLOB).unwrap(); // once, at boot; on error: the safe state
//! model.expect_sizes(2, 2).unwrap(); // the firmware's observation and action sizes
//! let mut scratch = Scratch::<64>::new(); // activations only
//! let mut step = [0.0f32; 2];
//! model.act(&[4.0, -2.5], &mut scratch, &mut step).unwrap();
//! assert!(step.iter().all(|s| s.is_finite() && s.abs() <= 0.25));
//! ```
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![deny(missing_docs)]

pub mod blob;
pub mod bounds;
mod clamp;
pub mod compare;
pub mod crc32;
pub mod critic;
pub mod error;
// The format's types (kind, encoding, shape, header): below `error` and `blob`, which both use
// them; public as `blob::ModelKind` and so on.
mod format;
pub mod half;
// Where an integer payload's parts lie: beside `format`, below `blob`; public as
// `blob::IntegerLayer` and so on.
mod integer_layout;
pub mod mlp;
pub mod model;
pub mod normal;
pub mod normalizer;
pub mod policy;
pub mod slot;
pub mod tanh;

// The names every user needs, at the root.
pub use blob::{Encoding, ModelKind, Shape};
pub use bounds::ActionBounds;
pub use crc32::crc32;
pub use critic::Critic;
pub use error::Error;
pub use mlp::{Activation, Dense, Trunk};
pub use normalizer::Normalizer;
pub use policy::Policy;

/// The repository README's firmware example, compiled and run as a doctest so it cannot rot.
#[cfg(doctest)]
#[doc = include_str!("../../README.md")]
pub struct ReadmeDoctests;

/// The firmware examples of the Cortex-M page, run as doctests like the README's.
#[cfg(doctest)]
#[doc = include_str!("../../docs/cortex-m.md")]
pub struct CortexMPageDoctests;

/// This crate's own front page, run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct CrateReadmeDoctests;
