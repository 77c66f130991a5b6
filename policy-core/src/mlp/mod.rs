//! The multilayer perceptron: activations, the layer kernels and the compiled layers.
//!
//! The forward pass fixes its summation order (bias first, then input columns in increasing
//! order, separate multiplies and adds) so that the host trainer can reproduce it bit for bit:
//! what the trainer evaluates and what the chip runs is the same arithmetic, not merely the same
//! maths. There is one set of kernels ([`accumulate_bytes`], [`accumulate_f16`],
//! [`accumulate_int8`], and [`accumulate`] for a compiled matrix), which the runtime
//! [`Model`](crate::model::Model) and the compiled [`Dense`] and [`Trunk`] both compute with.
//!
//! - `activation.rs`: [`Activation`] and [`squash`], the one definition of each.
//! - `kernels.rs`: `y = b + W x` for weights as f32 (words, bytes or a matrix), f16 or int8.
//! - `dense.rs`: [`Dense`] and [`Trunk`], the layers with their sizes in their types.
//! - [`integer`]: the integer encoding's layer (int8 codes, int32 accumulators, TFLite's
//!   fixed-point requantisation) and its entry and exit maps.

pub(crate) mod activation;
mod dense;
pub mod integer;
mod kernels;

pub use activation::{squash, Activation};
pub use dense::{Dense, Trunk};
pub use kernels::{accumulate, accumulate_bytes, accumulate_f16, accumulate_int8};
