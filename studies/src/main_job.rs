//! The main job's study (docs/results/main-job.md): its queue's folders read back, and the
//! page's results section written from them by the rules its protocol fixed.
//!
//! Each line of `experiments/main-job/plan.txt` ran `host-trainer train` into `RUNS/NAME/`,
//! timed by `experiments/main-job/run.sh`: `parts.txt` (one `PART EXIT ELAPSED USER SYSTEM` line
//! per part), `done` once `train` finished (exit 0 or 1: the gate's verdict), and the run's (or
//! race's) folder with its `eval.json` (and `race.json`).
//!
//! A run's folder stays on the machine that ran it; what the page needs of a finished line is
//! kept in the committed record (`experiments/main-job/record.tsv`, one tab-separated row per
//! line, with the commit of the binary and the machine), so the page can be rebuilt and the
//! queue continued on another machine. A line in the record is read from it; any other line
//! from its folder.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use anyhow::{bail, Context, Result};
use host_trainer::run::folder;
use host_trainer::run::race::RaceRecord;
use host_trainer::stats::binomial::{clopper_pearson, mcnemar_exact};
use host_trainer::sweep::record::read_report;
use serde::Deserialize;

/// A base seed *delivers* when its test success is at least this ...
pub const MIN_SUCCESS: f64 = 0.9;
/// ... and its mean settled error below this (the protocol's aim 1).
pub const MAX_ERROR: f64 = 0.5;
/// Aim 1: at least this many of the 20 pinwheel base seeds deliver.
pub const AIM_DELIVERED: usize = 19;
/// The pinwheel's base seeds.
pub const BASE_SEEDS: usize = 20;

/// What a line of the plan is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Kind {
    /// `train` as it ran before validation and races, for the wall-time ratio.
    Today,
    /// `train` with its defaults on the pinwheel.
    Pinwheel,
    /// On the generated rings layout.
    Rings,
    /// On the generated maze layout.
    Maze,
    /// Today's single run again, timed in the candidate stop rule's queue (the same machine).
    Single,
    /// `train` with the candidate stop rule (the protocol's amendment): rounds every 50
    /// episodes, the first round that meets the criteria ends the race.
    FirstRound,
    /// `train` with the second amendment's candidate: rounds every 10 episodes, the first round
    /// that meets the criteria ends the race.
    EveryTen,
}

impl Kind {
    /// The plan's word for it.
    fn name(self) -> &'static str {
        match self {
            Kind::Today => "today",
            Kind::Pinwheel => "pinwheel",
            Kind::Rings => "rings",
            Kind::Maze => "maze",
            Kind::Single => "single",
            Kind::FirstRound => "first-round",
            Kind::EveryTen => "every-10",
        }
    }

    fn of(name: &str) -> Result<(Kind, u64)> {
        let (kind, seed) = name
            .rsplit_once('-')
            .with_context(|| format!("plan line {name:?} is not KIND-SEED"))?;
        let kind = match kind {
            "today" => Kind::Today,
            "pinwheel" => Kind::Pinwheel,
            "rings" => Kind::Rings,
            "maze" => Kind::Maze,
            "single" => Kind::Single,
            "first-round" => Kind::FirstRound,
            "every-10" => Kind::EveryTen,
            other => bail!("plan line {name:?}: unknown kind {other:?}"),
        };
        Ok((
            kind,
            seed.parse()
                .with_context(|| format!("plan line {name:?}: seed"))?,
        ))
    }
}

/// One part of a line: `train`'s exit status and its times, in seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Part {
    /// Exit status.
    pub code: i32,
    /// Elapsed (wall) time.
    pub wall: f64,
    /// User plus system CPU time.
    pub cpu: f64,
}

/// The test report of the policy a line handed over.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Test {
    /// Success rate on the 100 test starts.
    pub success: f64,
    /// Mean settled error.
    pub error: f64,
    /// Stuck-at-margin rate.
    pub stuck: f64,
    /// The gate's verdict.
    pub passed: bool,
}

impl Test {
    /// Whether the base seed delivers (aim 1's rule).
    pub fn delivers(&self) -> bool {
        self.success >= MIN_SUCCESS && self.error < MAX_ERROR
    }
}

/// How a race ended, from its `race.json`.
#[derive(Clone, Debug, PartialEq)]
pub struct Race {
    /// The winner's index and seed.
    pub winner: (usize, u64),
    /// The race's last episode (the most any racer trained).
    pub ended_at: usize,
    /// Whether a racer's validation ended the race (else every budget was used).
    pub stopped_early: bool,
    /// The mean settled error of the validation round whose policy the winner handed over
    /// (`None` where the record does not have it).
    pub kept_error: Option<f64>,
}

