//! The plant link: a plant in another process, in any language, over its standard input and
//! output (docs/own-plant.md).
//!
//! - [`messages`]: the requests and answers and their frames (hil-protocol's framing, the
//!   plant protocol's own version).
//! - [`child`]: the host's side, a plant process as an [`crate::env::Env`].
//! - [`serve`]: the plant's side, any `Env` served over a stream (`firmware-sim serve-plant`).
//! - [`null`]: a plant that does nothing, to measure the link's own cost.

pub mod child;
pub mod messages;
pub mod null;
pub mod serve;
