//! An actor run partly in f32 and partly as its integer encoding runs it, to say which layer's
//! rounding moves the integer policy's action (docs/results/integer-cost.md, "Which part of the
//! integer computation").
//!
//! An f32 blob and its integer encoding describe one network. [`Hybrid`] runs the f32 network
//! and replaces the parts a range names by their integer computation. Part 0 is the
//! observation's input codes (rounded to the integer blob's input codes and read back as
//! reals); part `1 + l` is layer `l` (hidden layers, then the output layer with its tanh table):
//! its input is rounded to the codes of its input quantisation unless it already arrives as
//! codes, policy-core's own integer layer ([`IntegerDense`]) computes its output codes, and
//! the next f32 part reads them back as reals. With every part integer the hybrid computes the
//! integer blob's action bit for bit, and with none the f32 blob's, so what lies between is
//! split among the parts with the chip's arithmetic, not a model of it.
//!
//! The integer blob stores each layer's zero point and its requantisation multiplier
//! `s_in · s_w / s_out`, not the real scales, so the scales are read back from those and the
//! f32 weights (`s_w = max |w| / 127`, as the writer chose it): they agree with the writer's to
//! the precision of the stored f32 input scales and the multipliers' 31 bits.

use std::ops::Range;

use firmware_sim::controller::Controller;
use policy_core::blob::{self, IntegerLayer, Quantisation};
use policy_core::mlp::integer::{unit_of_code, IntegerDense};
use policy_core::mlp::{accumulate_bytes, squash, Activation};
use policy_core::model::Model;
use policy_core::normalizer::normalize_value;
use policy_core::{Encoding, ModelKind};

/// The codes of a tanh table's output, which the next layer reads: `u = code / 127`.
const UNIT: Quantisation = Quantisation {
    scale: 1.0 / 127.0,
    zero: 0,
};

/// One layer in both encodings.
struct Layer<'a> {
    /// The f32 weights (column-major) and biases as bytes, as policy-core's f32 kernel reads them.
    weights: Vec<u8>,
    bias: Vec<u8>,
    integer: IntegerDense<'a>,
    /// The quantisation of the layer's input codes (the one its integer computation assumes).
    input: Quantisation,
    outputs: usize,
}

impl Layer<'_> {
    /// The layer's output from its input `x`: as the integer blob computes it (codes in, codes
    /// out), or as the f32 blob does, then `activation` (none for the output layer, whose
    /// tanh comes last).
    fn run(&self, x: Values, integer: bool, activation: Option<Activation>) -> Values {
        if integer {
            let mut y = vec![0i32; self.outputs];
            self.integer
                .run(&x.codes(&self.input), self.input.zero, &mut y);
            return Values::Codes(y);
        }
        let mut y = vec![0.0f32; self.outputs];
        accumulate_bytes(&self.weights, &self.bias, &x.real(&self.input), &mut y);
        if let Some(a) = activation {
            y.iter_mut().for_each(|y| *y = a.apply(*y));
        }
        Values::Real(y)
    }
}

/// An f32 actor and its integer encoding, run with any range of parts in integers.
///
/// ```
/// use policy_core::{blob, model::Model};
/// use studies::hybrid::Hybrid;
/// static F32: &[u8] = include_bytes!("../../policy-core/tests/golden/actor_4x48.postcard");
/// let integer = blob::encode_integer(F32, &[4.0, -2.5, 0.0, 0.0, -5.0, 5.0]).unwrap();
/// let hybrid = Hybrid::new(F32, &integer).unwrap();
/// assert_eq!(hybrid.parts(), 6); // input codes, four hidden layers, the output layer
/// let (mut all, mut blob, mut scratch) = ([0.0f32; 2], [0.0f32; 2], [0.0f32; 96]);
/// hybrid.act(&[1.0, 2.0], &(0..6), &mut all).unwrap();
/// Model::from_blob(&integer).unwrap().act_in(&[1.0, 2.0], &mut scratch, &mut blob).unwrap();
/// assert_eq!(all, blob);
/// let mut first = [0.0f32; 2]; // only the first hidden layer in integers
/// hybrid.act(&[1.0, 2.0], &(1..2), &mut first).unwrap();
/// assert!(first.iter().zip(&all).all(|(a, b)| (a - b).abs() < 0.05));
/// ```
pub struct Hybrid<'a> {
    f32: Model<'a>,
    integer: Model<'a>,
    /// The normaliser's mean and inverse standard deviation per observation, and its clip.
    mean: Vec<f32>,
    inv_std: Vec<f32>,
    clip: f32,
    activation: Activation,
    layers: Vec<Layer<'a>>,
}