/// One line of the plan, as far as it has run.
#[derive(Clone, Debug, PartialEq)]
pub struct Line {
    /// Its name in the plan.
    pub name: String,
    /// What it is.
    pub kind: Kind,
    /// Its (base) seed.
    pub seed: u64,
    /// Its parts so far.
    pub parts: Vec<Part>,
    /// `train` finished (with the gate's verdict).
    pub done: bool,
    /// The test report, once done.
    pub test: Option<Test>,
    /// The race, for a line that raced.
    pub race: Option<Race>,
    /// Where a finished line came from: the commit of the binary and the machine, for a line
    /// of the record; `None` for one read from the queue's folder (the page's `--commit` and
    /// `--cpu` name those).
    pub origin: Option<(String, String)>,
}

impl Line {
    /// Wall time over its parts.
    pub fn wall(&self) -> f64 {
        self.parts.iter().fold(0.0, |t, p| t + p.wall)
    }

    /// CPU time over its parts.
    pub fn cpu(&self) -> f64 {
        self.parts.iter().fold(0.0, |t, p| t + p.cpu)
    }

    /// The wall, CPU and parts cells of its row (`–` before it has run).
    fn time_cells(&self) -> String {
        if self.parts.is_empty() {
            return "– | – | 0".to_string();
        }
        format!(
            "{:.0} | {:.0} | {}",
            self.wall(),
            self.cpu(),
            self.parts.len()
        )
    }
}

/// The test's figures of a finished line (`eval.json`, firmware-sim's report).
#[derive(Deserialize)]
struct Eval {
    success_rate: f64,
    mean_error: f64,
    stuck_rate: f64,
    pass: Pass,
}

#[derive(Deserialize)]
struct Pass {
    passed: bool,
}

/// Reads every line of `plan` (in its order): from `record` (the committed rows, as
/// [`read_record`] gives them) where it has the line, else from its folder in `runs`; a line
/// that has not started has no parts.
pub fn load(plan: &Path, runs: &Path, record: &BTreeMap<String, Line>) -> Result<Vec<Line>> {
    let text = std::fs::read_to_string(plan).with_context(|| format!("{}", plan.display()))?;
    let mut lines = Vec::new();
    for row in text.lines() {
        let row = row.trim();
        if row.is_empty() || row.starts_with('#') {
            continue;
        }
        let name = row.split_whitespace().next().unwrap_or_default();
        let (kind, seed) = Kind::of(name)?;
        match record.get(name) {
            Some(line) => lines.push(line.clone()),
            None => lines.push(load_line(&runs.join(name), name, kind, seed)?),
        }
    }
    Ok(lines)
}

/// The record's columns, in order.
const RECORD_COLUMNS: [&str; 15] = [
    "name",
    "commit",
    "machine",
    "parts",
    "wall_s",
    "cpu_s",
    "success",
    "settled_error",
    "stuck",
    "gate",
    "winner",
    "winner_seed",
    "ended_at",
    "ended_by",
    "kept_validation_error",
];

/// The record's finished lines by name (an absent file is an empty record). `#` starts a
/// comment line.
pub fn read_record(path: &Path) -> Result<BTreeMap<String, Line>> {
    let text = match std::fs::read_to_string(path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(BTreeMap::new()),
        Err(e) => return Err(e).with_context(|| format!("cannot read {}", path.display())),
    };
    let mut lines = BTreeMap::new();
    for (i, row) in text.lines().enumerate() {
        if row.trim().is_empty() || row.starts_with('#') {
            continue;
        }
        let at = || format!("{} line {}", path.display(), i + 1);
        let f: Vec<&str> = row.split('\t').collect();
        if f.len() != RECORD_COLUMNS.len() {
            bail!(
                "{}: expected {} tab-separated columns ({}), found {}",
                at(),
                RECORD_COLUMNS.len(),
                RECORD_COLUMNS.join(", "),
                f.len()
            );
        }
        let num = |k: usize| -> Result<f64> {
            f[k].parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .with_context(|| {
                    format!("{}: {} {:?} is not a number", at(), RECORD_COLUMNS[k], f[k])
                })
        };
        let (kind, seed) = Kind::of(f[0]).with_context(at)?;
        let parts = num(3)? as usize;
        if parts == 0 {
            bail!("{}: a finished line has at least one part", at());
        }
        let (wall, cpu) = (num(4)?, num(5)?);
        // The record keeps the sums; the first part carries them, the others are counted.
        let mut all = vec![Part { code: 0, wall, cpu }];
        all.extend((1..parts).map(|_| Part {
            code: 0,
            wall: 0.0,
            cpu: 0.0,
        }));
        let passed = match f[9] {
            "PASS" => true,
            "FAIL" => false,
            other => bail!("{}: gate {other:?} is neither PASS nor FAIL", at()),
        };
        let race = match f[10] {
            "-" => None,
            w => Some(Race {
                winner: (
                    w.parse()
                        .with_context(|| format!("{}: winner {w:?}", at()))?,
                    f[11]
                        .parse()
                        .with_context(|| format!("{}: winner_seed", at()))?,
                ),
                ended_at: f[12]
                    .parse()
                    .with_context(|| format!("{}: ended_at", at()))?,
                stopped_early: match f[13] {
                    "validation" => true,
                    "budget" => false,
                    other => bail!(
                        "{}: ended_by {other:?} is neither validation nor budget",
                        at()
                    ),
                },
                kept_error: match f[14] {
                    "-" => None,
                    _ => Some(num(14)?),
                },
            }),
        };
        let line = Line {
            name: f[0].to_string(),
            kind,
            seed,
            parts: all,
            done: true,
            test: Some(Test {
                success: num(6)?,
                error: num(7)?,
                stuck: num(8)?,
                passed,
            }),
            race,
            origin: Some((f[1].to_string(), f[2].to_string())),
        };
        if lines.insert(line.name.clone(), line).is_some() {
            bail!("{}: {} is in the record twice", at(), f[0]);
        }
    }
    Ok(lines)
}

