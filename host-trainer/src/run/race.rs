//! Seeds raced on every core (`train --race K`): K runs of the same settings from seeds derived
//! from the base seed train side by side, one thread each, and validate at the same episodes;
//! the first validation round at which a racer's validation ends its run names the winner, and
//! the others stop there.
//!
//! **Why the winner does not depend on timing.** Racers wait for each other at every validation
//! round: the decision on round r is made once every racer still running has validated round r,
//! from their figures alone ([`decide_round`]). Racing threads run at different speeds on a busy
//! machine; they never see each other's state between rounds. The same base seed and K give
//! the same winner and the same bytes on any machine, at any speed.
//!
//! **Why threads, not processes.** A racer is a [`Trainer`] with one worker thread in a thread
//! of its own: it shares nothing with the others but the board of validation figures. One
//! process means a kill of any kind takes every racer with it (no training left behind), the
//! board needs no protocol, and every racer checkpoints into its own run folder, so the race
//! continues from the racers' checkpoints with `train --resume` (their histories say which
//! rounds are decided). `sweep` keeps processes: its runs are independent and may fail alone.
//!
//! **Why racers run one thread each.** Two runs side by side do nearly twice the work of one on
//! the 2-vCPU machines measured, where a second worker thread speeds one run up by 1.13×
//! (docs/performance.md, "Threads"): a core is worth more as a racer than as a helper.

use std::ops::ControlFlow;
use std::path::{Component, Path, PathBuf};
use std::sync::{Condvar, Mutex, MutexGuard, PoisonError};
use std::time::Duration;

use firmware_sim::seed::training_stream;
use rand_core::Rng as _;
use serde::{Deserialize, Serialize};

use crate::run::folder::{self, RunDir};
use crate::run::metrics::EpisodeRow;
use crate::run::trainer::{self, Outcome, Trainer};
use crate::run::validation::Round;
use crate::Error;

/// The most racers one race may have.
pub const MAX_RACERS: usize = 64;

/// The seed of racer `index` of a race from `base`: racer 0 trains the base seed itself (a race
/// of one is the plain run), the others the draws of the base seed's `race` stream, kept to 32
/// bits so their folder names stay short.
///
/// ```
/// use host_trainer::run::race::racer_seed;
/// assert_eq!(racer_seed(7, 0), 7);
/// assert_eq!(racer_seed(7, 1), racer_seed(7, 1));
/// assert_ne!(racer_seed(7, 1), racer_seed(7, 2));
/// ```
pub fn racer_seed(base: u64, index: usize) -> u64 {
    if index == 0 {
        return base;
    }
    let mut stream = training_stream(base, "race");
    let mut seed = base;
    for _ in 0..index {
        seed = stream.next_u64() >> 32;
    }
    seed
}

/// How a round was decided.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Decision {
    /// No racer's validation ended its run: all go on.
    Continue,
    /// This racer's validation ended its run; the others stop.
    Winner(usize),
}

/// One racer's part of the board.
#[derive(Clone, Debug, Default)]
struct Lane {
    /// Its validation rounds, with whether each ended its run.
    rounds: Vec<(Round, bool)>,
    /// It trains no more: its budget is used up, it stopped, or it failed.
    finished: bool,
}

