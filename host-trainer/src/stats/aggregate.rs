//! Aggregates over runs and tasks as rliable computes them: the interquartile mean, the
//! probability of improvement and the performance profile, each with its stratified bootstrap
//! interval.
//!
//! Why these: over few runs the mean is pulled by one outlying seed and the median ignores all
//! but one or two; the interquartile mean (the mean of the middle half) is as robust as the
//! median and as efficient as the mean's neighbourhood allows (Agarwal et al., 2021, §4). The
//! probability of improvement asks what a user cares about, how often a run of one method
//! beats a run of another, with no scale to argue about.

use super::bootstrap::{stratified_bootstrap_ci, Interval};

/// The interquartile mean: the mean of what is left after cutting `⌊n/4⌋` values from each end
/// of the sorted values, exactly `scipy.stats.trim_mean(x, 0.25)` (rliable's IQM on the
/// flattened scores). `NaN` for no values.
///
/// ```
/// use host_trainer::stats::aggregate::iqm;
/// assert_eq!(iqm(&[1.0, 2.0, 3.0, 4.0]), 2.5); // cuts 1 and 4
/// assert_eq!(iqm(&[0.0, 0.0, 1.0, 1.0, 1.0]), 2.0 / 3.0); // n = 5 cuts one from each end
/// assert_eq!(iqm(&[100.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]), 4.5);
/// assert!(iqm(&[]).is_nan());
/// ```
pub fn iqm(xs: &[f64]) -> f64 {
    let mut sorted = xs.to_vec();
    sorted.sort_by(f64::total_cmp);
    let cut = xs.len() / 4;
    let middle = &sorted[cut..xs.len() - cut];
    middle.iter().sum::<f64>() / middle.len() as f64
}

/// The probability that a run of `x` beats a run of `y`: the Mann–Whitney U of `x` over `y`
/// divided by `n · m`, a tie counting ½, i.e. `P(X > Y) + ½ P(X = Y)` over all pairs (one task
/// of rliable's `probability_of_improvement`). `NaN` if either side is empty.
///
/// ```
/// use host_trainer::stats::aggregate::probability_of_improvement;
/// assert_eq!(probability_of_improvement(&[3.0, 4.0], &[1.0, 2.0]), 1.0);
/// assert_eq!(probability_of_improvement(&[1.0, 3.0], &[2.0, 2.0]), 0.5);
/// assert_eq!(probability_of_improvement(&[1.0], &[1.0]), 0.5);
/// ```
pub fn probability_of_improvement(x: &[f64], y: &[f64]) -> f64 {
    let u: f64 = x
        .iter()
        .flat_map(|a| y.iter().map(move |b| (a, b)))
        .map(|(a, b)| match a.partial_cmp(b) {
            Some(std::cmp::Ordering::Greater) => 1.0,
            Some(std::cmp::Ordering::Equal) => 0.5,
            _ => 0.0,
        })
        .sum();
    u / (x.len() * y.len()) as f64
}

/// The IQM of every run of every task, with its stratified bootstrap interval (runs resampled
/// within each task; `reps` replicates from the stream `seed`).
///
/// ```
/// use host_trainer::stats::aggregate::iqm_ci;
/// let tasks = vec![vec![0.5, 0.6, 0.7, 0.8], vec![0.1, 0.9, 0.9, 1.0]];
/// let ci = iqm_ci(&tasks, 0.95, 2_000, 0);
/// assert!((ci.estimate - 0.75).abs() < 1e-12); // the middle four of eight: 0.6, 0.7, 0.8, 0.9
/// assert!(ci.lo <= ci.estimate && ci.estimate <= ci.hi);
/// ```
pub fn iqm_ci(tasks: &[Vec<f64>], confidence: f64, reps: usize, seed: u64) -> Interval {
    stratified_bootstrap_ci(tasks, |t| iqm(&t.concat()), confidence, reps, seed)
}

