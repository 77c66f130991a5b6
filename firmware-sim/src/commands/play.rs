//! `firmware-sim match`: a badminton match between two players judged by the scenario's
//! criteria, or their measures (`--measures`).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use firmware_sim::{errln, out};

use firmware_sim::badminton::play::{play_match, Length, MeasuresReport};
use firmware_sim::badminton::{self, reference::PlayerKind};
use firmware_sim::files;

use super::{outputs_ok, written};

#[derive(Args, Debug)]
pub(crate) struct MatchArgs {
    /// Player 0: scripted, random, or a player folder (a directory holding player.toml and its
    /// three actor blobs).
    #[arg(long)]
    p0: PlayerKind,
    /// Player 1: scripted, random, or a player folder.
    #[arg(long)]
    p1: PlayerKind,
    /// Instead of a match: each player's catch test and serve test (--balls serves) and reset
    /// effect (--points points each way), against the other player.
    #[arg(long, conflicts_with_all = ["games", "svg"])]
    measures: bool,
    /// Serves of the catch and serve tests, 1..=1000000.
    #[arg(long, requires = "measures", default_value_t = 1000)]
    balls: u32,
    /// Points of the reset effect, each way, 1..=100000.
    #[arg(long, requires = "measures", default_value_t = 100)]
    points: u32,
    /// Games to play, 1..=1000.
    #[arg(long, default_value_t = 1)]
    games: u32,
    /// Seed of the players' random streams.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// The badminton scenario: "badminton" (built in) or a TOML file.
    #[arg(long, default_value = "badminton")]
    scenario: String,
    /// Write the match report as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Draw one rally (the first of at least 4 hits, else the longest) from above and from the
    /// side to this SVG file.
    #[arg(long)]
    svg: Option<PathBuf>,
}

/// `--svg` draws the first rally of at least this many hits.
pub(crate) const DRAWN_HITS: usize = 4;

/// The most games one `match` plays (a larger count is almost surely a typo).
pub(crate) const MAX_GAMES: u32 = 1000;

/// Plays the match; `Ok(passed)`. Inputs and output paths are checked before the first point.
pub(crate) fn play(args: &MatchArgs) -> Result<bool> {
    if !(1..=MAX_GAMES).contains(&args.games) {
        anyhow::bail!("--games must be in 1..={MAX_GAMES}, found {}", args.games);
    }
    outputs_ok(args.json.as_deref(), args.svg.as_deref())?;
    let config = badminton::Config::resolve(&args.scenario)?;
    let kinds = [args.p0.clone(), args.p1.clone()];
    if args.measures {
        return measures(args, &config, &kinds);
    }
    let mut drawn: Option<badminton::game::Rally> = None;
    let keep_rally = |game: &badminton::Badminton| {
        let hits = |r: &badminton::game::Rally| r.hits.len();
        let current = drawn.as_ref().map_or(0, hits);
        // The first rally of DRAWN_HITS hits or more (a readable figure), else the longest.
        if let Some(r) = game
            .rally()
            .filter(|r| current < DRAWN_HITS && hits(r) > current)
        {
            drawn = Some(r.clone());
        }
    };
    let length = Length::Games(args.games);
    let record = args.svg.is_some();
    let report = play_match(&config, &kinds, length, args.seed, record, keep_rally)?;
    out!("{}", report.summary());
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&report)?;
        written(files::write_atomic(path, text.as_bytes()), path)?;
    }
    if let (Some(path), Some(rally)) = (&args.svg, &drawn) {
        let end = rally.end.map_or("-".to_string(), |e| {
            let cause = serde_json::to_string(&e.cause).unwrap_or_default();
            let winner = e.winner.map_or("none".to_string(), |w| format!("p{w}"));
            format!("{}, point to {winner}", cause.trim_matches('"'))
        });
        let title = format!(
            "{} | p0 {} (blue) vs p1 {} (red) | seed {} | a rally of {} hits, ended by {end}",
            config.name,
            kinds[0],
            kinds[1],
            args.seed,
            rally.hits.len()
        );
        let svg = badminton::figure::rally_svg(rally, &config, &title);
        written(files::write_atomic(path, svg.as_bytes()), path)?;
    }
    if !report.pass.passed {
        errln!("FAIL: {}", report.pass.failures.join("; "));
    }
    Ok(report.pass.passed)
}

/// `match --measures`: `Ok(every agent booted)`.
pub(crate) fn measures(
    args: &MatchArgs,
    config: &badminton::Config,
    kinds: &[PlayerKind; 2],
) -> Result<bool> {
    for (flag, n, most) in [
        ("--balls", args.balls, 1_000_000),
        ("--points", args.points, 100_000),
    ] {
        anyhow::ensure!(
            (1..=most).contains(&n),
            "{flag} must be in 1..={most}, found {n}"
        );
    }
    let report = MeasuresReport::of(config, kinds, args.balls, args.points, args.seed)?;
    out!("{}", report.summary());
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&report)?;
        written(files::write_atomic(path, text.as_bytes()), path)?;
    }
    if !report.booted() {
        errln!("FAIL: an agent played the safe state (its blob did not boot)");
    }
    Ok(report.booted())
}
