//! Permutation tests of a difference of means: paired (sign flips) and unpaired (splits of the
//! pooled values), exact when every rearrangement can be listed, else a seeded Monte-Carlo.
//!
//! Why permutation tests: they assume only that, with no effect, the labels are exchangeable
//! (a paired difference is as likely to have either sign; a value as likely to sit in either
//! group). With five seeds nothing supports the normality a t test leans on, and the exact test
//! says plainly what five pairs can show: the smallest two-sided p over 5 pairs is 2/32 = 0.0625.
//!
//! Both tests are two-sided on the absolute difference of means: p is the share of
//! rearrangements (the observed one among them) whose |difference| is at least the observed
//! one. A Monte-Carlo p is `(1 + hits) / (1 + draws)`, never 0 (Phipson and Smyth, 2010), as
//! scipy's `permutation_test` computes it.

use std::fmt;

use firmware_sim::seed::{index, training_stream};
use rand_core::Rng;

/// Paired tests list every sign flip up to this many pairs (2^20 = 1,048,576 flips).
pub const EXACT_PAIRS: usize = 20;
/// Unpaired tests list every split up to this many splits.
pub const EXACT_SPLITS: u64 = 1_000_000;

/// How a p-value was computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Draws {
    /// Every rearrangement listed: this many.
    Exact(u64),
    /// This many random rearrangements from a seeded stream.
    MonteCarlo {
        /// Random rearrangements drawn.
        draws: u64,
        /// The seed of the stream they were drawn from.
        seed: u64,
    },
}

/// A p-value and how it was computed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PValue {
    /// The two-sided p-value.
    pub p: f64,
    /// Exact, or Monte-Carlo with its count and seed.
    pub draws: Draws,
}

impl fmt::Display for PValue {
    /// `p = 0.0625 (exact, 32 sign flips)`-like text without the noun: `p = 0.0625 (exact over
    /// 32)` or `p = 0.0123 (Monte-Carlo, 100000 draws, seed 0)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.draws {
            Draws::Exact(n) => write!(f, "p = {:.4} (exact over {n})", self.p),
            Draws::MonteCarlo { draws, seed } => write!(
                f,
                "p = {:.4} (Monte-Carlo, {draws} draws, seed {seed})",
                self.p
            ),
        }
    }
}

/// A statistic at least as extreme as `observed`, with room for rounding: sums of the same
/// values in another order can differ in their last bits.
fn at_least(value: f64, observed: f64, scale: f64) -> bool {
    value >= observed - 1e-12 * scale.max(1.0)
}

/// The two-sided sign-flip permutation p of the mean of paired differences `diffs` being 0:
/// the share of the 2^n sign patterns whose |sum| is at least the observed |sum|, listed
/// exactly for n ≤ [`EXACT_PAIRS`], else from `draws` random patterns of the stream `seed`.
///
/// ```
/// use host_trainer::stats::permutation::{sign_flip_permutation, Draws};
/// // Five positive differences: only all-plus and all-minus reach the observed |sum|.
/// let p = sign_flip_permutation(&[0.1, 0.2, 0.3, 0.4, 0.5], 10_000, 0);
/// assert_eq!(p.p, 2.0 / 32.0);
/// assert_eq!(p.draws, Draws::Exact(32));
/// // Experiment 1's claim 1: the paper's DCP minus DDPG, paired by seed (scipy: 0.25).
/// let p = sign_flip_permutation(&[0.17, -0.30, -0.26, -0.59, 0.0], 10_000, 0);
/// assert_eq!(p.p, 0.25);
/// assert_eq!(sign_flip_permutation(&[], 10, 0).p, 1.0);
/// ```
pub fn sign_flip_permutation(diffs: &[f64], draws: u64, seed: u64) -> PValue {
    if diffs.len() <= EXACT_PAIRS {
        exact_sign_flips(diffs)
    } else {
        sampled_sign_flips(diffs, draws, seed)
    }
}

/// The observed |sum| of `diffs` and the scale of its rounding.
fn observed_sum(diffs: &[f64]) -> (f64, f64) {
    let scale = diffs.iter().map(|d| d.abs()).sum();
    (diffs.iter().sum::<f64>().abs(), scale)
}

/// Every one of the 2^n sign patterns (n below 64).
fn exact_sign_flips(diffs: &[f64]) -> PValue {
    let (observed, scale) = observed_sum(diffs);
    let patterns = 1u64 << diffs.len();
    let hits = (0..patterns)
        .filter(|mask| {
            let sum: f64 = diffs
                .iter()
                .enumerate()
                .map(|(i, d)| if mask >> i & 1 == 1 { -d } else { *d })
                .sum();
            at_least(sum.abs(), observed, scale)
        })
        .count() as u64;
    PValue {
        p: hits as f64 / patterns as f64,
        draws: Draws::Exact(patterns),
    }
}

