//! Standard normal draws by the ziggurat method (Marsaglia and Tsang, "The Ziggurat Method for
//! Generating Random Variables", J. Stat. Softw. 5(8), 2000), 128 layers.
//!
//! Why not Box–Muller: DCP draws T × 2 normals per minibatch state (2,048 per update at T = 16),
//! and Box–Muller's `logf`, `cosf` and `sqrtf` made those draws 8 % of a training run. The
//! ziggurat returns after one 64-bit draw, a compare and a multiply about 99 % of the time; the
//! rest (the wedges and the tail beyond 3.44) use `libm`'s `exp` and `log`, which give the same
//! bits on every platform, so a seed still gives the same numbers everywhere.
//!
//! One change from the paper's code: the layer index and the signed 32-bit value come from
//! different bits of one 64-bit draw (the paper takes both from one 32-bit word, which
//! correlates the value with its layer).

use std::sync::OnceLock;

/// Layers of the ziggurat.
const LAYERS: usize = 128;
/// Where the tail starts (the paper's `r` for 128 layers).
const TAIL: f64 = 3.442_619_855_899;
/// The area of every layer (the paper's `v`).
const AREA: f64 = 9.912_563_035_262_17e-3;
/// 2^31: the signed 32-bit draws are scaled by `w = x / 2^31`.
const M: f64 = 2_147_483_648.0;

/// The paper's `kn`, `wn` and `fn` tables.
struct Tables {
    /// Fast-accept thresholds on `|hz|`.
    k: [u32; LAYERS],
    /// `x_i / 2^31`: a signed 32-bit draw times `w[i]` is uniform on `(-x_i, x_i)`.
    w: [f64; LAYERS],
    /// `exp(-x_i² / 2)`.
    f: [f64; LAYERS],
}

fn tables() -> &'static Tables {
    static TABLES: OnceLock<Tables> = OnceLock::new();
    TABLES.get_or_init(|| {
        let mut t = Tables {
            k: [0; LAYERS],
            w: [0.0; LAYERS],
            f: [0.0; LAYERS],
        };
        let mut dn = TAIL;
        let mut tn = dn;
        let q = AREA / libm::exp(-0.5 * dn * dn);
        t.k[0] = ((dn / q) * M) as u32;
        t.k[1] = 0;
        t.w[0] = q / M;
        t.w[LAYERS - 1] = dn / M;
        t.f[0] = 1.0;
        t.f[LAYERS - 1] = libm::exp(-0.5 * dn * dn);
        for i in (1..LAYERS - 1).rev() {
            dn = libm::sqrt(-2.0 * libm::log(AREA / dn + libm::exp(-0.5 * dn * dn)));
            t.k[i + 1] = ((dn / tn) * M) as u32;
            tn = dn;
            t.f[i] = libm::exp(-0.5 * dn * dn);
            t.w[i] = dn / M;
        }
        t
    })
}

/// A standard normal sample N(0, 1).
pub(crate) fn normal(rng: &mut impl rand_core::Rng) -> f32 {
    let t = tables();
    loop {
        let bits = rng.next_u64();
        let layer = (bits & (LAYERS as u64 - 1)) as usize;
        let hz = (bits >> 32) as u32 as i32;
        let x = f64::from(hz) * t.w[layer];
        if hz.unsigned_abs() < t.k[layer] {
            return x as f32;
        }
        if layer == 0 {
            return tail(rng, hz > 0);
        }
        // A wedge: accept x under the density between this layer's edge and the one above.
        let y = t.f[layer] + open_unit(rng) * (t.f[layer - 1] - t.f[layer]);
        if y < libm::exp(-0.5 * x * x) {
            return x as f32;
        }
    }
}

/// A draw from the normal tail beyond [`TAIL`] (Marsaglia's 1964 method), with `positive`'s sign.
fn tail(rng: &mut impl rand_core::Rng, positive: bool) -> f32 {
    loop {
        let x = -libm::log(open_unit(rng)) / TAIL;
        let y = -libm::log(open_unit(rng));
        if y + y >= x * x {
            let v = (TAIL + x) as f32;
            return if positive { v } else { -v };
        }
    }
}

/// Uniform on the open interval (0, 1), 32 random bits.
fn open_unit(rng: &mut impl rand_core::Rng) -> f64 {
    (f64::from(rng.next_u32()) + 0.5) / 4_294_967_296.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seed::stream;

    #[test]
    fn tables_match_the_papers_construction() {
        let t = tables();
        // The layers' edges shrink toward the top, and the base reaches the tail.
        assert!((t.w[LAYERS - 1] * M - TAIL).abs() < 1e-12);
        assert!(t.w[1..].windows(2).all(|p| p[0] < p[1]));
        assert!(t.f[1..].windows(2).all(|p| p[0] > p[1]));
        // The top layer's edge is near 0.27 (x_1 of the 128-layer ziggurat).
        let x1 = t.w[1] * M;
        assert!((0.2..0.35).contains(&x1), "x1 = {x1}");
    }

    /// Moments and tail frequencies of a million draws against N(0, 1). The tolerances are
    /// about five standard errors.
    #[test]
    fn draws_have_the_normal_distribution() {
        let mut rng = stream(21, "ziggurat");
        let n = 1_000_000;
        let (mut s1, mut s2, mut s4) = (0.0f64, 0.0f64, 0.0f64);
        let (mut beyond1, mut beyond2, mut beyond_tail) = (0u32, 0u32, 0u32);
        for _ in 0..n {
            let x = f64::from(normal(&mut rng));
            s1 += x;
            s2 += x * x;
            s4 += x * x * x * x;
            beyond1 += u32::from(x.abs() > 1.0);
            beyond2 += u32::from(x.abs() > 2.0);
            beyond_tail += u32::from(x.abs() > TAIL);
        }
        let n = f64::from(n);
        let (mean, var, kurt) = (s1 / n, s2 / n, s4 / n);
        assert!(mean.abs() < 0.005, "mean {mean}");
        assert!((var - 1.0).abs() < 0.008, "variance {var}");
        assert!((kurt - 3.0).abs() < 0.05, "fourth moment {kurt}");
        let freq = |c: u32| f64::from(c) / n;
        assert!(
            (freq(beyond1) - 0.317_31).abs() < 0.0025,
            "{}",
            freq(beyond1)
        );
        assert!(
            (freq(beyond2) - 0.045_50).abs() < 0.001,
            "{}",
            freq(beyond2)
        );
        // P(|x| > 3.4426) = 5.76e-4: the tail sampler is used and right.
        assert!(
            (freq(beyond_tail) - 5.76e-4).abs() < 1.3e-4,
            "{}",
            freq(beyond_tail)
        );
    }
}
