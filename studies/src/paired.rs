//! A paired difference as the studies' tables print it: the mean with the 95 % percentile
//! bootstrap interval of the differences ([`host_trainer::stats::bootstrap::mean_text`]), and the
//! two-sided sign-flip permutation p of the mean being 0
//! ([`host_trainer::stats::permutation`]: exact up to 20 pairs, else
//! [`host_trainer::stats::REPS`] random sign patterns of the stream seeded
//! [`host_trainer::stats::SEED`]).

use host_trainer::stats::bootstrap::mean_text;
use host_trainer::stats::permutation::sign_flip_permutation;
use host_trainer::stats::student_t::Range;
use host_trainer::stats::{REPS, SEED};

/// The range of a difference of two rates (for the t intervals the pre-registered rules read).
pub const RATE: Range = (-1.0, 1.0);
/// The range of a difference of two quantities without bounds of their own that bind it (two
/// settled errors).
pub const ANY: Range = (f64::NEG_INFINITY, f64::INFINITY);

/// `mean [lo, hi], p P` for the paired differences `diffs`, with `decimals` digits (p with 3);
/// `mean (all n equal), p 1.000` where every difference is the same; `–` for none.
///
/// ```
/// use studies::paired::paired_text;
/// // Five positive differences: only all-plus and all-minus reach the observed sum (2 of 32).
/// // The bootstrap interval stays within the differences seen.
/// assert_eq!(
///     paired_text(&[0.01, 0.02, 0.03, 0.04, 0.05], 2),
///     "0.03 [0.02, 0.04], p 0.062"
/// );
/// assert_eq!(paired_text(&[0.0; 4], 2), "0.00 (all 4 equal), p 1.000");
/// assert_eq!(paired_text(&[], 2), "–");
/// ```
pub fn paired_text(diffs: &[f64], decimals: usize) -> String {
    if diffs.is_empty() {
        return "–".into();
    }
    let p = sign_flip_permutation(diffs, REPS as u64, SEED);
    format!("{}, p {:.3}", mean_text(diffs, decimals), p.p)
}
