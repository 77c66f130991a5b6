//! Integration tests of firmware-sim: one binary, one module per concern.

/// Builders shared by the modules: random-weight policy blobs.
mod util;

/// Booting blobs: any shape and plant size through the runtime model, discrete policies, the
/// safe state on corrupt bytes or wrong sizes.
mod boot;
/// The CLI: summary, JSON, SVG, exit codes, one-line errors on bad input.
mod cli;
/// Same seed, same trajectory and report, bit for bit.
mod determinism;
/// Sensor, actuator and fault models: nothing non-finite or out of bounds reaches the plant.
mod faults;
/// Wall geometry properties: never crosses or leaves through a wall, slides parallel.
mod geometry;
/// Reference controllers: `straight` is caught stuck, `oracle` follows the gaps.
mod reference;
