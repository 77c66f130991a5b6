//! Experiment 2's results page, built from the team folders alone by the measures of
//! `docs/results/badminton-teams.md`: tables 5–7 per team with the reference players as rows,
//! the team scores and each player's contribution, the influence of T, the heat maps, and the
//! verdict on claim 4 by the rule that page fixed before the runs.
//!
//! Every measure plays the exported blobs through policy-core, as `firmware-sim match` does.

use std::fmt::Write as _;
use std::path::Path;

use firmware_sim::badminton::heatmap;
use firmware_sim::badminton::play::{measure, Measures};
use firmware_sim::badminton::reference::PlayerKind;
use firmware_sim::badminton::teams::{team_match, team_of};
use firmware_sim::badminton::Config;
use firmware_sim::files;
use plotters::prelude::*;

use super::figures::category_label;
use super::grid::Grid;
use super::teams::{self, TeamKind, TeamOutcome, TeamRun, KINDS};
use crate::stats::student_t::{self as stats, mean_interval};
use crate::Error;

/// How much each measure plays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Budget {
    /// Serves of the catch test and of the serve test, per player.
    pub balls: u32,
    /// Points each way of the reset effect, per player.
    pub points: u32,
    /// Points of each team match.
    pub match_points: u32,
}

impl Budget {
    /// The protocol's: 1,000 each.
    pub const FULL: Budget = Budget {
        balls: 1000,
        points: 1000,
        match_points: 1000,
    };
    /// A quick grid's.
    pub const QUICK: Budget = Budget {
        balls: 50,
        points: 50,
        match_points: 100,
    };

    fn of(grid: &Grid) -> Budget {
        if grid.quick {
            Budget::QUICK
        } else {
            Budget::FULL
        }
    }
}

fn sim(context: &str) -> impl Fn(firmware_sim::Error) -> Error + '_ {
    move |e| Error::Sim {
        context: context.to_string(),
        message: e.to_string(),
    }
}

/// A team's measures: the mean over its players of each rate (players with no trials left out).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TeamMeasures {
    /// Catch success (table 5).
    pub catch: Option<f64>,
    /// Serve error (table 6).
    pub serve_error: Option<f64>,
    /// Catch success, reset enabled (table 7).
    pub reset_enabled: Option<f64>,
    /// ... and disabled.
    pub reset_disabled: Option<f64>,
    /// Agents that played the safe state, as `player role: reason`.
    pub boot_errors: Vec<String>,
}

