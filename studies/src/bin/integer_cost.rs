//! `integer-cost`: what the integer encoding costs in the closed loop
//! (docs/results/integer-cost.md). Every given run folder's f32 `policy.postcard` and its
//! integer encoding, calibrated exactly as `host-trainer export --encoding integer` calibrates
//! it, each run through firmware-sim's test protocol (100 boundary starts, seed 0, the run's
//! own recorded plant) clean and with the faults of the HIL checks.
//!
//! ```text
//! cargo run --release -p studies --bin integer-cost -- [RUN_DIR...] [--group NAME RUN_DIR...]...
//! ```
//!
//! The folders after `--group NAME` form the group NAME; folders before any `--group` are
//! grouped by the folder that holds them (a sweep's output folder).
//!
//! Prints one markdown row per run and condition (both encodings' success, settled error and
//! stuck rate, and the differences integer − f32), then per (task, algorithm) and condition
//! the mean paired difference with its bootstrap interval and sign-flip p
//! ([`studies::paired`]), the starts whose pass/fail the encoding changed, and the protocol's
//! verdict for success and for settled error. Then the diagnosis of the faulty condition, and
//! which part of the integer computation moves the command the stuck actuator holds: the f32
//! actor with one part (input codes, a hidden layer, the output layer), or the parts up to it,
//! computed as the integer blob computes it ([`studies::hybrid`]), on the integer policy's
//! states, and each part alone in the faulty closed loop against the f32 blob.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use firmware_sim::controller::{BlobPolicy, Controller, Observed};
use firmware_sim::nav::faults::Faults;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::{evaluate, evaluate_controller, EvalConfig, Report};
use host_trainer::blob::export::{
    calibration_observations, encode_integer, visited_observations_in, CALIBRATION_EPISODES,
    CALIBRATION_SEED,
};
use host_trainer::run::folder;
use host_trainer::stats::bootstrap::mean_ci;
use host_trainer::stats::permutation::sign_flip_permutation;
use host_trainer::stats::power::power_paired;
use host_trainer::stats::sensitivity::sensitivity;
use host_trainer::stats::{REPS, SEED};
use policy_core::model::Model;
use policy_core::Encoding;
use studies::hybrid::{Hybrid, HybridPolicy};
use studies::paired::paired_text;
use studies::run_folder;

/// The faults of the "faults" condition: the HIL checks' set (docs/firmware-sim.md).
const FAULTS: &str = "dropout-nan:0.05,stuck:0@50";

/// The two conditions, in the order the tables print them.
const CONDITIONS: [&str; 2] = ["clean", "faults"];

/// One blob's outcome under one condition: success rate, settled error, stuck rate, and each
/// start's pass/fail (for the starts the encoding changed).
struct Outcome {
    measures: [f64; 3],
    passed: Vec<bool>,
}

/// One run under one condition: the f32 blob's and the integer blob's outcomes.
struct Pair {
    group: String,
    run: String,
    condition: &'static str,
    f32: Outcome,
    integer: Outcome,
}

fn outcome(
    blob: &[u8],
    name: &str,
    which: &str,
    scenario: &firmware_sim::nav::scenario::Scenario,
    config: &EvalConfig,
) -> Result<Outcome, String> {
    let report = evaluate(blob, scenario, config).map_err(|e| format!("{name}: {e}"))?;
    if let Some(e) = report.boot_error {
        return Err(format!("{name}: the {which} blob does not boot: {e}"));
    }
    Ok(Outcome {
        measures: [report.success_rate, report.mean_error, report.stuck_rate],
        passed: report.episodes.iter().map(|e| e.success).collect(),
    })
}

/// Why the integer blob loses with the faults on, per run: the share of observation components
/// whose input code saturates (−128 or 127) on the states the f32 policy meets in the test
/// episodes, clean and with the faults; and, with the faults on, the outcome of an integer blob
/// calibrated on the states of clean *and* faulty episodes (the calibration seed's, not the
/// test's) beside the f32 blob's.
struct Diagnosis {
    group: String,
    saturated: [f64; 2],
    f32_faults: [f64; 3],
    wide: [f64; 3],
    /// Integer − f32 (success, settled error) with each fault alone: [`ALONE`].
    alone: [[f64; 2]; 2],
    /// Mean |action 0| the stuck actuator holds: f32, integer.
    held: [f64; 2],
}

