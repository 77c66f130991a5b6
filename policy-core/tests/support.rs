//! Deterministic fixtures shared by the test modules.

use core::convert::Infallible;

use policy_core::blob::{self, Compiled};
use policy_core::{ActionBounds, Activation, Critic, Dense, ModelKind, Policy, Shape};
use rand_core::TryRng;

/// SplitMix64: tiny, fast and fully specified, so golden fixtures never depend on a crate's
/// stream staying the same across versions.
#[derive(Clone, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[-1, 1)` on a grid of 2^-23: exact in f32, so identical on every machine.
    pub fn symmetric(&mut self) -> f32 {
        (self.next() >> 40) as f32 * (1.0 / 8_388_608.0) - 1.0
    }

    /// Uniform integer in `0..n` (n > 0; the tiny modulo bias does not matter here).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    /// Any finite f32 bit pattern: normals, subnormals, both zeros, the extremes.
    pub fn finite_bits(&mut self) -> f32 {
        loop {
            let v = f32::from_bits(self.next() as u32);
            if v.is_finite() {
                return v;
            }
        }
    }
}

impl TryRng for SplitMix64 {
    type Error = Infallible;
    fn try_next_u32(&mut self) -> Result<u32, Infallible> {
        Ok((self.next() >> 32) as u32)
    }
    fn try_next_u64(&mut self) -> Result<u64, Infallible> {
        Ok(self.next())
    }
    fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), Infallible> {
        for chunk in dst.chunks_mut(8) {
            let bytes = self.next().to_le_bytes();
            chunk.copy_from_slice(&bytes[..chunk.len()]);
        }
        Ok(())
    }
}

/// DDPG's initialisation scale, uniform ±gain/√fan_in, for every weight and bias.
pub fn fill_dense<const I: usize, const O: usize>(
    d: &mut Dense<I, O>,
    gain: f32,
    rng: &mut SplitMix64,
) {
    let scale = gain / (I as f32).sqrt();
    d.w.iter_mut()
        .chain(d.b.iter_mut())
        .for_each(|v| *v = scale * rng.symmetric());
}

/// A policy for the navigation arena: positions in [-6, 6] (std ≈ 3.46), steps in ±0.25.
pub fn nav_policy<const S: usize, const H: usize, const L: usize, const A: usize>(
    seed: u64,
    activation: Activation,
) -> Policy<S, H, L, A> {
    let mut rng = SplitMix64(seed);
    let mut p = Policy::<S, H, L, A>::ZERO;
    p.normalizer
        .mean
        .iter_mut()
        .for_each(|m| *m = 0.5 * rng.symmetric());
    p.normalizer
        .inv_std
        .iter_mut()
        .for_each(|k| *k = (1.0 + 0.2 * rng.symmetric()) / 3.46);
    p.normalizer.clip = 5.0;
    p.bounds = ActionBounds::symmetric(0.25);
    fill_dense(&mut p.input, 1.0, &mut rng);
    p.trunk.activation = activation;
    p.trunk
        .hidden
        .iter_mut()
        .for_each(|d| fill_dense(d, 1.0, &mut rng));
    // A trained actor's output layer is larger than the ±1/√H init: gain 4 makes the actions
    // span the box, a few near its edges, most inside.
    fill_dense(&mut p.trunk.output, 4.0, &mut rng);
    p
}

/// A critic with the same normaliser as `nav_policy(seed)` and random DDPG-scale weights.
pub fn nav_critic<const S: usize, const H: usize, const L: usize, const A: usize>(
    seed: u64,
    activation: Activation,
) -> Critic<S, H, L, A> {
    let mut rng = SplitMix64(seed);
    let mut c = Critic::<S, H, L, A>::ZERO;
    c.normalizer
        .mean
        .iter_mut()
        .for_each(|m| *m = 0.5 * rng.symmetric());
    c.normalizer
        .inv_std
        .iter_mut()
        .for_each(|k| *k = (1.0 + 0.2 * rng.symmetric()) / 3.46);
    c.normalizer.clip = 5.0;
    let scale = 1.0 / ((S + A) as f32).sqrt();
    c.input
        .w
        .iter_mut()
        .for_each(|v| *v = scale * rng.symmetric());
    c.action_w
        .iter_mut()
        .for_each(|v| *v = scale * rng.symmetric());
    c.input
        .b
        .iter_mut()
        .for_each(|v| *v = scale * rng.symmetric());
    c.trunk.activation = activation;
    c.trunk
        .hidden
        .iter_mut()
        .for_each(|d| fill_dense(d, 1.0, &mut rng));
    fill_dense(&mut c.trunk.output, 1.0, &mut rng);
    c
}

