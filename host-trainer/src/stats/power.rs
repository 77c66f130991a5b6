//! How many seeds a comparison needs: the seeds per arm that detect an effect of a given size
//! at a given spread (two-sided α, power 1 − β), and the power a comparison had at its own n.
//!
//! The normal approximation Colas, Sigaud and Oudeyer use in "How Many Random Seeds?" (2018,
//! §5): a two-sample test of means needs `n = 2 (z₁₋α/₂ + z₁₋β)² σ² / Δ²` seeds per arm; a
//! paired one `n = (z₁₋α/₂ + z₁₋β)² σ_d² / Δ²` pairs, with `σ_d` the spread of the paired
//! differences; two rates `p₁`, `p₂` need `n = (z₁₋α/₂ √(2 p̄ q̄) + z₁₋β √(p₁q₁ + p₂q₂))² /
//! (p₁ − p₂)²` per arm (Fleiss, without continuity correction). The approximation is kind to
//! small n (a t or exact test needs a few seeds more), so the figure is a floor, not a promise;
//! the effect and spread are the observed ones, which a study planned from them must say.

use super::special::{normal_cdf, normal_quantile};

/// `z₁₋α/₂ + z_power`.
fn z_sum(alpha: f64, power: f64) -> f64 {
    normal_quantile(1.0 - alpha / 2.0) + normal_quantile(power)
}

/// Rounds a sample size up, never below 2; `None` for no effect (no n detects it).
fn seeds(n: f64) -> Option<u64> {
    (n.is_finite()).then(|| (n.ceil() as u64).max(2))
}

/// Seeds per arm for an unpaired difference of means `effect` at within-arm spread `sd`.
///
/// ```
/// use host_trainer::stats::power::seeds_for_mean_difference;
/// // Δ = σ: 2 (1.95996 + 0.84162)² = 15.70, so 16 per arm.
/// assert_eq!(seeds_for_mean_difference(1.0, 1.0, 0.05, 0.8), Some(16));
/// assert_eq!(seeds_for_mean_difference(0.0, 1.0, 0.05, 0.8), None);
/// ```
pub fn seeds_for_mean_difference(effect: f64, sd: f64, alpha: f64, power: f64) -> Option<u64> {
    seeds(2.0 * (z_sum(alpha, power) * sd / effect).powi(2))
}

/// Pairs (seeds per arm, paired by seed) for a mean paired difference `effect` whose
/// differences spread by `sd_diff`.
///
/// ```
/// use host_trainer::stats::power::pairs_for_mean_difference;
/// // Δ = σ_d: (1.95996 + 0.84162)² = 7.85, so 8 pairs.
/// assert_eq!(pairs_for_mean_difference(1.0, 1.0, 0.05, 0.8), Some(8));
/// ```
pub fn pairs_for_mean_difference(effect: f64, sd_diff: f64, alpha: f64, power: f64) -> Option<u64> {
    seeds(((z_sum(alpha, power) * sd_diff) / effect).powi(2))
}

/// Seeds per arm for rates `p1` against `p2` (e.g. failure rates of runs).
///
/// ```
/// use host_trainer::stats::power::seeds_for_rate_difference;
/// // 0.5 against 0.1: (1.95996 √0.42 + 0.84162 √0.34)² / 0.16 = 19.4, so 20 per arm.
/// assert_eq!(seeds_for_rate_difference(0.5, 0.1, 0.05, 0.8), Some(20));
/// assert_eq!(seeds_for_rate_difference(0.3, 0.3, 0.05, 0.8), None);
/// ```
pub fn seeds_for_rate_difference(p1: f64, p2: f64, alpha: f64, power: f64) -> Option<u64> {
    let pbar = (p1 + p2) / 2.0;
    let spread0 = (2.0 * pbar * (1.0 - pbar)).sqrt();
    let spread1 = (p1 * (1.0 - p1) + p2 * (1.0 - p2)).sqrt();
    let za = normal_quantile(1.0 - alpha / 2.0);
    let zb = normal_quantile(power);
    seeds((za * spread0 + zb * spread1).powi(2) / (p1 - p2).powi(2))
}

/// The power an unpaired comparison of `n` seeds per arm had to detect `effect` at spread
/// `sd`: `Φ(|Δ| / (σ √(2/n)) − z₁₋α/₂)` (the far tail left out).
///
/// ```
/// use host_trainer::stats::power::power_mean_difference;
/// let p = power_mean_difference(1.0, 1.0, 16, 0.05);
/// assert!((p - 0.807).abs() < 1e-3);
/// ```
pub fn power_mean_difference(effect: f64, sd: f64, n: u64, alpha: f64) -> f64 {
    let se = sd * (2.0 / n as f64).sqrt();
    normal_cdf(effect.abs() / se - normal_quantile(1.0 - alpha / 2.0))
}

/// The power a paired comparison of `n` pairs had: `Φ(|Δ| √n / σ_d − z₁₋α/₂)`.
///
/// ```
/// use host_trainer::stats::power::power_paired;
/// assert!((power_paired(1.0, 1.0, 8, 0.05) - 0.807).abs() < 1e-3);
/// ```
pub fn power_paired(effect: f64, sd_diff: f64, n: u64, alpha: f64) -> f64 {
    normal_cdf(effect.abs() * (n as f64).sqrt() / sd_diff - normal_quantile(1.0 - alpha / 2.0))
}

/// The power a comparison of rates `p1` and `p2` with `n` seeds per arm had:
/// `Φ((|p₁ − p₂| √n − z₁₋α/₂ √(2 p̄ q̄)) / √(p₁q₁ + p₂q₂))`.
///
/// ```
/// use host_trainer::stats::power::power_rate_difference;
/// // 5 of 10 against 1 of 10: about 0.50.
/// assert!((power_rate_difference(0.5, 0.1, 10, 0.05) - 0.496).abs() < 1e-3);
/// ```
pub fn power_rate_difference(p1: f64, p2: f64, n: u64, alpha: f64) -> f64 {
    let pbar = (p1 + p2) / 2.0;
    let spread0 = (2.0 * pbar * (1.0 - pbar)).sqrt();
    let spread1 = (p1 * (1.0 - p1) + p2 * (1.0 - p2)).sqrt();
    let za = normal_quantile(1.0 - alpha / 2.0);
    normal_cdf(((p1 - p2).abs() * (n as f64).sqrt() - za * spread0) / spread1)
}
