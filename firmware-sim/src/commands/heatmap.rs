//! `firmware-sim heatmap`: a badminton critic's Q over the court, as SVG.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use firmware_sim::outln;

use firmware_sim::badminton;
use firmware_sim::files;

use super::{outputs_ok, written};

#[derive(Args, Debug)]
#[command(group = clap::ArgGroup::new("source").required(true).args(["critic", "player"]))]
pub(crate) struct HeatmapArgs {
    /// The critic blob (a player's catch-critic.postcard or serve-critic.postcard).
    #[arg(long)]
    critic: Option<PathBuf>,
    /// A player folder: its manifest's critic for --role.
    #[arg(long)]
    player: Option<PathBuf>,
    /// Which agent's critic it is.
    #[arg(long, value_parser = ["catch", "serve"])]
    role: String,
    /// The SVG file to write.
    #[arg(long)]
    out: PathBuf,
    /// Grid steps per action dimension (catch: N×N targets, N at most 200; serve: N×N×N
    /// serves, N at most 64).
    #[arg(long, default_value_t = 41)]
    grid: usize,
    /// Badminton scenario: badminton or a scenario file.
    #[arg(long, default_value = "badminton")]
    scenario: String,
    /// The picture's title [default: the critic blob's label].
    #[arg(long)]
    title: Option<String>,
}

/// `heatmap`: every input checked before the map is computed; the SVG written atomically.
pub(crate) fn heatmap(args: &HeatmapArgs) -> Result<bool> {
    use firmware_sim::badminton::heatmap;
    outputs_ok(None, Some(&args.out))?;
    let config = badminton::Config::resolve(&args.scenario)?;
    let (path, critic) = match (&args.critic, &args.player) {
        (Some(file), _) => {
            let bytes = files::read_blob(file)
                .with_context(|| format!("cannot read critic {}", file.display()))?;
            (file.clone(), bytes)
        }
        (None, Some(folder)) => {
            let player = firmware_sim::badminton::blob_player::PlayerFolder::load(folder)?;
            let role = if args.role == "catch" { 0 } else { 1 };
            let Some(critics) = player.critics else {
                anyhow::bail!(
                    "{}: the player's manifest names no critics",
                    folder.display()
                );
            };
            critics[role].clone()
        }
        (None, None) => anyhow::bail!("--critic or --player is required"),
    };
    let path = path.display();
    let map = match args.role.as_str() {
        "catch" => heatmap::catch_map(&config, &critic, args.grid),
        _ => heatmap::serve_map(&config, &critic, args.grid),
    }
    .with_context(|| format!("{path}"))?;
    let title = match &args.title {
        Some(t) => t.clone(),
        None => policy_core::model::Model::from_blob(&critic)?
            .header()
            .label
            .as_str()
            .to_string(),
    };
    let svg = heatmap::svg(&map, &config, &format!("{title}, {} critic", args.role))?;
    written(files::write_atomic(&args.out, svg.as_bytes()), &args.out)?;
    outln!("wrote {} ({} points)", args.out.display(), map.points.len());
    Ok(true)
}
