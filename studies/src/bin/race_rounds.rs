//! `race-rounds`: what held a set of finished races: when each racer's validation first met
//! each criterion, and whether each winner's test settled error is its kept round's
//! (`studies::race_rounds`).
//!
//! ```sh
//! cargo run --release -p studies --bin race-rounds -- --runs runs/main-job \
//!     --lines first-round --seeds 10-19
//! ```

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Parser;
use host_trainer::sweep::plan::Seeds;
use studies::race_rounds::{read_line, summary};

#[derive(Parser, Debug)]
#[command(
    name = "race-rounds",
    about = "When each racer's validation first met each criterion, from finished races"
)]
struct Args {
    /// The queue's folder (`experiments/main-job/run.sh OUT`).
    #[arg(long)]
    runs: PathBuf,
    /// The lines' name before the seed (`first-round` reads `first-round-S`).
    #[arg(long)]
    lines: String,
    /// Their base seeds: `0-4`, `3`, `0,2,5` or combinations like `0-2,7`.
    #[arg(long)]
    seeds: Seeds,
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("race-rounds: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn run(args: Args) -> Result<()> {
    let (mut racers, mut winners) = (Vec::new(), Vec::new());
    for seed in args.seeds.0 {
        let dir = args.runs.join(format!("{}-{seed}", args.lines));
        let (r, w) = read_line(&dir).with_context(|| format!("{}", dir.display()))?;
        racers.extend(r);
        winners.push(w);
    }
    print!("{}", summary(&racers, &winners));
    Ok(())
}
