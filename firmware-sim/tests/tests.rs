//! Integration tests of firmware-sim: one binary, one module per concern.

/// Builders shared by the modules: random-weight policy blobs.
mod util;

/// Badminton: the reference players' gates of docs/design.md §3 (scripted against random
/// and itself, the catch and serve tests).
mod badminton_gates;
/// Badminton physics: the closed form without drag, terminal speed, landing interpolation, the
/// lines, the net, and the players' margins and speed limit.
mod badminton_physics;
/// Badminton rules: faults, the let at the rally cap, games, who serves, mirrored frames,
/// determinism, margins as ground truth, and the Plant interface's transition contract.
mod badminton_rules;
/// Player folders: `match` and `--measures` on a folder's blobs, reproducible; every bad folder
/// refused in one line; a blob that does not boot plays the safe state, and the report says so.
mod blob_players;
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
/// `firmware-sim heatmap`: the critics' maps of the court, their SVG and bad input.
mod heatmap_cli;
/// Hardware in the loop against a fake chip on a socket pair: the host loop's report bit for
/// bit, and each fault (silence, a garbled, cut or foreign-version frame, a reset, Ctrl-C)
/// stopping the run with its reason; `--hil` bad input.
mod hil;
/// Generated layouts: reproducible from their seed, valid, solved by the oracle from every
/// start, with margins that stop a straight-line controller.
mod layouts;
/// `firmware-sim match`: summary, JSON and SVG, exit codes, one-line errors.
mod match_cli;
/// The plant link against real plant processes (the C reference cart and its fault plant):
/// each fault stopped in one line naming the request, no plant left running, seeds reproduce.
mod plant_faults;
/// Golden plant link frames, the bytes the Python package's codec must write and read.
mod plant_link_frames;
/// The Rust host (`ChildPlant`) against the Python package's Gymnasium plant server.
mod plant_link_python;
/// A golden nav-walls trajectory, which the Python package's FirmwareSimEnv must reproduce.
mod plant_link_trajectory;
/// The test protocol for any plant and `run --plant-cmd`: navigation's figures under the one
/// stuck rule, the served plant bit for bit with the plant in process, bad input.
mod plant_test;
/// Reference controllers: `straight` is caught stuck, `oracle` follows the gaps.
mod reference;
/// `firmware-sim teams`: team against team from player folders, and its bad input.
mod teams_cli;