/// The probability of improvement of `x` over `y` averaged over tasks (`x[t]` and `y[t]` the
/// runs of task `t`), with its stratified bootstrap interval: each replicate resamples the runs
/// of each method within each task, as rliable does.
///
/// ```
/// use host_trainer::stats::aggregate::probability_of_improvement_ci;
/// let x = vec![vec![0.9, 0.8, 1.0], vec![0.6, 0.7, 0.5]];
/// let y = vec![vec![0.1, 0.2, 0.3], vec![0.6, 0.4, 0.5]];
/// let ci = probability_of_improvement_ci(&x, &y, 0.95, 2_000, 0);
/// // Task 1: x always wins; task 2: 6 wins, 2 ties of 9 pairs: (1 + 7/9) / 2.
/// assert!((ci.estimate - (1.0 + 7.0 / 9.0) / 2.0).abs() < 1e-12);
/// assert!(ci.lo >= 0.5 && ci.hi <= 1.0);
/// ```
pub fn probability_of_improvement_ci(
    x: &[Vec<f64>],
    y: &[Vec<f64>],
    confidence: f64,
    reps: usize,
    seed: u64,
) -> Interval {
    // Both methods' tasks as strata of one stratified resample: x's tasks, then y's.
    let strata: Vec<Vec<f64>> = x.iter().chain(y).cloned().collect();
    let tasks = x.len();
    let average = |s: &[Vec<f64>]| {
        (0..tasks)
            .map(|t| probability_of_improvement(&s[t], &s[tasks + t]))
            .sum::<f64>()
            / tasks as f64
    };
    stratified_bootstrap_ci(&strata, average, confidence, reps, seed)
}

/// The performance profile at `tau` (rliable's run-score distribution): the share of runs whose
/// score is above `tau`, averaged over tasks, so that each task weighs the same whatever its
/// number of runs. Tasks without runs are left out; `NaN` if none has any.
///
/// ```
/// use host_trainer::stats::aggregate::performance_profile;
/// let tasks = vec![vec![0.2, 0.6, 1.0, 1.0], vec![0.0, 0.9]];
/// assert_eq!(performance_profile(&tasks, 0.5), (3.0 / 4.0 + 1.0 / 2.0) / 2.0);
/// assert_eq!(performance_profile(&tasks, 1.0), 0.0); // strictly above
/// assert_eq!(performance_profile(&tasks, -1.0), 1.0);
/// ```
pub fn performance_profile(tasks: &[Vec<f64>], tau: f64) -> f64 {
    let shares: Vec<f64> = tasks
        .iter()
        .filter(|t| !t.is_empty())
        .map(|t| t.iter().filter(|&&x| x > tau).count() as f64 / t.len() as f64)
        .collect();
    shares.iter().sum::<f64>() / shares.len() as f64
}

/// [`performance_profile`] at each of `taus`, each with its stratified bootstrap interval. Every
/// `tau` draws the same resamples (the same stream `seed`), so the band is one set of
/// replicates read at each threshold, as rliable draws it.
///
/// ```
/// use host_trainer::stats::aggregate::performance_profile_ci;
/// let tasks = vec![vec![0.2, 0.6, 1.0, 1.0], vec![0.0, 0.9, 0.95]];
/// let band = performance_profile_ci(&tasks, &[0.0, 0.5, 0.99], 0.95, 2_000, 0);
/// assert_eq!(band.len(), 3);
/// // Never rising with the threshold, each estimate within its interval.
/// assert!(band.windows(2).all(|w| w[1].estimate <= w[0].estimate));
/// assert!(band.iter().all(|i| i.lo <= i.estimate && i.estimate <= i.hi && i.hi <= 1.0));
/// ```
pub fn performance_profile_ci(
    tasks: &[Vec<f64>],
    taus: &[f64],
    confidence: f64,
    reps: usize,
    seed: u64,
) -> Vec<Interval> {
    taus.iter()
        .map(|&tau| {
            stratified_bootstrap_ci(
                tasks,
                |t| performance_profile(t, tau),
                confidence,
                reps,
                seed,
            )
        })
        .collect()
}
