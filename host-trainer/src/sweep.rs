//! `host-trainer sweep`: one training run per (algo, seed), as parallel `train` processes.
//!
//! Why processes and not threads: a run is single-threaded and deterministic, and a child
//! process is exactly the run `train` would make alone (same blob bytes), with its own
//! Ctrl-C checkpoint, its own crash safety and its own exit code; a run that panics or is
//! killed takes no other run with it.
//!
//! A sweep is safe to re-run: the run folders are the only state. In order:
//! 1. [`plan`] looks at each run folder before anything starts: finished (it holds
//!    [`run_dir::EVAL`], the last file `train` writes) is skipped; started but unfinished (a
//!    killed sweep) is continued with `train --resume`; absent or empty is trained afresh. A
//!    folder whose recorded `config.toml` differs from what the sweep would run is an error.
//! 2. [`execute`] runs them, at most `jobs` at once; each child's stdout and stderr are appended
//!    to `OUT/sweep-logs/{run}.log` as it runs, so nothing it printed is lost to a kill. A run that
//!    fails is recorded with its exit code and last line, and the others go on.
//! 3. [`markdown`] and [`json`] summarise the runs: one row each, then per (task, algo) the mean
//!    and a 95 % Student-t interval over the finished seeds ([`crate::stats`]).

use std::fmt::Write as _;
use std::fs;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::str::FromStr;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use firmware_sim::files;
use indicatif::ProgressBar;
use serde::{Deserialize, Serialize};

use crate::run_dir;
use crate::stats::{self, MeanInterval};
use crate::train::{Algo, TrainConfig, Trainer};
use crate::Error;

/// The summary table, in the sweep's output folder.
pub const SUMMARY_MD: &str = "sweep.md";
/// The summary as JSON.
pub const SUMMARY_JSON: &str = "sweep.json";
/// The folder of the children's logs, `{run}.log` each.
pub const LOGS: &str = "sweep-logs";
/// The most runs one sweep may ask for: a seed range this long is a typo, not a plan.
pub const MAX_RUNS: usize = 10_000;

/// The seeds of `--seeds`: `0-4`, `3`, `0,2,5` or combinations like `0-2,7`; sorted, each
/// once.
///
/// ```
/// use host_trainer::sweep::Seeds;
/// let seeds: Seeds = "0-2,7,1".parse().unwrap();
/// assert_eq!(seeds.0, [0, 1, 2, 7]);
/// assert!("4-2".parse::<Seeds>().is_err());
/// assert!("x".parse::<Seeds>().is_err());
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Seeds(pub Vec<u64>);

impl FromStr for Seeds {
    type Err = String;

    fn from_str(text: &str) -> Result<Seeds, String> {
        let number = |s: &str| {
            s.trim()
                .parse::<u64>()
                .map_err(|_| format!("expected seeds like 0-4, 3 or 0,2,5, found {text:?}"))
        };
        let mut seeds = Vec::new();
        for part in text.split(',') {
            let (first, last) = match part.split_once('-') {
                Some((a, b)) => (number(a)?, number(b)?),
                None => (number(part)?, number(part)?),
            };
            if first > last {
                return Err(format!("the range {part} is empty ({first} > {last})"));
            }
            if last - first >= MAX_RUNS as u64 || seeds.len() > MAX_RUNS {
                return Err(format!("more than {MAX_RUNS} seeds in {text:?}"));
            }
            seeds.extend(first..=last);
        }
        seeds.sort_unstable();
        seeds.dedup();
        Ok(Seeds(seeds))
    }
}

/// How a planned run starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// No run in its folder yet: `train`.
    Fresh,
    /// Started and unfinished (a killed or failed sweep): `train --resume`.
    Resume,
    /// Finished (its `eval.json` exists): nothing to run.
    Skip,
}

/// One run of the sweep, before it runs.
#[derive(Clone, Debug)]
pub struct PlannedRun {
    /// The run's full configuration (the sweep's base with this algo and seed).
    pub config: TrainConfig,
    /// Its folder, `OUT/{task}__{algo}__{seed}`.
    pub dir: PathBuf,
    /// What to do with it.
    pub start: Start,
}