/// The record's row of a finished line (`None` for one not finished), with the commit and
/// machine it ran on; figures at the page's precision or finer.
pub fn record_row(line: &Line, commit: &str, machine: &str) -> Option<String> {
    let t = line.test.filter(|_| line.done)?;
    let (winner, seed, ended, by, kept) = match &line.race {
        Some(r) => (
            r.winner.0.to_string(),
            r.winner.1.to_string(),
            r.ended_at.to_string(),
            if r.stopped_early {
                "validation"
            } else {
                "budget"
            }
            .to_string(),
            r.kept_error.map_or("-".into(), |e| format!("{e:.6}")),
        ),
        None => ("-".into(), "-".into(), "-".into(), "-".into(), "-".into()),
    };
    Some(
        [
            line.name.clone(),
            commit.to_string(),
            machine.to_string(),
            line.parts.len().to_string(),
            format!("{:.2}", line.wall()),
            format!("{:.2}", line.cpu()),
            format!("{:.2}", t.success),
            format!("{:.6}", t.error),
            format!("{:.2}", t.stuck),
            if t.passed { "PASS" } else { "FAIL" }.to_string(),
            winner,
            seed,
            ended,
            by,
            kept,
        ]
        .join("\t"),
    )
}

fn load_line(dir: &Path, name: &str, kind: Kind, seed: u64) -> Result<Line> {
    let mut line = Line {
        name: name.to_string(),
        kind,
        seed,
        parts: Vec::new(),
        done: dir.join("done").is_file(),
        test: None,
        race: None,
        origin: None,
    };
    if let Ok(parts) = std::fs::read_to_string(dir.join("parts.txt")) {
        for p in parts.lines().filter(|l| !l.trim().is_empty()) {
            let f: Vec<&str> = p.split_whitespace().collect();
            let num = |i: usize| -> Result<f64> {
                f.get(i)
                    .with_context(|| format!("{name}: parts.txt line {p:?}"))?
                    .parse::<f64>()
                    .with_context(|| format!("{name}: parts.txt line {p:?}"))
            };
            line.parts.push(Part {
                code: num(1)? as i32,
                wall: num(2)?,
                cpu: num(3)? + num(4)?,
            });
        }
    }
    if !line.done {
        return Ok(line);
    }
    let run = std::fs::read_dir(dir)
        .with_context(|| format!("{}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| p.is_dir())
        .with_context(|| format!("{name}: done but no run folder"))?;
    let eval: Eval = read_report(&run).with_context(|| format!("{name}: the test"))?;
    line.test = Some(Test {
        success: eval.success_rate,
        error: eval.mean_error,
        stuck: eval.stuck_rate,
        passed: eval.pass.passed,
    });
    if run.join(folder::RACE).is_file() {
        let race = RaceRecord::read(&run).with_context(|| format!("{name}: the race"))?;
        let (w, winner) = race
            .winner
            .zip(race.winner_record())
            .with_context(|| format!("{name}: a finished race without a winner"))?;
        line.race = Some(Race {
            winner: (w, winner.seed),
            ended_at: race.racers.iter().map(|r| r.episodes).max().unwrap_or(0),
            stopped_early: race.why.contains("was the first whose validation"),
            kept_error: winner.kept_error(),
        });
    }
    Ok(line)
}

/// One row of the margin study's record, as its `A0` (DCP's defaults) rows give them.
#[derive(Deserialize)]
struct RecordRow {
    arm: String,
    task: String,
    seed: u64,
    success: f64,
    settled_error: f64,
    stuck: f64,
}

/// The margin study's `A0` test figures on the pinwheel, by seed (today's single run: the same
/// training bytes).
pub fn today_rows(records: &[&Path]) -> Result<BTreeMap<u64, Test>> {
    let mut rows = BTreeMap::new();
    for path in records {
        let text = std::fs::read_to_string(path).with_context(|| format!("{}", path.display()))?;
        for l in text.lines().filter(|l| !l.trim().is_empty()) {
            let r: RecordRow =
                serde_json::from_str(l).with_context(|| format!("{}: {l}", path.display()))?;
            if r.arm == "A0" && r.task == "nav-walls" {
                rows.insert(
                    r.seed,
                    Test {
                        success: r.success,
                        error: r.settled_error,
                        stuck: r.stuck,
                        passed: r.success >= 0.8 && r.stuck <= 0.2,
                    },
                );
            }
        }
    }
    Ok(rows)
}

/// Seeds as runs of consecutive numbers.
///
/// ```
/// assert_eq!(studies::main_job::seed_ranges(&[0, 1, 2, 3, 5, 7, 8]), "0–3, 5, 7–8");
/// assert_eq!(studies::main_job::seed_ranges(&[4]), "4");
/// ```
pub fn seed_ranges(seeds: &[u64]) -> String {
    let mut v = seeds.to_vec();
    v.sort_unstable();
    v.dedup();
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    while i < v.len() {
        let mut j = i;
        while j + 1 < v.len() && v[j + 1] == v[j] + 1 {
            j += 1;
        }
        out.push(if i == j {
            v[i].to_string()
        } else {
            format!("{}–{}", v[i], v[j])
        });
        i = j + 1;
    }
    out.join(", ")
}

/// The median of `xs` (the mean of the middle two for an even count); `None` when empty.
///
/// ```
/// assert_eq!(studies::main_job::median(&[3.0, 1.0, 2.0]), Some(2.0));
/// assert_eq!(studies::main_job::median(&[4.0, 1.0, 2.0, 3.0]), Some(2.5));
/// assert_eq!(studies::main_job::median(&[]), None);
/// ```
pub fn median(xs: &[f64]) -> Option<f64> {
    let mut v = xs.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(v[n / 2]),
        _ => Some((v[n / 2 - 1] + v[n / 2]) / 2.0),
    }
}

/// The least and the greatest of `xs`; `None` when empty.
///
/// ```
/// assert_eq!(studies::main_job::span(&[3.0, 1.0, 2.0]), Some((1.0, 3.0)));
/// assert_eq!(studies::main_job::span(&[]), None);
/// ```
pub fn span(xs: &[f64]) -> Option<(f64, f64)> {
    let first = *xs.first()?;
    Some(
        xs.iter()
            .fold((first, first), |(lo, hi), &x| (lo.min(x), hi.max(x))),
    )
}

/// Aim 1's sensitivity: the fewest base seeds whose verdict must change to flip the aim's.
///
/// ```
/// use studies::main_job::flips;
/// assert_eq!(flips(20), 2); // 20 deliver: two must fail to fall below 19
/// assert_eq!(flips(19), 1);
/// assert_eq!(flips(16), 3); // three more must deliver
/// ```
pub fn flips(delivered: usize) -> usize {
    if delivered >= AIM_DELIVERED {
        delivered + 1 - AIM_DELIVERED
    } else {
        AIM_DELIVERED - delivered
    }
}

fn yes(b: bool) -> &'static str {
    if b {
        "yes"
    } else {
        "no"
    }
}

