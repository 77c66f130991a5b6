//! `host-trainer`: train DCP or DDPG on a firmware-sim plant, export the blob, evaluate it.
//!
//! ```text
//! host-trainer train [--task nav-walls] [--algo dcp|ddpg|td3|ppo|dqn] [--hidden 4x48] [--reward gr] [--episodes 3000]
//!                    [--t 16] [--sigma 0.2] [--noise gaussian|ou] [--seed 0] [--out runs] [--config FILE] [--resume RUN_DIR]
//!                    [--threads N]
//! host-trainer eval --blob FILE [--task nav-walls] [--episodes 100] [--seed 0] [--json FILE]
//! host-trainer export --run RUN_DIR [--encoding f32|f16|int8]
//!                     [--image bin|hex --slot a|b --sequence N [--address ADDR] [--slot-size BYTES]]
//! host-trainer inspect BLOB
//! host-trainer sweep --seeds 0-4 [--algo dcp,ddpg] [--jobs N] --out DIR [--config FILE] [--quiet]
//! host-trainer team [--algo dcp] [--t 16] [--players 16] [--points 20000] [--seed 0] [--out DIR]
//! host-trainer reproduce exp1|exp2 --out DIR [--seeds 5] [--jobs N] [--slice I/N | --merge] [--quick]
//! ```
//! Exit status, one convention with `firmware-sim run`: 0 when the command did its work and,
//! where it judged a blob (`train`, `eval`), the gate passed; 1 when the judged blob fails the
//! gate (the summary ends with `gate FAIL (why)`); 2 on any error, one line on stderr; 130 after
//! Ctrl-C. `sweep` and `reproduce` judge no blob themselves: they exit 1 when some of their runs
//! failed or are missing. Each command is a file of [`commands`].

mod commands;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

use commands::act::{act_command, ActArgs};
use commands::eval::{eval_command, EvalArgs};
use commands::export::{export_command, ExportArgs};
use commands::inspect::{inspect_command, InspectArgs};
use commands::reproduce::{reproduce_command, ReproduceArgs};
use commands::sweep::{sweep_command, SweepArgs};
use commands::team::{team_command, TeamArgs};
use commands::train::{train_command, TrainArgs};

#[derive(Debug, Parser)]
#[command(
    name = "host-trainer",
    version,
    about = "Train DCP/DDPG policies on firmware-sim plants and export postcard blobs"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Train a policy; writes OUT/{task}__{algo}__{seed}/ and evaluates the exported blob
    /// (exit 0 when it passes the gate, 1 when it fails, 2 on an error).
    Train(TrainArgs),
    /// Evaluate a policy blob in firmware-sim on test starts (exit 0 when it passes the gate, 1
    /// when it fails, 2 on an error, as `firmware-sim run`).
    Eval(EvalArgs),
    /// Export policy.postcard (and, for DCP and DDPG, critic.postcard) from a run's checkpoint;
    /// with --encoding f16|int8, policy-f16.postcard or policy-int8.postcard.
    Export(ExportArgs),
    /// Print what a blob holds: kind, shape, label, sizes, CRC, normaliser, bounds or table.
    Inspect(InspectArgs),
    /// Print a blob's outputs for given inputs, as the chip computes them, with their bits: the
    /// reference a port of the forward pass is checked against.
    Act(ActArgs),
    /// Train one run per (algo, seed) as parallel processes; skips finished runs, continues
    /// unfinished ones, and writes OUT/sweep.md and OUT/sweep.json.
    Sweep(SweepArgs),
    /// Train a badminton team (experiment 2): N players of three agents each, random pairings,
    /// one point per episode; writes OUT/{scenario}__{algo}__{seed}/ and exports every player
    /// into its players/ folder.
    Team(TeamArgs),
    /// Rebuild an experiment of the paper: plan its grid of runs, run them (or one --slice of
    /// them) as sweep does, and build the results page and figures from the run folders
    /// (OUT/exp1.md or OUT/exp2.md, OUT/figures/).
    Reproduce(ReproduceArgs),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            // --help and --version.
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("host-trainer: {} (see --help)", usage_error(&e));
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Some(Command::Train(args)) => train_command(args),
        Some(Command::Eval(args)) => eval_command(args),
        Some(Command::Export(args)) => export_command(args).map(|()| ExitCode::SUCCESS),
        Some(Command::Inspect(args)) => inspect_command(&args).map(|()| ExitCode::SUCCESS),
        Some(Command::Act(args)) => act_command(&args).map(|()| ExitCode::SUCCESS),
        Some(Command::Sweep(args)) => sweep_command(args),
        Some(Command::Team(args)) => team_command(args),
        Some(Command::Reproduce(args)) => reproduce_command(args),
        None => {
            eprintln!(
                "host-trainer: missing a subcommand: train, eval, export, inspect, act, sweep, team or reproduce (see --help)"
            );
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("host-trainer: {e:#}");
            // 1 is the gate's FAIL (as firmware-sim run gives it); an error is 2.
            ExitCode::from(2)
        }
    }
}

/// A command-line error as one line: clap's message up to its usage block, folded, so the
/// names of missing arguments (listed on the lines after the first) and the accepted values
/// are kept, as firmware-sim prints them.
fn usage_error(e: &clap::Error) -> String {
    let text = e.to_string();
    let head: Vec<&str> = text
        .lines()
        .take_while(|l| !l.trim().is_empty())
        .map(str::trim)
        .collect();
    let line = head.join(" ");
    let line = line.trim_start_matches("error: ");
    if line.is_empty() {
        "invalid arguments".to_string()
    } else {
        line.to_string()
    }
}
