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
//! Sizes are const generics: `Policy<S, H, L, A>` has `S` observations, `L + 1` hidden layers of
//! width `H`, and `A` actions; the paper's 4×48 actor for the navigation task is
//! `Policy<2, 48, 3, 2>`.
//!
//! ```
//! use policy_core::Policy;
//! // A blob as it sits in flash.
//! static BLOB: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
//! let mut policy = Policy::<2, 32, 1, 2>::ZERO; // a `static` slot on a chip
//! policy.load_into(BLOB).unwrap();
//! let action = policy.act(&[4.0, -2.5]);
//! assert!(action.iter().all(|a| a.abs() <= 0.25));
//! ```
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![deny(missing_docs)]

pub mod blob;
pub mod bounds;
pub mod compare;
pub mod crc32;
pub mod critic;
pub mod error;
pub mod mlp;
pub mod normalizer;
pub mod policy;

pub use blob::{ModelKind, Shape};
pub use bounds::ActionBounds;
pub use crc32::crc32;
pub use critic::Critic;
pub use error::Error;
pub use mlp::{Activation, Dense, Trunk};
pub use normalizer::Normalizer;
pub use policy::Policy;