/// Which lines a set of aims judges, and the single runs it times them against.
struct Judged {
    /// The lines judged.
    kind: Kind,
    /// The single runs of the wall-time ratio.
    baseline: Kind,
    /// The heading of the aims' section.
    heading: &'static str,
    /// How the text names the judged lines.
    label: &'static str,
    /// How it names the single runs.
    baseline_label: &'static str,
    /// What an amendment adds: its own section and single runs, and aim 2 taken per half.
    amendment: Option<Amendment>,
}

/// An amendment's candidate: judged in a section of its own, aim 2 per half of its queue, each
/// line against its own half's single run (the first amendment's note: its halves ran on two
/// machines), rather than as a ratio of medians.
struct Amendment {
    /// The section's heading.
    title: &'static str,
    /// The seeds of the `single` lines that time the two halves (base seeds 0–9, then 10–19).
    singles: [u64; 2],
}

/// The protocol's aims: `train`'s defaults on the pinwheel against today's single run.
const DEFAULTS: Judged = Judged {
    kind: Kind::Pinwheel,
    baseline: Kind::Today,
    heading: "### The aims",
    label: "pinwheel",
    baseline_label: "today's single run",
    amendment: None,
};

/// The amendment's aims: the candidate stop rule against today's single run timed in its queue.
const CANDIDATE: Judged = Judged {
    kind: Kind::FirstRound,
    baseline: Kind::Single,
    heading: "#### Its aims",
    label: "first-round",
    baseline_label: "today's single run in the same queue",
    amendment: Some(Amendment {
        title: "The amendment's candidate: the first round that meets the criteria, rounds every 50 episodes",
        singles: [0, 1],
    }),
};

/// The second amendment's aims: rounds every 10 episodes, against today's single run timed in
/// its queue (`single-2`, `single-3`).
const SECOND: Judged = Judged {
    kind: Kind::EveryTen,
    baseline: Kind::Single,
    heading: "#### Its aims",
    label: "every-10",
    baseline_label: "today's single run in the same queue",
    amendment: Some(Amendment {
        title: "The second amendment's candidate: the first round that meets the criteria, rounds every 10 episodes",
        singles: [2, 3],
    }),
};

