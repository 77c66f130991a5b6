//! A claim judged twice: by the rule fixed before the runs (the pre-registered verdict, a 95 %
//! t interval of paired differences) and by exact tests ([`crate::stats`]), each with its
//! sensitivity, and the power the comparison had.
//!
//! A claim reads a list of runs, in arms of equal length paired by position (seed). A verdict
//! is a function of those runs' values, so [`sensitivity`] can ask which runs would flip it.
//! The exact rules:
//! - a difference is **above** (below) 0 when its two-sided test gives p < 0.05 and its mean is
//!   above (below) 0: the sign-flip permutation test of paired differences of a continuous
//!   quantity, the exact McNemar test of paired pass/fail outcomes;
//! - a claim that needs several differences all above 0 needs each at p < 0.05 (an
//!   intersection–union test, which needs no correction); one contradicted by any of `m`
//!   differences below 0 needs that one at p < 0.05 / m (Bonferroni).

use crate::stats::binomial::mcnemar_exact;
use crate::stats::permutation::{sign_flip_permutation, PValue};
use crate::stats::power::{pairs_for_mean_difference, power_paired};
use crate::stats::sensitivity::{sensitivity, Sensitivity};
use crate::stats::student_t::{self, mean_interval};
use crate::stats::{ALPHA, POWER, REPS, SEED};

/// The largest number of runs [`sensitivity`] changes at once.
pub const SENSITIVITY_RUNS: usize = 3;

/// A claim's verdict word.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Word {
    /// The rule's "reproduced".
    Reproduced,
    /// Neither way.
    NotReproduced,
    /// The rule's "contradicted".
    Contradicted,
}

impl Word {
    /// The word as the page prints it.
    pub fn text(self) -> &'static str {
        match self {
            Word::Reproduced => "reproduced",
            Word::NotReproduced => "not reproduced",
            Word::Contradicted => "contradicted",
        }
    }

    /// Reproduced if `reproduced`, else contradicted if `contradicted`, else not reproduced.
    pub fn of(reproduced: bool, contradicted: bool) -> Word {
        if contradicted {
            Word::Contradicted
        } else if reproduced {
            Word::Reproduced
        } else {
            Word::NotReproduced
        }
    }
}

/// Which side of 0 a paired difference lies on, by a test.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// Above 0.
    Above,
    /// Below 0.
    Below,
    /// Neither.
    Spans,
}

/// The side of 0 of the 95 % t interval of `diffs` (the pre-registered rule).
pub fn t_side(diffs: &[f64]) -> Side {
    match student_t::against(diffs, 0.0) {
        std::cmp::Ordering::Greater => Side::Above,
        std::cmp::Ordering::Less => Side::Below,
        std::cmp::Ordering::Equal => Side::Spans,
    }
}

/// The side of 0 of `diffs` by the sign-flip permutation test at level `alpha`.
pub fn permutation_side(diffs: &[f64], alpha: f64) -> Side {
    let mean: f64 = diffs.iter().sum();
    match sign_flip_permutation(diffs, REPS as u64, SEED).p < alpha {
        true if mean > 0.0 => Side::Above,
        true if mean < 0.0 => Side::Below,
        _ => Side::Spans,
    }
}

/// The discordant pairs of pass/fail differences (1 − 0 = 1, 0 − 1 = −1): `(b, c)`.
pub fn discordant(diffs: &[f64]) -> (u64, u64) {
    let b = diffs.iter().filter(|d| **d > 0.5).count() as u64;
    let c = diffs.iter().filter(|d| **d < -0.5).count() as u64;
    (b, c)
}

/// The side of 0 of pass/fail `diffs` by the exact McNemar test at level `alpha`.
pub fn mcnemar_side(diffs: &[f64], alpha: f64) -> Side {
    let (b, c) = discordant(diffs);
    match mcnemar_exact(b, c) < alpha {
        true if b > c => Side::Above,
        true if c > b => Side::Below,
        _ => Side::Spans,
    }
}

/// `a[i] − b[i]`.
pub fn differences(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}

/// The arms of `runs`, each `len` long, in order.
pub fn arms(runs: &[f64], len: usize) -> Vec<&[f64]> {
    runs.chunks(len.max(1)).collect()
}

