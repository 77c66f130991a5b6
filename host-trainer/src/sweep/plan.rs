//! Planning a sweep: the seeds of `--seeds`, and what each run does before anything starts.
//!
//! [`runs`] looks at each run folder: finished (it holds [`folder::EVAL`], the last file `train`
//! writes) is skipped; started but unfinished (a killed sweep) is continued with
//! `train --resume`; absent or empty is trained afresh. A folder whose recorded `config.toml`
//! differs from what the sweep would run is an error.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use firmware_sim::files;

use super::record::read_eval;
use super::report::SUMMARY_MD;
use crate::algorithms::Algo;
use crate::run::config::TrainConfig;
use crate::run::folder;
use crate::run::trainer::Trainer;
use crate::team::config::TeamConfig;
use crate::Error;

/// The most runs one sweep may ask for: a seed range this long is a typo, not a plan.
pub const MAX_RUNS: usize = 10_000;

/// The seeds of `--seeds`: `0-4`, `3`, `0,2,5` or combinations like `0-2,7`; sorted, each
/// once.
///
/// ```
/// use host_trainer::sweep::plan::Seeds;
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
        // Distinct seeds are what is counted: `0-9,0-9` is ten runs.
        let mut seeds = std::collections::BTreeSet::new();
        for part in text.split(',') {
            let (first, last) = match part.split_once('-') {
                Some((a, b)) => (number(a)?, number(b)?),
                None => (number(part)?, number(part)?),
            };
            if first > last {
                return Err(format!("the range {part} is empty ({first} > {last})"));
            }
            if last - first >= MAX_RUNS as u64 {
                return Err(format!("more than {MAX_RUNS} seeds in {text:?}"));
            }
            seeds.extend(first..=last);
            if seeds.len() > MAX_RUNS {
                return Err(format!("more than {MAX_RUNS} distinct seeds in {text:?}"));
            }
        }
        let seeds: Vec<u64> = seeds.into_iter().collect();
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

/// What a planned run trains: a `train` run, or a badminton team (`team`).
#[derive(Clone, Debug, PartialEq)]
pub enum Job {
    /// One agent on a navigation task: the run's full configuration.
    Train(TrainConfig),
    /// A badminton team: its full configuration.
    Team(TeamConfig),
}

impl Job {
    /// The run's folder name.
    pub fn name(&self) -> String {
        match self {
            Job::Train(c) => c.run_name(),
            Job::Team(c) => c.team_name(),
        }
    }

    /// The task as the folder names it.
    pub fn task(&self) -> String {
        match self {
            Job::Train(c) => c.task_name(),
            Job::Team(c) => c
                .team_name()
                .split("__")
                .next()
                .unwrap_or("badminton")
                .into(),
        }
    }

    /// The algorithm.
    pub fn algo(&self) -> Algo {
        match self {
            Job::Train(c) => c.algo,
            Job::Team(c) => c.algo,
        }
    }

    /// The seed.
    pub fn seed(&self) -> u64 {
        match self {
            Job::Train(c) => c.seed,
            Job::Team(c) => c.seed,
        }
    }

    /// The config file a fresh run starts from.
    pub fn to_toml(&self) -> String {
        match self {
            Job::Train(c) => c.to_toml(),
            Job::Team(c) => c.to_toml(),
        }
    }
}

/// One run of the sweep, before it runs.
#[derive(Clone, Debug)]
pub struct PlannedRun {
    /// What it trains (for a sweep, the sweep's base config with this algo and seed).
    pub job: Job,
    /// Its folder, `OUT/{task}__{algo}__{seed}`.
    pub dir: PathBuf,
    /// What to do with it.
    pub start: Start,
}

impl PlannedRun {
    /// The run's folder name.
    pub fn name(&self) -> String {
        self.job.name()
    }
}

/// Checks the settings and every run folder, and decides what each run does; writes nothing.
/// Every error a sweep can know of up front is found here, before any run starts: a config a
/// run would refuse, a missing output folder, a run folder of other settings.
pub fn runs(
    base: &TrainConfig,
    algos: &[Algo],
    seeds: &[u64],
    out: &Path,
) -> Result<Vec<PlannedRun>, Error> {
    // A missing --out is made by the sweep once the plan is checked (its parent must exist).
    folder::check_output_folder(out)?;
    if out.is_dir() {
        files::check_output(&out.join(SUMMARY_MD)).map_err(|source| Error::Io {
            path: out.to_path_buf(),
            source,
        })?;
    }
    if algos.len() * seeds.len() > MAX_RUNS {
        return Err(Error::InvalidConfig {
            what: "--algo and --seeds".into(),
            expected: format!("at most {MAX_RUNS} runs"),
            found: (algos.len() * seeds.len()).to_string(),
        });
    }
    // A setting some of the sweep's algorithms read is theirs; the others' runs get it at its
    // default, which is what they run anyway (and what they record).
    base.check_read(algos)?;
    let mut runs = Vec::new();
    for &algo in algos {
        // Building the trainer runs every check `train` makes (ranges, shape, task, evaluation
        // count); the seed changes none of them, so one trainer per algorithm is enough.
        let mut config = base.for_algo(algo)?;
        drop(Trainer::new(config.clone())?);
        for &seed in seeds {
            config.seed = seed;
            let dir = out.join(config.run_name());
            let start = start_of(&dir, &config)?;
            runs.push(PlannedRun {
                job: Job::Train(config.clone()),
                dir,
                start,
            });
        }
    }
    Ok(runs)
}

/// What a run folder's state asks for; an error if it holds a run of other settings.
fn start_of(dir: &Path, config: &TrainConfig) -> Result<Start, Error> {
    if folder::run_file_in(dir).is_none() {
        return Ok(Start::Fresh);
    }
    let recorded_path = dir.join(folder::CONFIG);
    if !recorded_path.exists() {
        return Err(Error::RunDiffers {
            path: dir.to_path_buf(),
            difference: format!("it holds run files but no {}", folder::CONFIG),
        });
    }
    // Settings the run's algorithm does not read play no part (a run recorded before they were
    // refused may hold some).
    let recorded = TrainConfig::from_file(&recorded_path)?;
    let recorded = recorded.for_algo(recorded.algo)?;
    if recorded != *config {
        return Err(Error::RunDiffers {
            path: dir.to_path_buf(),
            difference: first_difference(&recorded, config),
        });
    }
    if dir.join(folder::EVAL).exists() {
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

    /// `0-9998` three times is 9,999 distinct seeds, within the limit; it was counted as 29,997.
    #[test]
    fn only_distinct_seeds_count_against_the_limit() {
        let parse = |s: &str| s.parse::<Seeds>().map(|s| s.0.len());
        assert_eq!(parse("0-9998,0-9998,0-9998"), Ok(9_999));
        let over = parse("0-9998,20000-20001").expect_err("10,001 distinct seeds");
        assert!(over.contains("distinct"), "{over}");
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
}
