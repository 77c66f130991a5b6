//! A grid's output folder: which grid it holds, the runs of every cell, and what became of them.
//!
//! ```text
//! OUT/grid.json                           the grid (experiment, seeds, budget): written once
//! OUT/runs/{cell}/{task}__{algo}__{seed}/ the runs, as `train` writes them
//! OUT/runs/{cell}/sweep-logs/             each run's log, and `{run}.failed` for a failed run
//! OUT/exp1.md, OUT/figures/               the page and its figures, built from the above alone
//! ```
//! Every part of a grid (each `--slice`, on any machine sharing the folder) writes disjoint run
//! folders, so the parts never write the same file; `grid.json` is created once, whole, by
//! whichever part comes first, and every later part checks it holds the same grid.

use std::fs;
use std::path::{Path, PathBuf};

use firmware_sim::files;
use firmware_sim::nav::test_protocol::Report;

use super::grid::{Cell, Grid, GridRun, Slice};
use crate::run::config::TrainConfig;
use crate::run::folder;
use crate::sweep::plan::{self, PlannedRun};
use crate::sweep::record::{read_report, RunRecord, Status};
use crate::sweep::supervise::logs_of;
use crate::Error;

/// The grid's record in its folder.
pub const GRID_FILE: &str = "grid.json";

/// The grid `out` holds, if any.
pub fn recorded(out: &Path) -> Result<Option<Grid>, Error> {
    let path = out.join(GRID_FILE);
    match fs::read_to_string(&path) {
        Ok(text) => serde_json::from_str(&text)
            .map(Some)
            .map_err(|e| Error::GridRecord {
                path,
                message: e.to_string(),
            }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(source) => Err(Error::Io { path, source }),
    }
}

/// Records `grid` in `out` (the first part to come; `out` is created if missing), or checks that `out` holds this grid: a
/// folder of another grid is refused before anything is written, whatever its runs.
pub fn claim(out: &Path, grid: &Grid) -> Result<(), Error> {
    // A missing --out is made here, once every check has passed (its parent must exist).
    crate::run::folder::create_output_folder(out)?;
    let path = out.join(GRID_FILE);
    let text = serde_json::to_string_pretty(grid).unwrap_or_default() + "\n";
    // One part wins the race to create the record, and publishes it whole: a part that loses
    // reads the complete record (never an empty file) and checks it holds the same grid.
    match files::write_new(&path, text.as_bytes()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => check(out, grid),
        Err(source) => Err(Error::Io { path, source }),
    }
}

/// Checks that `out` holds `grid`.
pub fn check(out: &Path, grid: &Grid) -> Result<(), Error> {
    match recorded(out)? {
        Some(found) if found == *grid => Ok(()),
        Some(found) => Err(Error::GridDiffers {
            path: out.to_path_buf(),
            difference: format!(
                "it holds the grid `{}`, not `{}`",
                found.describe(),
                grid.describe()
            ),
        }),
        None => Err(Error::GridDiffers {
            path: out.to_path_buf(),
            difference: format!("it holds no grid ({GRID_FILE} is missing): nothing to merge"),
        }),
    }
}

/// Plans the slice's runs, cell by cell through `sweep`'s planner (a folder holding a run of
/// other settings is refused). Writes nothing: a cell whose folder does not exist yet has
/// only fresh runs ([`create_cells`] makes the folders once everything is checked).
pub fn plan(out: &Path, grid: &Grid, slice: Slice) -> Result<Vec<PlannedRun>, Error> {
    plan_runs(out, grid, &grid.slice(slice))
}

/// [`plan()`] for any runs of the grid's cells (a slice, or [`Grid::added_runs`]).
pub fn plan_runs(out: &Path, grid: &Grid, runs: &[GridRun]) -> Result<Vec<PlannedRun>, Error> {
    let mut planned = Vec::new();
    for cell in grid.cells() {
        let seeds: Vec<u64> = runs
            .iter()
            .filter(|r| r.cell == cell)
            .map(|r| r.seed)
            .collect();
        if seeds.is_empty() {
            continue;
        }
        let dir = Grid::cell_dir(out, &cell);
        let base = cell.config(grid.quick);
        if dir.is_dir() {
            planned.extend(plan::runs(&base, &[cell.agent.algo], &seeds, &dir)?);
            continue;
        }
        let config = base.for_algo(cell.agent.algo)?;
        planned.extend(seeds.into_iter().map(|seed| {
            let config = TrainConfig {
                seed,
                ..config.clone()
            };
            PlannedRun {
                dir: dir.join(config.run_name()),
                job: plan::Job::Train(config),
                start: plan::Start::Fresh,
            }
        }));
    }
    Ok(planned)
}

/// Creates the folders of the cells the plan's runs go in.
pub fn create_cells(plan: &[PlannedRun]) -> Result<(), Error> {
    for run in plan {
        if let Some(cell) = run.dir.parent() {
            fs::create_dir_all(cell).map_err(|source| Error::Io {
                path: cell.to_path_buf(),
                source,
            })?;
        }
    }
    Ok(())
}

/// The file that marks a failed run, beside its log.
fn failed_mark(run_dir: &Path) -> PathBuf {
    let name = run_dir.file_name().unwrap_or_default().to_string_lossy();
    logs_of(run_dir).join(format!("{name}.failed"))
}

/// The last line a failed run printed, if its folder's mark says it failed (the run itself,
/// a `train` run or a team, is at `run_dir`).
pub fn failed_line(run_dir: &Path) -> Option<String> {
    let text = fs::read_to_string(failed_mark(run_dir)).ok()?;
    let record: Option<RunRecord> = serde_json::from_str(&text).ok();
    Some(
        record
            .and_then(|r| r.last_line)
            .unwrap_or_else(|| "failed".into()),
    )
}

/// Marks the runs that failed (their record, as JSON, beside their log) and clears the mark
/// of those that finished: the page counts a failed run as failed, never drops it.
pub fn mark(plan: &[PlannedRun], records: &[RunRecord]) -> Result<(), Error> {
    for (run, record) in plan.iter().zip(records) {
        let path = failed_mark(&run.dir);
        let io = |source| Error::Io {
            path: path.clone(),
            source,
        };
        match record.status {
            Status::Failed => {
                let text = serde_json::to_string_pretty(record).unwrap_or_default() + "\n";
                files::write_atomic(&path, text.as_bytes()).map_err(io)?;
            }
            Status::Finished | Status::Skipped if path.exists() => {
                fs::remove_file(&path).map_err(io)?;
            }
            _ => {}
        }
    }
    Ok(())
}

/// What a run's folder says became of it.
#[derive(Clone, Debug)]
pub enum Outcome {
    /// Finished: its evaluation (firmware-sim's report on the exported blob) and its config.
    Finished(Box<Finished>),
    /// Failed: the last line its process printed.
    Failed(String),
    /// Not run, running, or stopped before its end.
    Missing,
}

/// A finished run.
#[derive(Clone, Debug)]
pub struct Finished {
    /// The run's folder.
    pub dir: PathBuf,
    /// Its recorded settings.
    pub config: TrainConfig,
    /// Its evaluation.
    pub report: Report,
    /// Seconds its training episodes took (the sum over `metrics.csv` of steps / steps per
    /// second: evaluation and checkpoint writes left out); none if the file does not say.
    pub training_seconds: Option<f64>,
}

/// Seconds of training a run folder's `metrics.csv` records, or none if it has no such columns
/// or no rows.
pub fn training_seconds(dir: &Path) -> Option<f64> {
    let text = fs::read_to_string(dir.join(folder::METRICS)).ok()?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next()?.split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name);
    let (steps, rate) = (column("steps")?, column("steps_per_s")?);
    let mut seconds = 0.0;
    let mut rows = 0;
    for line in lines {
        let cells: Vec<&str> = line.split(',').collect();
        let parse = |i: usize| cells.get(i).and_then(|c| c.parse::<f64>().ok());
        if let (Some(n), Some(r)) = (parse(steps), parse(rate)) {
            if r > 0.0 {
                seconds += n / r;
                rows += 1;
            }
        }
    }
    (rows > 0).then_some(seconds)
}

