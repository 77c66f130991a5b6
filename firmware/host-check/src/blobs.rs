//! The blobs the firmware runs, seen from the host: what a blob holds, deterministic blobs of any
//! shape, and the actions policy-core's runtime [`Model`] computes for them.
//!
//! There is no list of shapes or sizes here: the firmware runs any policy of at most
//! [`MAX_OBS`] observations and [`MAX_ACT`] actions whose widest layer fits its scratch, at the
//! blob's own sizes, and so does this side.

use anyhow::{bail, Context, Result};
use policy_core::blob::{self, Spec, MAX_WIDTH};
use policy_core::model::{Model, Scratch};
use policy_core::{Activation, Encoding, ModelKind, Shape};
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

use crate::codes;
use crate::observations::{fill, CASES};
use crate::sizes::{MAX_ACT, MAX_OBS};

/// The action size of the firmware's compare step (feature `refine`, firmware/src/refine.rs).
pub const REFINE_A: usize = 2;
/// The sizes `gen` writes unless told: the navigation task's 2 observations and 2 actions.
pub const NAV_SIZES: (u16, u16) = (2, 2);

/// What the measurements need to know about a blob.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BlobInfo {
    /// Actor or discrete policy.
    pub kind: ModelKind,
    /// Network sizes.
    pub shape: Shape,
    /// Hidden activation.
    pub activation: Activation,
    /// How the weights are stored (f32, f16 or int8).
    pub encoding: Encoding,
    /// Blob format version.
    pub version: u16,
}

impl BlobInfo {
    /// Verifies `bytes` as policy-core does at boot and checks the firmware's maxima.
    pub fn of(bytes: &[u8]) -> Result<Self> {
        let model = Model::from_blob(bytes)?;
        let h = model.header();
        if h.kind == ModelKind::Critic {
            bail!("the firmware runs policies (actor or discrete), not a critic");
        }
        Model::for_policy_within(bytes, MAX_OBS, MAX_ACT, MAX_WIDTH)?;
        Ok(BlobInfo {
            kind: h.kind,
            shape: h.shape,
            activation: h.activation,
            encoding: h.encoding,
            version: h.version,
        })
    }

    /// `DEPTHxWIDTH`, e.g. `4x48`, followed by the sizes when they are not the navigation
    /// task's, e.g. `2x32 3obs-1act`.
    pub fn name(&self) -> String {
        let s = self.shape;
        let name = format!("{}x{}", s.depth, s.width);
        if (s.observations, s.actions) == NAV_SIZES {
            name
        } else {
            format!("{name} {}obs-{}act", s.observations, s.actions)
        }
    }

    /// Observations the blob reads.
    pub fn observations(&self) -> usize {
        self.shape.observations.into()
    }

    /// Multiply-accumulates in one `act`: every weight is used once.
    pub fn macs(&self) -> u64 {
        let s = self.shape;
        let (h, l) = (u64::from(s.width), u64::from(s.depth) - 1);
        let (i, o) = (s.inputs(self.kind) as u64, s.outputs(self.kind) as u64);
        i * h + l * h * h + h * o
    }

    /// `tanhf` calls in one `act`: every hidden unit of a tanh network, and an actor's output
    /// squashing; none in the integer encoding, whose tanh is a table.
    pub fn tanh_calls(&self) -> u64 {
        if self.encoding == Encoding::Integer {
            return 0;
        }
        let hidden = match self.activation {
            Activation::Tanh => u64::from(self.shape.width) * u64::from(self.shape.depth),
            Activation::Relu => 0,
        };
        let squash = match self.kind {
            ModelKind::Actor => u64::from(self.shape.actions),
            ModelKind::Critic | ModelKind::Discrete => 0,
        };
        hidden + squash
    }
}

/// Parses an encoding name as policy-core prints it: `f32`, `f16`, `int8` or `integer`.
pub fn parse_encoding(text: &str) -> Result<Encoding> {
    Encoding::ALL
        .into_iter()
        .find(|e| e.to_string() == text)
        .with_context(|| format!("encoding {text:?}: expected f32, f16, int8 or integer"))
}