/// The two faults of [`FAULTS`] one at a time, for the diagnosis.
const ALONE: [&str; 2] = ["dropout-nan:0.05", "stuck:0@50"];

/// The tick from which [`FAULTS`]'s stuck actuator holds action 0 (`stuck:0@50`).
const STUCK_FROM: usize = 50;

/// What the loop holds: at the tick before the actuator sticks, |action 0| (the value the
/// actuator then holds for the rest of the episode) and the observation it acted on.
#[derive(Default)]
struct Held {
    held: Vec<f64>,
    states: Vec<f32>,
}

impl Held {
    fn mean_held(&self) -> f64 {
        self.held.iter().sum::<f64>() / self.held.len().max(1) as f64
    }
}

/// `blob` through the test protocol with `config`, noting what it holds (see [`Held`]).
fn held_run(blob: &[u8], scenario: &Scenario, config: &EvalConfig) -> Result<Held, String> {
    let inner = BlobPolicy::boot(blob).map_err(|e| e.to_string())?;
    Ok(held_run_of(inner, scenario, config)?.0)
}

/// Any controller through the test protocol with `config`, noting what it holds.
fn held_run_of<C: Controller>(
    inner: C,
    scenario: &Scenario,
    config: &EvalConfig,
) -> Result<(Held, Report), String> {
    let mut held = Held::default();
    let mut c = Observed::new(inner, |tick, obs: &[f32], action: &[f32]| {
        if tick + 1 == STUCK_FROM {
            let a0 = action.first().copied().unwrap_or(0.0);
            held.held.push(f64::from(a0.abs()));
            held.states.extend_from_slice(obs);
        }
    });
    let report = evaluate_controller(&mut c, scenario, config).map_err(|e| e.to_string())?;
    drop(c);
    Ok((held, report))
}

/// The mean |action 0| each episode of the stuck-actuator test holds, for `blob`.
fn mean_held(blob: &[u8], scenario: &Scenario, config: &EvalConfig) -> Result<f64, String> {
    Ok(held_run(blob, scenario, config)?.mean_held())
}

/// The finite rows of `observations` (rows of `width`): a NaN dropout carries no range.
fn finite_rows(observations: &[f32], width: usize) -> Vec<f32> {
    observations
        .chunks_exact(width.max(1))
        .filter(|row| row.iter().all(|x| x.is_finite()))
        .flatten()
        .copied()
        .collect()
}

/// The share of the components of `observations` whose input code is −128 or 127.
fn saturated_share(integer: &[u8], observations: &[f32], width: usize) -> Result<f64, String> {
    let model = Model::from_blob(integer).map_err(|e| e.to_string())?;
    let (mut saturated, mut all) = (0usize, 0usize);
    let mut codes = vec![0i8; width];
    for row in observations.chunks_exact(width.max(1)) {
        model
            .observation_codes(row, &mut codes)
            .map_err(|e| e.to_string())?;
        saturated += codes.iter().filter(|&&c| c == -128 || c == 127).count();
        all += width;
    }
    Ok(saturated as f64 / all.max(1) as f64)
}

