//! Counts of runs: the exact (Clopper–Pearson) interval of a rate, and the exact McNemar test
//! of paired pass/fail outcomes.
//!
//! Why Clopper–Pearson rather than Wilson: it is the interval that *guarantees* its coverage
//! (at least 95 % for every true rate and every n), where Wilson's is 95 % only on average over
//! the rate and falls below it near 0 and 1, which is where a failure rate of a few runs sits.
//! With five runs the price of the guarantee is width, and the width is the truth: 0 failures of
//! 5 is [0, 0.522], 4 of 5 is [0.284, 0.995]. A t interval on the same 0/1 values gives
//! "0.00 ± 0.00" and "0.80 ± 0.56", the first claiming certainty, the second running past 1.

use super::special::{beta_quantile, incomplete_beta};

/// The two-sided Clopper–Pearson interval of a rate seen `k` times in `n` trials, at
/// `confidence` (e.g. 0.95): `[B(α/2; k, n−k+1), B(1−α/2; k+1, n−k)]` with `B` the Beta
/// quantile and `α = 1 − confidence`, the lower end 0 when `k = 0` and the upper 1 when
/// `k = n`. `n = 0` gives `[0, 1]`.
///
/// ```
/// use host_trainer::stats::binomial::clopper_pearson;
/// let (lo, hi) = clopper_pearson(0, 5, 0.95);
/// assert_eq!(lo, 0.0);
/// assert!((hi - 0.5218).abs() < 1e-4);
/// let (lo, hi) = clopper_pearson(4, 5, 0.95);
/// assert!((lo - 0.2836).abs() < 1e-4 && (hi - 0.9949).abs() < 1e-4);
/// assert_eq!(clopper_pearson(0, 0, 0.95), (0.0, 1.0));
/// ```
pub fn clopper_pearson(k: u64, n: u64, confidence: f64) -> (f64, f64) {
    let k = k.min(n);
    let alpha = 1.0 - confidence;
    let (kf, nf) = (k as f64, n as f64);
    let lo = if k == 0 {
        0.0
    } else {
        beta_quantile(alpha / 2.0, kf, nf - kf + 1.0)
    };
    let hi = if k == n {
        1.0
    } else {
        beta_quantile(1.0 - alpha / 2.0, kf + 1.0, nf - kf)
    };
    (lo, hi)
}

/// `P(X ≤ k)` for `X` ~ Binomial(n, p), through `1 − I_p(k + 1, n − k)`.
///
/// ```
/// use host_trainer::stats::binomial::binomial_cdf;
/// assert!((binomial_cdf(0, 4, 0.5) - 0.0625).abs() < 1e-15);
/// assert!((binomial_cdf(2, 4, 0.5) - 0.6875).abs() < 1e-15);
/// assert_eq!(binomial_cdf(4, 4, 0.5), 1.0);
/// ```
pub fn binomial_cdf(k: u64, n: u64, p: f64) -> f64 {
    if k >= n {
        return 1.0;
    }
    1.0 - incomplete_beta(p, k as f64 + 1.0, (n - k) as f64)
}

/// The exact two-sided McNemar test of paired pass/fail outcomes: `b` pairs where the first
/// failed and the second did not, `c` the other way round (the concordant pairs carry no
/// information on the difference). Under the null each discordant pair goes either way with
/// probability ½, so `p = min(1, 2 · P(X ≤ min(b, c)))` with `X` ~ Binomial(b + c, ½), as
/// scipy's `binomtest(b, b + c, 0.5)` gives it. No discordant pair: p = 1.
///
/// The smallest p it can give is `2 · 0.5^(b+c)`: below 0.05 only from 6 discordant pairs on.
///
/// ```
/// use host_trainer::stats::binomial::mcnemar_exact;
/// assert_eq!(mcnemar_exact(4, 0), 0.125);
/// assert!((mcnemar_exact(1, 6) - 0.125).abs() < 1e-12);
/// assert_eq!(mcnemar_exact(0, 0), 1.0);
/// assert!((mcnemar_exact(7, 3) - 0.34375).abs() < 1e-12);
/// ```
pub fn mcnemar_exact(b: u64, c: u64) -> f64 {
    let n = b + c;
    if n == 0 {
        return 1.0;
    }
    (2.0 * binomial_cdf(b.min(c), n, 0.5)).min(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: (f64, f64), b: (f64, f64), tol: f64) -> bool {
        (a.0 - b.0).abs() < tol && (a.1 - b.1).abs() < tol
    }

    #[test]
    fn published_clopper_pearson_intervals() {
        // Newcombe (1998), "Two-sided confidence intervals for the single proportion",
        // Statistics in Medicine 17:857–872, Table II, the exact method, four decimals.
        for (k, n, lo, hi) in [
            (15, 148, 0.0578, 0.1617),
            (0, 20, 0.0, 0.1684),
            (1, 29, 0.0009, 0.1776),
        ] {
            let got = clopper_pearson(k, n, 0.95);
            assert!(close(got, (lo, hi), 5e-5), "{k}/{n}: {got:?}");
        }
        // The closed forms at the ends: 0 of n has upper end 1 − (α/2)^(1/n), n of n has lower
        // end (α/2)^(1/n).
        for n in 1..40u64 {
            let end = 0.025f64.powf(1.0 / n as f64);
            assert!((clopper_pearson(0, n, 0.95).1 - (1.0 - end)).abs() < 1e-12);
            assert!((clopper_pearson(n, n, 0.95).0 - end).abs() < 1e-12);
        }
    }

    #[test]
    fn intervals_stay_in_the_unit_range_and_hold_the_rate() {
        for n in 0..60u64 {
            for k in 0..=n {
                let (lo, hi) = clopper_pearson(k, n, 0.95);
                let rate = if n == 0 { 0.5 } else { k as f64 / n as f64 };
                assert!(
                    (0.0..=rate).contains(&lo) && (rate..=1.0).contains(&hi),
                    "{k}/{n}"
                );
            }
        }
    }

    #[test]
    fn mcnemar_is_symmetric_and_never_above_one() {
        for b in 0..15 {
            for c in 0..15 {
                let p = mcnemar_exact(b, c);
                assert_eq!(p, mcnemar_exact(c, b));
                assert!(p > 0.0 && p <= 1.0);
            }
        }
    }
}
