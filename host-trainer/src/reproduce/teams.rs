//! Experiment 2's grid: the badminton teams of `docs/results/badminton-teams.md`, five kinds ×
//! seeds, each a `host-trainer team` run in `OUT/teams/{scenario}__{algo}__{seed}/`, planned,
//! sliced and read back like experiment 1's runs.

use std::path::{Path, PathBuf};

use super::grid::{Grid, Slice};
use crate::algorithms::Algo;
use crate::run::folder;
use crate::sweep::plan::{Job, PlannedRun, Start};
use crate::team::config::TeamConfig;
use crate::team::folder::{exported, PLAYERS};
use crate::Error;

/// One kind of team: an algorithm, and DCP's T.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TeamKind {
    /// Its name in tables: `ddpg`, `dcp-t1`, `dcp-t4`, `dcp-t16`, `ppo`.
    pub name: &'static str,
    /// The algorithm of every learner.
    pub algo: Algo,
    /// DCP's proposals per state.
    pub t: Option<usize>,
}

/// The five kinds of team, in table order.
pub const KINDS: [TeamKind; 5] = [
    TeamKind::of("ddpg", Algo::Ddpg, None),
    TeamKind::of("dcp-t1", Algo::Dcp, Some(1)),
    TeamKind::of("dcp-t4", Algo::Dcp, Some(4)),
    TeamKind::of("dcp-t16", Algo::Dcp, Some(16)),
    TeamKind::of("ppo", Algo::Ppo, None),
];

impl TeamKind {
    const fn of(name: &'static str, algo: Algo, t: Option<usize>) -> TeamKind {
        TeamKind { name, algo, t }
    }

    /// The kind of this name.
    pub fn named(name: &str) -> Option<TeamKind> {
        KINDS.into_iter().find(|k| k.name == name)
    }

    /// The team's settings: `host-trainer team`'s defaults with the kind's algorithm and T;
    /// `quick` trains 2 players for 40 points (the machinery, not a result).
    pub fn config(&self, seed: u64, quick: bool) -> TeamConfig {
        let mut c = TeamConfig {
            algo: self.algo,
            seed,
            ..TeamConfig::default()
        };
        if let Some(t) = self.t {
            c.dcp.t = t;
        }
        if quick {
            c.players = 2;
            c.points = 40;
            c.checkpoint_every = 20;
        }
        c
    }
}

/// One team of the grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TeamRun {
    /// Its kind.
    pub kind: TeamKind,
    /// Its seed.
    pub seed: u64,
}

/// The folder under `--out` holding the teams.
pub const TEAMS: &str = "teams";

/// Every team, kind by kind and seed by seed.
pub fn runs(grid: &Grid) -> Vec<TeamRun> {
    KINDS
        .into_iter()
        .flat_map(|kind| (0..grid.seeds).map(move |seed| TeamRun { kind, seed }))
        .collect()
}

/// The teams of one slice: team `i` of [`runs`] belongs to slice `i mod count`.
pub fn slice(grid: &Grid, slice: Slice) -> Vec<TeamRun> {
    runs(grid)
        .into_iter()
        .enumerate()
        .filter(|(i, _)| *i as u64 % slice.count == slice.index)
        .map(|(_, run)| run)
        .collect()
}

/// A team's folder.
pub fn dir(out: &Path, grid: &Grid, run: &TeamRun) -> PathBuf {
    let config = run.kind.config(run.seed, grid.quick);
    out.join(TEAMS).join(config.team_name())
}

/// Plans the slice's teams; writes nothing. A team folder of other settings is refused.
pub fn plan(out: &Path, grid: &Grid, part: Slice) -> Result<Vec<PlannedRun>, Error> {
    slice(grid, part)
        .into_iter()
        .map(|run| {
            let config = run.kind.config(run.seed, grid.quick);
            config.validate()?;
            let dir = dir(out, grid, &run);
            let start = start_of(&dir, &config)?;
            Ok(PlannedRun {
                job: Job::Team(config),
                dir,
                start,
            })
        })
        .collect()
}

/// What a team folder's state asks for, by `sweep`'s rules: no run file, fresh; a team of
/// other settings, an error; exported, skipped; otherwise resumed.
fn start_of(dir: &Path, config: &TeamConfig) -> Result<Start, Error> {
    if folder::run_file_in(dir).is_none() {
        return Ok(Start::Fresh);
    }
    let recorded = TeamConfig::from_file(&dir.join(folder::CONFIG))?;
    if recorded != *config {
        return Err(Error::RunDiffers {
            path: dir.to_path_buf(),
            difference: "its config.toml is not the grid's setting for it".into(),
        });
    }
    Ok(if exported(dir, config) {
        Start::Skip
    } else {
        Start::Resume
    })
}

/// What became of a team, read from its folder alone.
#[derive(Debug)]
pub enum TeamOutcome {
    /// Trained and exported: its player folders, in order.
    Finished(Vec<PathBuf>),
    /// Its process failed: the last line it printed.
    Failed(String),
    /// Not run, running, or stopped before its end.
    Missing,
}

/// A team's outcome.
pub fn outcome(out: &Path, grid: &Grid, run: &TeamRun) -> Result<TeamOutcome, Error> {
    let config = run.kind.config(run.seed, grid.quick);
    let dir = dir(out, grid, run);
    if exported(&dir, &config) {
        let recorded = TeamConfig::from_file(&dir.join(folder::CONFIG))?;
        if recorded != config {
            return Err(Error::RunDiffers {
                path: dir,
                difference: "its config.toml is not the grid's setting for it".into(),
            });
        }
        let players = (0..config.players)
            .map(|p| {
                dir.join(PLAYERS)
                    .join(crate::team::folder::player_name(p, config.players))
            })
            .collect();
        return Ok(TeamOutcome::Finished(players));
    }
    Ok(super::folder::failed_line(&dir).map_or(TeamOutcome::Missing, TeamOutcome::Failed))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reproduce::grid::Experiment;

    #[test]
    fn dcp_teams_differ_in_t_only_and_slices_cover_the_grid() {
        let grid = Grid {
            experiment: Experiment::Exp2,
            seeds: 5,
            quick: false,
        };
        assert_eq!(runs(&grid).len(), 25);
        let t = |name| TeamKind::named(name).expect("a kind").config(3, false);
        let (t1, t16) = (t("dcp-t1"), t("dcp-t16"));
        assert_eq!(
            TeamConfig {
                dcp: t16.dcp.clone(),
                ..t1.clone()
            },
            t16
        );
        assert_eq!(
            t16,
            TeamConfig {
                seed: 3,
                ..TeamConfig::default()
            }
        );
        assert_eq!(t1.team_name(), "badminton__dcp-t1__3");
        let mut seen = 0;
        for index in 0..3 {
            seen += slice(&grid, Slice { index, count: 3 }).len();
        }
        assert_eq!(seen, 25);
    }
}
