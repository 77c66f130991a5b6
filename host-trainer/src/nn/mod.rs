//! The networks: the MLP with back-propagation, its optimiser, the running observation
//! normaliser, the hidden-layer shape, the training loop's forward pass that the exported
//! blob reproduces bit for bit, and a run's worker threads.

pub mod adam;
pub mod forward;
pub mod hidden;
pub mod net;
pub mod normalize;
pub mod workers;