fn diagnose(group: &str, dir: &Path, pairs: &[Pair]) -> Result<Diagnosis, String> {
    let name = run_folder::name(dir)?;
    let f32 = run_folder::read(dir, folder::POLICY)?;
    let scenario = run_folder::scenario(dir)?;
    let width = Model::from_blob(&f32)
        .map(|m| usize::from(m.header().shape.observations))
        .map_err(|e| format!("{name}: {e}"))?;
    let faults: Faults = FAULTS.parse().map_err(|e| format!("{FAULTS}: {e}"))?;
    let clean = calibration_observations(&f32, &scenario, CALIBRATION_EPISODES as usize)
        .map_err(|e| format!("{name}: calibration: {e}"))?;
    let integer = encode_integer(&f32, &clean).map_err(|e| format!("{name}: {e}"))?;
    let visited = |config: &EvalConfig| {
        visited_observations_in(&f32, &scenario, config)
            .map(|o| finite_rows(&o, width))
            .map_err(|e| format!("{name}: {e}"))
    };
    let test_clean = run_folder::test_protocol();
    let test_faults = EvalConfig {
        faults: faults.clone(),
        ..run_folder::test_protocol()
    };
    let saturated = [
        saturated_share(&integer, &visited(&test_clean)?, width)?,
        saturated_share(&integer, &visited(&test_faults)?, width)?,
    ];
    let faulty_calibration = visited(&EvalConfig {
        episodes: CALIBRATION_EPISODES as usize,
        seed: CALIBRATION_SEED,
        faults,
        ..EvalConfig::default()
    })?;
    let wide = encode_integer(&f32, &[clean, faulty_calibration].concat())
        .map_err(|e| format!("{name}: {e}"))?;
    let with_faults = pairs
        .iter()
        .find(|p| p.condition == "faults")
        .ok_or_else(|| format!("{name}: no faults condition"))?;
    let mut alone = [[0.0; 2]; 2];
    let mut held = [0.0; 2];
    for (d, fault) in alone.iter_mut().zip(ALONE) {
        let config = EvalConfig {
            faults: fault.parse().map_err(|e| format!("{fault}: {e}"))?,
            ..run_folder::test_protocol()
        };
        if fault.starts_with("stuck") {
            held = [
                mean_held(&f32, &scenario, &config).map_err(|e| format!("{name}: {e}"))?,
                mean_held(&integer, &scenario, &config).map_err(|e| format!("{name}: {e}"))?,
            ];
        }
        let a = outcome(&f32, &name, "f32", &scenario, &config)?.measures;
        let b = outcome(&integer, &name, "integer", &scenario, &config)?.measures;
        *d = [b[0] - a[0], b[1] - a[1]];
    }
    Ok(Diagnosis {
        group: group.to_string(),
        saturated,
        f32_faults: with_faults.f32.measures,
        wide: outcome(&wide, &name, "widely calibrated", &scenario, &test_faults)?.measures,
        alone,
        held,
    })
}

/// Which part of the integer computation moves the held command, per run
/// ([`studies::hybrid`]): the f32 actor with one part in integers (the observation's input
/// codes, a hidden layer, the output layer with its tanh table), or the parts up to it, on the
/// states the integer policy meets; and each part alone in the faulty closed loop.
struct Attribution {
    group: String,
    /// Per part: its place ([`part_key`]), then the action figures and the closed loop's.
    parts: Vec<(usize, PartFigures)>,
}

/// One part's figures; `[alone, up to it]` where a pair.
#[derive(Clone, Copy, Default)]
struct PartFigures {
    /// Mean |Δ action 0| against the f32 actor at the held tick of the faulty episodes.
    held_error: [f64; 2],
    /// Mean |action 0| at the held tick: the f32 actor's, then the hybrids'.
    held_f32: f64,
    held: [f64; 2],
    /// Mean |Δ action| (every component) against the f32 actor over the clean episodes' states.
    clean_error: [f64; 2],
    /// The part alone in the faulty loop, against the f32 blob: Δ success, Δ settled error;
    /// and the mean |action 0| the actuator held in the hybrid's own loop.
    loop_diff: [f64; 2],
    loop_held: f64,
    /// The mean |action 0| the actuator held in the f32 blob's own faulty loop.
    f32_loop_held: f64,
}

/// Where a part sits, for the tables: 0 the input codes, `k` hidden layer `k`, [`OUTPUT`] the
/// output layer (runs of different depths share their input and output rows).
fn part_key(part: usize, parts: usize) -> usize {
    if part + 1 == parts {
        OUTPUT
    } else {
        part
    }
}

const OUTPUT: usize = usize::MAX - 3;

/// The key of the row that runs every part in integers: the integer blob itself.
const ALL: usize = usize::MAX - 2;

