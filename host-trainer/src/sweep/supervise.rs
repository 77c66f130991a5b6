//! Supervising a sweep: the planned runs as `train` processes, at most `jobs` at once.
//!
//! Each child's stdout and stderr are appended to `OUT/sweep-logs/{run}.log` as it runs, so
//! nothing it printed is lost to a kill. A run that fails is recorded with its exit code and last
//! line, and the others go on.

use std::fs;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use indicatif::ProgressBar;

use super::plan::{Job, PlannedRun, Start};
use super::record::{exit_text, read_eval, EvalSummary, RunRecord, Status};
use crate::team;
use crate::Error;
use firmware_sim::files;

/// The folder of the children's logs, `{run}.log` each.
pub const LOGS: &str = "sweep-logs";
/// How the sweep's children are started and shown.
#[derive(Debug)]
pub struct Runner<'a> {
    /// The `host-trainer` binary (the running one).
    pub exe: PathBuf,
    /// Most runs at once.
    pub jobs: usize,
    /// Each run's `--threads` (the cores shared out between the runs at once).
    pub threads: usize,
    /// No progress bar.
    pub quiet: bool,
    /// A line on stdout for every run that ends, above the bar (failures get theirs on stderr
    /// either way).
    pub announce: bool,
    /// Ctrl-C presses so far (the caller's handler counts them).
    pub interrupts: &'a AtomicU32,
}

/// How long the supervisor sleeps between looks at its children: far below a run's length,
/// far above the cost of a look.
const POLL: Duration = Duration::from_millis(25);

/// A child in flight.
#[derive(Debug)]
struct Running {
    index: usize,
    child: Child,
    started: Instant,
    log: PathBuf,
    /// The log's length before this child wrote to it: its own lines start there.
    log_from: u64,
}

/// Runs the plan, `runner.jobs` at a time, and returns one record per run in plan order.
///
/// On Ctrl-C (a rise of `runner.interrupts`) no further run starts, the running children get
/// SIGINT (they checkpoint and exit 130; a terminal's Ctrl-C reaches them directly too, and
/// `train` takes the two deliveries as one press), and this returns once all have exited.
pub fn execute(plan: &[PlannedRun], runner: &Runner<'_>) -> Result<Vec<RunRecord>, Error> {
    let mut queue = (0..plan.len()).filter(|&i| plan[i].start != Start::Skip);
    for index in queue.clone() {
        let logs = logs_of(&plan[index].dir);
        fs::create_dir_all(&logs).map_err(|source| Error::Io { path: logs, source })?;
    }
    let mut sweep = Supervisor::new(plan, runner, queue.clone().count());
    let mut forwarded = 0;
    loop {
        let interrupts = runner.interrupts.load(Ordering::SeqCst);
        if interrupts > forwarded {
            forwarded = interrupts;
            sweep.running.iter().for_each(|r| signal(&r.child, "-INT"));
        }
        while interrupts == 0 && sweep.running.len() < runner.jobs {
            let Some(index) = queue.next() else { break };
            sweep.start(index);
        }
        if sweep.running.is_empty() {
            break;
        }
        sweep.reap(interrupts > 0);
        std::thread::sleep(POLL);
    }
    sweep.bar.finish_and_clear();
    Ok(sweep.records)
}

/// The sweep in progress: a record per run, the children in flight, the progress bar.
#[derive(Debug)]
struct Supervisor<'a> {
    plan: &'a [PlannedRun],
    runner: &'a Runner<'a>,
    records: Vec<RunRecord>,
    running: Vec<Running>,
    bar: ProgressBar,
}

impl<'a> Supervisor<'a> {
    /// Skipped runs are recorded at once (with their result); the bar counts the others.
    fn new(plan: &'a [PlannedRun], runner: &'a Runner<'a>, todo: usize) -> Self {
        let records = plan
            .iter()
            .map(|run| match run.start {
                Start::Skip => RunRecord {
                    eval: finished(run).ok().flatten(),
                    ..record_of(run, Status::Skipped)
                },
                _ => record_of(run, Status::Pending),
            })
            .collect();
        Supervisor {
            plan,
            runner,
            records,
            running: Vec::new(),
            bar: progress_bar(todo as u64, runner.quiet),
        }
    }

    /// A run that cannot start is a failed row like any other: giving up on the sweep here
    /// would leave the running children unwatched.
    fn start(&mut self, index: usize) {
        match spawn(self.runner, &self.plan[index], index) {
            Ok(child) => self.running.push(child),
            Err(e) => self.fail(index, format!("could not start: {e}")),
        }
        self.show();
    }