impl PlannedRun {
    /// The run's folder name.
    pub fn name(&self) -> String {
        self.config.run_name()
    }
}

/// Checks the settings and every run folder, and decides what each run does; writes nothing.
/// Every error a sweep can know of up front is found here, before any run starts: a config a
/// run would refuse, a missing output folder, a run folder of other settings.
pub fn plan(
    base: &TrainConfig,
    algos: &[Algo],
    seeds: &[u64],
    out: &Path,
) -> Result<Vec<PlannedRun>, Error> {
    if !out.is_dir() {
        return Err(Error::Io {
            path: out.to_path_buf(),
            source: std::io::Error::new(
                std::io::ErrorKind::NotFound,
                "output folder does not exist (create it first)",
            ),
        });
    }
    files::check_output(&out.join(SUMMARY_MD)).map_err(|source| Error::Io {
        path: out.to_path_buf(),
        source,
    })?;
    if algos.len() * seeds.len() > MAX_RUNS {
        return Err(Error::InvalidConfig {
            what: "--algo and --seeds".into(),
            expected: format!("at most {MAX_RUNS} runs"),
            found: (algos.len() * seeds.len()).to_string(),
        });
    }
    let mut runs = Vec::new();
    for &algo in algos {
        // Building the trainer runs every check `train` makes (ranges, shape, task, evaluation
        // count); the seed changes none of them, so one trainer per algorithm is enough.
        let mut config = base.clone();
        config.algo = algo;
        drop(Trainer::new(config.clone())?);
        for &seed in seeds {
            config.seed = seed;
            let dir = out.join(config.run_name());
            let start = start_of(&dir, &config)?;
            runs.push(PlannedRun {
                config: config.clone(),
                dir,
                start,
            });
        }
    }
    Ok(runs)
}

/// What a run folder's state asks for; an error if it holds a run of other settings.
fn start_of(dir: &Path, config: &TrainConfig) -> Result<Start, Error> {
    if run_dir::run_file_in(dir).is_none() {
        return Ok(Start::Fresh);
    }
    let recorded_path = dir.join(run_dir::CONFIG);
    if !recorded_path.exists() {
        return Err(Error::RunDiffers {
            path: dir.to_path_buf(),
            difference: format!("it holds run files but no {}", run_dir::CONFIG),
        });
    }
    let recorded = TrainConfig::from_file(&recorded_path)?;
    if recorded != *config {
        return Err(Error::RunDiffers {
            path: dir.to_path_buf(),
            difference: first_difference(&recorded, config),
        });
    }
    if dir.join(run_dir::EVAL).exists() {
        read_eval(dir)?; // a finished run whose result does not read is found now, not at the end
        Ok(Start::Skip)
    } else {
        Ok(Start::Resume)
    }
}

/// The first setting (as `section.key`) whose value differs, for the error message.
fn first_difference(recorded: &TrainConfig, wanted: &TrainConfig) -> String {
    let flat = |c: &TrainConfig| {
        let mut keys = Vec::new();
        if let Ok(table) = toml::Table::try_from(c) {
            flatten("", &toml::Value::Table(table), &mut keys);
        }
        keys
    };
    let (a, b) = (flat(recorded), flat(wanted));
    let value = |list: &[(String, String)], key: &str| {
        list.iter()
            .find(|(k, _)| k == key)
            .map_or_else(|| "unset".to_string(), |(_, v)| v.clone())
    };
    a.iter()
        .chain(&b)
        .map(|(key, _)| key)
        .find(|key| value(&a, key) != value(&b, key))
        .map_or_else(
            || "the recorded config differs".to_string(),
            |key| {
                format!(
                    "{key} = {} recorded, {} in the sweep",
                    value(&a, key),
                    value(&b, key)
                )
            },
        )
}

fn flatten(prefix: &str, value: &toml::Value, out: &mut Vec<(String, String)>) {
    match value {
        toml::Value::Table(table) => {
            for (key, v) in table {
                let key = if prefix.is_empty() {
                    key.clone()
                } else {
                    format!("{prefix}.{key}")
                };
                flatten(&key, v, out);
            }
        }
        other => out.push((prefix.to_string(), other.to_string())),
    }
}

