//! The actor shapes the firmware can be built for, and what the host does with each: write a
//! deterministic blob, and recompute the actions the firmware printed.

use anyhow::{bail, Result};
use policy_core::{blob, mlp::Dense, ActionBounds, Activation, Normalizer, Policy};
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

/// Observations and actions of every shape (the navigation task).
pub const S: usize = 2;
/// See [`S`].
pub const A: usize = 2;

/// A firmware shape: hidden layers x width, e.g. `4x48`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShapeName {
    /// Hidden layers (the blob's `depth`).
    pub depth: u8,
    /// Hidden width.
    pub width: u16,
}

impl ShapeName {
    /// The shapes the firmware has a cargo feature for.
    pub const ALL: [ShapeName; 3] = [
        ShapeName {
            depth: 2,
            width: 32,
        },
        ShapeName {
            depth: 4,
            width: 48,
        },
        ShapeName {
            depth: 6,
            width: 64,
        },
    ];

    /// Parses `DEPTHxWIDTH`; only the compiled shapes are accepted.
    pub fn parse(text: &str) -> Result<Self> {
        match Self::ALL.iter().find(|s| s.to_string() == text) {
            Some(&s) => Ok(s),
            None => bail!("unknown shape {text:?}: expected one of 2x32, 4x48, 6x64"),
        }
    }

    /// Multiply-accumulates in one `act`: every weight is used once.
    pub fn macs(&self) -> u64 {
        let (h, l) = (self.width as u64, self.depth as u64 - 1);
        S as u64 * h + l * h * h + h * A as u64
    }

    /// `tanhf` calls in one `act`: every hidden unit, and the output squashing.
    pub fn tanh_calls(&self) -> u64 {
        self.width as u64 * self.depth as u64 + A as u64
    }
}

impl std::fmt::Display for ShapeName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{}", self.depth, self.width)
    }
}

/// Reads the shape a blob holds (checking header, length and checksum).
pub fn shape_of(bytes: &[u8]) -> Result<ShapeName> {
    let header = blob::verify(bytes)?.header;
    let sh = header.shape;
    let name = ShapeName {
        depth: sh.depth,
        width: sh.width,
    };
    if header.kind != policy_core::ModelKind::Actor
        || sh.observations as usize != S
        || sh.actions as usize != A
        || !ShapeName::ALL.contains(&name)
    {
        bail!("the firmware has no build for a {} {} (expected an actor, 2 observations, 2 actions, 2x32/4x48/6x64)", header.kind, sh);
    }
    Ok(name)
}

/// The actions policy-core computes on the host for `bytes` and each observation.
pub fn actions(bytes: &[u8], observations: &[[f32; S]]) -> Result<Vec<[f32; A]>> {
    fn run<const H: usize, const L: usize>(
        bytes: &[u8],
        obs: &[[f32; S]],
    ) -> Result<Vec<[f32; A]>> {
        let policy = Policy::<S, H, L, A>::from_blob(bytes)?;
        Ok(obs.iter().map(|o| policy.act(o)).collect())
    }
    match shape_of(bytes)? {
        ShapeName {
            depth: 2,
            width: 32,
        } => run::<32, 1>(bytes, observations),
        ShapeName {
            depth: 4,
            width: 48,
        } => run::<48, 3>(bytes, observations),
        _ => run::<64, 5>(bytes, observations),
    }
}

/// A blob of `shape` with the given hidden activation and deterministic random weights: one ChaCha8 stream per shape, derived from
/// `seed`, so the same seed gives the same bytes on every machine.
///
/// The normaliser and bounds are those of a realistic navigation actor (positions in metres, mean
/// off zero, clip 5; actions within ±0.25), so the observations exercise clipping both ways.
pub fn generate(shape: ShapeName, seed: u64, activation: Activation) -> Result<Vec<u8>> {
    fn build<const H: usize, const L: usize>(
        rng: &mut ChaCha8Rng,
        label: &str,
        activation: Activation,
    ) -> Result<Vec<u8>> {
        let mut p = Policy::<S, H, L, A>::ZERO;
        p.normalizer = Normalizer::identity(5.0);
        p.normalizer.mean.copy_from_slice(&[1.5, -0.7]);
        p.normalizer
            .inv_std
            .copy_from_slice(&[1.0 / 2.3, 1.0 / 1.7]);
        p.bounds = ActionBounds::symmetric(0.25);
        p.trunk.activation = activation;
        xavier(&mut p.input, rng);
        for layer in &mut p.trunk.hidden {
            xavier(layer, rng);
        }
        xavier(&mut p.trunk.output, rng);
        Ok(p.to_blob(label)?)
    }
    let mut rng =
        ChaCha8Rng::seed_from_u64(seed ^ ((shape.depth as u64) << 32 | shape.width as u64));
    let label = format!("host-check {shape} {activation} seed {seed}");
    match (shape.depth, shape.width) {
        (2, 32) => build::<32, 1>(&mut rng, &label, activation),
        (4, 48) => build::<48, 3>(&mut rng, &label, activation),
        _ => build::<64, 5>(&mut rng, &label, activation),
    }
}

/// Glorot-uniform weights (limit `sqrt(6 / (in + out))`) and small biases in `[-0.1, 0.1)`.
fn xavier<const I: usize, const O: usize>(layer: &mut Dense<I, O>, rng: &mut ChaCha8Rng) {
    let limit = (6.0 / (I + O) as f32).sqrt();
    layer.w.iter_mut().for_each(|w| *w = uniform(rng) * limit);
    layer.b.iter_mut().for_each(|b| *b = uniform(rng) * 0.1);
}

/// Uniform in `[-1, 1)` from the top 24 bits of one draw (exact in f32).
fn uniform(rng: &mut ChaCha8Rng) -> f32 {
    (rng.next_u32() >> 8) as f32 * (2.0 / 16_777_216.0) - 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_bytes_and_shape_round_trips() {
        let shape = ShapeName::parse("2x32").unwrap();
        let a = generate(shape, 7, Activation::Tanh).unwrap();
        assert_eq!(a, generate(shape, 7, Activation::Tanh).unwrap());
        assert_ne!(a, generate(shape, 8, Activation::Tanh).unwrap());
        assert_eq!(shape_of(&a).unwrap(), shape);
    }

    #[test]
    fn macs_count_every_weight_once() {
        // 4x48: 2*48 + 3*48*48 + 48*2 = 7104 (the payload minus normaliser, bounds and biases).
        assert_eq!(ShapeName::parse("4x48").unwrap().macs(), 7104);
        assert_eq!(ShapeName::parse("4x48").unwrap().tanh_calls(), 194);
        assert!(ShapeName::parse("3x48").is_err());
    }

    #[test]
    fn generated_actions_are_in_bounds_and_not_all_equal() {
        let blob = generate(ShapeName::parse("4x48").unwrap(), 4, Activation::Tanh).unwrap();
        let acts = actions(&blob, &crate::observations::OBSERVATIONS).unwrap();
        assert!(acts
            .iter()
            .flatten()
            .all(|a| a.is_finite() && a.abs() <= 0.25));
        assert!(
            acts.windows(2).any(|w| w[0] != w[1]),
            "random weights must move the actions"
        );
    }
}