/// The outcome of one run of the grid, read from its folder alone.
pub fn outcome(out: &Path, grid: &Grid, run: &GridRun) -> Result<Outcome, Error> {
    let cell_dir = Grid::cell_dir(out, &run.cell);
    let mut config = run.cell.config(grid.quick).for_algo(run.cell.agent.algo)?;
    config.seed = run.seed;
    let dir = cell_dir.join(config.run_name());
    let eval = dir.join(folder::EVAL);
    if eval.exists() {
        let report: Report = read_report(&dir)?;
        let recorded = TrainConfig::from_file(&dir.join(folder::CONFIG))?;
        let recorded = recorded.for_algo(recorded.algo)?;
        if recorded != config {
            // The merge refuses runs of other settings as the planner does.
            return Err(Error::RunDiffers {
                path: dir,
                difference: "its config.toml is not the grid's setting for it".into(),
            });
        }
        return Ok(Outcome::Finished(Box::new(Finished {
            training_seconds: training_seconds(&dir),
            dir,
            config,
            report,
        })));
    }
    Ok(failed_line(&dir).map_or(Outcome::Missing, Outcome::Failed))
}

/// Refuses to run `slice` in `out` while another part whose runs overlap it is running there
/// (holds its part's lock): each part locks only its own folder, so the whole grid and
/// `--slice 0/2` started together once both trained the same runs. Slices `a/n` and `b/m` share
/// a run when some index `i` has `i mod n = a` and `i mod m = b`, which (for a grid long enough,
/// and refusing is the safe side) is when `a` and `b` agree modulo gcd(n, m).
pub fn refuse_overlapping_parts(out: &Path, slice: Slice) -> Result<(), Error> {
    let Ok(entries) = fs::read_dir(out.join(super::PARTS)) else {
        return Ok(());
    };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(other) = name.split_once("-of-").and_then(|(i, n)| {
            Some(Slice {
                index: i.parse().ok()?,
                count: n.parse().ok()?,
            })
        }) else {
            continue;
        };
        if other == slice || !overlap(other, slice) {
            continue;
        }
        if let Some(holder) = crate::run::lock::holder(&entry.path()) {
            let holder = if holder.is_empty() {
                "another process".to_string()
            } else {
                format!("process {holder}")
            };
            return Err(Error::PartRunning {
                path: out.to_path_buf(),
                running: format!(
                    "part {}/{} is running there (host-trainer {holder}), which shares runs with part {}/{}",
                    other.index, other.count, slice.index, slice.count
                ),
            });
        }
    }
    Ok(())
}