/// The columns of a finished run's `eval.json` (firmware-sim's report) that the summary shows.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EvalSummary {
    /// Fraction of test starts that settled within 2 of the centre.
    pub success_rate: f64,
    /// Mean settled distance from the centre.
    pub mean_error: f64,
    /// Fraction flagged stuck at a margin.
    pub stuck_rate: f64,
    /// Fraction that came within 0.25 of the centre.
    pub near_pass_rate: f64,
    /// Fraction that held within 0.1 of the centre for 10 steps.
    pub strict_reach_rate: f64,
}

fn read_eval(dir: &Path) -> Result<EvalSummary, Error> {
    let path = dir.join(run_dir::EVAL);
    let text = fs::read_to_string(&path).map_err(|source| Error::Io {
        path: path.clone(),
        source,
    })?;
    serde_json::from_str(&text).map_err(|e| Error::ConfigFile {
        path,
        message: format!("not a firmware-sim report: {e}"),
    })
}

/// How a run of the sweep ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// Trained (or continued) to the end by this sweep.
    Finished,
    /// Already finished before this sweep; untouched.
    Skipped,
    /// Its process failed; the row says how.
    Failed,
    /// Stopped by Ctrl-C at a checkpoint; the next sweep continues it.
    Interrupted,
    /// Not started because the sweep was interrupted first.
    Pending,
}

/// One row of the summary.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// The task as the folder names it.
    pub task: String,
    /// The algorithm.
    pub algo: Algo,
    /// The seed.
    pub seed: u64,
    /// How it ended.
    pub status: Status,
    /// Wall-clock seconds of this sweep's process for it (none when skipped).
    pub wall_seconds: Option<f64>,
    /// The child's exit code (none if killed by a signal or not run).
    pub exit_code: Option<i32>,
    /// The signal that killed the child, if one did.
    pub signal: Option<i32>,
    /// The last line the child printed (its error, for a failed run).
    pub last_line: Option<String>,
    /// The run's evaluation (finished and skipped runs).
    pub eval: Option<EvalSummary>,
}

impl RunRecord {
    fn new(run: &PlannedRun, status: Status) -> RunRecord {
        RunRecord {
            task: run.config.task_name(),
            algo: run.config.algo,
            seed: run.config.seed,
            status,
            wall_seconds: None,
            exit_code: None,
            signal: None,
            last_line: None,
            eval: None,
        }
    }
}

/// How the sweep's children are started and shown.
#[derive(Debug)]
pub struct Runner<'a> {
    /// The `host-trainer` binary (the running one).
    pub exe: PathBuf,
    /// The `--config` file the fresh runs get, if any.
    pub config_file: Option<PathBuf>,
    /// The output folder.
    pub out: PathBuf,
    /// Most runs at once.
    pub jobs: usize,
    /// No progress bar.
    pub quiet: bool,
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
    let logs = runner.out.join(LOGS);
    fs::create_dir_all(&logs).map_err(|source| Error::Io {
        path: logs.clone(),
        source,
    })?;
    let mut queue = (0..plan.len()).filter(|&i| plan[i].start != Start::Skip);
    let mut sweep = Supervisor::new(plan, runner, logs, queue.clone().count());
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
    logs: PathBuf,
    records: Vec<RunRecord>,
    running: Vec<Running>,
    bar: ProgressBar,
}

impl<'a> Supervisor<'a> {
    /// Skipped runs are recorded at once (with their result); the bar counts the others.
    fn new(plan: &'a [PlannedRun], runner: &'a Runner<'a>, logs: PathBuf, todo: usize) -> Self {
        let records = plan
            .iter()
            .map(|run| match run.start {
                Start::Skip => RunRecord {
                    eval: read_eval(&run.dir).ok(),
                    ..RunRecord::new(run, Status::Skipped)
                },
                _ => RunRecord::new(run, Status::Pending),
            })
            .collect();
        Supervisor {
            plan,
            runner,
            logs,
            records,
            running: Vec::new(),
            bar: progress_bar(todo as u64, runner.quiet),
        }
    }

