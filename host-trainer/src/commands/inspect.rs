//! `host-trainer inspect`: what a blob holds, and its weights' error against an f32 blob.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use firmware_sim::files;
use firmware_sim::out;
use host_trainer::blob::inspect;

#[derive(Debug, Args)]
pub(crate) struct InspectArgs {
    /// The blob file (policy.postcard, critic.postcard, ...).
    blob: PathBuf,
    /// An f32 blob the inspected (quantised) blob was made from: prints each layer's largest
    /// weight error against it.
    #[arg(long)]
    against: Option<PathBuf>,
}

pub(crate) fn inspect_command(args: &InspectArgs) -> Result<()> {
    let path = args.blob.display();
    let bytes = files::read_blob(&args.blob).with_context(|| format!("cannot read blob {path}"))?;
    let text = inspect::describe(&bytes).with_context(|| format!("{path} is not a valid blob"))?;
    out!("{text}");
    if let Some(reference) = &args.against {
        let other = reference.display();
        let f32 =
            files::read_blob(reference).with_context(|| format!("cannot read blob {other}"))?;
        let errors = inspect::describe_errors(&bytes, &f32)
            .with_context(|| format!("cannot compare {path} with {other}"))?;
        out!("{errors}");
    }
    Ok(())
}
