//! Dynamic input normalisation: running observation statistics, frozen into policy-core's
//! `Normalizer` at export.
//!
//! The replay buffer keeps raw observations and every batch is normalised with the statistics
//! of the moment ("dynamic input normalisation"), so old samples are never stuck with stale
//! scaling. Statistics are accumulated in f64 (Welford) and rounded to f32 once, in
//! [`RunningNorm::mean_f32`] / [`RunningNorm::inv_std_f32`]: those f32 values are what the blob
//! stores, and [`RunningNorm::normalize`] uses them with policy-core's exact formula.

use policy_core::normalizer::normalize_value;
use serde::{Deserialize, Serialize};

use super::net::Matrix;

/// Added to the variance before the square root, so a constant input does not divide by 0.
pub const VARIANCE_FLOOR: f64 = 1e-8;

/// Running mean and variance of observations (Welford's algorithm).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunningNorm {
    /// Samples seen (non-finite samples are skipped and not counted).
    pub count: u64,
    /// Running mean per dimension.
    pub mean: Vec<f64>,
    /// Running sum of squared deviations per dimension.
    pub m2: Vec<f64>,
    /// Normalised values are clipped to `[-clip, clip]`.
    pub clip: f32,
}

impl RunningNorm {
    /// Empty statistics for `dim` dimensions (5.0 is the usual `clip`).
    ///
    /// ```
    /// use host_trainer::nn::normalize::RunningNorm;
    /// let n = RunningNorm::new(2, 5.0);
    /// assert_eq!((n.mean_f32(), n.inv_std_f32()), (vec![0.0, 0.0], vec![1.0, 1.0]));
    /// ```
    pub fn new(dim: usize, clip: f32) -> Self {
        Self {
            count: 0,
            mean: vec![0.0; dim],
            m2: vec![0.0; dim],
            clip,
        }
    }

    /// Number of dimensions.
    ///
    /// ```
    /// assert_eq!(host_trainer::nn::normalize::RunningNorm::new(3, 5.0).dim(), 3);
    /// ```
    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    /// Adds one observation. A sample with any non-finite component (or of the wrong length)
    /// is ignored: one sensor glitch must not poison the statistics forever.
    ///
    /// ```
    /// use host_trainer::nn::normalize::RunningNorm;
    /// let mut n = RunningNorm::new(1, 5.0);
    /// for x in [1.0, 3.0, f32::NAN] {
    ///     n.update(&[x]);
    /// }
    /// assert_eq!(n.count, 2);
    /// assert_eq!(n.mean_f32(), vec![2.0]);
    /// assert!((n.inv_std_f32()[0] - 1.0).abs() < 1e-6); // population std of {1, 3} is 1
    /// ```
    pub fn update(&mut self, obs: &[f32]) {
        if obs.len() != self.dim() || !obs.iter().all(|x| x.is_finite()) {
            return;
        }
        self.count += 1;
        let n = self.count as f64;
        for ((mean, m2), &x) in self.mean.iter_mut().zip(&mut self.m2).zip(obs) {
            let x = f64::from(x);
            let delta = x - *mean;
            *mean += delta / n;
            *m2 += delta * (x - *mean);
        }
    }

    /// The mean as exported (f32).
    ///
    /// ```
    /// use host_trainer::nn::normalize::RunningNorm;
    /// let mut n = RunningNorm::new(1, 5.0);
    /// [0.1, 0.2, 0.3].iter().for_each(|&x| n.update(&[x]));
    /// assert_eq!(n.mean_f32(), vec![0.2]);
    /// ```
    pub fn mean_f32(&self) -> Vec<f32> {
        self.mean.iter().map(|&m| m as f32).collect()
    }

    /// The inverse standard deviation as exported: `1 / sqrt(var + 1e-8)` with the population
    /// variance, or 1 before two samples have been seen.
    ///
    /// ```
    /// use host_trainer::nn::normalize::RunningNorm;
    /// let mut n = RunningNorm::new(1, 5.0);
    /// [2.0, 4.0, 2.0, 4.0].iter().for_each(|&x| n.update(&[x]));
    /// assert!((n.inv_std_f32()[0] - 1.0).abs() < 1e-7); // std 1
    /// ```
    pub fn inv_std_f32(&self) -> Vec<f32> {
        self.m2.iter().map(|&m2| self.inv_std_of(m2)).collect()
    }

    fn inv_std_of(&self, m2: f64) -> f32 {
        if self.count < 2 {
            return 1.0;
        }
        (1.0 / (m2 / self.count as f64 + VARIANCE_FLOOR).sqrt()) as f32
    }

    /// Normalises one observation with the current frozen f32 parameters, bit for bit as
    /// `policy_core::Normalizer::normalize` does with the exported ones: non-finite inputs map
    /// to 0, everything else to `clamp((x - mean) * inv_std, -clip, clip)`.
    ///
    /// # Panics
    /// If `obs` or `out` does not have the normaliser's dimension, or `clip` is NaN.
    ///
    /// ```
    /// use host_trainer::nn::normalize::RunningNorm;
    /// let n = RunningNorm::new(2, 5.0);
    /// let mut z = [0.0; 2];
    /// n.normalize(&[f32::INFINITY, 7.0], &mut z);
    /// assert_eq!(z, [0.0, 5.0]);
    /// ```
    pub fn normalize(&self, obs: &[f32], out: &mut [f32]) {
        assert_eq!(
            obs.len(),
            self.dim(),
            "RunningNorm::normalize: observation size"
        );
        assert_eq!(out.len(), self.dim(), "RunningNorm::normalize: output size");
        for (((z, &x), &mean), &m2) in out.iter_mut().zip(obs).zip(&self.mean).zip(&self.m2) {
            *z = normalize_value(x, mean as f32, self.inv_std_of(m2), self.clip);
        }
    }

