//! `firmware-sim serve-plant`: one of firmware-sim's plants served over standard input and
//! output with the plant link, so another program (a Gymnasium environment in Python, a test
//! in C, the trainer's `--plant-cmd`) can drive it.

use std::io::{BufReader, BufWriter};

use anyhow::{Context, Result};
use clap::Args;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::{NavEnv, Reward};
use firmware_sim::plant_link::null::NullPlant;
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
    /// OBS,ACT: serve a plant that does nothing, of these sizes, instead (the link's own cost,
    /// for the plant-link bench).
    #[arg(long, value_parser = parse_sizes, conflicts_with_all = ["scenario", "reward"])]
    null: Option<(usize, usize)>,
}

fn parse_sizes(s: &str) -> Result<(usize, usize), String> {
    let sizes = s
        .split_once(',')
        .and_then(|(o, a)| Some((o.trim().parse().ok()?, a.trim().parse().ok()?)));
    match sizes {
        Some((o, a)) if (1..=4096).contains(&o) && (1..=256).contains(&a) => Ok((o, a)),
        _ => Err(format!(
            "expected OBS,ACT with OBS in 1..=4096 and ACT in 1..=256, found {s:?}"
        )),
    }
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
    let mut input = BufReader::new(std::io::stdin().lock());
    let mut output = BufWriter::new(std::io::stdout().lock());
    if let Some((observations, actions)) = args.null {
        let mut null = NullPlant::new(observations, actions);
        serve("null", &mut null, &mut input, &mut output)
            .context("the plant link to the client broke")?;
        return Ok(true);
    }
    let mut scenario = Scenario::resolve(&args.scenario)?;
    if let Some(reward) = args.reward {
        scenario.reward = reward;
    }
    let mut env = NavEnv::new(&scenario)?;
    serve(&scenario.name, &mut env, &mut input, &mut output)
        .context("the plant link to the client broke")?;
    Ok(true)
}