/// A layer's input or output: reals, or codes in the quantisation of the layer that reads them.
enum Values {
    Real(Vec<f32>),
    Codes(Vec<i32>),
}

impl Values {
    fn codes(self, q: &Quantisation) -> Vec<i32> {
        match self {
            Values::Codes(c) => c,
            Values::Real(x) => x
                .iter()
                .map(|&v| {
                    ((f64::from(v) / q.scale).round() + f64::from(q.zero)).clamp(-128.0, 127.0)
                        as i32
                })
                .collect(),
        }
    }

    fn real(self, q: &Quantisation) -> Vec<f32> {
        match self {
            Values::Real(x) => x,
            Values::Codes(c) => c
                .iter()
                .map(|&c| (q.scale * f64::from(c - q.zero)) as f32)
                .collect(),
        }
    }
}

impl<'a> Hybrid<'a> {
    /// The f32 actor blob `f32` and its integer encoding `integer` (made from it by
    /// `encode_integer`), or why they are not such a pair.
    pub fn new(f32: &'a [u8], integer: &'a [u8]) -> Result<Hybrid<'a>, String> {
        let f32_model = Model::from_blob(f32).map_err(|e| format!("the f32 blob: {e}"))?;
        let int_model = Model::from_blob(integer).map_err(|e| format!("the integer blob: {e}"))?;
        let (h, hi) = (f32_model.header().clone(), int_model.header().clone());
        if h.kind != ModelKind::Actor || h.encoding != Encoding::F32 {
            return Err("the first blob is not an f32 actor".into());
        }
        if hi.encoding != Encoding::Integer || (hi.shape, hi.activation) != (h.shape, h.activation)
        {
            return Err("the second blob is not the first's integer encoding".into());
        }
        let payload = blob::verify(integer).map_err(|e| e.to_string())?.payload;
        let values: Vec<f32> = f32_model.values().collect();
        let s = usize::from(h.shape.observations);
        let mut hybrid = Hybrid {
            f32: f32_model,
            integer: int_model,
            mean: values[..s].to_vec(),
            inv_std: values[s..2 * s].to_vec(),
            clip: values[2 * s],
            activation: h.activation,
            layers: Vec::new(),
        };
        let mut at = h.shape.prefix_count(h.kind);
        let mut input = hybrid.input_quantisation(payload)?;
        let mut integer_layers = Vec::new();
        blob::integer_layers(hi.kind, hi.shape, hi.activation, |_, l| {
            integer_layers.push(l)
        });
        for layer in integer_layers {
            let weights = &values[at..at + layer.inputs * layer.outputs];
            let bias = &values[at + weights.len()..at + weights.len() + layer.outputs];
            at += weights.len() + layer.outputs;
            let integer = layer.dense(payload, h.activation == Activation::Relu);
            let next = match layer.table {
                Some(_) => UNIT,
                None => Quantisation {
                    scale: output_scale(payload, &layer, weights, input.scale),
                    zero: integer.output_zero,
                },
            };
            hybrid.layers.push(Layer {
                weights: weights.iter().flat_map(|w| w.to_le_bytes()).collect(),
                bias: bias.iter().flat_map(|b| b.to_le_bytes()).collect(),
                integer,
                input,
                outputs: layer.outputs,
            });
            input = next;
        }
        Ok(hybrid)
    }

    /// The parts: the input codes, then the layers (hidden, then output).
    pub fn parts(&self) -> usize {
        1 + self.layers.len()
    }

    /// The f32 actor (its bounds, its header).
    pub fn f32_model(&self) -> &Model<'a> {
        &self.f32
    }

    /// The real value of one input code step: the input block stores `inv_std / s_in` per
    /// observation (as f32), so `s_in` is read back from the first observation's.
    fn input_quantisation(&self, payload: &[u8]) -> Result<Quantisation, String> {
        let h = self.integer.header();
        let (input, _) = blob::integer_layers(h.kind, h.shape, h.activation, |_, _| {})
            .ok_or("the integer blob has no input block")?;
        let scale = f32::from_le_bytes(word(payload, input.scales));
        Ok(Quantisation {
            scale: f64::from(self.inv_std[0]) / f64::from(scale),
            zero: i32::from_le_bytes(word(payload, input.zero)),
        })
    }

    /// The first layer's input: the integer blob's input codes, or the normalised observation.
    fn entry(&self, obs: &[f32], integer: bool) -> Result<Values, String> {
        if !integer {
            let z = obs.iter().zip(self.mean.iter().zip(&self.inv_std));
            let z = z.map(|(&x, (&m, &k))| normalize_value(x, m, k, self.clip));
            return Ok(Values::Real(z.collect()));
        }
        let mut codes = vec![0i8; obs.len()];
        self.integer
            .observation_codes(obs, &mut codes)
            .map_err(|e| e.to_string())?;
        Ok(Values::Codes(codes.into_iter().map(i32::from).collect()))
    }

    /// The unit-box action with the parts in `integer` run in integers (part 0 the input codes,
    /// part `1 + l` layer `l`), into `unit`.
    pub fn act_unit(
        &self,
        obs: &[f32],
        integer: &Range<usize>,
        unit: &mut [f32],
    ) -> Result<(), String> {
        if obs.len() != self.mean.len() {
            return Err(format!(
                "{} observations, not {}",
                obs.len(),
                self.mean.len()
            ));
        }
        let mut v = self.entry(obs, integer.contains(&0))?;
        let last = self.layers.len() - 1;
        for (l, layer) in self.layers.iter().enumerate() {
            let activation = (l < last).then_some(self.activation);
            v = layer.run(v, integer.contains(&(1 + l)), activation);
        }
        // The output layer's codes are unit codes (its table's); its reals are pre-tanh.
        let out: Vec<f32> = match v {
            Values::Codes(c) => c.into_iter().map(unit_of_code).collect(),
            Values::Real(y) => y.into_iter().map(squash).collect(),
        };
        if out.len() != unit.len() {
            return Err(format!("{} actions, not {}", out.len(), unit.len()));
        }
        unit.copy_from_slice(&out);
        Ok(())
    }

    /// [`Hybrid::act_unit`] mapped into the actor's bounds, as `Model::act` maps it.
    pub fn act(
        &self,
        obs: &[f32],
        integer: &Range<usize>,
        action: &mut [f32],
    ) -> Result<(), String> {
        self.act_unit(obs, integer, action)?;
        self.f32.scale(action);
        Ok(())
    }
}

