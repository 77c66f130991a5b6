//! # policy-core
//!
//! The part of margin-safe RL that runs on the microcontroller: a fixed-size MLP policy trained
//! by Deep Comparative Policy (DCP), loaded from a checked weight blob in flash, turning an
//! observation into a bounded action with no allocator and no panic.
//!
//! - [`Policy`]: normaliser + actor + action bounds; [`Policy::act`] is always finite and in
//!   bounds, whatever the observation (NaN and infinities included).
//! - [`Critic`]: Q(s, a) in the same format; [`compare::refine`] is DCP's compare step on the
//!   device.
//! - [`blob`]: the one definition of the weight-blob format (postcard header, `f32` payload,
//!   CRC-32), read on the chip and written on the host. See `docs/blob-format.md`.
//!
//! Guarantees, each backed by tests in `tests/`: loading never panics and rejects every
//! truncation and every 1- and 2-bit corruption of a blob with a typed [`Error`], leaving the
//! slot untouched; `act` never panics and returns a finite, in-bounds action for any
//! observation; the forward pass's arithmetic (summation order, `libm::tanhf`, no fused
//! multiply-add) is fixed, so the committed golden vectors (`tests/golden/vectors.txt`) hold
//! bit for bit, and a trainer that follows [`mlp::accumulate`]'s order reproduces them.
//!
//! Sizes are const generics: `Policy<S, H, L, A>` has `S` observations, `L + 1` hidden layers of
//! width `H`, and `A` actions; the paper's 4×48 actor for the navigation task is
//! `Policy<2, 48, 3, 2>`.
//!
//! ```
//! use policy_core::{Error, Policy};
//!
//! /// The blob exported by the trainer, linked into flash (or a slice of flash).
//! static BLOB: &[u8] = include_bytes!("../tests/golden/actor_4x48.postcard");
//!
//! /// The paper's 4×48 navigation actor: 2 observations (x, y), 2 actions (a step in ±0.25).
//! type NavPolicy = Policy<2, 48, 3, 2>;
//!
//! fn boot(slot: &mut NavPolicy) -> Result<(), Error> {
//!     // Checks magic, version, kind, shape, length, CRC-32, finiteness and bounds; on any
//!     // error the slot keeps its contents (`Policy::ZERO`: every action 0, the safe state).
//!     slot.load_into(BLOB)
//! }
//!
//! fn control_step(slot: &NavPolicy, position: [f32; 2]) -> [f32; 2] {
//!     slot.act(&position) // finite and inside the bounds, even for NaN or infinite inputs
//! }
//!
//! let mut slot = NavPolicy::ZERO; // on a chip: a `static` slot, loaded once at boot
//! boot(&mut slot).unwrap();
//! let step = control_step(&slot, [4.0, -2.5]);
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
pub mod mlp;
pub mod model;
pub mod normalizer;
pub mod policy;
pub mod tanh;

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