/// The results section: every line's row, then the aims judged by the protocol's rules (only
/// once all their lines are in).
pub fn render(lines: &[Line], today: &BTreeMap<u64, Test>, commit: &str, cpu: &str) -> String {
    let mut out = String::new();
    let of = |k: Kind| lines.iter().filter(move |l| l.kind == k);
    let done = |k: Kind| of(k).filter(|l| l.done).count();
    // Which binary and machine each line that ran ran on, in the order they first appear.
    type Seeds = BTreeMap<Kind, Vec<u64>>;
    let mut origins: Vec<((String, String), Seeds)> = Vec::new();
    for l in lines.iter().filter(|l| !l.parts.is_empty()) {
        let o = l
            .origin
            .clone()
            .unwrap_or_else(|| (commit.to_string(), cpu.to_string()));
        let at = match origins.iter().position(|(k, _)| *k == o) {
            Some(at) => at,
            None => {
                origins.push((o, BTreeMap::new()));
                origins.len() - 1
            }
        };
        origins[at].1.entry(l.kind).or_default().push(l.seed);
    }
    let measured: Vec<String> = origins
        .iter()
        .map(|((c, m), kinds)| {
            let lines: Vec<String> = kinds
                .iter()
                .map(|(k, seeds)| format!("{} {}", k.name(), seed_ranges(seeds)))
                .collect();
            format!("the binary of commit {c} on {m} ({})", lines.join("; "))
        })
        .collect();
    // The amendment's lines are counted once the plan has them.
    let amended: String = [Kind::FirstRound, Kind::EveryTen, Kind::Single]
        .into_iter()
        .filter(|&k| of(k).count() > 0)
        .map(|k| format!(", {} {} of {}", k.name(), done(k), of(k).count()))
        .collect();
    let _ = writeln!(
        out,
        "Measured with {}. Lines in: pinwheel {} of {}, today {} of {}, rings {} of {}, maze {} of {}{amended}.\n",
        if measured.is_empty() { "nothing yet".to_string() } else { measured.join("; ") },
        done(Kind::Pinwheel),
        of(Kind::Pinwheel).count(),
        done(Kind::Today),
        of(Kind::Today).count(),
        done(Kind::Rings),
        of(Kind::Rings).count(),
        done(Kind::Maze),
        of(Kind::Maze).count(),
    );
    let _ = writeln!(out, "### The pinwheel, base seeds 0–19\n");
    let _ = writeln!(out, "| base seed | winner (racer, seed) | race ended at episode | ended by | test success | settled error | stuck | delivers | gate | wall s | CPU s | parts | today (A0): success, error, delivers |");
    let _ = writeln!(
        out,
        "|---:|---|---:|---|---:|---:|---:|---|---|---:|---:|---:|---|"
    );
    for l in of(Kind::Pinwheel) {
        let t0 = today.get(&l.seed).map_or_else(
            || "–".to_string(),
            |t| format!("{:.2}, {:.3}, {}", t.success, t.error, yes(t.delivers())),
        );
        let _ = writeln!(out, "{} | {t0} |", row(l));
    }
    let _ = writeln!(out, "\n### Today's single run, for the wall-time ratio\n");
    single_runs(&mut out, of(Kind::Today), today);
    aims(&mut out, lines, today, cpu, &DEFAULTS);
    for j in [&CANDIDATE, &SECOND] {
        if let (Some(a), true) = (&j.amendment, of(j.kind).count() > 0) {
            candidate(&mut out, lines, today, cpu, j, a);
        }
    }
    for (kind, title) in [
        (Kind::Rings, "rings-1-seed12"),
        (Kind::Maze, "maze-1-seed12"),
    ] {
        let _ = writeln!(out, "\n### {title} (reported, not judged)\n");
        let _ = writeln!(out, "| base seed | winner (racer, seed) | race ended at episode | ended by | test success | settled error | stuck | delivers | gate | wall s | CPU s | parts |");
        let _ = writeln!(
            out,
            "|---:|---|---:|---|---:|---:|---:|---|---|---:|---:|---:|"
        );
        let mut any = false;
        for l in of(kind).filter(|l| !l.parts.is_empty()) {
            any = true;
            let _ = writeln!(out, "{} |", row(l));
        }
        if !any {
            let _ = writeln!(out, "| no line has started | | | | | | | | | | | |");
        }
    }
    out
}

/// The table of single runs (today's, or the amendment's `single` lines): the test figures,
/// whether they are the margin study's A0 row (the same training bytes), and the times.
fn single_runs<'a>(
    out: &mut String,
    lines: impl Iterator<Item = &'a Line>,
    today: &BTreeMap<u64, Test>,
) {
    let _ = writeln!(out, "| seed | test success | settled error | stuck | the margin study's A0 row | wall s | CPU s | parts |");
    let _ = writeln!(out, "|---:|---:|---:|---:|---|---:|---:|---:|");
    for l in lines {
        let (figures, same) = match (&l.test, today.get(&l.seed)) {
            (Some(t), row) => (
                format!("{:.2} | {:.3} | {:.2}", t.success, t.error, t.stuck),
                match row {
                    Some(r) => {
                        let same = (t.success - r.success).abs() < 0.005
                            && (t.error - r.error).abs() < 0.0005
                            && (t.stuck - r.stuck).abs() < 0.005;
                        if same { "the same" } else { "differs" }.to_string()
                    }
                    None => "–".to_string(),
                },
            ),
            (None, _) => (
                "in progress or not started | | ".to_string(),
                "–".to_string(),
            ),
        };
        let _ = writeln!(
            out,
            "| {} | {figures} | {same} | {} |",
            l.seed,
            l.time_cells()
        );
    }
}