/// Re-encodes an f32 blob (any format version policy-core reads) into `encoding`, as
/// host-trainer's `export::encode` does: the runtime model decodes the f32 parameters in blob
/// order and policy-core's writer quantises the weights (f16: nearest; int8: one scale per
/// output). Header fields and label are kept; the result is verified before it is returned.
pub fn encode(bytes: &[u8], encoding: Encoding) -> Result<Vec<u8>> {
    // policy-core's one definition (what host-trainer's `export --encoding` runs too).
    blob::encode(bytes, encoding)
        .context("cannot re-encode the blob (only an f32 blob is re-encoded)")
}

/// Parses `DEPTHxWIDTH` (any sizes within the blob format's limits) for a policy of
/// `(observations, actions)`, within the firmware's maxima.
pub fn parse_shape(text: &str, (observations, actions): (u16, u16)) -> Result<Shape> {
    let parsed = text
        .split_once('x')
        .and_then(|(d, w)| Some((d.parse().ok()?, w.parse().ok()?)));
    let Some((depth, width)) = parsed else {
        bail!("shape {text:?}: expected DEPTHxWIDTH, e.g. 4x48");
    };
    if !(1..=MAX_OBS).contains(&observations.into()) || !(1..=MAX_ACT).contains(&actions.into()) {
        bail!("{observations} observations and {actions} actions: the firmware takes 1 to {MAX_OBS} and 1 to {MAX_ACT}");
    }
    let shape = Shape {
        observations,
        actions,
        width,
        depth,
        choices: 0,
    };
    shape
        .check(ModelKind::Actor)
        .with_context(|| format!("shape {text:?}"))?;
    Ok(shape)
}

/// The fixed observations (firmware/src/observations.rs) at the blob's observation size, as the
/// firmware fills them.
pub fn observations(bytes: &[u8]) -> Result<Vec<Vec<f32>>> {
    let n = BlobInfo::of(bytes)?.observations();
    Ok((0..CASES)
        .map(|k| {
            let mut obs = vec![0.0; n];
            fill(k, &mut obs);
            obs
        })
        .collect())
}

/// The actions policy-core's runtime model computes on the host for `bytes` and each
/// observation (the widest scratch the format allows, so any blob runs), at the blob's sizes.
pub fn actions(bytes: &[u8], observations: &[Vec<f32>]) -> Result<Vec<Vec<f32>>> {
    let model = Model::from_blob(bytes)?;
    let mut scratch = Box::new(Scratch::<MAX_WIDTH>::new());
    observations
        .iter()
        .map(|obs| {
            let mut action = vec![0.0; model.header().shape.actions.into()];
            model.act(obs, &mut scratch, &mut action)?;
            Ok(action)
        })
        .collect()
}

/// The observation codes of firmware-m0 (firmware-m0/src/codes.rs) at the blob's observation
/// size, as that firmware fills them.
pub fn observation_codes(bytes: &[u8]) -> Result<Vec<Vec<i8>>> {
    let n = BlobInfo::of(bytes)?.observations();
    Ok((0..codes::CASES)
        .map(|k| {
            let mut c = vec![0; n];
            codes::fill(k, &mut c);
            c
        })
        .collect())
}

/// The unit codes policy-core's integer entry ([`Model::act_codes_in`]) computes on the host for
/// an integer blob and each vector of observation codes, at the blob's sizes.
pub fn action_codes(bytes: &[u8], codes: &[Vec<i8>]) -> Result<Vec<Vec<i8>>> {
    let model = Model::from_blob(bytes)?;
    let mut scratch = vec![0i32; 2 * MAX_WIDTH];
    codes
        .iter()
        .map(|c| {
            let mut unit = vec![0; model.header().shape.actions.into()];
            model.act_codes_in(c, &mut scratch, &mut unit)?;
            Ok(unit)
        })
        .collect()
}

