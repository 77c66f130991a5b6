//! `firmware-sim serve-plant`: one of firmware-sim's plants served over standard input and
//! output with the plant link, so another program (a Gymnasium environment in Python, a test
//! in C, the trainer's `--plant-cmd`) can drive it.

use std::io::{BufReader, BufWriter};

use anyhow::{Context, Result};
use clap::Args;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::{NavEnv, Reward};
use firmware_sim::plant_link::serve::serve;

#[derive(Args, Debug)]
pub(crate) struct ServePlantArgs {
    /// Built-in navigation scenario name (nav-walls, nav-open, ...) or a TOML file.
    #[arg(long, default_value = "nav-walls")]
    scenario: String,
    /// The reward form instead of the scenario's: lr, gr or lr-gr (host-trainer trains with gr
    /// by default; serve the same to train on the same plant through the link).
    #[arg(long, value_parser = parse_reward)]
    reward: Option<Reward>,
}

fn parse_reward(s: &str) -> Result<Reward, String> {
    match s {
        "lr" => Ok(Reward::Lr),
        "gr" => Ok(Reward::Gr),
        "lr-gr" | "lrgr" => Ok(Reward::LrGr),
        _ => Err(format!("expected lr, gr or lr-gr, found {s:?}")),
    }
}

/// Serves until the client closes the link or its input ends; `Ok(true)`.
pub(crate) fn serve_plant(args: &ServePlantArgs) -> Result<bool> {
    let mut scenario = Scenario::resolve(&args.scenario)?;
    if let Some(reward) = args.reward {
        scenario.reward = reward;
    }
    let mut env = NavEnv::new(&scenario)?;
    let mut input = BufReader::new(std::io::stdin().lock());
    let mut output = BufWriter::new(std::io::stdout().lock());
    serve(&scenario.name, &mut env, &mut input, &mut output)
        .context("the plant link to the client broke")?;
    Ok(true)
}
