//! Percentile bootstrap intervals with a fixed seed: of one sample, and stratified (runs
//! resampled within each task, rliable's scheme for scores aggregated over several tasks).
//!
//! Why percentile intervals and a fixed seed: rliable (Agarwal et al., NeurIPS 2021) reports
//! means and aggregates with percentile bootstrap intervals, and a page must be rebuilt byte
//! for byte, so the resamples come from the workspace's seeded ChaCha streams
//! (`firmware_sim::seed::training_stream(seed, "bootstrap")`).
//!
//! A cell's mean over its seeds takes the percentile interval ([`mean_ci`], [`mean_text`]): it
//! never leaves the range of the values themselves (a rate stays in [0, 1], an error at 0 or
//! above, with no clipping), and it claims nothing from seeds that all gave one value. Its price
//! is coverage: it cannot reach beyond the values seen, and its width is that of a normal
//! interval with n rather than n − 1 in the spread, so over five normally spread values it
//! holds the mean about 83 % of the time rather than 95 % (the test below measures it). It
//! describes the spread of the seeds; verdicts rest on the exact tests of
//! [`super::permutation`] and [`super::binomial`], never on whether two such intervals overlap.

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

/// The mean of `values` with its 95 % percentile bootstrap interval
/// ([`CONFIDENCE`](super::CONFIDENCE), [`REPS`](super::REPS) resamples of the stream
/// [`SEED`](super::SEED)); `None` for no values.
///
/// ```
/// use host_trainer::stats::bootstrap::mean_ci;
/// // The paper's DCP on the pinwheel, seeds 0–4. The exact bootstrap distribution (all 5^5
/// // resamples, numpy) has its 2.5 % and 97.5 % points at 0.354 and 0.948.
/// let ci = mean_ci(&[1.0, 0.12, 0.74, 0.41, 1.0]).unwrap();
/// assert!((ci.estimate - 0.654).abs() < 1e-12);
/// assert!((ci.lo - 0.354).abs() < 0.01 && (ci.hi - 0.948).abs() < 0.01);
/// assert_eq!(mean_ci(&[]), None);
/// ```
pub fn mean_ci(values: &[f64]) -> Option<Interval> {
    let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
    (!values.is_empty())
        .then(|| bootstrap_percentile_ci(values, mean, super::CONFIDENCE, super::REPS, super::SEED))
}

/// `mean [lo, hi]` with [`mean_ci`]'s interval and `decimals` digits; `value (all n equal)`
/// when every value is the same (no spread, so no interval: never `± 0.00`); the value alone
/// for one; `–` for none.
///
/// ```
/// use host_trainer::stats::bootstrap::mean_text;
/// assert_eq!(mean_text(&[1.0, 0.12, 0.74, 0.41, 1.0], 2), "0.65 [0.35, 0.95]");
/// assert_eq!(mean_text(&[1.0; 5], 2), "1.00 (all 5 equal)");
/// assert_eq!(mean_text(&[0.5], 2), "0.50 (1 seed)");
/// assert_eq!(mean_text(&[], 2), "–");
/// ```
pub fn mean_text(values: &[f64], decimals: usize) -> String {
    match values {
        [] => "–".into(),
        [one] => format!("{one:.decimals$} (1 seed)"),
        // `+ 0.0` turns a −0 into 0, which would print as "-0.00".
        [first, rest @ ..] if rest.iter().all(|v| v == first) => {
            format!("{:.decimals$} (all {} equal)", first + 0.0, values.len())
        }
        _ => match mean_ci(values) {
            Some(ci) => format!(
                "{:.decimals$} [{:.decimals$}, {:.decimals$}]",
                ci.estimate, ci.lo, ci.hi
            ),
            None => "–".into(),
        },
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use firmware_sim::seed::normal;

    #[test]
    fn a_cell_interval_stays_in_the_range_of_its_values() {
        let xs = [0.0, 0.0, 0.0, 1.0, 1.0];
        let ci = mean_ci(&xs).expect("values");
        assert!(0.0 <= ci.lo && ci.lo <= ci.estimate && ci.estimate <= ci.hi && ci.hi <= 1.0);
        // Three values 10, 20, 30: each extreme resample (all one value) has probability
        // 1/27 = 3.7 % > 2.5 %, so the interval is the values' range.
        let ci = mean_ci(&[10.0, 20.0, 30.0]).expect("values");
        assert_eq!((ci.lo, ci.hi), (10.0, 30.0));
    }

    #[test]
    fn over_five_normal_values_the_interval_covers_about_83_percent() {
        // The figure the module docs give: 2,000 samples of 5 standard normal values, 1,000
        // resamples each; the share of intervals holding the true mean 0. (A simulation in
        // numpy with 4,000 samples and 2,000 resamples gave 0.833.)
        let mut rng = firmware_sim::seed::training_stream(7, "coverage");
        let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
        let samples = 2_000;
        let held = (0..samples)
            .filter(|&i| {
                let xs: Vec<f64> = (0..5).map(|_| normal(&mut rng)).collect();
                let ci = bootstrap_percentile_ci(&xs, mean, 0.95, 1_000, i);
                ci.lo <= 0.0 && 0.0 <= ci.hi
            })
            .count();
        let coverage = held as f64 / samples as f64;
        assert!((0.80..0.87).contains(&coverage), "{coverage}");
    }
}