/// The actions the firmware built with feature `refine` computes: the compare step with `t`
/// proposals at σ = 0.2 and the critic blob, one proposal stream (firmware/src/proposals.rs,
/// included here) over the observations in order, as the firmware draws it.
pub fn refined_actions(
    actor: &[u8],
    critic: &[u8],
    observations: &[Vec<f32>],
    t: usize,
) -> Result<Vec<Vec<f32>>> {
    use crate::proposals::{Proposals, SEED};
    let (actor, critic) = (Model::from_blob(actor)?, Model::from_blob(critic)?);
    let mut scratch = Box::new(Scratch::<MAX_WIDTH>::new());
    let mut rng = Proposals(SEED);
    observations
        .iter()
        .map(|obs| {
            let r = policy_core::compare::refine_model::<REFINE_A, MAX_WIDTH, _>(
                &actor,
                &critic,
                obs,
                &mut scratch,
                &mut rng,
                t,
                0.2,
            )?;
            Ok(r.action.to_vec())
        })
        .collect()
}

/// An actor blob of `shape` with the given hidden activation and deterministic random weights:
/// one ChaCha8 stream per shape, derived from `seed`, so the same seed gives the same bytes on
/// every machine. Written with policy-core's runtime writer: no compiled type is involved. The
/// f32 weights are drawn first and then quantised by [`encode`], so the f16 and int8 blobs of a
/// seed are the f32 blob re-encoded; the integer blob is the f32 blob calibrated on observations
/// drawn after the weights.
///
/// The normaliser and bounds are those of a realistic navigation actor (positions in metres, mean
/// off zero, clip 5; actions within ±0.25), so the observations exercise clipping both ways; a
/// blob of other sizes repeats the navigation actor's per-dimension values (mean 1.5, -0.7, 1.5,
/// ...), and its label names its sizes (`3to1`). The navigation sizes give the same bytes as ever.
pub fn generate(
    shape: Shape,
    seed: u64,
    activation: Activation,
    encoding: Encoding,
) -> Result<Vec<u8>> {
    let mut rng =
        ChaCha8Rng::seed_from_u64(seed ^ (u64::from(shape.depth) << 32 | u64::from(shape.width)));
    let (w, depth) = (shape.width as usize, shape.depth as usize);
    let (s, a) = (shape.observations as usize, shape.actions as usize);
    // Layers in blob order: input (s -> w), depth - 1 hidden (w -> w), output (w -> a).
    let mut layers = vec![xavier(s, w, &mut rng)];
    for _ in 1..depth {
        layers.push(xavier(w, w, &mut rng));
    }
    layers.push(xavier(w, a, &mut rng));
    let mut label = if (shape.observations, shape.actions) == NAV_SIZES {
        format!("host-check {depth}x{w} {activation} seed {seed}")
    } else {
        format!("host-check {depth}x{w} {s}to{a} {activation} seed {seed}")
    };
    label.truncate(blob::LABEL_CAPACITY); // the format's limit (ASCII: any cut is a boundary)
    let spec = Spec {
        kind: ModelKind::Actor,
        encoding: policy_core::Encoding::F32,
        shape,
        activation,
        label: &label,
    };
    let per_dim = |pair: [f32; 2], n: usize| (0..n).map(move |j| pair[j % 2]);
    // mean, inverse std, clip
    let normalizer: Vec<f32> = per_dim([1.5, -0.7], s)
        .chain(per_dim([1.0 / 2.3, 1.0 / 1.7], s))
        .chain([5.0])
        .collect();
    let bounds: Vec<f32> = per_dim([-0.25; 2], a)
        .chain(per_dim([0.25; 2], a))
        .collect(); // low, high
    let f32_blob = blob::to_vec_with(&spec, &mut |sink| {
        sink(&normalizer);
        sink(&bounds);
        for (weights, biases) in &layers {
            sink(weights);
            sink(biases);
        }
    })?;
    match encoding {
        Encoding::F32 => Ok(f32_blob),
        Encoding::F16 | Encoding::Int8 => encode(&f32_blob, encoding),
        // The integer encoding is calibrated on observations: drawn after the weights (so the
        // f32 blob of a seed stays the same), uniform within the normaliser's clip (5 standard
        // deviations about the mean), so that the firmware's test inputs, which reach the clip,
        // stay within the calibrated ranges.
        Encoding::Integer => {
            let (mean, std) = ([1.5, -0.7], [2.3, 1.7]);
            let observations: Vec<f32> = (0..CALIBRATION_STATES * s)
                .map(|i| mean[i % s % 2] + 5.0 * std[i % s % 2] * uniform(&mut rng))
                .collect();
            blob::encode_integer(&f32_blob, &observations)
                .context("cannot encode the generated actor in the integer encoding")
        }
    }
}