fn word(payload: &[u8], at: usize) -> [u8; 4] {
    payload
        .get(at..at + 4)
        .and_then(|b| b.try_into().ok())
        .unwrap_or_default()
}

/// A layer's output scale, from its input scale, the f32 weights (column-major) and the stored
/// multiplier `s_in · s_w[o] / s_out` of the output with the largest |weight| (an all-zero
/// output's weight scale is not the f32 weights').
fn output_scale(payload: &[u8], layer: &IntegerLayer, weights: &[f32], s_in: f64) -> f64 {
    let largest = |o: usize| {
        (0..layer.inputs)
            .map(|j| weights[j * layer.outputs + o].abs())
            .fold(0.0f32, f32::max)
    };
    let o = (0..layer.outputs)
        .max_by(|&a, &b| largest(a).total_cmp(&largest(b)))
        .unwrap_or(0);
    let multiplier = i32::from_le_bytes(word(payload, layer.multipliers + 4 * o));
    let shift = i32::from(payload.get(layer.shifts + o).copied().unwrap_or(0) as i8);
    s_in * (f64::from(largest(o)) / 127.0) / blob::real_multiplier(multiplier, shift)
}

/// A [`Hybrid`] in firmware-sim's loop, with a fixed range of parts in integers; a failing
/// step gives the safe action 0, as a booted blob's does.
pub struct HybridPolicy<'h, 'a> {
    /// The actor.
    pub hybrid: &'h Hybrid<'a>,
    /// The parts run in integers.
    pub integer: Range<usize>,
}

