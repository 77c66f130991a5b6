//! `firmware-sim`: the closed-loop simulator as a command line. `run` tests a policy blob (or a
//! reference controller, or the firmware image itself) against a navigation scenario as a CI
//! gate; `match`, `teams` and `heatmap` play and draw badminton players; `scenario generate`
//! writes navigation layouts. Exit codes: 0 the scenario's pass criteria hold, 1 they fail (or
//! the blob did not boot), 2 bad input (one line on stderr).
//!
//! Every input is checked, and every output path probed, before the first episode runs. Memory
//! does not grow with `--episodes`: the summary comes from running totals, and each episode's
//! record is streamed into the JSON report and the SVG plot as soon as it ends. Outputs appear
//! only when complete (written to temporary files and renamed into place).
//!
//! Each command is a file of [`commands`].

mod commands;

use std::process::ExitCode;

use clap::{CommandFactory, Parser, Subcommand};
use firmware_sim::errln;

use commands::heatmap::{heatmap, HeatmapArgs};
use commands::play::{play, MatchArgs};
use commands::run::{run, RunArgs};
use commands::scenario::{generate_layout, ScenarioCommand};
use commands::serve_plant::{serve_plant, ServePlantArgs};
use commands::teams::{teams, TeamsArgs};
use commands::test_starts::{test_starts, TestStartsArgs};

#[derive(Parser, Debug)]
#[command(
    name = "firmware-sim",
    version,
    about = "Closed-loop firmware simulator for policy blobs"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Boot a blob (or a reference controller) and run the scenario's test protocol.
    // Boxed: the run's flags outweigh the match's many times (clippy::large_enum_variant).
    Run(Box<RunArgs>),
    /// Play a badminton match between two players and judge it by the scenario's criteria.
    Match(MatchArgs),
    /// Navigation layouts as scenario files.
    #[command(subcommand)]
    Scenario(ScenarioCommand),
    /// Play two badminton teams against each other: points between random pairings of their
    /// players, each team serving half; the teams' scores and each player's contribution.
    Teams(TeamsArgs),
    /// Draw a badminton critic's Q over the court as SVG: the catch critic over the targets it
    /// can ask for, the serve critic over the landing points of its serves.
    Heatmap(HeatmapArgs),
    /// Serve a navigation scenario's plant over standard input and output with the plant link
    /// (docs/own-plant.md), for a Gymnasium environment or any other client.
    ServePlant(ServePlantArgs),
    /// Print the reset seeds of the test protocol's episodes (`run --plant-cmd` resets episode
    /// i with line i), so another harness can test its policy from the same starts.
    TestStarts(TestStartsArgs),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            errln!("{}", usage_error(&e));
            return ExitCode::from(2);
        }
    };
    let outcome = match &cli.command {
        Command::Run(args) => run(args),
        Command::Match(args) => play(args),
        Command::Scenario(ScenarioCommand::Generate(args)) => generate_layout(args),
        Command::Heatmap(args) => heatmap(args),
        Command::Teams(args) => teams(args),
        Command::ServePlant(args) => serve_plant(args),
        Command::TestStarts(args) => test_starts(args),
    };
    match outcome {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(e) => {
            errln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

/// A command-line error as one line.
fn usage_error(e: &clap::Error) -> String {
    use clap::error::ErrorKind;
    if matches!(
        e.kind(),
        ErrorKind::MissingSubcommand | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
    ) {
        // clap prints the whole help here, whose first line does not say what is wrong. The
        // command that lacks one is the deepest the arguments name (`scenario`, not the
        // binary): its own subcommands are what the user can choose from.
        let mut cmd = Cli::command();
        let mut path = vec![cmd.get_name().to_string()];
        for arg in std::env::args().skip(1) {
            let Some(sub) = cmd.find_subcommand(&arg).cloned() else {
                break;
            };
            path.push(sub.get_name().to_string());
            cmd = sub;
        }
        let names: Vec<&str> = cmd.get_subcommands().map(|c| c.get_name()).collect();
        let path = path.join(" ");
        return format!(
            "{path}: missing a subcommand: {} (see {path} --help)",
            names.join(", ")
        );
    }
    // clap's message up to its usage block, folded into one line.
    let text = e.to_string();
    let head: Vec<&str> = text
        .lines()
        .take_while(|l| !l.trim().is_empty())
        .map(str::trim)
        .collect();
    head.join(" ")
}
