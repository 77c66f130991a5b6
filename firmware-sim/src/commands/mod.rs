//! The `firmware-sim` binary's commands, one file each (the library lives beside them in
//! `src/`, under `lib.rs`; these files belong to `main.rs` alone), and the output checks they
//! share.

pub(crate) mod heatmap;
pub(crate) mod play;
pub(crate) mod run;
pub(crate) mod scenario;
pub(crate) mod serve_plant;
pub(crate) mod teams;
pub(crate) mod test_starts;

use std::io;
use std::path::Path;

use anyhow::{Context, Result};
use firmware_sim::files;

/// Checks that the report and plot paths can be written, before any work.
pub(crate) fn outputs_ok(json: Option<&Path>, svg: Option<&Path>) -> Result<()> {
    let paths: Vec<&Path> = json.into_iter().chain(svg).collect();
    Ok(files::check_outputs(&paths)?)
}

/// An output error with the path it was writing.
pub(crate) fn written<T>(result: io::Result<T>, path: &Path) -> Result<T> {
    result.with_context(|| format!("cannot write {}", path.display()))
}