impl Controller for HybridPolicy<'_, '_> {
    fn name(&self) -> String {
        format!("hybrid, parts {:?} integer", self.integer)
    }
    fn observations(&self) -> usize {
        usize::from(self.hybrid.f32.header().shape.observations)
    }
    fn actions(&self) -> usize {
        usize::from(self.hybrid.f32.header().shape.actions)
    }
    fn act(&mut self, obs: &[f32], action: &mut [f32]) {
        if self.hybrid.act(obs, &self.integer, action).is_err() {
            action.fill(0.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use policy_core::blob::Spec;

    /// A tanh actor (4 × 48 hidden layers, 2 observations, 2 actions).
    static TANH: &[u8] = include_bytes!("../../policy-core/tests/golden/actor_4x48.postcard");

    /// The same parameters as a ReLU actor, the activation of the study's DCP policies.
    fn relu() -> Vec<u8> {
        let model = Model::from_blob(TANH).unwrap();
        let params: Vec<f32> = model.values().collect();
        let header = model.header().clone();
        let spec = Spec {
            activation: Activation::Relu,
            ..Spec::like(&header, Encoding::F32)
        };
        blob::to_vec_with(&spec, &mut |sink| sink(&params)).unwrap()
    }

    /// `n` observations of 2 components in ±6 (a small LCG: no dependency), flattened.
    fn observations(n: usize, seed: u32) -> Vec<f32> {
        let mut state = seed;
        (0..2 * n)
            .map(|_| {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                (state >> 8) as f32 / (1u32 << 24) as f32 * 12.0 - 6.0
            })
            .collect()
    }

    fn act(model: &Model<'_>, obs: &[f32]) -> [f32; 2] {
        let mut a = [0.0f32; 2];
        model
            .act_in(obs, &mut vec![0.0; model.scratch_floats()], &mut a)
            .unwrap();
        a
    }

    #[test]
    fn all_parts_integer_is_the_integer_blob_and_none_the_f32_blob() {
        for f32 in [TANH.to_vec(), relu()] {
            let integer = blob::encode_integer(&f32, &observations(200, 1)).unwrap();
            let hybrid = Hybrid::new(&f32, &integer).unwrap();
            let (f, i) = (
                Model::from_blob(&f32).unwrap(),
                Model::from_blob(&integer).unwrap(),
            );
            let mut states = observations(300, 2);
            states.extend([f32::NAN, 1.0, 1e9, -1e9]); // a dropout, and codes at both ends
            for obs in states.chunks_exact(2) {
                let mut a = [0.0f32; 2];
                hybrid.act(obs, &(0..hybrid.parts()), &mut a).unwrap();
                assert_eq!(
                    a.map(f32::to_bits),
                    act(&i, obs).map(f32::to_bits),
                    "{obs:?}"
                );
                hybrid.act(obs, &(0..0), &mut a).unwrap();
                assert_eq!(
                    a.map(f32::to_bits),
                    act(&f, obs).map(f32::to_bits),
                    "{obs:?}"
                );
            }
        }
    }

    /// The scales read back from the multipliers are the writer's: for a ReLU layer, the
    /// calibrated range `[0, hi]` over 255 steps (no layer of this actor is widened).
    #[test]
    fn the_scales_read_back_are_the_writers() {
        let f32 = relu();
        let calibration = observations(200, 1);
        let ranges = blob::calibrate(&f32, &calibration).unwrap();
        let integer = blob::encode_integer(&f32, &calibration).unwrap();
        let hybrid = Hybrid::new(&f32, &integer).unwrap();
        let clip = hybrid.clip;
        let (lo, hi) = ranges[0];
        let input = (hi.min(clip).max(0.0) - lo.max(-clip).min(0.0)) as f64 / 255.0;
        let relative = |a: f64, b: f64| (a - b).abs() / b;
        assert!(relative(hybrid.layers[0].input.scale, input) < 1e-6);
        for (layer, &(_, hi)) in hybrid.layers[1..].iter().zip(&ranges[1..]) {
            let relu = f64::from(hi) / 255.0;
            assert!(
                relative(layer.input.scale, relu) < 1e-6,
                "{} against {relu}",
                layer.input.scale
            );
        }
    }

    /// Each part alone moves the action by a few code steps at most, and some part moves it: a
    /// scale read back wrongly would move it by far more.
    #[test]
    fn one_integer_part_moves_the_action_a_little() {
        let f32 = relu();
        let integer = blob::encode_integer(&f32, &observations(200, 1)).unwrap();
        let hybrid = Hybrid::new(&f32, &integer).unwrap();
        let states = observations(200, 3);
        for part in 0..hybrid.parts() {
            let mut largest = 0.0f32;
            for obs in states.chunks_exact(2) {
                let (mut a, mut b) = ([0.0f32; 2], [0.0f32; 2]);
                hybrid.act_unit(obs, &(0..0), &mut a).unwrap();
                hybrid.act_unit(obs, &(part..part + 1), &mut b).unwrap();
                largest = a
                    .iter()
                    .zip(&b)
                    .map(|(a, b)| (a - b).abs())
                    .fold(largest, f32::max);
            }
            assert!(largest > 0.0 && largest < 0.1, "part {part}: {largest}");
        }
    }
}