    /// [`RunningNorm::normalize`] on every row of a batch.
    ///
    /// ```
    /// use host_trainer::nn::{net::Matrix, normalize::RunningNorm};
    /// let n = RunningNorm::new(1, 2.0);
    /// let z = n.normalize_batch(&Matrix::from_vec(2, 1, vec![-3.0, 1.5]));
    /// assert_eq!(z.data, vec![-2.0, 1.5]);
    /// ```
    pub fn normalize_batch(&self, obs: &Matrix) -> Matrix {
        let mut out = Matrix::default();
        self.normalize_batch_into(obs, &mut out);
        out
    }

    /// [`RunningNorm::normalize_batch`] into a reused matrix (no allocation once warm).
    ///
    /// ```
    /// use host_trainer::nn::{net::Matrix, normalize::RunningNorm};
    /// let n = RunningNorm::new(2, 1.0);
    /// let mut z = Matrix::default();
    /// n.normalize_batch_into(&Matrix::from_vec(1, 2, vec![0.5, f32::NAN]), &mut z);
    /// assert_eq!(z, Matrix::from_vec(1, 2, vec![0.5, 0.0]));
    /// ```
    pub fn normalize_batch_into(&self, obs: &Matrix, out: &mut Matrix) {
        out.reshape(obs.rows, obs.cols);
        for (zr, xr) in out
            .data
            .chunks_exact_mut(obs.cols.max(1))
            .zip(obs.data.chunks_exact(obs.cols.max(1)))
        {
            self.normalize(xr, zr);
        }
    }

    /// The frozen parameters as policy-core's normaliser (what the blob stores).
    ///
    /// # Panics
    /// If the dimension is not `S`.
    ///
    /// ```
    /// use host_trainer::nn::normalize::RunningNorm;
    /// let mut n = RunningNorm::new(2, 5.0);
    /// n.update(&[1.0, 2.0]);
    /// n.update(&[3.0, 2.0]);
    /// let frozen = n.to_policy::<2>();
    /// let mut z = [0.0; 2];
    /// n.normalize(&[2.5, 9.0], &mut z);
    /// assert_eq!(frozen.normalize(&[2.5, 9.0]).as_slice(), &z);
    /// ```
    pub fn to_policy<const S: usize>(&self) -> policy_core::Normalizer<S> {
        assert_eq!(self.dim(), S, "RunningNorm::to_policy: dimension");
        let mut n = policy_core::Normalizer::<S>::ZERO;
        n.mean.as_mut_slice().copy_from_slice(&self.mean_f32());
        n.inv_std
            .as_mut_slice()
            .copy_from_slice(&self.inv_std_f32());
        n.clip = self.clip;
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firmware_sim::seed::{training_stream, uniform_in};

    #[test]
    fn welford_matches_two_pass_statistics() {
        let mut rng = training_stream(1, "norm");
        let xs: Vec<[f32; 2]> = (0..1000)
            .map(|_| {
                [
                    uniform_in(&mut rng, -6.0, 6.0),
                    uniform_in(&mut rng, 2.0, 3.0),
                ]
            })
            .collect();
        let mut n = RunningNorm::new(2, 5.0);
        xs.iter().for_each(|x| n.update(x));
        for d in 0..2 {
            let mean = xs.iter().map(|x| f64::from(x[d])).sum::<f64>() / 1000.0;
            let var = xs
                .iter()
                .map(|x| (f64::from(x[d]) - mean).powi(2))
                .sum::<f64>()
                / 1000.0;
            assert!((n.mean[d] - mean).abs() < 1e-12);
            assert!((n.m2[d] / 1000.0 - var).abs() < 1e-12);
            assert!((f64::from(n.inv_std_f32()[d]) - 1.0 / var.sqrt()).abs() < 1e-5 / var.sqrt());
        }
    }

    #[test]
    fn normalize_is_bit_exact_with_policy_core() {
        let mut rng = training_stream(2, "norm");
        let mut n = RunningNorm::new(2, 3.0);
        for _ in 0..50 {
            n.update(&[
                uniform_in(&mut rng, -1.0, 4.0),
                uniform_in(&mut rng, -0.01, 0.01),
            ]);
        }
        let frozen = n.to_policy::<2>();
        let specials = [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            -f32::MAX,
            0.0,
            -0.0,
            1e-30,
        ];
        let mut cases: Vec<[f32; 2]> = (0..1000)
            .map(|_| {
                [
                    uniform_in(&mut rng, -20.0, 20.0),
                    uniform_in(&mut rng, -0.1, 0.1),
                ]
            })
            .collect();
        cases.extend(
            specials
                .iter()
                .flat_map(|&a| specials.iter().map(move |&b| [a, b])),
        );
        for obs in cases {
            let mut z = [0.0; 2];
            n.normalize(&obs, &mut z);
            let expected = frozen.normalize(&obs);
            assert_eq!(
                z.map(f32::to_bits),
                [expected[0].to_bits(), expected[1].to_bits()],
                "obs {obs:?}"
            );
        }
    }

    #[test]
    fn before_two_samples_the_scale_is_one() {
        let mut n = RunningNorm::new(1, 5.0);
        n.update(&[4.0]);
        assert_eq!(n.inv_std_f32(), vec![1.0]);
        assert_eq!(n.mean_f32(), vec![4.0]);
        n.update(&[4.0]);
        // A constant input gets the variance floor, not a division by zero.
        assert_eq!(n.inv_std_f32(), vec![1e4]);
    }
}