/// The keys of the controls: the f32 actor with its weights rounded to f16 or int8 (the other
/// encodings, activations in f32), a smaller and a like-sized change that is no integer part.
const F16: usize = usize::MAX - 1;
const INT8: usize = usize::MAX;

fn part_name(key: usize) -> String {
    match key {
        0 => "input codes".into(),
        OUTPUT => "output layer and tanh table".into(),
        ALL => "all (the integer blob)".into(),
        F16 => "control: f16 weights, f32 activations".into(),
        INT8 => "control: int8 weights, f32 activations".into(),
        k => format!("hidden layer {k}"),
    }
}

/// How a policy under comparison acts on one observation (into the action, in its bounds).
type Act<'a> = dyn Fn(&[f32], &mut [f32]) -> Result<(), String> + 'a;

/// Means over the states (`width` components each) of |Δ action 0| and |action 0| of `act`, and
/// of |Δ action| over every component, against the f32 actor.
fn action_figures(
    hybrid: &Hybrid<'_>,
    states: &[f32],
    width: usize,
    act: &Act<'_>,
) -> Result<[f64; 3], String> {
    let actions = usize::from(hybrid.f32_model().header().shape.actions);
    let (mut a, mut b) = (vec![0.0f32; actions], vec![0.0f32; actions]);
    let mut sums = [0.0f64; 3];
    let n = states.len() / width.max(1);
    for obs in states.chunks_exact(width.max(1)) {
        hybrid.act(obs, &(0..0), &mut a)?;
        act(obs, &mut b)?;
        let d0 = f64::from((b[0] - a[0]).abs());
        let all: f32 = a.iter().zip(&b).map(|(a, b)| (a - b).abs()).sum();
        sums[0] += d0;
        sums[1] += f64::from(b[0].abs());
        sums[2] += f64::from(all) / actions as f64;
    }
    Ok(sums.map(|s| s / n.max(1) as f64))
}

/// What [`attribute`] measures the variants on: the f32 actor in both encodings, the states
/// the integer policy meets, and the faulty loop with the f32 blob's outcome in it.
struct Bench<'h, 'a> {
    hybrid: &'h Hybrid<'a>,
    width: usize,
    held_states: Vec<f32>,
    clean_states: Vec<f32>,
    scenario: Scenario,
    faults: EvalConfig,
    /// The f32 blob in the faulty loop: success, settled error, mean held |action 0|.
    f32_faults: [f64; 3],
}

impl Bench<'_, '_> {
    /// The action figures of `alone` and `through` (`[alone, up to it]`) and `controller`'s
    /// outcome in the faulty loop.
    fn figures(
        &self,
        alone: &Act<'_>,
        through: &Act<'_>,
        controller: impl Controller,
    ) -> Result<PartFigures, String> {
        let mut f = PartFigures {
            held_f32: action_figures(self.hybrid, &self.held_states, self.width, &|o, a| {
                self.hybrid.act(o, &(0..0), a)
            })?[1],
            f32_loop_held: self.f32_faults[2],
            ..PartFigures::default()
        };
        for (k, act) in [alone, through].into_iter().enumerate() {
            let [d0, held, _] = action_figures(self.hybrid, &self.held_states, self.width, act)?;
            let [_, _, clean] = action_figures(self.hybrid, &self.clean_states, self.width, act)?;
            (f.held_error[k], f.held[k], f.clean_error[k]) = (d0, held, clean);
        }
        let (c, report) = held_run_of(controller, &self.scenario, &self.faults)?;
        f.loop_diff = [
            report.success_rate - self.f32_faults[0],
            report.mean_error - self.f32_faults[1],
        ];
        f.loop_held = c.mean_held();
        Ok(f)
    }
}

fn attribute(group: &str, dir: &Path, pairs: &[Pair]) -> Result<Attribution, String> {
    let name = run_folder::name(dir)?;
    attribute_run(group, dir, pairs).map_err(|e| format!("{name}: {e}"))
}

