//! `firmware-sim test-starts`: the reset seeds of the test protocol's episodes, one per line,
//! so a harness outside firmware-sim (a Stable-Baselines3 evaluation, a C test) can run its
//! policy from the same starts as `firmware-sim run --plant-cmd` and compare episode by episode.

use std::io::Write;

use anyhow::Result;
use clap::Args;
use firmware_sim::seed::episode_seed;

#[derive(Args, Debug)]
pub(crate) struct TestStartsArgs {
    /// Number of test starts, at most 1,000,000 (as `run --episodes`).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    episodes: u64,
    /// The run's seed (as `run --seed`).
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

/// Prints episode `i`'s reset seed on line `i`; `Ok(true)`.
pub(crate) fn test_starts(args: &TestStartsArgs) -> Result<bool> {
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    for index in 0..args.episodes {
        writeln!(out, "{}", episode_seed(args.seed, index))?;
    }
    out.flush()?;
    Ok(true)
}
