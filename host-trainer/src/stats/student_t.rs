//! The mean of a per-run quantity over a handful of seeds and its 95 % Student-t interval,
//! clipped to the quantity's range, and Welch's interval of a difference of independent means.
//!
//! A cell has a few seeds, so the interval uses Student's t rather than the normal 1.96: with 5
//! seeds the normal interval would be 36 % too narrow. The two-sided 97.5 % quantile is
//! tabulated for 1 to 30 degrees of freedom (four decimals, the values of any statistics table)
//! and taken as 1.96 beyond, where it is within 4 % of the exact value (2.040 at 31, 1.984 at
//! 100); Welch's fractional degrees of freedom take the exact quantile ([`t_975_df`]).
//!
//! Where t intervals stay: in the rules studies fixed before their runs ("the 95 % t interval
//! of the paired differences lies below 0"), which are kept as written and labelled
//! pre-registered, and on pages built before the bootstrap rule of docs/design.md §7. A cell's
//! mean is now shown with the percentile bootstrap interval of [`super::bootstrap`]: a t
//! interval over five values can leave the quantity's range (0.65 ± 0.48 runs past 1) and, over
//! five equal values, claims certainty ("± 0.00"); clipping hides the first and
//! [`clipped_text`] says "all 5 equal" for the second, which is how the older pages read.
//! A rate *of runs* (how many of five failed) is a count, and takes the exact interval of
//! [`super::binomial`] instead.

use super::special::beta_quantile;

/// The two-sided 95 % quantile of Student's t, `t(0.975, df)`, for df = 1..=30.
const T_975: [f64; 30] = [
    12.7062, 4.3027, 3.1824, 2.7764, 2.5706, 2.4469, 2.3646, 2.3060, 2.2622, 2.2281, // 1-10
    2.2010, 2.1788, 2.1604, 2.1448, 2.1314, 2.1199, 2.1098, 2.1009, 2.0930, 2.0860, // 11-20
    2.0796, 2.0739, 2.0687, 2.0639, 2.0595, 2.0555, 2.0518, 2.0484, 2.0452, 2.0423, // 21-30
];

/// `t(0.975, df)`: the table for df 1..=30, the normal 1.96 beyond; `None` for df = 0 (one
/// value has no spread, so no interval).
///
/// ```
/// use host_trainer::stats::student_t::t_975;
/// assert_eq!(t_975(0), None);
/// assert_eq!(t_975(2), Some(4.3027));
/// assert_eq!(t_975(30), Some(2.0423));
/// assert_eq!(t_975(31), Some(1.96));
/// ```
pub fn t_975(df: usize) -> Option<f64> {
    match df {
        0 => None,
        1..=30 => Some(T_975[df - 1]),
        _ => Some(1.96),
    }
}

/// `t(0.975, df)` for any positive `df`, fractional ones included (Welch's): the `t` with
/// `P(|T| > t) = 0.05`, from `P(|T| > t) = I_{df/(df+t²)}(df/2, 1/2)`.
///
/// ```
/// use host_trainer::stats::student_t::t_975_df;
/// assert!((t_975_df(4.0) - 2.7764).abs() < 1e-4);
/// // scipy.stats.t.ppf(0.975, 2.5) = 3.5746548420036817
/// assert!((t_975_df(2.5) - 3.574_654_842).abs() < 1e-8);
/// ```
pub fn t_975_df(df: f64) -> f64 {
    let x = beta_quantile(0.05, df / 2.0, 0.5);
    (df * (1.0 - x) / x).sqrt()
}

