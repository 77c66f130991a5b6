//! `host-trainer reproduce`: an experiment's grid, or one slice of it, run through `sweep`'s
//! supervisor, and its page built from the run folders.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::Ordering;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use firmware_sim::outln;
use host_trainer::reproduce::{
    self,
    grid::{self, Experiment, Grid, Slice},
};
use host_trainer::run::lock;
use host_trainer::sweep::plan::PlannedRun;
use host_trainer::sweep::record::Status;
use host_trainer::sweep::supervise;

use super::signals::{INTERRUPTED, INTERRUPTS};
use super::sweep::runner;

#[derive(Debug, Args)]
pub(crate) struct ReproduceArgs {
    /// The experiment: exp1 (navigation among walls: tables 1–3, figures 4–7) or exp2
    /// (badminton teams: tables 5–7, team scores, influence of T, heat maps).
    #[arg(value_enum)]
    experiment: Experiment,
    /// Output folder: the grid's runs, its page and figures go there (created if missing; its
    /// parent must exist).
    #[arg(long)]
    out: PathBuf,
    /// Seeds 0..N of every cell (at least 5 unless --quick).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..=1000))]
    seeds: u64,
    /// Most runs at once [default: the number of cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    jobs: Option<u32>,
    /// Run only part I of N (from 0) of the grid, e.g. a Slurm array task's
    /// $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT; the page is built by --merge.
    #[arg(long, conflicts_with = "merge")]
    slice: Option<Slice>,
    /// A few episodes per run: a test of the machinery, not a result.
    #[arg(long)]
    quick: bool,
    /// Run nothing: build the page from the run folders of every part, and say which runs
    /// are missing (exit 1 if any).
    #[arg(long)]
    merge: bool,
    /// Train the runs claims 2 and 3 gained after the grid instead of the grid's own
    /// (docs/results/reproduction.md, "Added seeds for claims 2 and 3": more seeds of their
    /// cells, into the same cell folders), then build the page; experiment 1 only.
    #[arg(long, conflicts_with_all = ["merge", "slice"])]
    added_seeds: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

/// Checks everything (the grid against the folder, every run folder) before the first run; runs
/// the slice; records the part; builds the page when the whole grid ran here.
pub(crate) fn reproduce_command(args: ReproduceArgs) -> Result<ExitCode> {
    let grid = Grid {
        experiment: args.experiment,
        seeds: args.seeds,
        quick: args.quick,
    };
    if !grid.quick && grid.seeds < grid::MIN_SEEDS {
        anyhow::bail!(
            "--seeds {}: a grid's cells need at least {} seeds (docs/design.md §7); --quick runs fewer",
            grid.seeds,
            grid::MIN_SEEDS
        );
    }
    // A file as --out is named as such, not as the system's "Not a directory" on OUT/grid.json.
    host_trainer::run::folder::check_output_folder(&args.out)?;
    if args.merge {
        reproduce::folder::check(&args.out, &grid)?;
        return merge(&args.out, &grid);
    }
    if args.added_seeds {
        return added_seeds(&args, &grid);
    }
    let slice = args.slice.unwrap_or(Slice::WHOLE);
    if let Some(found) = reproduce::folder::recorded(&args.out)? {
        if found != grid {
            reproduce::folder::check(&args.out, &grid)?;
        }
    }
    // Every check first (nothing is written if one fails), then the grid's record and the
    // part's lock, then the plan again: another process of this part may have moved its runs
    // on before the lock was ours.
    reproduce::plan(&args.out, &grid, slice)?;
    reproduce::folder::claim(&args.out, &grid)?;
    let busy = format!(
        "part {}/{} of this grid is already running there",
        slice.index, slice.count
    );
    let record = reproduce::Part::path(&args.out, slice);
    let Some(part) = run_part(&args.out, &record, slice.to_string(), &busy, &args, || {
        // Another part's runs may be this part's too (the whole grid beside `--slice 0/2`).
        reproduce::folder::refuse_overlapping_parts(&args.out, slice)?;
        reproduce::plan(&args.out, &grid, slice)
    })?
    else {
        return Ok(ExitCode::from(INTERRUPTED));
    };
    outln!("part {slice} of {}: {}", grid.describe(), part.tally());
    if slice != Slice::WHOLE {
        outln!(
            "when every part has run: host-trainer reproduce {} --out {} --merge",
            grid.describe(),
            args.out.display()
        );
        return Ok(if part.failed > 0 {
            ExitCode::FAILURE
        } else {
            ExitCode::SUCCESS
        });
    }
    let code = merge(&args.out, &grid)?;
    Ok(if part.failed > 0 {
        ExitCode::FAILURE
    } else {
        code
    })
}

/// `--added-seeds`: the grid recorded in the folder (or claimed for it), then the added runs
/// through the same planner, lock and supervisor as a part of the grid, under the part name
/// `added`; then the page.
fn added_seeds(args: &ReproduceArgs, grid: &Grid) -> Result<ExitCode> {
    let runs = grid.added_runs();
    if runs.is_empty() {
        anyhow::bail!(
            "--added-seeds: {} has no added seeds (they are claims 2 and 3's, of exp1)",
            grid.experiment
        );
    }
    if let Some(found) = reproduce::folder::recorded(&args.out)? {
        if found != *grid {
            reproduce::folder::check(&args.out, grid)?;
        }
    }
    reproduce::folder::plan_runs(&args.out, grid, &runs)?;
    reproduce::folder::claim(&args.out, grid)?;
    let record = reproduce::Part::added_path(&args.out);
    let busy = "the added seeds are already running there";
    let plan = || reproduce::folder::plan_runs(&args.out, grid, &runs);
    let Some(part) = run_part(
        &args.out,
        &record,
        reproduce::ADDED.into(),
        busy,
        args,
        plan,
    )?
    else {
        return Ok(ExitCode::from(INTERRUPTED));
    };
    outln!("the added seeds of {}: {}", grid.describe(), part.tally());
    let code = merge(&args.out, grid)?;
    Ok(if part.failed > 0 {
        ExitCode::FAILURE
    } else {
        code
    })
}

/// One part's runs: under the part's lock (one process per part: a second one would run the
/// same runs beside the first; `busy` says so), planned again by `plan` once the lock is ours
/// (another process of this part may have moved its runs on before), trained by the sweep's
/// supervisor, marked in their cells, and recorded as the part `slice` in `record`. `None` when
/// an interrupt stopped it (the stopped runs keep a checkpoint, and the message says how to go
/// on).
fn run_part(
    out: &Path,
    record: &Path,
    slice: String,
    busy: &str,
    args: &ReproduceArgs,
    plan: impl Fn() -> Result<Vec<PlannedRun>, host_trainer::Error>,
) -> Result<Option<reproduce::Part>> {
    let part_dir = record.with_extension("");
    std::fs::create_dir_all(&part_dir)
        .with_context(|| format!("cannot create {}", part_dir.display()))?;
    let _lock = lock::acquire(&part_dir).map_err(|e| match e {
        host_trainer::Error::Locked { holder, .. } => host_trainer::Error::PartRunning {
            path: out.to_path_buf(),
            running: format!("{busy} ({holder})"),
        },
        e => e,
    })?;
    let plan = plan()?;
    reproduce::folder::create_cells(&plan)?;
    let runner = runner(&plan, args.jobs, args.quiet, true)?;
    let started = Instant::now();
    let records = supervise::execute(&plan, &runner)?;
    reproduce::folder::mark(&plan, &records)?;
    let count = |s: Status| records.iter().filter(|r| r.status == s).count();
    let part = reproduce::Part {
        slice,
        commit: reproduce::COMMIT.into(),
        runs: plan.len(),
        finished: count(Status::Finished),
        skipped: count(Status::Skipped),
        failed: count(Status::Failed),
        wall_seconds: started.elapsed().as_secs_f64(),
        total_wall_seconds: 0.0,
    }
    .write(record.to_path_buf())?;
    if INTERRUPTS.load(Ordering::SeqCst) > 0 {
        eprintln!("host-trainer: reproduce interrupted; the stopped runs kept a checkpoint. Re-run the same command to continue (finished runs are skipped)");
        return Ok(None);
    }
    Ok(Some(part))
}

/// Builds the page; exit 1 when runs are missing.
pub(crate) fn merge(out: &Path, grid: &Grid) -> Result<ExitCode> {
    let built = reproduce::build_page(out, grid)?;
    let page = out.join(reproduce::page_file(grid));
    outln!(
        "wrote {} and {}/: {} runs, {} failed, {} missing",
        page.display(),
        out.join(reproduce::FIGURES).display(),
        built.runs,
        built.failed,
        built.missing
    );
    if built.missing > 0 {
        eprintln!(
            "host-trainer: {} of {} runs are missing (listed at the end of {}); run the missing parts, then merge again",
            built.missing,
            built.runs,
            page.display()
        );
        return Ok(ExitCode::FAILURE);
    }
    Ok(ExitCode::SUCCESS)
}