fn overlap(a: Slice, b: Slice) -> bool {
    fn gcd(x: u64, y: u64) -> u64 {
        if y == 0 {
            x
        } else {
            gcd(y, x % y)
        }
    }
    a.index.abs_diff(b.index) % gcd(a.count, b.count) == 0
}

/// Every run's outcome, in grid order.
pub fn outcomes(out: &Path, grid: &Grid) -> Result<Vec<(GridRun, Outcome)>, Error> {
    outcomes_of(out, grid, grid.runs())
}

/// The outcome of each of `runs` (of the grid's cells), in their order.
pub fn outcomes_of(
    out: &Path,
    grid: &Grid,
    runs: Vec<GridRun>,
) -> Result<Vec<(GridRun, Outcome)>, Error> {
    runs.into_iter()
        .map(|run| outcome(out, grid, &run).map(|o| (run, o)))
        .collect()
}

/// The cell's finished runs' outcomes, looked up in `all`.
pub fn of_cell<'a>(all: &'a [(GridRun, Outcome)], cell: &Cell) -> Vec<&'a (GridRun, Outcome)> {
    all.iter().filter(|(run, _)| run.cell == *cell).collect()
}

#[cfg(test)]
mod tests {
    use super::super::grid::Experiment;
    use super::*;

    #[test]
    fn parts_racing_to_claim_a_folder_all_agree_and_no_reader_sees_half_a_record() {
        let grid = |seeds| Grid {
            experiment: Experiment::Exp1,
            seeds,
            quick: true,
        };
        let root = std::env::temp_dir().join(format!("reproduce-claim-{}", std::process::id()));
        for round in 0..40 {
            let out = root.join(round.to_string());
            fs::create_dir_all(&out).expect("dir");
            let start = std::sync::Barrier::new(5);
            std::thread::scope(|s| {
                let claims: Vec<_> = (0..4)
                    .map(|_| {
                        s.spawn(|| {
                            start.wait();
                            claim(&out, &grid(5))
                        })
                    })
                    .collect();
                // A reader polling the record while the parts race: it sees no record or the
                // whole one, never an error (an empty or half-written file).
                let reader = s.spawn(|| {
                    start.wait();
                    loop {
                        match recorded(&out) {
                            Ok(None) => std::thread::yield_now(),
                            Ok(Some(found)) => return Ok(found),
                            Err(e) => return Err(e.to_string()),
                        }
                    }
                });
                for claim in claims {
                    claim.join().expect("no panic").expect("every part agrees");
                }
                assert_eq!(reader.join().expect("no panic"), Ok(grid(5)));
            });
            let left: Vec<_> = fs::read_dir(&out)
                .expect("list")
                .map(|e| e.expect("entry").file_name())
                .collect();
            assert_eq!(left, [GRID_FILE], "only the record, no sibling left behind");
            let err = claim(&out, &grid(6)).expect_err("another grid is refused");
            assert!(matches!(err, Error::GridDiffers { .. }), "{err}");
        }
        fs::remove_dir_all(&root).expect("cleanup");
    }

    #[test]
    fn training_time_is_summed_from_the_metrics() {
        let dir = std::env::temp_dir().join(format!("reproduce-metrics-{}", std::process::id()));
        fs::create_dir_all(&dir).expect("dir");
        assert_eq!(training_seconds(&dir), None, "no metrics.csv");
        let csv = "episode,return,steps,success,total_steps,steps_per_s\n\
                   1,-3,200,0,200,100\n2,-1,50,1,250,25\n3,0,10,1,260,nan\n";
        fs::write(dir.join(folder::METRICS), csv).expect("write");
        assert_eq!(training_seconds(&dir), Some(4.0)); // 200/100 + 50/25; the NaN row left out
        fs::write(dir.join(folder::METRICS), "episode,steps\n1,200\n").expect("write");
        assert_eq!(training_seconds(&dir), None, "no steps_per_s column");
        fs::remove_dir_all(&dir).expect("cleanup");
    }
}