/// How many observations calibrate a generated integer actor.
const CALIBRATION_STATES: usize = 256;

/// Glorot-uniform weights (limit `sqrt(6 / (in + out))`, column-major: `inputs` columns of
/// `outputs` values) and small biases in `[-0.1, 0.1)`, drawn in that order.
fn xavier(inputs: usize, outputs: usize, rng: &mut ChaCha8Rng) -> (Vec<f32>, Vec<f32>) {
    let limit = (6.0 / (inputs + outputs) as f32).sqrt();
    let weights = (0..inputs * outputs)
        .map(|_| uniform(rng) * limit)
        .collect();
    let biases = (0..outputs).map(|_| uniform(rng) * 0.1).collect();
    (weights, biases)
}

/// Uniform in `[-1, 1)` from the top 24 bits of one draw (exact in f32).
fn uniform(rng: &mut ChaCha8Rng) -> f32 {
    (rng.next_u32() >> 8) as f32 * (2.0 / 16_777_216.0) - 1.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use policy_core::Policy;

    #[test]
    fn same_seed_same_bytes_and_the_shape_round_trips() {
        let shape = parse_shape("3x40", NAV_SIZES).unwrap();
        let a = generate(shape, 7, Activation::Relu, Encoding::F32).unwrap();
        assert_eq!(
            a,
            generate(shape, 7, Activation::Relu, Encoding::F32).unwrap()
        );
        assert_ne!(
            a,
            generate(shape, 8, Activation::Relu, Encoding::F32).unwrap()
        );
        let info = BlobInfo::of(&a).unwrap();
        assert_eq!((info.name(), info.kind), ("3x40".into(), ModelKind::Actor));
        assert!(parse_shape("4x", NAV_SIZES).is_err() && parse_shape("0x48", NAV_SIZES).is_err());
        // Other sizes: their own label and name; beyond the firmware's maxima, refused.
        let cart = generate(
            parse_shape("3x40", (3, 1)).unwrap(),
            7,
            Activation::Relu,
            Encoding::F32,
        )
        .unwrap();
        let info = BlobInfo::of(&cart).unwrap();
        assert_eq!(info.name(), "3x40 3obs-1act");
        assert_eq!((info.observations(), info.tanh_calls()), (3, 1));
        assert!(parse_shape("3x40", (10, 2)).is_ok()); // MuJoCo's reacher
        assert!(parse_shape("3x40", (17, 1)).is_err() && parse_shape("3x40", (2, 9)).is_err());
        assert!(parse_shape("3x40", (2, 0)).is_err());
    }

    #[test]
    fn macs_count_every_weight_once() {
        let info = BlobInfo::of(
            &generate(
                parse_shape("4x48", NAV_SIZES).unwrap(),
                4,
                Activation::Tanh,
                Encoding::F32,
            )
            .unwrap(),
        )
        .unwrap();
        // 2*48 + 3*48*48 + 48*2 = 7104 (the payload minus normaliser, bounds and biases).
        assert_eq!(info.macs(), 7104);
        assert_eq!(info.tanh_calls(), 194);
        let relu = BlobInfo {
            activation: Activation::Relu,
            ..info
        };
        assert_eq!(relu.tanh_calls(), 2);
    }

    #[test]
    fn quantised_blobs_are_the_f32_blob_re_encoded() {
        let shape = parse_shape("4x48", NAV_SIZES).unwrap();
        let f32_blob = generate(shape, 4, Activation::Relu, Encoding::F32).unwrap();
        let exact = actions(&f32_blob, &observations(&f32_blob).unwrap()).unwrap();
        for encoding in [Encoding::F16, Encoding::Int8] {
            let q = generate(shape, 4, Activation::Relu, encoding).unwrap();
            assert_eq!(q, encode(&f32_blob, encoding).unwrap());
            let info = BlobInfo::of(&q).unwrap();
            assert_eq!(
                (info.encoding, info.version, info.macs()),
                (encoding, 3, 7104)
            );
            assert!(
                q.len() < f32_blob.len() / 2 + 1024,
                "{encoding}: {} B",
                q.len()
            );
            let acts = actions(&q, &observations(&q).unwrap()).unwrap();
            for (a, e) in acts.iter().flatten().zip(exact.iter().flatten()) {
                assert!(
                    a.abs() <= 0.25 && (a - e).abs() < 0.02,
                    "{encoding}: {a} vs {e}"
                );
            }
            // Only f32 is re-encoded.
            assert!(encode(&q, Encoding::Int8).is_err());
        }
        assert_eq!(parse_encoding("int8").unwrap(), Encoding::Int8);
        assert!(parse_encoding("f64").is_err());
    }

    #[test]
    fn integer_blobs_are_calibrated_from_the_seed_and_close_to_f32() {
        // Sizes off every multiple the kernels block by: 3 inputs, 13 wide, 5 actions.
        let shape = parse_shape("2x13", (3, 5)).unwrap();
        let f32_blob = generate(shape, 9, Activation::Relu, Encoding::F32).unwrap();
        let q = generate(shape, 9, Activation::Relu, Encoding::Integer).unwrap();
        assert_eq!(
            q,
            generate(shape, 9, Activation::Relu, Encoding::Integer).unwrap()
        );
        assert_ne!(
            q,
            generate(shape, 10, Activation::Relu, Encoding::Integer).unwrap()
        );
        let info = BlobInfo::of(&q).unwrap();
        assert_eq!((info.encoding, info.version), (Encoding::Integer, 4));
        let exact = actions(&f32_blob, &observations(&f32_blob).unwrap()).unwrap();
        let acts = actions(&q, &observations(&q).unwrap()).unwrap();
        // Within the 0.25 box, and each action within a few output codes (one is 0.25 / 127).
        for (a, e) in acts.iter().flatten().zip(exact.iter().flatten()) {
            assert!(a.abs() <= 0.25 && (a - e).abs() < 0.03, "{a} vs {e}");
        }
    }

    // The runtime model and the compiled type must agree on a generated blob, bit for bit.
    #[test]
    fn generated_actions_are_in_bounds_and_match_the_compiled_policy() {
        let blob = generate(
            parse_shape("4x48", NAV_SIZES).unwrap(),
            4,
            Activation::Tanh,
            Encoding::F32,
        )
        .unwrap();
        let acts = actions(&blob, &observations(&blob).unwrap()).unwrap();
        assert!(acts
            .iter()
            .flatten()
            .all(|a| a.is_finite() && a.abs() <= 0.25));
        assert!(
            acts.windows(2).any(|w| w[0] != w[1]),
            "random weights must move the actions"
        );
        let compiled = Policy::<2, 48, 3, 2>::from_blob(&blob).unwrap();
        for (obs, act) in crate::observations::OBSERVATIONS.iter().zip(&acts) {
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&compiled.act(obs)), bits(act));
        }
    }
}
