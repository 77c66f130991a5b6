//! The statistics every results page and summary uses: which interval for which quantity,
//! which test for which comparison, and how fragile and how well-powered each verdict is.
//!
//! Why one module: a verdict is only as good as the test behind it, and with five seeds the
//! choice of test decides verdicts (a t interval on five 0/1 outcomes runs past 1, or claims
//! certainty from five equal values). The choices, each defended in its file:
//! - a **rate of runs** (k runs of n failed): the exact Clopper–Pearson interval
//!   ([`binomial::clopper_pearson`]);
//! - a **per-run quantity averaged over seeds** (success on the test starts, settled error):
//!   the mean with its percentile bootstrap interval, which never leaves the values' range
//!   ([`bootstrap::mean_text`]), or no interval when every seed gave the same value; the t
//!   interval ([`student_t`]) only where a rule fixed before the runs names it;
//! - **paired pass/fail outcomes**: the exact McNemar test ([`binomial::mcnemar_exact`]);
//! - **paired differences**: the sign-flip permutation test ([`permutation`]); unpaired groups,
//!   the two-sample permutation test;
//! - **several tasks aggregated**: the interquartile mean and the probability of improvement,
//!   with stratified bootstrap intervals as rliable computes them ([`aggregate`],
//!   [`bootstrap`]);
//! - every verdict with its **sensitivity** (the fewest runs whose change flips it,
//!   [`sensitivity`]) and its **power** (the seeds per arm that would detect the observed
//!   effect, and the power at the seeds it had, [`power`]).
//!
//! The functions are pure: the same inputs (and seed, where there is one) give the same
//! numbers on every machine. `tests/golden/stats_scipy.py` computes the same quantities with scipy;
//! its output, `tests/golden/stats_scipy.json`, is asserted by the unit tests.
//!
//! References: Agarwal et al., "Deep Reinforcement Learning at the Edge of the Statistical
//! Precipice" (NeurIPS 2021; rliable); Colas, Sigaud and Oudeyer, "How Many Random Seeds?"
//! (2018); Clopper and Pearson (1934); Newcombe (1998) for the published interval values.

pub mod aggregate;
pub mod binomial;
pub mod bootstrap;
pub mod permutation;
pub mod power;
pub mod sensitivity;
pub mod special;
pub mod student_t;

#[cfg(test)]
mod golden;

/// The confidence of every interval on the pages.
pub const CONFIDENCE: f64 = 0.95;
/// The two-sided level of every test on the pages.
pub const ALPHA: f64 = 0.05;
/// The power a study is planned for.
pub const POWER: f64 = 0.8;
/// Resamples of every bootstrap interval and Monte-Carlo permutation test on the pages.
pub const REPS: usize = 10_000;
/// The seed of the pages' resampling streams (`training_stream(SEED, "bootstrap")`...).
pub const SEED: u64 = 0;