fn attribute_run(group: &str, dir: &Path, pairs: &[Pair]) -> Result<Attribution, String> {
    let name = run_folder::name(dir)?;
    let f32 = run_folder::read(dir, folder::POLICY)?;
    let scenario = run_folder::scenario(dir)?;
    let integer = integer_of(&f32, &scenario, &name)?;
    let hybrid = Hybrid::new(&f32, &integer)?;
    let faults = EvalConfig {
        faults: FAULTS.parse().map_err(|e| format!("{FAULTS}: {e}"))?,
        ..run_folder::test_protocol()
    };
    let with_faults = pairs
        .iter()
        .find(|p| p.condition == "faults")
        .ok_or("no faults condition")?
        .f32
        .measures;
    let bench = Bench {
        hybrid: &hybrid,
        width: usize::from(hybrid.f32_model().header().shape.observations),
        held_states: held_run(&integer, &scenario, &faults)?.states,
        clean_states: visited_observations_in(&integer, &scenario, &run_folder::test_protocol())
            .map_err(|e| e.to_string())?,
        f32_faults: [
            with_faults[0],
            with_faults[1],
            held_run(&f32, &scenario, &faults)?.mean_held(),
        ],
        scenario,
        faults,
    };
    let n = hybrid.parts();
    let mut parts = Vec::new();
    for part in 0..=n {
        // Part `n` stands for every part at once: the integer blob, as a check of the others.
        let (key, alone) = if part == n {
            (ALL, 0..n)
        } else {
            (part_key(part, n), part..part + 1)
        };
        let through = 0..(part + 1).min(n);
        let f = bench.figures(
            &|o, a| hybrid.act(o, &alone, a),
            &|o, a| hybrid.act(o, &through, a),
            HybridPolicy {
                hybrid: &hybrid,
                integer: alone.clone(),
            },
        )?;
        parts.push((key, f));
    }
    for (key, encoding) in [(F16, Encoding::F16), (INT8, Encoding::Int8)] {
        let blob = policy_core::blob::encode(&f32, encoding).map_err(|e| e.to_string())?;
        let model = Model::from_blob(&blob).map_err(|e| e.to_string())?;
        let act = |o: &[f32], a: &mut [f32]| {
            let mut scratch = vec![0.0; model.scratch_floats()];
            model.act_in(o, &mut scratch, a).map_err(|e| e.to_string())
        };
        let controller = BlobPolicy::boot(&blob).map_err(|e| e.to_string())?;
        parts.push((key, bench.figures(&act, &act, controller)?));
    }
    Ok(Attribution {
        group: group.to_string(),
        parts,
    })
}

/// The integer encoding of `f32`, made as `export --encoding integer` makes it: calibrated on
/// the f32 policy's own visited states.
fn integer_of(f32: &[u8], scenario: &Scenario, name: &str) -> Result<Vec<u8>, String> {
    let observations = calibration_observations(f32, scenario, CALIBRATION_EPISODES as usize)
        .map_err(|e| format!("{name}: calibration: {e}"))?;
    encode_integer(f32, &observations).map_err(|e| format!("{name}: integer export failed: {e}"))
}