/// The decision on round `r` from every racer's figures at that round: the racers whose run the
/// round ends are the candidates, the best by [`Round::better_than`] wins, ties to the lowest
/// index. `None` while a racer still running has not validated round `r`.
///
/// ```
/// use host_trainer::run::race::{decide_round, Decision};
/// use host_trainer::run::validation::Round;
/// let r = |error| Round { meets: true, gate: true, error: Some(error), ..Round::default() };
/// // Racer 1 ends its run at round 0 with the lower error; racer 0 does not end its run.
/// let lanes = [(vec![(r(0.1), false)], false), (vec![(r(0.3), true)], false)];
/// assert_eq!(decide_round(&lanes, 0), Some(Decision::Winner(1)));
/// // Racer 1 has not validated round 1 yet: no decision.
/// let lanes = [(vec![(r(0.1), false), (r(0.1), true)], false), (vec![(r(0.3), true)], false)];
/// assert_eq!(decide_round(&lanes, 1), None);
/// ```
pub fn decide_round(lanes: &[(Vec<(Round, bool)>, bool)], r: usize) -> Option<Decision> {
    let mut best: Option<(usize, &Round)> = None;
    for (index, (rounds, finished)) in lanes.iter().enumerate() {
        match rounds.get(r) {
            None if *finished => continue,
            None => return None,
            Some((round, ends)) => {
                if *ends && best.is_none_or(|(_, b)| round.better_than(b)) {
                    best = Some((index, round));
                }
            }
        }
    }
    Some(best.map_or(Decision::Continue, |(i, _)| Decision::Winner(i)))
}

/// The board the racers share: their rounds, and the decisions made so far.
#[derive(Debug)]
pub struct Board {
    state: Mutex<Vec<Lane>>,
    changed: Condvar,
}

impl Board {
    /// A board for racers whose histories (restored from their checkpoints) are `rounds`, each
    /// round with whether it ended that racer's run.
    pub fn new(rounds: Vec<Vec<(Round, bool)>>) -> Board {
        let lanes = rounds
            .into_iter()
            .map(|rounds| Lane {
                rounds,
                finished: false,
            })
            .collect();
        Board {
            state: Mutex::new(lanes),
            changed: Condvar::new(),
        }
    }

    fn lanes(&self) -> MutexGuard<'_, Vec<Lane>> {
        // A racer thread that panicked leaves plain data behind: the figures are still good.
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The first round with a winner, if one has been decided (every decision before it is
    /// [`Decision::Continue`]).
    pub fn winner(&self) -> Option<(usize, usize)> {
        let lanes = self.lanes();
        winner_of(&lanes)
    }

    /// Whether every racer has finished.
    pub fn all_finished(&self) -> bool {
        self.lanes().iter().all(|l| l.finished)
    }

    /// Records racer `index`'s round.
    pub fn report(&self, index: usize, round: Round, ends: bool) {
        let mut lanes = self.lanes();
        if let Some(lane) = lanes.get_mut(index) {
            lane.rounds.push((round, ends));
        }
        self.changed.notify_all();
    }

    /// Marks racer `index` finished (it trains no more).
    pub fn finish(&self, index: usize) {
        let mut lanes = self.lanes();
        if let Some(lane) = lanes.get_mut(index) {
            lane.finished = true;
        }
        self.changed.notify_all();
    }

    /// Waits for the decision on racer `index`'s round `r`; `None` if `interrupted` says so
    /// first (checked every 50 ms).
    pub fn wait(&self, r: usize, interrupted: &dyn Fn() -> bool) -> Option<Decision> {
        let mut lanes = self.lanes();
        loop {
            if let Some((round, who)) = winner_of(&lanes) {
                if round <= r {
                    return Some(Decision::Winner(who));
                }
            }
            if let Some(decision) = decide_round(&as_pairs(&lanes), r) {
                return Some(decision);
            }
            if interrupted() {
                return None;
            }
            lanes = self
                .changed
                .wait_timeout(lanes, Duration::from_millis(50))
                .unwrap_or_else(PoisonError::into_inner)
                .0;
        }
    }
}

fn as_pairs(lanes: &[Lane]) -> Vec<(Vec<(Round, bool)>, bool)> {
    lanes
        .iter()
        .map(|l| (l.rounds.clone(), l.finished))
        .collect()
}

/// The first decided round with a winner, and the winner.
fn winner_of(lanes: &[Lane]) -> Option<(usize, usize)> {
    let pairs = as_pairs(lanes);
    let rounds = pairs.iter().map(|(r, _)| r.len()).max().unwrap_or(0);
    for r in 0..rounds {
        match decide_round(&pairs, r)? {
            Decision::Continue => continue,
            Decision::Winner(i) => return Some((r, i)),
        }
    }
    None
}

/// How one racer's part of the race ended.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Ending {
    /// Its validation ended its run and it won.
    Won,
    /// Another racer won; it stopped at that round (checkpoint written).
    Stopped,
    /// Its budget is used up.
    Finished,
    /// Ctrl-C (checkpoint written): the race continues with `train --resume`.
    Interrupted,
    /// It failed (diverged, or its plant failed): out of the race.
    Failed(String),
}