/// For each run of arm `i`, the lowest and highest value of arm `partner(i)`: the change a
/// sensitivity figure tries ("a run that came out like the other arm's worst or best run").
pub fn partner_extremes(runs: &[f64], len: usize, partner: fn(usize) -> usize) -> Vec<Vec<f64>> {
    let arms = arms(runs, len);
    (0..runs.len())
        .map(|i| {
            let other = arms[partner(i / len)];
            let lo = other.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = other.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            vec![lo, hi]
        })
        .collect()
}

/// A claim judged both ways.
#[derive(Debug)]
pub struct Judged {
    /// The pre-registered verdict.
    pub pre: Word,
    /// Its sensitivity.
    pub pre_sensitivity: Sensitivity,
    /// The verdict by exact tests.
    pub exact: Word,
    /// Its sensitivity.
    pub exact_sensitivity: Sensitivity,
}

/// Judges `runs` by `pre` and `exact`, with their sensitivities under `alternatives`.
pub fn judge(
    runs: &[f64],
    alternatives: &[Vec<f64>],
    pre: impl Fn(&[f64]) -> Word,
    exact: impl Fn(&[f64]) -> Word,
) -> Judged {
    let alt = |i: usize, _: f64| alternatives[i].clone();
    Judged {
        pre: pre(runs),
        pre_sensitivity: sensitivity(runs, alt, &pre, SENSITIVITY_RUNS),
        exact: exact(runs),
        exact_sensitivity: sensitivity(runs, alt, &exact, SENSITIVITY_RUNS),
    }
}

/// `mean ± h over n seeds` (the pre-registered interval, as the rule reads it).
pub fn t_text(diffs: &[f64]) -> String {
    format!(
        "{} over {} seeds",
        student_t::interval_text(diffs, 2),
        diffs.len()
    )
}

/// The sign-flip test of `diffs` as text: `mean −0.20, p = 0.2500 (exact over 32)`.
pub fn permutation_text(diffs: &[f64]) -> String {
    let p: PValue = sign_flip_permutation(diffs, REPS as u64, SEED);
    let mean = diffs.iter().sum::<f64>() / diffs.len().max(1) as f64;
    format!("mean {mean:+.2}, {p}")
}

/// The power of a paired comparison of `diffs` at its own n, and the pairs that 0.8 needs, for
/// its observed mean and spread: `power 0.21 at 5 pairs; 0.8 needs 23`.
pub fn paired_power_text(diffs: &[f64]) -> String {
    let Some(m) = mean_interval(diffs) else {
        return "no power figure without pairs".into();
    };
    let sd = if diffs.len() > 1 {
        (diffs.iter().map(|d| (d - m.mean).powi(2)).sum::<f64>() / (diffs.len() - 1) as f64).sqrt()
    } else {
        0.0
    };
    if m.mean == 0.0 || sd == 0.0 {
        return format!(
            "no power figure (observed {} 0)",
            if m.mean == 0.0 { "mean" } else { "spread" }
        );
    }
    let power = power_paired(m.mean, sd, diffs.len() as u64, ALPHA);
    let needed =
        pairs_for_mean_difference(m.mean, sd, ALPHA, POWER).map_or("–".into(), |n| n.to_string());
    format!(
        "power {power:.2} at {} pairs for the observed {:+.2} (sd {sd:.2}); {POWER} needs {needed}",
        diffs.len(),
        m.mean
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sides_by_each_test() {
        let up = [0.5, 0.6, 0.7, 0.8, 0.9, 0.4];
        assert_eq!(t_side(&up), Side::Above);
        assert_eq!(permutation_side(&up, 0.05), Side::Above); // 2/64
        assert_eq!(permutation_side(&up[..5], 0.05), Side::Spans); // 2/32 at best
        let fails = [1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 1.0, 1.0];
        assert_eq!(discordant(&fails), (6, 0));
        assert_eq!(mcnemar_side(&fails, 0.05), Side::Above); // 2/64
        assert_eq!(mcnemar_side(&fails[..5], 0.05), Side::Spans); // 4 discordant: 0.125
    }

    #[test]
    fn partners_are_the_other_arm() {
        let runs = [0.1, 0.2, 0.9, 0.7];
        let alt = partner_extremes(&runs, 2, |a| 1 - a);
        assert_eq!(
            alt,
            vec![
                vec![0.7, 0.9],
                vec![0.7, 0.9],
                vec![0.1, 0.2],
                vec![0.1, 0.2]
            ]
        );
    }
}