/// The attribution's two tables: the action figures per part (alone and up to it), then each
/// part alone in the faulty loop, per group.
fn print_attribution(attributions: &[Attribution]) {
    let mut rows: BTreeMap<(&str, usize), Vec<PartFigures>> = BTreeMap::new();
    for a in attributions {
        for (key, f) in &a.parts {
            rows.entry((&a.group, *key)).or_default().push(*f);
        }
    }
    let mean = |fs: &[PartFigures], g: &dyn Fn(&PartFigures) -> f64| {
        fs.iter().map(g).sum::<f64>() / fs.len().max(1) as f64
    };
    println!("| group | integer part | runs | mean \\|Δ action 0\\| at the held tick, part alone | the same, parts up to it | mean held \\|action 0\\|, f32 → part alone | f32 → parts up to it | mean \\|Δ action\\|, clean episodes' states, part alone | the same, parts up to it |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for ((group, key), fs) in &rows {
        println!(
            "| {group} | {} | {} | {:.4} | {:.4} | {:.4} → {:.4} | {:.4} → {:.4} | {:.4} | {:.4} |",
            part_name(*key),
            fs.len(),
            mean(fs, &|f| f.held_error[0]),
            mean(fs, &|f| f.held_error[1]),
            mean(fs, &|f| f.held_f32),
            mean(fs, &|f| f.held[0]),
            mean(fs, &|f| f.held_f32),
            mean(fs, &|f| f.held[1]),
            mean(fs, &|f| f.clean_error[0]),
            mean(fs, &|f| f.clean_error[1]),
        );
    }
    println!();
    println!("| group | integer part alone, with the faults | runs | Δ success | Δ settled error | mean held \\|action 0\\| in its own loop, f32 → this |");
    println!("|---|---|---:|---:|---:|---:|");
    for ((group, key), fs) in &rows {
        let diffs = |k: usize| -> Vec<f64> { fs.iter().map(|f| f.loop_diff[k]).collect() };
        println!(
            "| {group} | {} | {} | {} | {} | {:.4} → {:.4} |",
            part_name(*key),
            fs.len(),
            paired_text(&diffs(0), 3),
            paired_text(&diffs(1), 3),
            mean(fs, &|f| f.f32_loop_held),
            mean(fs, &|f| f.loop_held),
        );
    }
}

fn run_one(group: &str, dir: &Path) -> Result<Vec<Pair>, String> {
    // The folder that holds the run (a sweep's output folder), or nothing for a bare name.
    let holder = dir
        .parent()
        .and_then(Path::file_name)
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = format!("{holder}/{}", run_folder::name(dir)?);
    let f32 = run_folder::read(dir, folder::POLICY)?;
    let scenario = run_folder::scenario(dir)?;
    let integer = integer_of(&f32, &scenario, &name)?;
    let faults: Faults = FAULTS.parse().map_err(|e| format!("{FAULTS}: {e}"))?;
    let mut pairs = Vec::new();
    for condition in CONDITIONS {
        let mut config = run_folder::test_protocol();
        if condition == "faults" {
            config.faults = faults.clone();
        }
        pairs.push(Pair {
            group: if group.is_empty() {
                holder.clone()
            } else {
                group.to_string()
            },
            run: name.clone(),
            condition,
            f32: outcome(&f32, &name, "f32", &scenario, &config)?,
            integer: outcome(&integer, &name, "integer", &scenario, &config)?,
        });
    }
    Ok(pairs)
}

/// The command line's run folders, each with its group (`--group NAME` before them, or empty:
/// the folder that holds it); `None` for no folder, or a `--group` without a name or a folder.
fn grouped(args: impl Iterator<Item = String>) -> Option<Vec<(String, PathBuf)>> {
    let mut group = String::new();
    let mut dirs = Vec::new();
    let mut args = args.peekable();
    while let Some(arg) = args.next() {
        if arg == "--group" {
            group = args.next()?;
            if args.peek().is_none_or(|a| a == "--group") {
                return None;
            }
        } else {
            dirs.push((group.clone(), PathBuf::from(arg)));
        }
    }
    (!dirs.is_empty()).then_some(dirs)
}

/// The protocol's verdict on one measure's paired differences: `better_up` says whether a
/// larger value is better (success) or worse (settled error). Holds where the 95 % bootstrap
/// interval of the mean difference contains 0 or lies on the better side; costs where it lies
/// on the worse side and the sign-flip p < 0.05; unclear otherwise.
fn verdict(diffs: &[f64], better_up: bool) -> &'static str {
    let Some(ci) = mean_ci(diffs) else {
        return "no runs";
    };
    let worse = if better_up { ci.hi < 0.0 } else { ci.lo > 0.0 };
    if !worse {
        "holds"
    } else if sign_flip_permutation(diffs, REPS as u64, SEED).p < 0.05 {
        "costs"
    } else {
        "unclear"
    }
}