/// The amendment's section: the candidate stop rule's rows beside the defaults' line of the
/// same base seed (whose racers trained the same bytes up to the earlier stop), its single
/// runs, its aims, and the adoption rule's decision.
fn candidate(
    out: &mut String,
    lines: &[Line],
    today: &BTreeMap<u64, Test>,
    cpu: &str,
    j: &Judged,
    a: &Amendment,
) {
    let of = |k: Kind| lines.iter().filter(move |l| l.kind == k);
    // The second amendment's rows also show the first candidate's end and the validation
    // round the winner's policy came from (its protocol asks for both).
    let second = j.kind == Kind::EveryTen;
    let _ = writeln!(out, "\n### {}\n", a.title);
    let _ = writeln!(
        out,
        "| base seed | winner (racer, seed) | race ended at episode | ended by | test success | settled error | stuck | delivers | gate | wall s | CPU s | parts | the defaults' line: ended at, delivers |{}",
        if second { " the first candidate's line: ended at | the kept round's validation settled error |" } else { "" }
    );
    let _ = writeln!(
        out,
        "|---:|---|---:|---|---:|---:|---:|---|---|---:|---:|---:|---|{}",
        if second { "---:|---:|" } else { "" }
    );
    for l in of(j.kind) {
        let defaults = of(Kind::Pinwheel)
            .find(|d| d.seed == l.seed && d.done)
            .map_or_else(
                || "–".to_string(),
                |d| {
                    let ended = d
                        .race
                        .as_ref()
                        .map_or("–".into(), |r| r.ended_at.to_string());
                    let delivers = d.test.map_or("–", |t| yes(t.delivers()));
                    format!("{ended}, {delivers}")
                },
            );
        let extra = if second {
            let first = of(Kind::FirstRound)
                .find(|d| d.seed == l.seed && d.done)
                .and_then(|d| d.race.as_ref())
                .map_or("–".to_string(), |r| r.ended_at.to_string());
            let kept = l
                .race
                .as_ref()
                .and_then(|r| r.kept_error)
                .map_or("–".to_string(), |e| format!("{e:.3}"));
            format!(" {first} | {kept} |")
        } else {
            String::new()
        };
        let _ = writeln!(out, "{} | {defaults} |{extra}", row(l));
    }
    let _ = writeln!(out, "\n#### Today's single run, timed in the same queue\n");
    single_runs(
        out,
        of(Kind::Single).filter(|l| a.singles.contains(&l.seed)),
        today,
    );
    let (delivered, fast) = aims(out, lines, today, cpu, j);
    let _ = match (delivered, fast) {
        (Some(true), Some(true)) => writeln!(
            out,
            "\nBy the amendment's rule the candidate is **adopted**: both aims are met."
        ),
        (Some(_), Some(_)) => writeln!(
            out,
            "\nBy the amendment's rule the candidate is **not adopted**: `train`'s defaults stay as they are."
        ),
        _ => writeln!(
            out,
            "\nNot decided yet: the amendment's rule decides once every line of the candidate and of its single runs is in."
        ),
    };
}

/// A race line's table cells, without the closing bar.
fn row(l: &Line) -> String {
    let (winner, ended, by) = match &l.race {
        Some(r) => (
            format!("{}, {}", r.winner.0, r.winner.1),
            r.ended_at.to_string(),
            if r.stopped_early {
                "validation"
            } else {
                "budget"
            }
            .to_string(),
        ),
        None => ("–".into(), "–".into(), "–".into()),
    };
    let test = match &l.test {
        Some(t) => format!(
            "{:.2} | {:.3} | {:.2} | {} | {}",
            t.success,
            t.error,
            t.stuck,
            yes(t.delivers()),
            if t.passed { "PASS" } else { "FAIL" }
        ),
        None if l.parts.is_empty() => "not started | | | | ".to_string(),
        None => "in progress | | | | ".to_string(),
    };
    format!(
        "| {} | {winner} | {ended} | {by} | {test} | {}",
        l.seed,
        l.time_cells()
    )
}