    /// Records the children that have exited.
    fn reap(&mut self, interrupted: bool) {
        let mut i = 0;
        while i < self.running.len() {
            match self.running[i].child.try_wait() {
                Ok(None) => i += 1,
                Ok(Some(status)) => {
                    let done = self.running.swap_remove(i);
                    let record = &mut self.records[done.index];
                    finish(record, &self.plan[done.index], &done, status, interrupted);
                    self.ended(done.index);
                }
                Err(e) => {
                    // Not expected for a child spawned here and not yet reaped; if it happens,
                    // that run is reported and the others are still watched.
                    let lost = self.running.swap_remove(i);
                    self.fail(lost.index, format!("cannot watch its process: {e}"));
                }
            }
        }
    }

    fn fail(&mut self, index: usize, why: String) {
        self.records[index].status = Status::Failed;
        self.records[index].last_line = Some(why);
        self.ended(index);
    }

    fn ended(&mut self, index: usize) {
        report(&self.bar, &self.records[index], &self.plan[index]);
        if self.runner.announce {
            announce(&self.bar, &self.records[index], &self.plan[index]);
        }
        self.bar.inc(1);
        self.show();
    }

    fn show(&self) {
        let failed = self.records.iter().filter(|r| r.status == Status::Failed);
        self.bar.set_message(format!(
            "{} failed, {} running",
            failed.count(),
            self.running.len()
        ));
    }
}

/// The folder of a run's log: `sweep-logs/` beside the run's folder (the sweep's `--out` for a
/// sweep; a grid of several sweeps has one per folder of runs).
pub fn logs_of(run_dir: &Path) -> PathBuf {
    run_dir.parent().unwrap_or(Path::new(".")).join(LOGS)
}

/// Starts one run's `train` child, its output appended to its log.
fn spawn(runner: &Runner<'_>, run: &PlannedRun, index: usize) -> Result<Running, Error> {
    let logs = logs_of(&run.dir);
    let log = logs.join(format!("{}.log", run.name()));
    // A fresh run starts from its own config file beside its log: the sweep's config with the
    // run's algorithm and seed, and the settings that algorithm does not read at their defaults
    // (`train` refuses those, and the sweep's config may hold them for its other algorithms).
    let config = logs.join(format!("{}.toml", run.name()));
    if run.start == Start::Fresh {
        files::write_atomic(&config, run.job.to_toml().as_bytes()).map_err(|source| Error::Io {
            path: config.clone(),
            source,
        })?;
    }
    let args = child_args(runner, run, &config);
    let io = |source| Error::Io {
        path: log.clone(),
        source,
    };
    // Appended, not written atomically: the child writes it while it runs, so a kill of the
    // sweep loses nothing, and a continued run adds below the earlier attempt's lines.
    let mut file = fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log)
        .map_err(io)?;
    writeln!(file, "--- host-trainer {}", args.join(" ")).map_err(io)?;
    let log_from = file.metadata().map_err(io)?.len();
    let child = Command::new(&runner.exe)
        .args(&args)
        // A pipe nobody writes to: the child's end sees end-of-file when this process dies,
        // however it dies, and the child (`--stop-when-stdin-closes`) then stops at a
        // checkpoint. The crate forbids `unsafe`, so no `prctl(PR_SET_PDEATHSIG)`.
        .stdin(Stdio::piped())
        .stdout(file.try_clone().map_err(io)?)
        .stderr(file)
        .spawn()
        .map_err(|source| Error::Io {
            path: runner.exe.clone(),
            source,
        })?;
    Ok(Running {
        index,
        child,
        started: Instant::now(),
        log,
        log_from,
    })
}

/// `train --config CONFIG --out OUT --race 1 --threads T --quiet --stop-when-stdin-closes`, or
/// `train --resume DIR --threads T --quiet --stop-when-stdin-closes`; `team` likewise, without
/// `--race` and `--threads` (a team trains on one thread). A sweep's run is one seed: the
/// sweep is the one that runs seeds side by side.
fn child_args(runner: &Runner<'_>, run: &PlannedRun, config: &Path) -> Vec<String> {
    let path = |p: &Path| p.to_string_lossy().into_owned();
    let command = match run.job {
        Job::Train(_) => "train",
        Job::Team(_) => "team",
    };
    let mut args = vec![command.to_string()];
    if run.start == Start::Resume {
        args.extend(["--resume".into(), path(&run.dir)]);
    } else {
        let out = run.dir.parent().unwrap_or(Path::new("."));
        args.extend(["--config".into(), path(config), "--out".into(), path(out)]);
        if let Job::Train(_) = run.job {
            args.extend(["--race".into(), "1".into()]);
        }
    }
    if let Job::Train(_) = run.job {
        args.extend(["--threads".into(), runner.threads.to_string()]);
    }
    args.extend(["--quiet".into(), "--stop-when-stdin-closes".into()]);
    args
}