/// The verdict with its sensitivity (a run's difference set to 0, as if the encoding changed
/// nothing on it, or to the lowest or highest difference seen; up to two runs at once: each
/// try reruns the bootstrap) and the power the paired comparison had at the observed mean and
/// spread.
fn verdict_text(diffs: &[f64], better_up: bool) -> String {
    let (lo, hi) = diffs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &d| {
            (l.min(d), h.max(d))
        });
    let alternatives = |_: usize, v: f64| -> Vec<f64> {
        let mut a: Vec<f64> = [0.0, lo, hi].into_iter().filter(|&x| x != v).collect();
        a.dedup();
        a
    };
    let s = sensitivity(diffs, alternatives, |v| verdict(v, better_up), 2);
    let n = diffs.len();
    let mean = diffs.iter().sum::<f64>() / n as f64;
    let sd = (diffs.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / (n.max(2) - 1) as f64).sqrt();
    let power = if sd > 0.0 && mean != 0.0 {
        format!("power {:.2}", power_paired(mean, sd, n as u64, 0.05))
    } else {
        "power –, no spread".into()
    };
    format!("**{}** ({s}; {power})", verdict(diffs, better_up))
}

fn main() -> ExitCode {
    let Some(dirs) = grouped(std::env::args().skip(1)) else {
        eprintln!("usage: integer-cost [RUN_DIR...] [--group NAME RUN_DIR...]...");
        return ExitCode::from(2);
    };
    let mut pairs = Vec::new();
    let mut diagnoses = Vec::new();
    let mut attributions = Vec::new();
    for (group, dir) in &dirs {
        let measured = run_one(group, dir).and_then(|p| {
            let key = p.first().map(|p| p.group.clone()).unwrap_or_default();
            diagnoses.push(diagnose(&key, dir, &p)?);
            attributions.push(attribute(&key, dir, &p)?);
            Ok(p)
        });
        match measured {
            Ok(mut p) => pairs.append(&mut p),
            Err(e) => {
                eprintln!("integer-cost: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    println!("| run | condition | success f32 → integer | settled error f32 → integer | stuck f32 → integer | Δ success | Δ settled error | Δ stuck |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|");
    // (task and algorithm, condition) -> the runs' pairs.
    let mut groups: BTreeMap<(String, usize), Vec<&Pair>> = BTreeMap::new();
    for p in &pairs {
        let (a, b) = (p.f32.measures, p.integer.measures);
        println!(
            "| {} | {} | {:.2} → {:.2} | {:.3} → {:.3} | {:.2} → {:.2} | {:+.2} | {:+.3} | {:+.2} |",
            p.run,
            p.condition,
            a[0],
            b[0],
            a[1],
            b[1],
            a[2],
            b[2],
            b[0] - a[0],
            b[1] - a[1],
            b[2] - a[2]
        );
        let c = CONDITIONS
            .iter()
            .position(|&c| c == p.condition)
            .unwrap_or(0);
        groups.entry((p.group.clone(), c)).or_default().push(p);
    }
    println!();
    println!("| group | condition | runs | Δ success | Δ settled error | Δ stuck at margin | starts lost / gained | success | settled error |");
    println!("|---|---|---:|---:|---:|---:|---:|---|---|");
    for ((group, c), runs) in &groups {
        let diffs = |k: usize| -> Vec<f64> {
            runs.iter()
                .map(|p| p.integer.measures[k] - p.f32.measures[k])
                .collect()
        };
        let (mut lost, mut gained) = (0, 0);
        for p in runs {
            for (f, i) in p.f32.passed.iter().zip(&p.integer.passed) {
                lost += usize::from(*f && !*i);
                gained += usize::from(!*f && *i);
            }
        }
        println!(
            "| {group} | {} | {} | {} | {} | {} | {lost} / {gained} | {} | {} |",
            CONDITIONS[*c],
            runs.len(),
            paired_text(&diffs(0), 3),
            paired_text(&diffs(1), 3),
            paired_text(&diffs(2), 3),
            verdict_text(&diffs(0), true),
            verdict_text(&diffs(1), false),
        );
    }
    println!();
    println!("| group | runs | input codes saturated, clean | with the faults | Δ success with the faults, calibrated on clean and faulty episodes | Δ settled error, the same | Δ success, {} alone | Δ settled error, the same | Δ success, {} alone | Δ settled error, the same | mean held action 0, f32 → integer |", ALONE[0], ALONE[1]);
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    let mut by_group: BTreeMap<&str, Vec<&Diagnosis>> = BTreeMap::new();
    for d in &diagnoses {
        by_group.entry(&d.group).or_default().push(d);
    }
    for (group, ds) in by_group {
        let mean =
            |f: &dyn Fn(&Diagnosis) -> f64| ds.iter().map(|d| f(d)).sum::<f64>() / ds.len() as f64;
        let diffs =
            |k: usize| -> Vec<f64> { ds.iter().map(|d| d.wide[k] - d.f32_faults[k]).collect() };
        let alone = |f: usize, k: usize| -> String {
            let d: Vec<f64> = ds.iter().map(|d| d.alone[f][k]).collect();
            paired_text(&d, 3)
        };
        println!(
            "| {group} | {} | {:.1} % | {:.1} % | {} | {} | {} | {} | {} | {} | {:.4} → {:.4} |",
            ds.len(),
            100.0 * mean(&|d| d.saturated[0]),
            100.0 * mean(&|d| d.saturated[1]),
            paired_text(&diffs(0), 3),
            paired_text(&diffs(1), 3),
            alone(0, 0),
            alone(0, 1),
            alone(1, 0),
            alone(1, 1),
            mean(&|d| d.held[0]),
            mean(&|d| d.held[1]),
        );
    }
    println!();
    print_attribution(&attributions);
    ExitCode::SUCCESS
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folders_take_the_group_named_before_them() {
        let args = |v: &[&str]| {
            v.iter()
                .map(|s| s.to_string())
                .collect::<Vec<_>>()
                .into_iter()
        };
        let g = grouped(args(&[
            "a", "--group", "G 1", "b", "c", "--group", "H", "d",
        ]))
        .unwrap();
        let names: Vec<(&str, &str)> = g
            .iter()
            .map(|(g, d)| (g.as_str(), d.to_str().unwrap()))
            .collect();
        assert_eq!(names, [("", "a"), ("G 1", "b"), ("G 1", "c"), ("H", "d")]);
        assert!(grouped(args(&[])).is_none());
        assert!(grouped(args(&["--group"])).is_none());
        assert!(grouped(args(&["--group", "G"])).is_none());
        assert!(grouped(args(&["a", "--group", "G", "--group", "H", "b"])).is_none());
    }

    #[test]
    fn the_rule_reads_the_interval_then_the_exact_test() {
        // The encoding changed nothing: holds.
        assert_eq!(verdict(&[0.0; 20], true), "holds");
        // 20 runs that all lose 0.01 to 0.05 of success: interval below 0, exact p = 2/2^20.
        let lose: Vec<f64> = (0..20).map(|i| -0.01 - 0.002 * f64::from(i)).collect();
        assert_eq!(verdict(&lose, true), "costs");
        // The same for a settled error, where higher is worse.
        let higher: Vec<f64> = lose.iter().map(|d| -d).collect();
        assert_eq!(verdict(&higher, false), "costs");
        assert_eq!(verdict(&lose, false), "holds");
        // Five runs all worse: the interval lies below 0, but no sign-flip test of 5 pairs
        // reaches p < 0.05 (2 of 32 patterns = 0.0625).
        assert_eq!(verdict(&[-0.1, -0.2, -0.1, -0.3, -0.2], true), "unclear");
        assert_eq!(verdict(&[], true), "no runs");
    }

    #[test]
    fn the_verdict_names_its_sensitivity_and_power() {
        let text = verdict_text(&[-0.1, -0.2, -0.1, -0.3, -0.2], true);
        // Two runs set to 0 leave the interval below 0 (a resample of only zeros is 1 in 100).
        assert_eq!(
            text,
            "**unclear** (no change of up to 2 of the 5 runs flips it; power 1.00)"
        );
        let none = verdict_text(&[0.0; 4], true);
        assert_eq!(
            none,
            "**holds** (no change of up to 2 of the 4 runs flips it; power –, no spread)"
        );
    }
}
