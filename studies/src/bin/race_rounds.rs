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
    /// Their base seeds, as `A-B` or one number.
    #[arg(long, value_parser = seeds)]
    seeds: (u64, u64),
}

/// `A-B` (inclusive) or `A`.
fn seeds(s: &str) -> Result<(u64, u64), String> {
    let n = |t: &str| {
        t.trim()
            .parse::<u64>()
            .map_err(|_| format!("{s:?} is not a seed or a range A-B of seeds"))
    };
    let (a, b) = match s.split_once('-') {
        Some((a, b)) => (n(a)?, n(b)?),
        None => (n(s)?, n(s)?),
    };
    if a > b {
        return Err(format!("{s:?}: the range runs backwards"));
    }
    Ok((a, b))
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
    for seed in args.seeds.0..=args.seeds.1 {
        let dir = args.runs.join(format!("{}-{seed}", args.lines));
        let (r, w) = read_line(&dir).with_context(|| format!("{}", dir.display()))?;
        racers.extend(r);
        winners.push(w);
    }
    print!("{}", summary(&racers, &winners));
    Ok(())
}