fn mean(values: impl Iterator<Item = Option<f64>>) -> Option<f64> {
    let v: Vec<f64> = values.flatten().collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// Measures every player of a team against the scripted reference player.
pub fn team_measures(
    config: &Config,
    players: &[PlayerKind],
    budget: Budget,
    seed: u64,
) -> Result<TeamMeasures, Error> {
    let measured: Vec<Measures> = players
        .iter()
        .map(|p| {
            measure(
                config,
                p,
                &PlayerKind::Scripted,
                budget.balls,
                budget.points,
                seed,
            )
            .map_err(sim("measuring a player"))
        })
        .collect::<Result<_, _>>()?;
    Ok(TeamMeasures {
        catch: mean(measured.iter().map(|m| m.catches.value())),
        serve_error: mean(measured.iter().map(|m| m.serve_errors.value())),
        reset_enabled: mean(measured.iter().map(|m| m.reset_enabled.value())),
        reset_disabled: mean(measured.iter().map(|m| m.reset_disabled.value())),
        boot_errors: measured
            .iter()
            .flat_map(|m| m.boot_errors.iter().map(move |e| format!("{} {e}", m.name)))
            .collect(),
    })
}

/// A team's players and measures, or why it has none ("missing", "failed: ...").
type Measured = Result<(Vec<PlayerKind>, TeamMeasures), String>;

/// A team match's result for the page: the seed, team A's score, each team's players'
/// (won, played).
type Scored = (u64, f64, [Vec<(u32, u32)>; 2]);

/// What the page is built from: every team's players and measures.
struct Teams {
    grid: Grid,
    budget: Budget,
    config: Config,
    /// Per kind, per seed: the team's players and measures, or why there are none.
    rows: Vec<(TeamKind, Vec<(u64, Measured)>)>,
    /// The reference players' measures (seed 0), the last rows of every table.
    references: Vec<(PlayerKind, TeamMeasures)>,
    /// Teams whose process failed.
    failed: usize,
}

impl Teams {
    fn players(&self, kind: &str, seed: u64) -> Option<&[PlayerKind]> {
        self.rows
            .iter()
            .find(|(k, _)| k.name == kind)?
            .1
            .iter()
            .find(|(s, _)| *s == seed)
            .and_then(|(_, r)| r.as_ref().ok())
            .map(|(p, _)| p.as_slice())
    }

    /// One measure per seed of a kind (finished teams with a value).
    fn per_seed(&self, kind: &TeamKind, get: fn(&TeamMeasures) -> Option<f64>) -> Vec<(u64, f64)> {
        self.rows
            .iter()
            .filter(|(k, _)| k == kind)
            .flat_map(|(_, seeds)| seeds.iter())
            .filter_map(|(seed, r)| {
                r.as_ref()
                    .ok()
                    .and_then(|(_, m)| get(m))
                    .map(|v| (*seed, v))
            })
            .collect()
    }
}

/// The finished teams' players and measures, the others' state.
fn gather(out: &Path, grid: &Grid) -> Result<(Teams, Vec<String>), Error> {
    let config = Config::builtin();
    let budget = Budget::of(grid);
    let mut missing = Vec::new();
    let mut failed = 0;
    let mut rows = Vec::new();
    for kind in KINDS {
        let mut seeds = Vec::new();
        for seed in 0..grid.seeds {
            let run = TeamRun { kind, seed };
            let entry = match teams::outcome(out, grid, &run)? {
                TeamOutcome::Finished(_) => {
                    let dir = teams::dir(out, grid, &run);
                    let players = team_of(&dir.to_string_lossy()).map_err(sim("a team folder"))?;
                    let m = team_measures(&config, &players, budget, seed)?;
                    Ok((players, m))
                }
                TeamOutcome::Failed(line) => {
                    failed += 1;
                    Err(format!("failed: {line}"))
                }
                TeamOutcome::Missing => {
                    missing.push(format!("team {} seed {seed}", kind.name));
                    Err("missing".into())
                }
            };
            seeds.push((seed, entry));
        }
        rows.push((kind, seeds));
    }
    let references = [PlayerKind::Scripted, PlayerKind::Random]
        .into_iter()
        .map(|r| {
            let m = team_measures(&config, std::slice::from_ref(&r), budget, 0)?;
            Ok((r, m))
        })
        .collect::<Result<_, Error>>()?;
    Ok((
        Teams {
            grid: *grid,
            budget,
            config,
            rows,
            references,
            failed,
        },
        missing,
    ))
}

/// The protocol's rule reads the 95 % t interval (`mean ± half-width`).
fn interval_text(values: &[f64]) -> String {
    stats::interval_text(values, 3)
}

/// A table's mean over seeds: the percentile bootstrap interval, never outside the values'
/// range, `(all 5 equal)` without spread (docs/design.md §7).
fn mean_text(values: &[f64]) -> String {
    crate::stats::bootstrap::mean_text(values, 3)
}

fn per_seed_text(values: &[(u64, f64)]) -> String {
    values
        .iter()
        .map(|(s, v)| format!("{s}: {v:.3}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A table of one team measure, the reference players as the last rows.
fn measure_table(teams: &Teams, get: fn(&TeamMeasures) -> Option<f64>) -> String {
    let mut t = String::from(
        "| team | teams measured | mean (95 % bootstrap) | per seed |\n|---|---|---|---|\n",
    );
    for (kind, seeds) in &teams.rows {
        let values = teams.per_seed(kind, get);
        let v: Vec<f64> = values.iter().map(|p| p.1).collect();
        let _ = writeln!(
            t,
            "| {} | {} of {} | {} | {} |",
            kind.name,
            values.len(),
            seeds.len(),
            mean_text(&v),
            per_seed_text(&values)
        );
    }
    for (reference, m) in &teams.references {
        let value = get(m).map_or("–".into(), |v| format!("{v:.3}"));
        let _ = writeln!(t, "| {reference} (reference) | – | {value} | seed 0 |");
    }
    t
}

/// Team A's share of the points won against team B, per seed where both finished.
fn scores(teams: &Teams, a: &str, b: &str) -> Result<Vec<Scored>, Error> {
    scores_against(teams, a, |seed| teams.players(b, seed).map(<[_]>::to_vec))
}

/// Team A's share of the points won against the players `b` gives for each seed.
fn scores_against(
    teams: &Teams,
    a: &str,
    b: impl Fn(u64) -> Option<Vec<PlayerKind>>,
) -> Result<Vec<Scored>, Error> {
    let mut out = Vec::new();
    for seed in 0..teams.grid.seeds {
        let (Some(pa), Some(pb)) = (teams.players(a, seed), b(seed)) else {
            continue;
        };
        let score = team_match(
            &teams.config,
            &[pa.to_vec(), pb],
            teams.budget.match_points,
            seed,
        )
        .map_err(sim("a team match"))?;
        if let Some(s) = score.score(0) {
            let shares = score
                .players
                .map(|team| team.iter().map(|p| (p.won, p.played)).collect());
            out.push((seed, s, shares));
        }
    }
    Ok(out)
}

/// Writes table 4's row of team `a` against `b` and returns A's score per seed.
fn score_row(page: &mut String, a: &str, b: &str, scored: &[Scored]) -> Vec<f64> {
    let values: Vec<(u64, f64)> = scored.iter().map(|(seed, v, _)| (*seed, *v)).collect();
    let v: Vec<f64> = values.iter().map(|p| p.1).collect();
    let _ = writeln!(
        page,
        "| {a} | {b} | {} | {} | {} |",
        v.len(),
        mean_text(&v),
        per_seed_text(&values)
    );
    v
}

/// Builds the page's body and writes its figures into `figures`; returns the body, the teams
/// that are missing and how many failed.
pub fn body(
    out: &Path,
    grid: &Grid,
    figures: &Path,
) -> Result<(String, Vec<String>, usize), Error> {
    let (teams, missing) = gather(out, grid)?;
    let mut page = String::new();
    let b = teams.budget;
    let _ = writeln!(
        page,
        "Every measure plays the exported blobs through policy-core against the scripted \
         reference player: {} serves for the catch and serve tests, {} points each way for the \
         reset effect, {} points per team match. A team's value is the mean over its players; \
         the tables give its mean over seeds with the 95 % percentile bootstrap interval, the \
         rule of claim 4 the 95 % Student-t interval it names.\n",
        b.balls, b.points, b.match_points
    );
    let _ = writeln!(
        page,
        "## Table 5: catch success\n\n{}",
        measure_table(&teams, |m| m.catch)
    );
    let _ = writeln!(
        page,
        "## Table 6: serve error\n\n{}",
        measure_table(&teams, |m| m.serve_error)
    );
    let _ = writeln!(
        page,
        "## Table 7: catch success with the reset agent enabled, and disabled\n\nEnabled:\n\n{}\nDisabled:\n\n{}",
        measure_table(&teams, |m| m.reset_enabled),
        measure_table(&teams, |m| m.reset_disabled)
    );
    let boot: Vec<String> = teams
        .rows
        .iter()
        .flat_map(|(k, seeds)| seeds.iter().map(move |(s, r)| (k, s, r)))
        .filter_map(|(k, s, r)| r.as_ref().ok().map(|(_, m)| (k, s, m)))
        .flat_map(|(k, s, m)| {
            m.boot_errors
                .iter()
                .map(move |e| format!("- {} seed {s}: {e}", k.name))
        })
        .collect();
    if !boot.is_empty() {
        let _ = writeln!(
            page,
            "Agents that did not boot and played the safe state:\n\n{}\n",
            boot.join("\n")
        );
    }

    // Team scores, every pair of kinds, same seed.
    let _ = writeln!(
        page,
        "## Table 4: team scores (figures 10–13)\n\nTeam A's share of the points won against \
         team B (lets left out), pairings drawn uniformly from their players, each team serving \
         half; the reference players as a team B of one player.\n\n\
         | team A | team B | seeds | A's score (95 % bootstrap) | per seed |\n|---|---|---|---|---|"
    );
    for kind in KINDS {
        for (reference, _) in &teams.references {
            let s = scores_against(&teams, kind.name, |_| Some(vec![reference.clone()]))?;
            score_row(
                &mut page,
                kind.name,
                &format!("{reference} (reference)"),
                &s,
            );
        }
    }
    let mut against_ddpg = Vec::new();
    let mut contributions: Vec<(String, Vec<f64>)> = Vec::new();
    for (i, a) in KINDS.iter().enumerate() {
        for b in &KINDS[i + 1..] {
            let s = scores(&teams, a.name, b.name)?;
            let v = score_row(&mut page, a.name, b.name, &s);
            if a.name == "ddpg" && b.algo == crate::algorithms::Algo::Dcp {
                // A DCP team's score against DDPG is the rest of DDPG's share of the same
                // match's decided points.
                against_ddpg.push((b.name, v.iter().map(|s| 1.0 - s).collect::<Vec<f64>>()));
            }
            if let Some((_, _, shares)) = s.iter().find(|(seed, _, _)| *seed == 0) {
                for (kind, team) in [(a.name, &shares[0]), (b.name, &shares[1])] {
                    let share = team
                        .iter()
                        .map(|&(won, played)| {
                            if played == 0 {
                                0.0
                            } else {
                                f64::from(won) / f64::from(played)
                            }
                        })
                        .collect();
                    contributions.push((
                        format!("{kind} vs {}", if kind == a.name { b.name } else { a.name }),
                        share,
                    ));
                }
            }
        }
    }
    page.push('\n');

    // Figures.
    let mut names = Vec::new();
    let contribution_svg = contributions_figure(&contributions)?;
    write(figures, FIGURE_CONTRIBUTIONS, &contribution_svg)?;
    names.push(FIGURE_CONTRIBUTIONS);
    write(figures, FIGURE_T, &influence_of_t(&against_ddpg)?)?;
    names.push(FIGURE_T);
    for (kind, file_catch, file_serve) in [
        ("ddpg", "fig15-catch-q-ddpg.svg", "fig16-serve-q-ddpg.svg"),
        (
            "dcp-t16",
            "fig15-catch-q-dcp-t16.svg",
            "fig16-serve-q-dcp-t16.svg",
        ),
    ] {
        let Some(player) = teams.players(kind, 0).and_then(|p| p.first()) else {
            continue;
        };
        let PlayerKind::Folder(folder) = player else {
            continue;
        };
        // Critics in role order (catch, serve, reset), as the manifest names them.
        let Some([(_, catch_critic), (_, serve_critic), _]) = &folder.critics else {
            continue;
        };
        let config = &teams.config;
        let grid_n = if grid.quick { 9 } else { 41 };
        let catch =
            heatmap::catch_map(config, catch_critic, grid_n).map_err(sim("the catch heat map"))?;
        let serve =
            heatmap::serve_map(config, serve_critic, 11).map_err(sim("the serve heat map"))?;
        let title = |role| format!("{kind}, seed 0, player 0: {role} critic");
        write(
            figures,
            file_catch,
            &heatmap::svg(&catch, config, &title("catch")).map_err(sim("drawing"))?,
        )?;
        write(
            figures,
            file_serve,
            &heatmap::svg(&serve, config, &title("serve")).map_err(sim("drawing"))?,
        )?;
        names.extend([file_catch, file_serve]);
    }

    // Influence of T and the verdict.
    let _ = writeln!(page, "## Influence of T (figure 14)\n\n| DCP | seeds | score against DDPG | beats DDPG |\n|---|---|---|---|");
    for (kind, v) in &against_ddpg {
        let word = match stats::against(v, 0.5) {
            std::cmp::Ordering::Greater => "beats",
            std::cmp::Ordering::Less => "loses",
            std::cmp::Ordering::Equal => "ties",
        };
        let _ = writeln!(
            page,
            "| {kind} | {} | {} | {word} |",
            v.len(),
            interval_text(v)
        );
    }
    page.push('\n');
    let serve =
        |kind: &str| teams.per_seed(&TeamKind::named(kind).expect("a kind"), |m| m.serve_error);
    let (s16, sd) = (serve("dcp-t16"), serve("ddpg"));
    let e: Vec<f64> = s16
        .iter()
        .filter_map(|&(seed, x)| sd.iter().find(|p| p.0 == seed).map(|p| x - p.1))
        .collect();
    let _ = writeln!(page, "## Claim 4\n");
    if grid.quick {
        let _ = writeln!(page, "No verdict: a quick grid trains 2 players for 40 points, a test of the machinery, not a result.\n");
    } else {
        let t = |kind: &str| {
            against_ddpg
                .iter()
                .find(|(k, _)| *k == kind)
                .map(|(_, v)| stats::against(v, 0.5))
        };
        let verdict = claim4(t("dcp-t16"), t("dcp-t1"), stats::against(&e, 0.0));
        let _ = writeln!(
            page,
            "**Claim 4** (DCP beats DDPG once T > 4, mostly through fewer serve errors): \
             **{verdict}**. E, the serve error of DCP T = 16 minus DDPG paired by seed: {} over \
             {} seeds.\n",
            interval_text(&e),
            e.len()
        );
    }
    let _ = writeln!(page, "## Figures\n");
    for name in names {
        let _ = writeln!(page, "![{name}](figures/{name})\n");
    }
    Ok((page, missing, teams.failed))
}

/// The verdict on claim 4 by the protocol's rule, from where DCP T = 16's and T = 1's scores
/// against DDPG lie against 0.5 (none: no team pair finished) and where E, the paired serve
/// error difference of T = 16 minus DDPG, lies against 0.
pub fn claim4(
    t16: Option<std::cmp::Ordering>,
    t1: Option<std::cmp::Ordering>,
    e: std::cmp::Ordering,
) -> &'static str {
    use std::cmp::Ordering::{Equal, Greater, Less};
    match (t16, t1, e) {
        (Some(Greater), Some(t1), Less) if t1 != Greater => "reproduced",
        (Some(Greater), _, _) => "reproduced in part",
        (Some(Less), _, _) => "contradicted",
        (Some(Equal), _, _) | (None, _, _) => "not reproduced",
    }
}

/// Figures 10–13's file: each player's contribution, seed 0.
pub const FIGURE_CONTRIBUTIONS: &str = "fig10-13-contributions.svg";
/// Figure 14's file.
pub const FIGURE_T: &str = "fig14-influence-of-t.svg";

fn write(dir: &Path, name: &str, svg: &str) -> Result<(), Error> {
    std::fs::create_dir_all(dir).map_err(|source| Error::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let path = dir.join(name);
    files::write_atomic(&path, svg.as_bytes()).map_err(|source| Error::Io { path, source })
}

fn drawing(e: impl std::fmt::Display) -> Error {
    Error::Sim {
        context: "drawing a figure".into(),
        message: e.to_string(),
    }
}

/// Each team's players' shares of the points they played and won, one row of bars per match
/// of seed 0.
fn contributions_figure(rows: &[(String, Vec<f64>)]) -> Result<String, Error> {
    let mut text = String::new();
    {
        let height = (40 + 26 * rows.len().max(1)) as u32;
        let root = SVGBackend::with_string(&mut text, (900, height.max(200))).into_drawing_area();
        root.fill(&WHITE).map_err(drawing)?;
        let widest = rows.iter().map(|r| r.1.len()).max().unwrap_or(1).max(1);
        // The row names are drawn in the plot, left of the bars: a categorical axis of many
        // rows gets only some of its labels from the mesh.
        let label_space = 4.0;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "Each player's share of the points it played that its team won (seed 0)",
                ("sans-serif", 14),
            )
            .margin(8)
            .x_label_area_size(24)
            .y_label_area_size(10)
            .build_cartesian_2d(-label_space..widest as f64, 0.0..rows.len().max(1) as f64)
            .map_err(drawing)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .disable_y_axis()
            .x_labels(widest + 1)
            .x_label_formatter(&|x| {
                if *x >= 0.0 {
                    format!("{x:.0}")
                } else {
                    String::new()
                }
            })
            .x_desc("player (bar height: share won, 0 to 1)")
            .draw()
            .map_err(drawing)?;
        for (i, (name, _)) in rows.iter().enumerate() {
            chart
                .draw_series(std::iter::once(Text::new(
                    name.clone(),
                    (-label_space + 0.1, i as f64 + 0.7),
                    ("sans-serif", 12),
                )))
                .map_err(drawing)?;
        }
        for (i, (_, shares)) in rows.iter().enumerate() {
            for (p, &share) in shares.iter().enumerate() {
                let y0 = i as f64 + 0.1;
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(p as f64 + 0.1, y0), (p as f64 + 0.9, y0 + 0.8 * share)],
                        Palette99::pick(i).filled(),
                    )))
                    .map_err(drawing)?;
            }
        }
        root.present().map_err(drawing)?;
    }
    Ok(text)
}

