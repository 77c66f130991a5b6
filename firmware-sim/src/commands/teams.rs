//! `firmware-sim teams`: two badminton teams against each other, their scores and each
//! player's contribution.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use firmware_sim::{errln, out, outln};

use firmware_sim::badminton;
use firmware_sim::files;

use super::{outputs_ok, written};

#[derive(Args, Debug)]
pub(crate) struct TeamsArgs {
    /// Team A: a trained team's folder (or its players/), a player folder, scripted or random.
    #[arg(long)]
    a: String,
    /// Team B, named the same ways.
    #[arg(long)]
    b: String,
    /// Points to play.
    #[arg(long, default_value_t = 1000)]
    points: u32,
    /// Seed of the pairings and of the reference players' noise.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Badminton scenario: badminton or a scenario file.
    #[arg(long, default_value = "badminton")]
    scenario: String,
    /// Write the result as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
}

/// The outputs of one command, checked together before any work (writable, two different
/// files even when spelt differently), so a long run never ends in "cannot write" and never
/// writes one report over the other.
/// `teams`: both teams loaded and checked before the first point; exit 1 if a player's blob
/// did not boot (it played in the safe state).
pub(crate) fn teams(args: &TeamsArgs) -> Result<bool> {
    use firmware_sim::badminton::teams::{team_match, team_of};
    outputs_ok(args.json.as_deref(), None)?;
    let config = badminton::Config::resolve(&args.scenario)?;
    let teams = [team_of(&args.a)?, team_of(&args.b)?];
    let score = team_match(&config, &teams, args.points, args.seed)?;
    out!("{}", score.summary([&args.a, &args.b]));
    let mut booted = true;
    for (t, team) in teams.iter().enumerate() {
        for kind in team {
            for (role, e) in kind.boot_errors() {
                booted = false;
                outln!(
                    "  {} {kind} {}: safe state (blob did not boot: {e})",
                    ["A", "B"][t],
                    role.name()
                );
            }
        }
    }
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&score)? + "\n";
        written(files::write_atomic(path, text.as_bytes()), path)?;
    }
    // As `match`: an exit 1 says why on stderr, where a script that keeps only stderr looks.
    if !booted {
        errln!("FAIL: a player played the safe state (its blob did not boot)");
    }
    Ok(booted)
}