/// Overwrites every parameter with an arbitrary finite bit pattern, then repairs the
/// normaliser and bounds so the model is valid (the loader's rules: inv_std >= 0, clip > 0,
/// low <= high with a representable width).
pub fn scramble<M: Compiled>(model: &mut M, rng: &mut SplitMix64) {
    model.params_mut(&mut |s| s.iter_mut().for_each(|v| *v = rng.finite_bits()));
}

pub fn arbitrary_policy<const S: usize, const H: usize, const L: usize, const A: usize>(
    seed: u64,
) -> Policy<S, H, L, A> {
    let mut rng = SplitMix64(seed);
    let mut p = Policy::<S, H, L, A>::ZERO;
    scramble(&mut p, &mut rng);
    p.trunk.activation = activation_from(seed);
    p.normalizer.inv_std.iter_mut().for_each(|k| *k = k.abs());
    p.normalizer.clip = p.normalizer.clip.abs().max(f32::MIN_POSITIVE);
    for (lo, hi) in p.bounds.low.iter_mut().zip(p.bounds.high.iter_mut()) {
        let (a, b) = (*lo / 4.0, *hi / 4.0); // a quarter of f32's range: width stays finite
        (*lo, *hi) = (a.min(b), a.max(b));
    }
    p
}

pub fn arbitrary_critic<const S: usize, const H: usize, const L: usize, const A: usize>(
    seed: u64,
) -> Critic<S, H, L, A> {
    let mut rng = SplitMix64(seed);
    let mut c = Critic::<S, H, L, A>::ZERO;
    scramble(&mut c, &mut rng);
    c.trunk.activation = activation_from(seed);
    c.normalizer.inv_std.iter_mut().for_each(|k| *k = k.abs());
    c.normalizer.clip = c.normalizer.clip.abs().max(f32::MIN_POSITIVE);
    c
}

pub fn activation_from(seed: u64) -> Activation {
    if seed % 2 == 0 {
        Activation::Tanh
    } else {
        Activation::Relu
    }
}

/// A blob in a new vector, without needing the `std` feature.
pub fn blob_of<M: Compiled>(model: &M, label: &str) -> Vec<u8> {
    let mut out = vec![0u8; blob::blob_len(model, label).expect("blob length")];
    let n = blob::write_into(model, label, &mut out).expect("write blob");
    assert_eq!(n, out.len());
    out
}

/// Recomputes the trailing CRC after a test edits a blob on purpose.
pub fn reseal(blob: &mut [u8]) {
    let (body, crc) = blob.split_last_chunk_mut::<4>().expect("a blob has a CRC");
    *crc = policy_core::crc32(body).to_le_bytes();
}

/// The tiny model of `docs/blob-format.md`'s worked example: 1 observation, one hidden layer
/// of 2 tanh units, 1 action.
pub fn tiny_policy() -> Policy<1, 2, 0, 1> {
    let mut p = Policy::<1, 2, 0, 1>::ZERO;
    p.normalizer.mean[0] = 0.5;
    p.normalizer.inv_std[0] = 2.0;
    p.normalizer.clip = 5.0;
    p.bounds = ActionBounds::symmetric(0.25);
    p.input.w[(0, 0)] = 1.0;
    p.input.w[(1, 0)] = -1.0;
    p.input.b[0] = 0.0;
    p.input.b[1] = 0.5;
    p.trunk.output.w[(0, 0)] = 0.75;
    p.trunk.output.w[(0, 1)] = -0.5;
    p.trunk.output.b[0] = 0.125;
    p.trunk.activation = Activation::Tanh;
    p
}

pub const TINY_LABEL: &str = "tiny";

