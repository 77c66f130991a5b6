//! The special functions the tests and intervals need: the regularized incomplete beta function
//! and its inverse (exact binomial intervals), and the standard normal distribution (power).
//!
//! Why our own rather than a statistics crate: the module needs four functions, `libm` (already
//! a dependency, the musl ports) gives `lgamma` and `erfc`, and a continued fraction plus a
//! bisection are some sixty lines that the tests check against scipy to 1e-10; `statrs` would
//! bring `nalgebra` 0.33 and `rand` 0.8 beside the workspace's own pins of both.

/// The regularized incomplete beta function `I_x(a, b)`, for `a, b > 0` and `x` in `[0, 1]`
/// (the CDF of the Beta(a, b) distribution at `x`).
///
/// The continued fraction of Numerical Recipes §6.4, evaluated by the modified Lentz method,
/// on the side of `x = (a + 1) / (a + b + 2)` where it converges fast, the other side through
/// `I_x(a, b) = 1 − I_{1−x}(b, a)`.
///
/// ```
/// use host_trainer::stats::special::incomplete_beta;
/// // Beta(1, 1) is uniform; Beta(2, 1) has CDF x².
/// assert!((incomplete_beta(0.3, 1.0, 1.0) - 0.3).abs() < 1e-14);
/// assert!((incomplete_beta(0.3, 2.0, 1.0) - 0.09).abs() < 1e-14);
/// // scipy.special.betainc(2.5, 4.0, 0.4)
/// assert!((incomplete_beta(0.4, 2.5, 4.0) - 0.555_801_921_551_194_5).abs() < 1e-12);
/// ```
pub fn incomplete_beta(x: f64, a: f64, b: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let ln_front =
        libm::lgamma(a + b) - libm::lgamma(a) - libm::lgamma(b) + a * x.ln() + b * (1.0 - x).ln();
    if x < (a + 1.0) / (a + b + 2.0) {
        ln_front.exp() * beta_fraction(x, a, b) / a
    } else {
        1.0 - ln_front.exp() * beta_fraction(1.0 - x, b, a) / b
    }
}

/// The continued fraction of `I_x(a, b)` by the modified Lentz method.
fn beta_fraction(x: f64, a: f64, b: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    d = 1.0 / if d.abs() < TINY { TINY } else { d };
    let mut h = d;
    for m in 1..=1000 {
        let m = f64::from(m);
        let m2 = 2.0 * m;
        // The even step, then the odd step, of the fraction.
        for coefficient in [
            m * (b - m) * x / ((qam + m2) * (a + m2)),
            -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2)),
        ] {
            d = 1.0 + coefficient * d;
            d = 1.0 / if d.abs() < TINY { TINY } else { d };
            c = 1.0 + coefficient / c;
            if c.abs() < TINY {
                c = TINY;
            }
            h *= d * c;
            if coefficient != 0.0 && (d * c - 1.0).abs() < 1e-16 {
                return h;
            }
        }
        if (d * c - 1.0).abs() < 1e-16 {
            break;
        }
    }
    h
}

/// The `p`-quantile of Beta(a, b): the `x` with `I_x(a, b) = p`, by bisection on `[0, 1]`
/// (the CDF is increasing, so bisection always converges; 200 halvings reach the last bit).
///
/// ```
/// use host_trainer::stats::special::beta_quantile;
/// // Beta(1, 5): CDF 1 − (1 − x)^5, so the 0.975-quantile is 1 − 0.025^(1/5).
/// let x = beta_quantile(0.975, 1.0, 5.0);
/// assert!((x - (1.0 - 0.025f64.powf(0.2))).abs() < 1e-12);
/// ```
pub fn beta_quantile(p: f64, a: f64, b: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if incomplete_beta(mid, a, b) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The standard normal CDF `Φ(z)`, as `erfc(−z/√2) / 2` (accurate in both tails).
///
/// ```
/// use host_trainer::stats::special::normal_cdf;
/// assert_eq!(normal_cdf(0.0), 0.5);
/// assert!((normal_cdf(1.959_963_984_540_054) - 0.975).abs() < 1e-15);
/// ```
pub fn normal_cdf(z: f64) -> f64 {
    0.5 * libm::erfc(-z / core::f64::consts::SQRT_2)
}

/// The standard normal quantile `Φ⁻¹(p)` for `p` in `(0, 1)`, by bisection on [`normal_cdf`].
///
/// ```
/// use host_trainer::stats::special::normal_quantile;
/// assert!((normal_quantile(0.975) - 1.959_963_984_540_054).abs() < 1e-12);
/// assert!((normal_quantile(0.8) - 0.841_621_233_572_914_3).abs() < 1e-12);
/// ```
pub fn normal_quantile(p: f64) -> f64 {
    let (mut lo, mut hi) = (-40.0f64, 40.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if normal_cdf(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_incomplete_beta_is_symmetric_and_monotone() {
        for &(a, b) in &[(0.5, 0.5), (1.0, 20.0), (3.0, 7.0), (50.0, 2.0)] {
            let mut last = 0.0;
            for i in 1..100 {
                let x = f64::from(i) / 100.0;
                let v = incomplete_beta(x, a, b);
                assert!(v >= last, "a {a} b {b} x {x}");
                let mirrored = 1.0 - incomplete_beta(1.0 - x, b, a);
                assert!((v - mirrored).abs() < 1e-12, "a {a} b {b} x {x}");
                last = v;
            }
        }
    }
}