/// Welch's 95 % interval of `Σ sign · mean(group)` over independent groups, as
/// `(estimate, half_width)`: the variance `Σ s²/n`, the Welch–Satterthwaite degrees of
/// freedom `(Σ s²/n)² / Σ (s²/n)² / (n − 1)` and [`t_975_df`]. `None` if a group has fewer than
/// two values or there is no spread at all.
///
/// ```
/// use host_trainer::stats::student_t::welch_interval;
/// let a = [1.0, 2.0, 3.0, 4.0];
/// let b = [2.0, 2.5, 3.5, 6.0, 7.0];
/// let (d, h) = welch_interval(&[(&a[..], 1.0), (&b[..], -1.0)]).unwrap();
/// // scipy.stats.ttest_ind(a, b, equal_var=False).confidence_interval(): [-4.51703, 1.11703]
/// assert!((d + 1.7).abs() < 1e-12 && (h - 2.817_026_455).abs() < 1e-8);
/// ```
pub fn welch_interval(groups: &[(&[f64], f64)]) -> Option<(f64, f64)> {
    let mut estimate = 0.0;
    let (mut var, mut df_den) = (0.0, 0.0);
    for (values, sign) in groups {
        let m = mean_interval(values).filter(|m| m.n > 1)?;
        let n = m.n as f64;
        let s2 = values.iter().map(|v| (v - m.mean).powi(2)).sum::<f64>() / (n - 1.0);
        estimate += sign * m.mean;
        var += s2 / n;
        df_den += (s2 / n).powi(2) / (n - 1.0);
    }
    (var > 0.0).then(|| (estimate, t_975_df(var * var / df_den) * var.sqrt()))
}

/// The mean of some values and the half-width of its 95 % confidence interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeanInterval {
    /// How many values.
    pub n: usize,
    /// Their mean.
    pub mean: f64,
    /// `t(0.975, n - 1) · s / √n` with `s` the sample standard deviation (n − 1 in the
    /// denominator); `None` for a single value.
    pub half_width: Option<f64>,
}