/// A runtime-shape model's parameters in blob order, drawn from `rng`: a valid normaliser and
/// bounds (and, for a discrete policy, a table inside the bounds), weights in ±1 scaled by
/// 1/√inputs like a trained network.
pub fn runtime_params(kind: ModelKind, shape: Shape, rng: &mut SplitMix64) -> Vec<f32> {
    let (s, a) = (shape.observations as usize, shape.actions as usize);
    let mut p = Vec::new();
    p.extend((0..s).map(|_| rng.symmetric() * 3.0));
    p.extend((0..s).map(|_| 0.2 + rng.symmetric().abs()));
    p.push(5.0);
    if kind != ModelKind::Critic {
        p.extend((0..a).map(|i| -0.25 - 0.1 * i as f32));
        p.extend((0..a).map(|i| 0.25 + 0.1 * i as f32));
    }
    if kind == ModelKind::Discrete {
        for k in 0..shape.choices as usize {
            let angle = k as f32 * core::f32::consts::FRAC_PI_4;
            p.extend((0..a).map(|i| 0.25 * if i % 2 == 0 { angle.cos() } else { angle.sin() }));
        }
    }
    let total = shape.param_count(kind).expect("shape fits");
    let scale = 1.0 / (shape.inputs(kind).max(shape.width as usize) as f32).sqrt();
    while p.len() < total {
        p.push(rng.symmetric() * scale);
    }
    p
}

/// The blob of a runtime-shape model (see [`runtime_params`]).
pub fn runtime_blob(kind: ModelKind, shape: Shape, activation: Activation, seed: u64) -> Vec<u8> {
    let params = runtime_params(kind, shape, &mut SplitMix64(seed));
    let spec = blob::Spec {
        kind,
        encoding: policy_core::Encoding::F32,
        shape,
        activation,
        label: "runtime",
    };
    write_vec(&spec, &params).expect("blob")
}

/// [`blob::write`] into a new vector (policy-core's own `to_vec_with` needs `std`, and these
/// tests also run without it).
pub fn write_vec(spec: &blob::Spec<'_>, params: &[f32]) -> Result<Vec<u8>, policy_core::Error> {
    let mut out = vec![0u8; blob::encoded_len(spec)?];
    let n = blob::write(spec, &mut |sink| sink(params), &mut out)?;
    out.truncate(n);
    Ok(out)
}

/// The navigation task's discrete policy: 8 moves of 0.25 at n·45°, a 2x16 Q network.
pub fn discrete_blob(seed: u64) -> Vec<u8> {
    let shape = Shape {
        observations: 2,
        actions: 2,
        width: 16,
        depth: 2,
        choices: 8,
    };
    runtime_blob(ModelKind::Discrete, shape, Activation::Relu, seed)
}

/// The f32 actor blob `f32_blob` in the integer encoding, calibrated on `observations`
/// (flattened) and written by policy-core's writer: what `blob::encode_integer` does, without
/// the crate's `std` feature.
pub fn integer_vec(f32_blob: &[u8], observations: &[f32]) -> Result<Vec<u8>, policy_core::Error> {
    let model = policy_core::model::Model::from_blob(f32_blob)?;
    let h = model.header().clone();
    let mut ranges = vec![(f32::INFINITY, f32::NEG_INFINITY); usize::from(h.shape.depth) + 2];
    let mut scratch = vec![0.0; model.scratch_floats()];
    blob::calibrate_into(&model, observations, &mut scratch, &mut ranges)?;
    let params: Vec<f32> = model.values().collect();
    let spec = blob::Spec::like(&h, policy_core::Encoding::Integer);
    let mut out = vec![0u8; blob::encoded_len(&spec)?];
    let n = blob::write_integer(&spec, &ranges, &mut |sink| sink(&params), &mut out)?;
    out.truncate(n);
    Ok(out)
}

/// Observations of `size` components for calibration: `count` of them, each component uniform
/// in `[-scale, scale]`.
pub fn calibration_observations(size: usize, count: usize, scale: f32, seed: u64) -> Vec<f32> {
    let mut rng = SplitMix64(seed);
    (0..size * count).map(|_| rng.symmetric() * scale).collect()
}