/// Figure 14: DCP's score against DDPG for T = 1, 4, 16, mean and interval over seeds.
fn influence_of_t(rows: &[(&str, Vec<f64>)]) -> Result<String, Error> {
    let names: Vec<&str> = rows.iter().map(|r| r.0).collect();
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (640, 400)).into_drawing_area();
        root.fill(&WHITE).map_err(drawing)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "DCP's score against DDPG by T (mean ± 95 % over seeds; 0.5 = even)",
                ("sans-serif", 14),
            )
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(40)
            .build_cartesian_2d(-0.5..rows.len() as f64 - 0.5, 0.0..1.0)
            .map_err(drawing)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(rows.len())
            .x_label_formatter(&|x| category_label(&names, *x))
            .y_desc("share of the points won against DDPG")
            .draw()
            .map_err(drawing)?;
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(-0.5, 0.5), (rows.len() as f64 - 0.5, 0.5)],
                BLACK.mix(0.5),
            )))
            .map_err(drawing)?;
        for (i, (_, values)) in rows.iter().enumerate() {
            let x = i as f64;
            for &v in values {
                chart
                    .draw_series(std::iter::once(Circle::new(
                        (x + 0.15, v),
                        3,
                        BLUE.mix(0.5).filled(),
                    )))
                    .map_err(drawing)?;
            }
            if let Some(m) = mean_interval(values) {
                let h = m.half_width.unwrap_or(0.0);
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        vec![(x, m.mean - h), (x, m.mean + h)],
                        RED.stroke_width(2),
                    )))
                    .map_err(drawing)?;
                chart
                    .draw_series(std::iter::once(Circle::new((x, m.mean), 5, RED.filled())))
                    .map_err(drawing)?;
            }
        }
        root.present().map_err(drawing)?;
    }
    Ok(text)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cmp::Ordering::{Equal, Greater, Less};

    #[test]
    fn claim_four_follows_the_protocol() {
        assert_eq!(claim4(Some(Greater), Some(Equal), Less), "reproduced");
        assert_eq!(claim4(Some(Greater), Some(Less), Less), "reproduced");
        // No threshold in T, or not through the serve: in part.
        assert_eq!(
            claim4(Some(Greater), Some(Greater), Less),
            "reproduced in part"
        );
        assert_eq!(
            claim4(Some(Greater), Some(Equal), Equal),
            "reproduced in part"
        );
        assert_eq!(claim4(Some(Equal), Some(Less), Less), "not reproduced");
        assert_eq!(claim4(None, None, Equal), "not reproduced");
        assert_eq!(claim4(Some(Less), Some(Greater), Less), "contradicted");
    }

    #[test]
    fn an_interval_is_judged_against_its_line() {
        assert_eq!(stats::against(&[0.6, 0.7, 0.65], 0.5), Greater);
        assert_eq!(stats::against(&[0.3, 0.35, 0.4], 0.5), Less);
        assert_eq!(stats::against(&[0.3, 0.7, 0.5], 0.5), Equal);
        assert_eq!(stats::against(&[0.9], 0.5), Equal); // one seed has no interval
    }
}