/// The mean and 95 % interval of `values`; `None` if there are none.
///
/// ```
/// use host_trainer::stats::student_t::mean_interval;
/// let m = mean_interval(&[1.0, 2.0, 3.0]).unwrap();
/// assert_eq!(m.mean, 2.0);
/// // s = 1, t(0.975, 2) = 4.3027: 4.3027 / √3
/// assert!((m.half_width.unwrap() - 2.4842).abs() < 1e-4);
/// assert_eq!(mean_interval(&[5.0]).unwrap().half_width, None);
/// assert_eq!(mean_interval(&[]), None);
/// ```
pub fn mean_interval(values: &[f64]) -> Option<MeanInterval> {
    let n = values.len();
    if n == 0 {
        return None;
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    let half_width = t_975(n - 1).map(|t| {
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        t * var.sqrt() / (n as f64).sqrt()
    });
    Some(MeanInterval {
        n,
        mean,
        half_width,
    })
}

/// `mean ± half-width` with `decimals` digits, the mean alone for one value, `–` for none.
///
/// ```
/// use host_trainer::stats::student_t::interval_text;
/// assert_eq!(interval_text(&[1.0, 2.0, 3.0], 2), "2.00 ± 2.48");
/// assert_eq!(interval_text(&[5.0], 1), "5.0");
/// assert_eq!(interval_text(&[], 1), "–");
/// ```
pub fn interval_text(values: &[f64], decimals: usize) -> String {
    match mean_interval(values) {
        None => "–".into(),
        Some(MeanInterval {
            mean,
            half_width: Some(h),
            ..
        }) => format!("{mean:.decimals$} ± {h:.decimals$}"),
        Some(m) => format!("{:.decimals$}", m.mean),
    }
}

/// A quantity's range, for clipping an interval.
pub type Range = (f64, f64);
/// A rate: success, strict reach, stuck at margin.
pub const UNIT: Range = (0.0, 1.0);
/// A distance, a time, a count: never below 0.
pub const NON_NEGATIVE: Range = (0.0, f64::INFINITY);

/// The mean of `values` and its 95 % t interval clipped to `range`, as `(mean, lo, hi)`;
/// `None` with fewer than two values or no spread (every value equal), which have no interval.
///
/// ```
/// use host_trainer::stats::student_t::{clipped_interval, UNIT};
/// // 0.65 ± 0.48 would run past 1.
/// let (mean, lo, hi) = clipped_interval(&[1.0, 0.12, 0.74, 0.41, 1.0], UNIT).unwrap();
/// assert!((mean - 0.654).abs() < 1e-12 && (lo - 0.1765).abs() < 1e-4 && hi == 1.0);
/// assert_eq!(clipped_interval(&[1.0; 5], UNIT), None);
/// ```
pub fn clipped_interval(values: &[f64], range: Range) -> Option<(f64, f64, f64)> {
    let m = mean_interval(values)?;
    let h = m.half_width.filter(|&h| h > 0.0)?;
    Some((m.mean, (m.mean - h).max(range.0), (m.mean + h).min(range.1)))
}

/// `mean [lo, hi]` with the t interval clipped to `range`; `mean (all n equal)` when every
/// value is the same; the value alone for one; `–` for none.
///
/// ```
/// use host_trainer::stats::student_t::{clipped_text, NON_NEGATIVE, UNIT};
/// assert_eq!(clipped_text(&[1.0, 0.12, 0.74, 0.41, 1.0], 2, UNIT), "0.65 [0.18, 1.00]");
/// assert_eq!(clipped_text(&[1.0; 5], 2, UNIT), "1.00 (all 5 equal)");
/// assert_eq!(clipped_text(&[0.1, 0.0, 0.0], 2, NON_NEGATIVE), "0.03 [0.00, 0.18]");
/// assert_eq!(clipped_text(&[0.5], 2, UNIT), "0.50 (1 seed)");
/// assert_eq!(clipped_text(&[], 2, UNIT), "–");
/// ```
pub fn clipped_text(values: &[f64], decimals: usize, range: Range) -> String {
    match (values.len(), clipped_interval(values, range)) {
        (0, _) => "–".into(),
        (1, _) => format!("{:.decimals$} (1 seed)", values[0]),
        (_, Some((mean, lo, hi))) => {
            format!("{mean:.decimals$} [{lo:.decimals$}, {hi:.decimals$}]")
        }
        (n, None) => format!("{:.decimals$} (all {n} equal)", values[0]),
    }
}

/// Where the 95 % interval of `values` lies against `line`: entirely above (`Greater`),
/// entirely below (`Less`), or holding it (`Equal`, also with fewer than two values, which
/// have no interval).
///
/// ```
/// use std::cmp::Ordering;
/// use host_trainer::stats::student_t::against;
/// assert_eq!(against(&[0.6, 0.7, 0.65], 0.5), Ordering::Greater);
/// assert_eq!(against(&[0.9], 0.5), Ordering::Equal);
/// ```
pub fn against(values: &[f64], line: f64) -> std::cmp::Ordering {
    match mean_interval(values) {
        Some(MeanInterval {
            mean,
            half_width: Some(h),
            ..
        }) if mean - h > line => std::cmp::Ordering::Greater,
        Some(MeanInterval {
            mean,
            half_width: Some(h),
            ..
        }) if mean + h < line => std::cmp::Ordering::Less,
        _ => std::cmp::Ordering::Equal,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-4
    }

    #[test]
    fn known_intervals() {
        // Two values 0 and 2: mean 1, s = √2, t(0.975, 1) = 12.7062: 12.7062 · √2 / √2.
        let m = mean_interval(&[0.0, 2.0]).expect("two");
        assert!(close(m.mean, 1.0) && close(m.half_width.expect("df 1"), 12.7062));
        // Five seeds 10, 12, 14, 16, 18: s = √10, t(0.975, 4) = 2.7764: 2.7764 · √10 / √5.
        let m = mean_interval(&[10.0, 12.0, 14.0, 16.0, 18.0]).expect("five");
        assert!(close(m.mean, 14.0));
        assert!(close(m.half_width.expect("df 4"), 2.7764 * 2f64.sqrt()));
        // Equal values: no spread, a zero-width interval.
        let m = mean_interval(&[0.5; 4]).expect("four");
        assert_eq!(m.half_width, Some(0.0));
    }

    #[test]
    fn the_table_falls_towards_the_normal_quantile() {
        for df in 1..40 {
            let (a, b) = (t_975(df).expect("df"), t_975(df + 1).expect("df + 1"));
            assert!(a > b || (a == 1.96 && b == 1.96), "df {df}: {a} then {b}");
            assert!(b >= 1.96);
        }
    }
}