/// Fills in a record from its child's exit.
fn finish(
    record: &mut RunRecord,
    run: &PlannedRun,
    done: &Running,
    status: ExitStatus,
    interrupted: bool,
) {
    use std::os::unix::process::ExitStatusExt;
    record.wall_seconds = Some(done.started.elapsed().as_secs_f64());
    record.exit_code = status.code();
    record.signal = status.signal();
    record.last_line = last_line(&done.log, done.log_from);
    // `train` exits 1 when its blob fails the gate: a finished run, judged (errors are 2).
    record.status = if matches!(status.code(), Some(0 | 1)) {
        match finished(run) {
            Ok(eval) => {
                record.eval = eval;
                Status::Finished
            }
            Err(e) => {
                record.last_line = Some(format!(
                    "exited {} but {e}",
                    status.code().unwrap_or_default()
                ));
                Status::Failed
            }
        }
    } else if interrupted && status.code() == Some(130) {
        Status::Interrupted
    } else {
        Status::Failed
    };
}

/// What a run that exited 0 left: a `train` run's evaluation (an error if it has none); a
/// team's exported players (an error if they are not all there).
fn finished(run: &PlannedRun) -> Result<Option<EvalSummary>, Error> {
    match &run.job {
        Job::Train(_) => read_eval(&run.dir).map(Some),
        Job::Team(config) if team::folder::exported(&run.dir, config) => Ok(None),
        Job::Team(_) => Err(Error::Io {
            path: run.dir.join(team::folder::PLAYERS),
            source: std::io::Error::new(
                std::io::ErrorKind::NotFound,
                "the team's players were not all exported",
            ),
        }),
    }
}

/// The last non-empty line of a log from byte `from` on.
fn last_line(log: &Path, from: u64) -> Option<String> {
    let bytes = fs::read(log).ok()?;
    let tail = bytes.get(usize::try_from(from).ok()?..)?;
    String::from_utf8_lossy(tail)
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .map(|l| l.trim().to_string())
}

/// A failure gets a line on stderr as it happens (above the bar); the summary has it too.
fn report(bar: &ProgressBar, record: &RunRecord, run: &PlannedRun) {
    if record.status == Status::Failed {
        bar.suspend(|| {
            eprintln!(
                "host-trainer: {} failed ({}): {}",
                run.name(),
                exit_text(record),
                record.last_line.as_deref().unwrap_or("no output")
            );
        });
    }
}

/// A finished run's line: where it is, how long it took, its headline numbers.
fn announce(bar: &ProgressBar, record: &RunRecord, run: &PlannedRun) {
    let (Status::Finished, Some(eval)) = (record.status, &record.eval) else {
        return;
    };
    let settled = eval
        .mean_error
        .map_or(String::new(), |e| format!(", settled error {e:.3}"));
    let line = format!(
        "finished {} in {:.0} s: success {:.2}{settled}, stuck {:.2}",
        run.dir.display(),
        record.wall_seconds.unwrap_or(0.0),
        eval.success_rate,
        eval.stuck_rate
    );
    bar.suspend(|| firmware_sim::outln!("{line}"));
}

/// `kill SIGNAL PID` through the `kill` command (the crate forbids `unsafe`, so no libc).
fn signal(child: &Child, which: &str) {
    let _ = Command::new("kill")
        .args([which, &child.id().to_string()])
        .stderr(Stdio::null())
        .status();
}

fn progress_bar(len: u64, quiet: bool) -> ProgressBar {
    let bar = crate::run::progress::bar(len, "runs", quiet);
    // Runs take minutes: tick so the elapsed time and the ETA move in between.
    bar.enable_steady_tick(Duration::from_secs(1));
    bar
}

fn record_of(run: &PlannedRun, status: Status) -> RunRecord {
    RunRecord {
        task: run.job.task(),
        algo: run.job.algo(),
        seed: run.job.seed(),
        status,
        wall_seconds: None,
        exit_code: None,
        signal: None,
        last_line: None,
        eval: None,
    }
}
