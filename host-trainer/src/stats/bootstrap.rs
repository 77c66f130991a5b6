//! Percentile bootstrap intervals with a fixed seed: of one sample, and stratified (runs
//! resampled within each task, rliable's scheme for scores aggregated over several tasks).
//!
//! Why percentile intervals and a fixed seed: rliable (Agarwal et al., NeurIPS 2021) reports
//! aggregates over tasks with stratified percentile bootstrap intervals, and a page must be
//! rebuilt byte for byte, so the resamples come from the workspace's seeded ChaCha streams
//! (`firmware_sim::seed::training_stream(seed, "bootstrap")`). With five runs of one cell a
//! bootstrap interval is too narrow (it cannot see beyond the five values, and its width is
//! that of a normal interval with n, not n − 1, in the spread), so a single cell's mean keeps
//! the t interval, clipped to the quantity's range ([`super::student_t`]).

use firmware_sim::seed::{index, training_stream};

/// An estimate and its interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    /// The statistic on the data as observed.
    pub estimate: f64,
    /// The lower end.
    pub lo: f64,
    /// The upper end.
    pub hi: f64,
}

/// The `q`-quantile of `sorted` values by linear interpolation between order statistics
/// (numpy's default), `NaN` for no values.
///
/// ```
/// use host_trainer::stats::bootstrap::quantile;
/// assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0], 0.5), 2.5);
/// assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0], 0.0), 1.0);
/// assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0], 0.25), 1.75);
/// ```
pub fn quantile(sorted: &[f64], q: f64) -> f64 {
    let Some(last) = sorted.len().checked_sub(1) else {
        return f64::NAN;
    };
    let h = last as f64 * q.clamp(0.0, 1.0);
    let below = h.floor() as usize;
    let above = (below + 1).min(last);
    sorted[below] + (h - below as f64) * (sorted[above] - sorted[below])
}

/// The percentile interval of `replicates` at `confidence`, around `estimate`.
fn percentile_interval(mut replicates: Vec<f64>, estimate: f64, confidence: f64) -> Interval {
    replicates.sort_by(f64::total_cmp);
    let alpha = 1.0 - confidence;
    Interval {
        estimate,
        lo: quantile(&replicates, alpha / 2.0),
        hi: quantile(&replicates, 1.0 - alpha / 2.0),
    }
}

/// One resample of `xs` with replacement, drawn into `into`.
fn resample(xs: &[f64], rng: &mut firmware_sim::seed::SimRng, into: &mut Vec<f64>) {
    into.clear();
    into.extend((0..xs.len()).map(|_| xs[index(rng, xs.len())]));
}

/// The percentile bootstrap interval of `statistic(xs)` at `confidence`: `reps` resamples of
/// `xs` with replacement from the stream `seed`, and the α/2 and 1 − α/2 quantiles of the
/// statistic over them. No values: every field `NaN`.
///
/// ```
/// use host_trainer::stats::bootstrap::bootstrap_percentile_ci;
/// let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
/// let xs = [0.2, 0.4, 0.5, 0.7, 0.9, 1.0, 0.3, 0.6];
/// let ci = bootstrap_percentile_ci(&xs, mean, 0.95, 10_000, 0);
/// assert!((ci.estimate - 0.575).abs() < 1e-12);
/// // The exact bootstrap distribution (all 8^8 resamples, on a grid of 0.0125) has its 2.5 %
/// // and 97.5 % points at 0.4 and 0.7625; 10,000 resamples land within a step of them.
/// assert!((ci.lo - 0.4).abs() <= 0.0125 && (ci.hi - 0.7625).abs() <= 0.0125);
/// assert_eq!(ci, bootstrap_percentile_ci(&xs, mean, 0.95, 10_000, 0)); // same seed
/// ```
pub fn bootstrap_percentile_ci(
    xs: &[f64],
    statistic: impl Fn(&[f64]) -> f64,
    confidence: f64,
    reps: usize,
    seed: u64,
) -> Interval {
    if xs.is_empty() {
        return Interval {
            estimate: f64::NAN,
            lo: f64::NAN,
            hi: f64::NAN,
        };
    }
    let mut rng = training_stream(seed, "bootstrap");
    let mut draw = Vec::with_capacity(xs.len());
    let replicates = (0..reps)
        .map(|_| {
            resample(xs, &mut rng, &mut draw);
            statistic(&draw)
        })
        .collect();
    percentile_interval(replicates, statistic(xs), confidence)
}

/// The stratified percentile bootstrap interval of `statistic(tasks)`: each replicate resamples
/// the runs of every task with replacement, within the task (the number of runs per task is
/// kept, no run moves to another task), as rliable's `StratifiedBootstrap` does; `reps`
/// replicates from the stream `seed`.
///
/// ```
/// use host_trainer::stats::bootstrap::stratified_bootstrap_ci;
/// use host_trainer::stats::aggregate::iqm;
/// let tasks = vec![vec![0.1, 0.2, 0.3], vec![0.8, 0.9, 1.0]];
/// let pooled_iqm = |t: &[Vec<f64>]| iqm(&t.concat());
/// let ci = stratified_bootstrap_ci(&tasks, pooled_iqm, 0.95, 2_000, 0);
/// assert!((ci.estimate - 0.55).abs() < 1e-12);
/// // Every replicate keeps three runs of each task, so IQM stays between the tasks' middles.
/// assert!(ci.lo >= 0.2 && ci.hi <= 0.9 && ci.lo < ci.estimate && ci.estimate < ci.hi);
/// ```
pub fn stratified_bootstrap_ci(
    tasks: &[Vec<f64>],
    statistic: impl Fn(&[Vec<f64>]) -> f64,
    confidence: f64,
    reps: usize,
    seed: u64,
) -> Interval {
    let mut rng = training_stream(seed, "bootstrap");
    let mut draw: Vec<Vec<f64>> = tasks.iter().map(|t| Vec::with_capacity(t.len())).collect();
    let replicates = (0..reps)
        .map(|_| {
            for (task, into) in tasks.iter().zip(&mut draw) {
                if !task.is_empty() {
                    resample(task, &mut rng, into);
                }
            }
            statistic(&draw)
        })
        .collect();
    percentile_interval(replicates, statistic(tasks), confidence)
}