/// Trains racer `index` on `board` until its run ends, the race is won, or `interrupted`.
/// `on_episode` sees every episode (for a progress bar).
pub fn race_one(
    index: usize,
    trainer: &mut Trainer,
    run: &RunDir,
    board: &Board,
    interrupted: &(dyn Fn() -> bool + Sync),
    on_episode: &(dyn Fn(usize, &EpisodeRow) + Sync),
) -> Ending {
    let ending = race_inner(index, trainer, run, board, interrupted, on_episode);
    board.finish(index);
    ending
}

fn race_inner(
    index: usize,
    trainer: &mut Trainer,
    run: &RunDir,
    board: &Board,
    interrupted: &(dyn Fn() -> bool + Sync),
    on_episode: &(dyn Fn(usize, &EpisodeRow) + Sync),
) -> Ending {
    // A resumed racer whose last round is undecided waits for it before training on.
    if let Some(last) = trainer.validation.len().checked_sub(1) {
        match board.wait(last, interrupted) {
            None => return Ending::Interrupted,
            Some(Decision::Winner(w)) if w == index => return Ending::Won,
            Some(Decision::Winner(_)) => return Ending::Stopped,
            Some(Decision::Continue) => {}
        }
    }
    let mut stopped_by_race = false;
    let mut won = false;
    let outcome = trainer::run(trainer, run, &mut |row, t| {
        on_episode(index, row);
        if let Some(round) = t.validation.last().filter(|r| r.episode == t.episode) {
            let r = t.validation.len() - 1;
            board.report(index, round.clone(), t.stopped_at_gate());
            match board.wait(r, interrupted) {
                None => return ControlFlow::Break(()),
                Some(Decision::Winner(w)) if w == index => won = true,
                Some(Decision::Winner(_)) => {
                    stopped_by_race = true;
                    return ControlFlow::Break(());
                }
                Some(Decision::Continue) => {}
            }
        }
        if interrupted() {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    match outcome {
        Err(e) => Ending::Failed(e.to_string()),
        Ok(Outcome::Stopped { .. }) if stopped_by_race => Ending::Stopped,
        Ok(Outcome::Stopped { .. }) => Ending::Interrupted,
        Ok(Outcome::Finished) if won => Ending::Won,
        Ok(Outcome::Finished) => Ending::Finished,
    }
}

/// One racer as the race's record shows it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RacerRecord {
    /// Its seed.
    pub seed: u64,
    /// Its run folder, relative to the race's folder.
    pub folder: String,
    /// How its part ended (`None` while it runs).
    pub ending: Option<Ending>,
    /// Episodes trained.
    pub episodes: usize,
    /// Its validation rounds.
    pub validation: Vec<Round>,
    /// The round its kept policy comes from.
    pub kept: Option<Round>,
}

impl RacerRecord {
    /// Its run folder inside the race's folder `race_dir`; a record edited to point anywhere but
    /// a folder of `racers/` is refused, not followed.
    ///
    /// ```
    /// use host_trainer::run::race::RacerRecord;
    /// let r = |folder: &str| RacerRecord { seed: 0, folder: folder.into(), ending: None, episodes: 0, validation: vec![], kept: None };
    /// let dir = std::path::Path::new("race");
    /// assert_eq!(r("racers/a").folder_in(dir).unwrap(), dir.join("racers/a"));
    /// assert!(r("racers/../../etc").folder_in(dir).is_err());
    /// assert!(r("/tmp/x").folder_in(dir).is_err());
    /// ```
    pub fn folder_in(&self, race_dir: &Path) -> Result<PathBuf, Error> {
        let parts: Vec<_> = Path::new(&self.folder).components().collect();
        let inside = parts.len() == 2
            && parts[0].as_os_str() == folder::RACERS
            && matches!(parts[1], Component::Normal(_));
        if !inside {
            return Err(Error::InvalidConfig {
                what: format!("{} racer folder", folder::RACE),
                expected: format!("a folder of {}/", folder::RACERS),
                found: format!("{:?}", self.folder),
            });
        }
        Ok(race_dir.join(&self.folder))
    }

    /// The mean settled error of the round its kept policy comes from, if it has one.
    pub fn kept_error(&self) -> Option<f64> {
        self.kept.as_ref().and_then(|k| k.error)
    }
}

/// The race's record, `race.json`: written when the race starts (so `--resume` finds it) and
/// again when it ends, with the winner and why it won.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RaceRecord {
    /// The base seed the racers' seeds derive from ([`racer_seed`]).
    pub base_seed: u64,
    /// The settings every racer trains with but its seed, as `config.toml` text (a racer
    /// killed before its folder held anything starts from them again).
    pub config_toml: String,
    /// Every racer.
    pub racers: Vec<RacerRecord>,
    /// The winner's index (`None` while the race runs, or if every racer failed).
    pub winner: Option<usize>,
    /// Why the winner won, in one sentence.
    pub why: String,
}

impl RaceRecord {
    /// Reads the record in the race's folder `race_dir`.
    pub fn read(race_dir: &Path) -> Result<Self, Error> {
        let path = race_dir.join(folder::RACE);
        let text = crate::run::config::read_text(&path)?;
        serde_json::from_str(&text).map_err(|e| Error::RaceRecord {
            path,
            message: crate::run::config::one_line(&e.to_string()),
        })
    }

    /// The winner's record (`None` while the race runs, or if every racer failed).
    ///
    /// ```
    /// use host_trainer::run::race::{RaceRecord, RacerRecord};
    /// let racer = |seed| RacerRecord { seed, folder: String::new(), ending: None, episodes: 0, validation: vec![], kept: None };
    /// let mut race = RaceRecord { base_seed: 0, config_toml: String::new(), racers: vec![racer(7), racer(9)], winner: None, why: String::new() };
    /// assert!(race.winner_record().is_none());
    /// race.winner = Some(1);
    /// assert_eq!(race.winner_record().map(|r| r.seed), Some(9));
    /// ```
    pub fn winner_record(&self) -> Option<&RacerRecord> {
        self.winner.and_then(|w| self.racers.get(w))
    }
}

/// The winner of a race every racer has finished without one: the racer whose kept policy is
/// best by [`Round::better_than`], ties to the lowest index; failed racers are out.
///
/// ```
/// use host_trainer::run::race::{best_kept, Ending};
/// use host_trainer::run::validation::Round;
/// let r = |error| Some(Round { error: Some(error), ..Round::default() });
/// let racers = [(r(0.9), Ending::Finished), (r(0.5), Ending::Finished), (r(0.1), Ending::Failed("x".into()))];
/// assert_eq!(best_kept(&racers), Some(1));
/// ```
pub fn best_kept(racers: &[(Option<Round>, Ending)]) -> Option<usize> {
    let mut best: Option<(usize, &Round)> = None;
    for (i, (kept, ending)) in racers.iter().enumerate() {
        let (Some(round), false) = (kept, matches!(ending, Ending::Failed(_))) else {
            continue;
        };
        if best.is_none_or(|(_, b)| round.better_than(b)) {
            best = Some((i, round));
        }
    }
    best.map(|(i, _)| i)
}