/// Aims 1 and 2 for the lines `j` names, with their verdicts (`None` until all their lines
/// are in). `cpu` names the machine of the lines read from the queue's folder.
fn aims(
    out: &mut String,
    lines: &[Line],
    today: &BTreeMap<u64, Test>,
    cpu: &str,
    j: &Judged,
) -> (Option<bool>, Option<bool>) {
    let judged: Vec<&Line> = lines.iter().filter(|l| l.kind == j.kind).collect();
    let finished: Vec<&Line> = judged.iter().copied().filter(|l| l.done).collect();
    let delivered = finished
        .iter()
        .filter(|l| l.test.is_some_and(|t| t.delivers()))
        .count();
    let _ = writeln!(out, "\n{}\n", j.heading);
    let n = finished.len();
    if n == 0 {
        let _ = writeln!(out, "Not judged yet: no {} base seed is in.", j.label);
        return (None, None);
    }
    let (lo, hi) = clopper_pearson(delivered as u64, n.max(1) as u64, 0.95);
    let today_in: Vec<&Test> = finished.iter().filter_map(|l| today.get(&l.seed)).collect();
    let today_delivered = today_in.iter().filter(|t| t.delivers()).count();
    // McNemar's discordant pairs: b = delivers now, not today; c = the other way.
    let (mut b, mut c) = (0u64, 0u64);
    for l in &finished {
        if let (Some(t), Some(t0)) = (l.test, today.get(&l.seed)) {
            match (t.delivers(), t0.delivers()) {
                (true, false) => b += 1,
                (false, true) => c += 1,
                _ => {}
            }
        }
    }
    let _ = writeln!(
        out,
        "**1. Delivered policies.** {delivered} of the {n} {} base seeds in deliver (95 % exact interval of the rate {lo:.2}–{hi:.2}); today's single run delivers on {today_delivered} of the same {} seeds (the margin study's A0 rows). Pairs by base seed: {b} deliver now and not today, {c} the other way; exact McNemar p = {:.3}.",
        j.label,
        today_in.len(),
        mcnemar_exact(b, c),
    );
    let mut verdicts = (None, None);
    if n == BASE_SEEDS {
        let met = delivered >= AIM_DELIVERED;
        verdicts.0 = Some(met);
        let _ = writeln!(
            out,
            "Verdict: the aim (at least {AIM_DELIVERED} of {BASE_SEEDS}) is **{}**; {} base seed{} changing {} would flip it.",
            if met { "met" } else { "not met" },
            flips(delivered),
            if flips(delivered) == 1 { "" } else { "s" },
            if met { "to not delivering" } else { "to delivering" }
        );
    } else {
        let _ = writeln!(
            out,
            "Not judged yet: {} of {BASE_SEEDS} base seeds are in. With {delivered} of {n} delivering, the aim {}.",
            n,
            if n - delivered > BASE_SEEDS - AIM_DELIVERED {
                "can no longer be met".to_string()
            } else {
                format!(
                    "is still open ({} more failing seed{} would end it)",
                    BASE_SEEDS - AIM_DELIVERED + 1 - (n - delivered),
                    if BASE_SEEDS - AIM_DELIVERED + 1 - (n - delivered) == 1 { "" } else { "s" }
                )
            }
        );
    }
    if let Some(a) = &j.amendment {
        verdicts.1 = wall_per_half(out, &finished, lines, cpu, j.label, a);
        return verdicts;
    }
    let walls: Vec<f64> = finished.iter().map(|l| l.wall()).collect();
    let cpus: Vec<f64> = finished.iter().map(|l| l.cpu()).collect();
    let single_walls: Vec<f64> = lines
        .iter()
        .filter(|l| l.kind == j.baseline && l.done)
        .map(Line::wall)
        .collect();
    match (median(&walls), span(&walls), median(&single_walls)) {
        (Some(m), Some((lo, hi)), Some(m0)) => {
            let _ = writeln!(
                out,
                "\n**2. Wall time.** Median {m:.0} s (range {lo:.0}–{hi:.0}, CPU median {:.0} s) over the {n} {} lines in, against {m0:.0} s for {} ({} line{} in: {}): a ratio of {:.2}.",
                median(&cpus).unwrap_or(f64::NAN),
                j.label,
                j.baseline_label,
                single_walls.len(),
                if single_walls.len() == 1 { "" } else { "s" },
                single_walls.iter().map(|w| format!("{w:.0} s")).collect::<Vec<_>>().join(", "),
                m / m0
            );
            if n == BASE_SEEDS && single_walls.len() == 2 {
                let met = m <= 0.5 * m0;
                verdicts.1 = Some(met);
                let _ = writeln!(
                    out,
                    "Verdict: the aim (at most half) is **{}**.",
                    if met { "met" } else { "not met" }
                );
            } else {
                let _ = writeln!(out, "Not judged yet: not every line is in.");
            }
        }
        _ => {
            let _ = writeln!(
                out,
                "\n**2. Wall time.** Not judged yet: no {} line and {} both in.",
                j.label, j.baseline_label
            );
        }
    }
    verdicts
}

/// The half of an amendment's queue a base seed's line ran in (0 for seeds 0–9, 1 for 10–19),
/// which names its single line in [`Amendment::singles`].
fn half(seed: u64) -> usize {
    usize::from(seed >= HALF as u64)
}

/// Base seeds per half of an amendment's queue.
const HALF: usize = BASE_SEEDS / 2;

