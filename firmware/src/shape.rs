//! The actor shape compiled into this firmware: exactly one `shape-*` cargo feature picks it.
//!
//! All three are the navigation task's actor (2 observations, 2 actions); they differ in depth and
//! width, which is what flash, RAM and time scale with.

#[cfg(feature = "shape-2x32")]
/// 2 hidden layers of 32.
pub type Actor = policy_core::Policy<2, 32, 1, 2>;
#[cfg(feature = "shape-4x48")]
/// 4 hidden layers of 48 (the paper's navigation actor).
pub type Actor = policy_core::Policy<2, 48, 3, 2>;
#[cfg(feature = "shape-6x64")]
/// 6 hidden layers of 64.
pub type Actor = policy_core::Policy<2, 64, 5, 2>;

#[cfg(not(any(feature = "shape-2x32", feature = "shape-4x48", feature = "shape-6x64")))]
compile_error!("select an actor shape: --features shape-2x32, shape-4x48 or shape-6x64");

#[cfg(any(
    all(feature = "shape-2x32", feature = "shape-4x48"),
    all(feature = "shape-2x32", feature = "shape-6x64"),
    all(feature = "shape-4x48", feature = "shape-6x64"),
))]
compile_error!("select one actor shape only (use --no-default-features with --features shape-...)");