    /// A run that cannot start is a failed row like any other: giving up on the sweep here
    /// would leave the running children unwatched.
    fn start(&mut self, index: usize) {
        match spawn(self.runner, &self.plan[index], index, &self.logs) {
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

/// Starts one run's `train` child, its output appended to its log.
fn spawn(
    runner: &Runner<'_>,
    run: &PlannedRun,
    index: usize,
    logs: &Path,
) -> Result<Running, Error> {
    let args = child_args(runner, run);
    let log = logs.join(format!("{}.log", run.name()));
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
        .stdin(Stdio::null())
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

/// `train --config F --algo A --seed S --out OUT --quiet`, or `train --resume DIR --quiet`.
fn child_args(runner: &Runner<'_>, run: &PlannedRun) -> Vec<String> {
    let path = |p: &Path| p.to_string_lossy().into_owned();
    let mut args = vec!["train".to_string()];
    if run.start == Start::Resume {
        args.extend(["--resume".into(), path(&run.dir)]);
    } else {
        if let Some(config) = &runner.config_file {
            args.extend(["--config".into(), path(config)]);
        }
        args.extend([
            "--algo".into(),
            run.config.algo.to_string(),
            "--seed".into(),
            run.config.seed.to_string(),
            "--out".into(),
            path(&runner.out),
        ]);
    }
    args.push("--quiet".into());
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
    record.status = if status.success() {
        match read_eval(&run.dir) {
            Ok(eval) => {
                record.eval = Some(eval);
                Status::Finished
            }
            Err(e) => {
                record.last_line = Some(format!("exited 0 but {e}"));
                Status::Failed
            }
        }
    } else if interrupted && status.code() == Some(130) {
        Status::Interrupted
    } else {
        Status::Failed
    };
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

fn exit_text(record: &RunRecord) -> String {
    match (record.exit_code, record.signal) {
        (Some(code), _) => format!("exit {code}"),
        (None, Some(signal)) => format!("signal {signal}"),
        (None, None) => "not run".into(),
    }
}

/// `kill SIGNAL PID` through the `kill` command (the crate forbids `unsafe`, so no libc).
fn signal(child: &Child, which: &str) {
    let _ = Command::new("kill")
        .args([which, &child.id().to_string()])
        .stderr(Stdio::null())
        .status();
}

fn progress_bar(len: u64, quiet: bool) -> ProgressBar {
    let bar = crate::progress::bar(len, "runs", quiet);
    // Runs take minutes: tick so the elapsed time and the ETA move in between.
    bar.enable_steady_tick(Duration::from_secs(1));
    bar
}

/// A column of the summary: header, JSON key, value of a run, decimals.
struct Column {
    header: &'static str,
    key: &'static str,
    value: fn(&RunRecord) -> Option<f64>,
    decimals: usize,
}

/// Rates are shown in percent, as `train` and `eval` print them.
const COLUMNS: [Column; 6] = [
    Column {
        header: "wall s",
        key: "wall_seconds",
        value: |r| r.wall_seconds,
        decimals: 1,
    },
    Column {
        header: "success %",
        key: "success_pct",
        value: |r| r.eval.map(|e| 100.0 * e.success_rate),
        decimals: 1,
    },
    Column {
        header: "settled error",
        key: "mean_error",
        value: |r| r.eval.map(|e| e.mean_error),
        decimals: 3,
    },
    Column {
        header: "stuck at margin %",
        key: "stuck_pct",
        value: |r| r.eval.map(|e| 100.0 * e.stuck_rate),
        decimals: 1,
    },
    Column {
        header: "pass within 0.25 %",
        key: "near_pass_pct",
        value: |r| r.eval.map(|e| 100.0 * e.near_pass_rate),
        decimals: 1,
    },
    Column {
        header: "strict reach %",
        key: "strict_reach_pct",
        value: |r| r.eval.map(|e| 100.0 * e.strict_reach_rate),
        decimals: 1,
    },
];

/// The (task, algo) groups in first-seen order, each with its runs that have a result.
fn groups(records: &[RunRecord]) -> Vec<((String, Algo), Vec<&RunRecord>)> {
    let mut groups: Vec<((String, Algo), Vec<&RunRecord>)> = Vec::new();
    for r in records {
        let key = (r.task.clone(), r.algo);
        let at = match groups.iter().position(|(k, _)| *k == key) {
            Some(at) => at,
            None => {
                groups.push((key, Vec::new()));
                groups.len() - 1
            }
        };
        if r.eval.is_some() {
            groups[at].1.push(r);
        }
    }
    groups
}

fn column_interval(runs: &[&RunRecord], column: &Column) -> Option<MeanInterval> {
    let values: Vec<f64> = runs.iter().filter_map(|r| (column.value)(r)).collect();
    stats::mean_interval(&values)
}

/// The summary as a markdown table of runs, then a table of means with 95 % intervals.
pub fn markdown(records: &[RunRecord]) -> String {
    let headers: Vec<&str> = COLUMNS.iter().map(|c| c.header).collect();
    let mut md = String::from("## Runs\n\n");
    let _ = writeln!(
        md,
        "| task | algo | seed | status | {} | note |",
        headers.join(" | ")
    );
    let _ = writeln!(
        md,
        "|---|---|---:|---|{}---|",
        "---:|".repeat(COLUMNS.len())
    );
    for r in records {
        let cells: Vec<String> = COLUMNS
            .iter()
            .map(|c| (c.value)(r).map_or("-".into(), |v| format!("{v:.*}", c.decimals)))
            .collect();
        let note = match r.status {
            Status::Failed | Status::Interrupted => format!(
                "{}: {}",
                exit_text(r),
                r.last_line.as_deref().unwrap_or("no output")
            ),
            _ => String::new(),
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} |",
            r.task,
            r.algo,
            r.seed,
            status_text(r.status),
            cells.join(" | "),
            note.replace('|', "\\|")
        );
    }
    md.push_str("\n## Mean ± 95 % confidence interval over the finished seeds\n\n");
    md.push_str(
        "Student's t, two-sided, n − 1 degrees of freedom; one seed has no interval (n/a).\n\n",
    );
    let _ = writeln!(md, "| task | algo | n | {} |", headers.join(" | "));
    let _ = writeln!(md, "|---|---|---:|{}", "---:|".repeat(COLUMNS.len()));
    for ((task, algo), runs) in groups(records) {
        let cells: Vec<String> = COLUMNS
            .iter()
            .map(|c| match column_interval(&runs, c) {
                None => "-".into(),
                Some(m) => {
                    let half = m
                        .half_width
                        .map_or("n/a".into(), |h| format!("{h:.*}", c.decimals));
                    // Wall seconds exist only for runs this sweep ran, not for skipped ones.
                    let n = if m.n == runs.len() {
                        String::new()
                    } else {
                        format!(" (n={})", m.n)
                    };
                    format!("{:.*} ± {half}{n}", c.decimals, m.mean)
                }
            })
            .collect();
        let _ = writeln!(
            md,
            "| {task} | {algo} | {} | {} |",
            runs.len(),
            cells.join(" | ")
        );
    }
    md
}

fn status_text(status: Status) -> &'static str {
    match status {
        Status::Finished => "finished",
        Status::Skipped => "skipped",
        Status::Failed => "failed",
        Status::Interrupted => "interrupted",
        Status::Pending => "not started",
    }
}

/// One (task, algo) group's means and intervals in `sweep.json`.
#[derive(Debug, Serialize)]
struct GroupJson {
    task: String,
    algo: Algo,
    /// Runs with a result (finished or skipped).
    n: usize,
    /// Per column key: `{ "n": .., "mean": .., "half_width": .. }` (`half_width` null for
    /// n = 1; a column's n is below the group's for wall seconds, which skipped runs lack).
    columns: serde_json::Map<String, serde_json::Value>,
}

/// The summary as JSON: `{"runs": [...], "groups": [...], "interval": "..."}`.
pub fn json(records: &[RunRecord]) -> String {
    let groups: Vec<GroupJson> = groups(records)
        .into_iter()
        .map(|((task, algo), runs)| {
            let columns = COLUMNS
                .iter()
                .filter_map(|c| {
                    let m = column_interval(&runs, c)?;
                    let value =
                        serde_json::json!({ "n": m.n, "mean": m.mean, "half_width": m.half_width });
                    Some((c.key.to_string(), value))
                })
                .collect();
            GroupJson {
                task,
                algo,
                n: runs.len(),
                columns,
            }
        })
        .collect();
    let doc = serde_json::json!({
        "interval": "95 % two-sided Student's t over the finished seeds, df = n - 1",
        "runs": records,
        "groups": groups,
    });
    serde_json::to_string_pretty(&doc).unwrap_or_default() + "\n"
}

/// Writes `sweep.md` and `sweep.json` atomically into `out`.
pub fn write_summary(out: &Path, records: &[RunRecord]) -> Result<(), Error> {
    for (name, text) in [
        (SUMMARY_MD, markdown(records)),
        (SUMMARY_JSON, json(records)),
    ] {
        let path = out.join(name);
        files::write_atomic(&path, text.as_bytes()).map_err(|source| Error::Io { path, source })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeds_parse_ranges_lists_and_combinations() {
        let parse = |s: &str| s.parse::<Seeds>().map(|s| s.0);
        assert_eq!(parse("0-4"), Ok(vec![0, 1, 2, 3, 4]));
        assert_eq!(parse("3"), Ok(vec![3]));
        assert_eq!(parse("0,2,5"), Ok(vec![0, 2, 5]));
        assert_eq!(parse("0-2,7"), Ok(vec![0, 1, 2, 7]));
        assert_eq!(parse("5,1-2,2"), Ok(vec![1, 2, 5]));
        for bad in ["4-2", "x", "", "1-", "-3", "1,,2", "0-18446744073709551615"] {
            assert!(parse(bad).is_err(), "{bad:?} must be refused");
        }
    }

    #[test]
    fn the_first_differing_setting_is_named() {
        let a = TrainConfig::smoke(Algo::Dcp, 0);
        let mut b = a.clone();
        b.agent.batch = 32;
        assert_eq!(
            first_difference(&a, &b),
            "agent.batch = 16 recorded, 32 in the sweep"
        );
    }

    fn record(seed: u64, status: Status, success: Option<f64>) -> RunRecord {
        RunRecord {
            task: "nav-walls".into(),
            algo: Algo::Dcp,
            seed,
            status,
            wall_seconds: Some(1.0),
            exit_code: Some(if status == Status::Failed { 1 } else { 0 }),
            signal: None,
            last_line: (status == Status::Failed).then(|| "host-trainer: a | b".into()),
            eval: success.map(|s| EvalSummary {
                success_rate: s,
                mean_error: 1.0,
                stuck_rate: 0.0,
                near_pass_rate: 0.0,
                strict_reach_rate: 0.0,
            }),
        }
    }

    #[test]
    fn the_summary_averages_finished_seeds_only() {
        let records = [
            record(0, Status::Finished, Some(0.1)),
            record(1, Status::Skipped, Some(0.2)),
            record(2, Status::Finished, Some(0.3)),
            record(3, Status::Failed, None),
        ];
        let md = markdown(&records);
        assert!(md.contains("| nav-walls | dcp | 3 | failed |"), "{md}");
        assert!(md.contains("exit 1: host-trainer: a \\| b"), "{md}");
        // success 10, 20, 30 %: mean 20, s = 10, t(0.975, 2) · 10 / √3 = 24.8.
        assert!(
            md.contains("| nav-walls | dcp | 3 | 1.0 ± 0.0 | 20.0 ± 24.8 |"),
            "{md}"
        );
        let one = markdown(&records[..1]);
        assert!(one.contains("10.0 ± n/a"), "{one}");
        let doc: serde_json::Value = serde_json::from_str(&json(&records)).expect("json");
        assert_eq!(doc["runs"].as_array().map(Vec::len), Some(4));
        assert_eq!(doc["groups"][0]["n"], 3);
        let half = doc["groups"][0]["columns"]["success_pct"]["half_width"].as_f64();
        assert!(half.is_some_and(|h| (h - 24.842).abs() < 1e-3), "{half:?}");
    }
}