/// The amendment's aim 2, judged per half (its protocol's note: the halves ran on two
/// machines): each candidate line's wall time over that of its own half's single line, met when
/// the median of the 20 ratios is at most 0.5. Each half's ratio of medians and the pooled one
/// of the first wording are printed beside it; the pooled one says when it mixes machines.
fn wall_per_half(
    out: &mut String,
    finished: &[&Line],
    lines: &[Line],
    cpu: &str,
    label: &str,
    a: &Amendment,
) -> Option<bool> {
    let machine = |l: &Line| l.origin.as_ref().map_or(cpu, |o| o.1.as_str()).to_string();
    let single = |h: usize| {
        lines
            .iter()
            .find(|l| l.kind == Kind::Single && l.seed == a.singles[h] && l.done)
    };
    let ratios: Vec<f64> = finished
        .iter()
        .filter_map(|l| single(half(l.seed)).map(|s| l.wall() / s.wall()))
        .collect();
    let Some(m) = median(&ratios) else {
        let _ = writeln!(
            out,
            "\n**2. Wall time, per half.** Not judged yet: no {label} line and the single run of its half both in."
        );
        return None;
    };
    let (lo, hi) = span(&ratios).unwrap_or((m, m));
    let within = ratios.iter().filter(|&&r| r <= 0.5).count();
    let _ = write!(
        out,
        "\n**2. Wall time, per half.** Each {label} line's wall time over that of its half's single run: a median ratio of {m:.2} over {} lines (range {lo:.2}–{hi:.2}; {within} at most 0.5).",
        ratios.len()
    );
    for h in 0..2 {
        let walls: Vec<f64> = finished
            .iter()
            .filter(|l| half(l.seed) == h)
            .map(|l| l.wall())
            .collect();
        if let (Some(s), Some(w)) = (single(h), median(&walls)) {
            let _ = write!(
                out,
                " Seeds {}–{} ({} in) on {}: median {w:.0} s against {:.0} s for `single-{}`, {:.2}.",
                h * HALF,
                h * HALF + HALF - 1,
                walls.len(),
                machine(s),
                s.wall(),
                s.seed,
                w / s.wall()
            );
        }
    }
    let singles: Vec<&Line> = (0..2).filter_map(single).collect();
    let walls: Vec<f64> = finished.iter().map(|l| l.wall()).collect();
    let single_walls: Vec<f64> = singles.iter().map(|l| l.wall()).collect();
    if let (Some(w), Some(w0)) = (median(&walls), median(&single_walls)) {
        let mut machines: Vec<String> = finished
            .iter()
            .copied()
            .chain(singles.iter().copied())
            .map(machine)
            .collect();
        machines.sort();
        machines.dedup();
        let _ = write!(
            out,
            " Pooled as first worded{}: median {w:.0} s against {w0:.0} s, {:.2}.",
            if machines.len() > 1 {
                format!(
                    " (mixing {} machines, so not what is judged)",
                    machines.len()
                )
            } else {
                String::new()
            },
            w / w0
        );
    }
    let _ = writeln!(out);
    if ratios.len() < BASE_SEEDS {
        let _ = writeln!(out, "Not judged yet: not every line is in.");
        return None;
    }
    let met = m <= 0.5;
    let flips = median_flips(&ratios, 0.5);
    let _ = writeln!(
        out,
        "Verdict: the aim (a median ratio at most 0.5) is **{}**; {flips} line{} whose ratio crossed 0.5 would flip it.",
        if met { "met" } else { "not met" },
        if flips == 1 { "" } else { "s" }
    );
    Some(met)
}

/// The sensitivity of "the median of `xs` is at most `at_most`", for values that cannot be
/// negative: the fewest values that must change to flip it (the largest ones at most `at_most`
/// raised without bound, or the smallest ones above it lowered to zero).
///
/// ```
/// use studies::main_job::median_flips;
/// assert_eq!(median_flips(&[0.3, 0.4, 0.6], 0.5), 1); // 0.4 above 0.5 flips it
/// assert_eq!(median_flips(&[0.1, 0.2, 0.3, 0.6], 0.5), 2);
/// assert_eq!(median_flips(&[0.6, 0.7, 0.8], 0.5), 2);
/// ```
pub fn median_flips(xs: &[f64], at_most: f64) -> usize {
    let met = |v: &[f64]| median(v).is_some_and(|m| m <= at_most);
    let was = met(xs);
    let mut v = xs.to_vec();
    v.sort_by(f64::total_cmp);
    // The values on the verdict's side, nearest the threshold first.
    let order: Vec<usize> = if was {
        (0..v.len()).rev().filter(|&i| v[i] <= at_most).collect()
    } else {
        (0..v.len()).filter(|&i| v[i] > at_most).collect()
    };
    for (changed, &i) in order.iter().enumerate() {
        v[i] = if was { f64::INFINITY } else { 0.0 };
        if met(&v) != was {
            return changed + 1;
        }
    }
    order.len() + 1
}
