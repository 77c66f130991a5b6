//! Exploration noise: the "random process" added to the actor's action while training.
//!
//! The paper says only "random process". Two are offered, both in the unit action box and both
//! with the same σ:
//! - [`Noise::Gaussian`]: independent N(0, σ²) every step (the default \[ours\]).
//! - [`Noise::Ou`]: the Ornstein-Uhlenbeck process DDPG was published with,
//!   `x ← x - θ x + σ N(0, 1)`, reset to 0 at the start of every episode. Successive steps are
//!   correlated for about 1/θ steps, so the agent drifts in one direction for a while instead of
//!   jittering on the spot, which is what it takes to slide along a wall to its end.
//!
//! ```
//! use host_trainer::algorithms::noise::{Noise, NoiseProcess};
//! let mut rng = firmware_sim::seed::training_stream(1, "doc");
//! let mut ou = NoiseProcess::new(Noise::Ou, 0.2, 0.15, 2);
//! assert_eq!(ou.state(), &[0.0, 0.0]); // at rest: the trainer starts one per episode
//! let first = ou.sample(&mut rng).to_vec();
//! assert_eq!(first.len(), 2);
//! ```

use serde::{Deserialize, Serialize};

use firmware_sim::seed;
use policy_core::normal::standard_normals;

/// Which random process explores.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Noise {
    /// Independent Gaussian noise every step.
    #[default]
    Gaussian,
    /// Ornstein-Uhlenbeck noise, reset every episode.
    Ou,
}

/// The running noise of one episode, one value per action dimension.
#[derive(Clone, Debug, PartialEq)]
pub struct NoiseProcess {
    kind: Noise,
    sigma: f32,
    theta: f32,
    x: Vec<f32>,
}

impl NoiseProcess {
    /// A process for `dims` action dimensions, at rest. The trainer starts a new one every
    /// episode, so the noise never carries state across an episode boundary (where checkpoints
    /// are taken).
    pub fn new(kind: Noise, sigma: f32, theta: f32, dims: usize) -> NoiseProcess {
        NoiseProcess {
            kind,
            sigma,
            theta,
            x: vec![0.0; dims],
        }
    }

    /// The next noise vector, one normal draw per dimension in order.
    pub fn sample(&mut self, rng: &mut seed::SimRng) -> &[f32] {
        // A few dimensions at a time, drawn as one batch (the same draws as one by one).
        for xs in self.x.chunks_mut(8) {
            let mut draws = [0.0; 8];
            let draws = &mut draws[..xs.len()];
            standard_normals(rng, draws);
            for (x, &z) in xs.iter_mut().zip(&*draws) {
                let n = self.sigma * z;
                *x = match self.kind {
                    Noise::Gaussian => n,
                    Noise::Ou => *x - self.theta * *x + n,
                };
            }
        }
        &self.x
    }

    /// The current noise vector.
    pub fn state(&self) -> &[f32] {
        &self.x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lag1_correlation(kind: Noise) -> f32 {
        let mut rng = seed::training_stream(7, "noise-test");
        let mut p = NoiseProcess::new(kind, 0.2, 0.15, 1);
        let xs: Vec<f32> = (0..20_000).map(|_| p.sample(&mut rng)[0]).collect();
        let mean = xs.iter().sum::<f32>() / xs.len() as f32;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f32>();
        let cov = xs
            .windows(2)
            .map(|w| (w[0] - mean) * (w[1] - mean))
            .sum::<f32>();
        cov / var
    }

    #[test]
    fn gaussian_steps_are_independent_and_ou_steps_are_correlated() {
        // OU's lag-1 correlation is 1 - θ = 0.85; Gaussian's is 0.
        assert!(lag1_correlation(Noise::Gaussian).abs() < 0.05);
        assert!((lag1_correlation(Noise::Ou) - 0.85).abs() < 0.05);
    }

    #[test]
    fn ou_stationary_spread_is_sigma_over_sqrt_of_2_theta_minus_theta_squared() {
        let mut rng = seed::training_stream(8, "noise-test");
        let mut p = NoiseProcess::new(Noise::Ou, 0.2, 0.15, 1);
        let xs: Vec<f32> = (0..50_000).map(|_| p.sample(&mut rng)[0]).collect();
        let std = (xs.iter().map(|x| x * x).sum::<f32>() / xs.len() as f32).sqrt();
        let expected = 0.2 / (2.0f32 * 0.15 - 0.15 * 0.15).sqrt();
        assert!(
            (std - expected).abs() < 0.03 * expected,
            "{std} vs {expected}"
        );
    }

    #[test]
    fn a_new_process_is_at_rest_until_sampled() {
        let mut rng = seed::training_stream(9, "noise-test");
        let mut p = NoiseProcess::new(Noise::Ou, 0.5, 0.15, 3);
        assert_eq!(p.state(), &[0.0; 3]);
        p.sample(&mut rng);
        assert!(p.state().iter().any(|&x| x != 0.0));
    }
}