/// `draws` random sign patterns, one bit of the stream per sign.
fn sampled_sign_flips(diffs: &[f64], draws: u64, seed: u64) -> PValue {
    let (observed, scale) = observed_sum(diffs);
    let mut rng = training_stream(seed, "sign-flips");
    let hits = (0..draws)
        .filter(|_| {
            let mut word = 0u64;
            let sum: f64 = diffs
                .iter()
                .enumerate()
                .map(|(i, d)| {
                    if i % 64 == 0 {
                        word = rng.next_u64();
                    }
                    if word >> (i % 64) & 1 == 1 {
                        -d
                    } else {
                        *d
                    }
                })
                .sum();
            at_least(sum.abs(), observed, scale)
        })
        .count() as u64;
    PValue {
        p: (1 + hits) as f64 / (1 + draws) as f64,
        draws: Draws::MonteCarlo { draws, seed },
    }
}

/// `n` choose `k`, saturating at `u64::MAX`.
///
/// ```
/// use host_trainer::stats::permutation::choose;
/// assert_eq!(choose(10, 5), 252);
/// assert_eq!(choose(5, 0), 1);
/// ```
pub fn choose(n: u64, k: u64) -> u64 {
    let k = k.min(n - k.min(n));
    (0..k).fold(1u64, |acc, i| {
        acc.checked_mul(n - i).map_or(u64::MAX, |v| v / (i + 1))
    })
}

/// The two-sided permutation p of `mean(a) − mean(b)` being 0, for unpaired groups: the share
/// of the ways to split the pooled values into groups of `a`'s and `b`'s sizes whose
/// |difference of means| is at least the observed one; every split listed when there are at
/// most [`EXACT_SPLITS`], else `draws` random splits of the stream `seed`.
///
/// ```
/// use host_trainer::stats::permutation::{permutation_two_sample, Draws};
/// // The observed split is the most extreme of the 10 splits of 5 values into 2 and 3, and so
/// // is its mirror image (difference of the other sign but smaller): p = 1/10.
/// let p = permutation_two_sample(&[10.0, 11.0], &[1.0, 2.0, 3.0], 10_000, 0);
/// assert_eq!(p.draws, Draws::Exact(10));
/// assert!((p.p - 0.1).abs() < 1e-12);
/// ```
pub fn permutation_two_sample(a: &[f64], b: &[f64], draws: u64, seed: u64) -> PValue {
    let pooled: Vec<f64> = a.iter().chain(b).copied().collect();
    let (n, k) = (pooled.len(), a.len());
    if k == 0 || k == n {
        return PValue {
            p: 1.0,
            draws: Draws::Exact(1),
        };
    }
    let total: f64 = pooled.iter().sum();
    let scale: f64 = pooled.iter().map(|v| v.abs()).sum();
    let gap = |sum_a: f64| (sum_a / k as f64 - (total - sum_a) / (n - k) as f64).abs();
    let observed = gap(a.iter().sum());
    let splits = choose(n as u64, k as u64);
    if splits <= EXACT_SPLITS {
        let mut picked: Vec<usize> = (0..k).collect();
        let mut hits = 0u64;
        loop {
            let sum: f64 = picked.iter().map(|&i| pooled[i]).sum();
            hits += u64::from(at_least(gap(sum), observed, scale));
            if !next_combination(&mut picked, n) {
                break;
            }
        }
        return PValue {
            p: hits as f64 / splits as f64,
            draws: Draws::Exact(splits),
        };
    }
    let mut rng = training_stream(seed, "splits");
    let mut order: Vec<usize> = (0..n).collect();
    let hits = (0..draws)
        .filter(|_| {
            // A partial Fisher–Yates shuffle: the first k places are a uniform k-subset.
            for i in 0..k {
                let j = i + index(&mut rng, n - i);
                order.swap(i, j);
            }
            let sum: f64 = order[..k].iter().map(|&i| pooled[i]).sum();
            at_least(gap(sum), observed, scale)
        })
        .count() as u64;
    PValue {
        p: (1 + hits) as f64 / (1 + draws) as f64,
        draws: Draws::MonteCarlo { draws, seed },
    }
}

/// The next k-subset of `0..n` in lexicographic order; false after the last.
pub(super) fn next_combination(picked: &mut [usize], n: usize) -> bool {
    let k = picked.len();
    let Some(i) = (0..k).rev().find(|&i| picked[i] < n - k + i) else {
        return false;
    };
    picked[i] += 1;
    for j in i + 1..k {
        picked[j] = picked[j - 1] + 1;
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_split_is_listed_once() {
        let mut picked = vec![0, 1, 2];
        let mut count = 1;
        while next_combination(&mut picked, 7) {
            count += 1;
        }
        assert_eq!(count, choose(7, 3));
    }

    #[test]
    fn monte_carlo_agrees_with_the_exact_count() {
        // 22 pairs is past the exact limit; listed exactly here all the same (4 M patterns).
        let diffs: Vec<f64> = (0..22).map(|i| f64::from(i % 5) - 1.2).collect();
        let exact = exact_sign_flips(&diffs).p;
        let sampled = sign_flip_permutation(&diffs, 20_000, 3);
        assert!(matches!(
            sampled.draws,
            Draws::MonteCarlo { draws: 20_000, .. }
        ));
        // Within four standard errors of the exact p.
        let se = (exact * (1.0 - exact) / 20_000.0).sqrt();
        assert!(
            (sampled.p - exact).abs() < 4.0 * se + 1e-4,
            "{} {exact}",
            sampled.p
        );
        assert_eq!(sampled, sign_flip_permutation(&diffs, 20_000, 3));
    }
}
