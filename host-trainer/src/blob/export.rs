//! From trained networks to policy-core blobs.
//!
//! [`actor_blob`] / [`critic_blob`] write the trainer's networks with policy-core's runtime
//! writer ([`blob::Spec`] and [`blob::to_vec_with`]): any shape within the format's limits, no
//! table of compiled shapes. Every blob is loaded back through policy-core's runtime
//! [`Model`] before it is returned, so an exported blob always boots. The trainer's evaluations
//! (`host-trainer eval`, the end-of-training evaluation) run the blob through that same
//! [`Model`] in firmware-sim.
//!
//! The training loop's own forward pass ([`crate::nn::forward`]: [`Net::forward_one`],
//! policy-core's arithmetic on the trainer's weights, no blob needed) is what the blob
//! reproduces bit for bit: the tests here hold it bit-equal to [`Model`] on the exported blob.

use policy_core::blob::{self, Spec};
use policy_core::model::Model;
use policy_core::{Activation, Encoding, ModelKind, Shape};

use crate::error::Error;
use crate::nn::forward::ActorParts;
use crate::nn::hidden::Hidden;
use crate::nn::net::{Net, Output};
use crate::nn::normalize::RunningNorm;

/// The blob shape of a network with `observations` inputs, `actions` outputs and `hidden`
/// layers, checked against policy-core's limits ([`Shape::check`]) and the format's payload
/// maximum for both the actor and the critic. Nothing is allocated: the trainer calls this
/// before it builds any network, so a shape like `100x100000` is a one-line error, not a 40 GB
/// allocation.
///
/// ```
/// use host_trainer::{blob::export::check_supported, nn::hidden::Hidden};
/// let shape = check_supported(2, 2, Hidden { depth: 3, width: 40 }).unwrap();
/// assert_eq!((shape.depth, shape.width), (3, 40));
/// let err = check_supported(2, 2, Hidden { depth: 100, width: 100_000 }).unwrap_err();
/// assert!(err.to_string().contains("unsupported network shape"), "{err}");
/// assert!(err.to_string().contains("width must be in 1..=1024"), "{err}");
/// ```
pub fn check_supported(
    observations: usize,
    actions: usize,
    hidden: Hidden,
) -> Result<Shape, Error> {
    let unsupported = |reason: policy_core::Error| Error::UnsupportedShape {
        shape: format!("{observations} observations, {hidden} hidden, {actions} actions"),
        reason: reason.to_string(),
    };
    let shape = shape_of(observations, actions, hidden).map_err(unsupported)?;
    for kind in [ModelKind::Actor, ModelKind::Critic] {
        let spec = Spec {
            kind,
            encoding: policy_core::Encoding::F32,
            shape,
            activation: Activation::Tanh,
            label: "",
        };
        blob::encoded_len(&spec).map_err(unsupported)?;
    }
    Ok(shape)
}

/// The header's [`Shape`] of these sizes; a size beyond its field's limit is
/// [`policy_core::Error::ShapeBeyondLimits`] (never truncated into a smaller shape).
fn shape_of(
    observations: usize,
    actions: usize,
    hidden: Hidden,
) -> Result<Shape, policy_core::Error> {
    let sizes = [
        ("observations", observations, blob::MAX_OBSERVATIONS),
        ("actions", actions, blob::MAX_ACTIONS),
        ("width", hidden.width, blob::MAX_WIDTH),
        ("depth", hidden.depth, blob::MAX_DEPTH),
    ];
    for (what, found, max) in sizes {
        if found < 1 || found > max {
            return Err(policy_core::Error::ShapeBeyondLimits {
                what,
                min: 1,
                max,
                found,
            });
        }
    }
    // Every size is now within its limit, which fits its header field.
    let field = |v: usize| u16::try_from(v).unwrap_or(u16::MAX);
    Ok(Shape {
        observations: field(observations),
        actions: field(actions),
        width: field(hidden.width),
        depth: u8::try_from(hidden.depth).unwrap_or(u8::MAX),
        choices: 0,
    })
}

/// The actor as blob bytes (policy-core's format, any shape within its limits), labelled
/// `label` (at most 32 bytes). Parameter order: normaliser (mean, inverse std, clip), bounds
/// (low, high), then every layer's column-major weights and biases, first to output.
///
/// ```
/// # use host_trainer::blob::export::actor_blob;
/// # use host_trainer::nn::{forward::{act, ActorParts}, net::{Net, NetConfig, Output},
/// #     normalize::RunningNorm};
/// use policy_core::model::{Model, Scratch};
/// # let config = NetConfig { inputs: 2, width: 40, depth: 3, outputs: 2,
/// #     activation: policy_core::Activation::Tanh, output: Output::Tanh, dropout: 0.0 };
/// let net = Net::new(config, &mut firmware_sim::seed::training_stream(1, "actor"));
/// let norm = RunningNorm::new(2, 5.0);
/// let parts = ActorParts { net: &net, norm: &norm, low: &[-0.25; 2], high: &[0.25; 2] };
/// let blob = actor_blob(&parts, "doc").unwrap();
/// let model = Model::from_blob(&blob).unwrap();
/// let mut action = [0.0; 2];
/// model.act(&[1.0, 2.0], &mut Scratch::<40>::new(), &mut action).unwrap();
/// assert_eq!(action.to_vec(), act(&parts, &[1.0, 2.0]));
/// ```
pub fn actor_blob(parts: &ActorParts<'_>, label: &str) -> Result<Vec<u8>, Error> {
    let net = parts.net;
    check_net(net, Output::Tanh, "actor")?;
    check_size(
        "actor input vs normaliser",
        parts.norm.dim(),
        net.config.inputs,
    )?;
    check_size("action bounds (low)", net.config.outputs, parts.low.len())?;
    check_size("action bounds (high)", net.config.outputs, parts.high.len())?;
    let bounds = [parts.low, parts.high];
    write(
        ModelKind::Actor,
        net,
        parts.norm,
        net.config.outputs,
        &bounds,
        label,
    )
}

/// The critic as blob bytes. `net` takes `[observation, unit action]` (`act_dim` actions last)
/// and has one linear output; `norm` is the actor's normaliser (the critic shares it). Parameter
/// order: normaliser, then every layer's weights and biases (the first layer's columns are the
/// observation's, then the action's).
///
/// ```
/// # use host_trainer::blob::export::critic_blob;
/// # use host_trainer::nn::{forward::q, net::{Net, NetConfig, Output}, normalize::RunningNorm};
/// use policy_core::model::{Model, Scratch};
/// # let config = NetConfig { inputs: 4, width: 32, depth: 2, outputs: 1,
/// #     activation: policy_core::Activation::Relu, output: Output::Linear, dropout: 0.0 };
/// let net = Net::new(config, &mut firmware_sim::seed::training_stream(1, "critic"));
/// let norm = RunningNorm::new(2, 5.0);
/// let blob = critic_blob(&net, &norm, 2, "doc").unwrap();
/// let model = Model::from_blob(&blob).unwrap();
/// let value = model.q(&[1.0, 2.0], &[0.5, -0.5], &mut Scratch::<32>::new()).unwrap();
/// assert_eq!(value, q(&net, &norm, &[1.0, 2.0], &[0.5, -0.5]));
/// ```
pub fn critic_blob(
    net: &Net,
    norm: &RunningNorm,
    act_dim: usize,
    label: &str,
) -> Result<Vec<u8>, Error> {
    check_net(net, Output::Linear, "critic")?;
    check_size("critic outputs", 1, net.config.outputs)?;
    check_size(
        "critic inputs (observations + actions)",
        norm.dim() + act_dim,
        net.config.inputs,
    )?;
    write(ModelKind::Critic, net, norm, act_dim, &[], label)
}

/// Writes `net` as a blob of `kind` with policy-core's runtime writer, then loads it back
/// through [`Model::from_blob`], which applies every rule the chip applies (finite parameters,
/// low <= high, positive clip): an exported blob always boots.
/// A discrete-policy blob (DQN): the Q-network `net` (linear, one output per row of the action
/// table), the normaliser, the action bounds and the `table` (`net.config.outputs` rows of
/// `low.len()` plant-unit actions). policy-core's `Model::act` takes the argmax of Q and returns
/// that row.
pub fn discrete_blob(
    net: &Net,
    norm: &RunningNorm,
    low: &[f32],
    high: &[f32],
    table: &[f32],
    label: &str,
) -> Result<Vec<u8>, Error> {
    check_net(net, Output::Linear, "discrete policy")?;
    check_size(
        "Q-network input vs normaliser",
        norm.dim(),
        net.config.inputs,
    )?;
    check_size("action bounds (high)", low.len(), high.len())?;
    check_size(
        "action table (rows x actions)",
        net.config.outputs * low.len(),
        table.len(),
    )?;
    write(
        ModelKind::Discrete,
        net,
        norm,
        low.len(),
        &[low, high, table],
        label,
    )
}

fn write(
    kind: ModelKind,
    net: &Net,
    norm: &RunningNorm,
    actions: usize,
    bounds: &[&[f32]],
    label: &str,
) -> Result<Vec<u8>, Error> {
    let c = &net.config;
    let hidden = Hidden {
        depth: c.depth,
        width: c.width,
    };
    let mut shape = check_supported(norm.dim(), actions, hidden)?;
    if kind == ModelKind::Discrete {
        shape.choices = u16::try_from(c.outputs).map_err(|_| Error::UnsupportedShape {
            shape: format!("{} moves", c.outputs),
            reason: format!("at most {} rows in an action table", blob::MAX_CHOICES),
        })?;
    }
    let spec = Spec {
        kind,
        encoding: policy_core::Encoding::F32,
        shape,
        activation: c.activation,
        label,
    };
    let (mean, inv_std) = (norm.mean_f32(), norm.inv_std_f32());
    let bytes = blob::to_vec_with(&spec, &mut |sink| {
        sink(&mean);
        sink(&inv_std);
        sink(&[norm.clip]);
        bounds.iter().for_each(|b| sink(b));
        for layer in &net.layers {
            sink(&layer.w);
            sink(&layer.b);
        }
    })?;
    Model::from_blob(&bytes)?;
    Ok(bytes)
}

fn check_net(net: &Net, output: Output, what: &'static str) -> Result<(), Error> {
    if !net.is_consistent() {
        return Err(Error::ShapeMismatch {
            what: "network layers vs config",
            expected: net.config.depth + 1,
            found: net.layers.len(),
        });
    }
    if net.config.output != output {
        return Err(Error::UnsupportedShape {
            shape: format!("{what} with {:?} output", net.config.output),
            reason: format!("a {what} blob needs a {output:?} output"),
        });
    }
    Ok(())
}

fn check_size(what: &'static str, expected: usize, found: usize) -> Result<(), Error> {
    if expected == found {
        Ok(())
    } else {
        Err(Error::ShapeMismatch {
            what,
            expected,
            found,
        })
    }
}

/// The blob `bytes` (f32 weights) with its weights stored in `encoding` instead:
/// [`policy_core::blob::encode`] (its one definition), with this crate's error.
///
/// ```
/// use host_trainer::blob::export::encode;
/// use policy_core::Encoding;
/// static F32: &[u8] = include_bytes!("../../../policy-core/tests/golden/actor_4x48.postcard");
/// assert!(encode(F32, Encoding::Int8).unwrap().len() < F32.len() / 3);
/// ```
pub fn encode(bytes: &[u8], encoding: Encoding) -> Result<Vec<u8>, Error> {
    Ok(blob::encode(bytes, encoding)?)
}

/// Episodes of firmware-sim's test protocol an integer export is calibrated on by default.
pub const CALIBRATION_EPISODES: u64 = 20;

/// The seed of the calibration episodes: its own, so that no start the test protocol (seed 0 by
/// default) or validation draws is the one the ranges were measured on.
pub const CALIBRATION_SEED: u64 = 0xCA11_B8A7;

/// The observations an actor visits on its plant, for the integer encoding's calibration: every
/// observation the f32 `policy` blob is given in `episodes` episodes of firmware-sim's test
/// protocol on `scenario` (ideal sensors, seed [`CALIBRATION_SEED`]), flattened. These are the
/// states the exported policy itself meets in closed loop, which neither the replay buffer
/// (exploration's states, and only off-policy algorithms have one) nor a validation round
/// (which keeps no observations) gives.
///
/// ```
/// use firmware_sim::nav::scenario::Scenario;
/// use host_trainer::blob::export::calibration_observations;
/// static F32: &[u8] = include_bytes!("../../../policy-core/tests/golden/actor_4x48.postcard");
/// let s = Scenario::builtin("nav-walls").unwrap();
/// let obs = calibration_observations(F32, &s, 2).unwrap();
/// assert!(obs.len() >= 2 * 2 && obs.len() % 2 == 0);
/// ```
pub fn calibration_observations(
    policy: &[u8],
    scenario: &firmware_sim::nav::scenario::Scenario,
    episodes: usize,
) -> Result<Vec<f32>, Error> {
    visited_observations(policy, scenario, episodes, CALIBRATION_SEED)
}

/// Every observation the `policy` blob is given in `episodes` episodes of firmware-sim's test
/// protocol on `scenario` with `seed` (ideal sensors), flattened.
pub fn visited_observations(
    policy: &[u8],
    scenario: &firmware_sim::nav::scenario::Scenario,
    episodes: usize,
    seed: u64,
) -> Result<Vec<f32>, Error> {
    let config = firmware_sim::nav::test_protocol::EvalConfig {
        episodes,
        seed,
        ..Default::default()
    };
    visited_observations_in(policy, scenario, &config)
}

/// Every observation the `policy` blob is given in firmware-sim's test protocol run with
/// `config` (its sensor, actuator and faults: a NaN dropout is recorded as the NaN the policy
/// is given), flattened.
pub fn visited_observations_in(
    policy: &[u8],
    scenario: &firmware_sim::nav::scenario::Scenario,
    config: &firmware_sim::nav::test_protocol::EvalConfig,
) -> Result<Vec<f32>, Error> {
    use firmware_sim::controller::{BlobPolicy, Observed};
    use firmware_sim::nav::test_protocol::evaluate_controller;
    let sim = |e: firmware_sim::Error| Error::Sim {
        context: "calibration episodes".into(),
        message: e.to_string(),
    };
    let inner = BlobPolicy::boot(policy).map_err(sim)?;
    let mut seen = Vec::new();
    let mut recording = Observed::new(inner, |_, obs: &[f32], _: &[f32]| {
        seen.extend_from_slice(obs);
    });
    evaluate_controller(&mut recording, scenario, config).map_err(sim)?;
    drop(recording);
    Ok(seen)
}

/// The f32 actor blob `policy` in the integer encoding, calibrated on `observations`
/// (flattened): [`policy_core::blob::encode_integer`] (its one definition), with this crate's
/// error. A NaN in the data or a layer whose range is zero is policy-core's
/// `Calibration` error, which names the observation or the layer.
///
/// ```
/// use host_trainer::blob::export::encode_integer;
/// static F32: &[u8] = include_bytes!("../../../policy-core/tests/golden/actor_4x48.postcard");
/// assert!(encode_integer(F32, &[4.0, -2.5, 0.0, 1.0]).unwrap().len() < F32.len() / 2);
/// let err = encode_integer(F32, &[f32::NAN, 0.0]).unwrap_err();
/// assert!(err.to_string().contains("NaN or infinite observation"), "{err}");
/// ```
pub fn encode_integer(policy: &[u8], observations: &[f32]) -> Result<Vec<u8>, Error> {
    Ok(blob::encode_integer(policy, observations)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nn::forward::{act, act_unit, q};
    use crate::nn::net::NetConfig;
    use firmware_sim::seed::{training_stream, uniform_in};
    use policy_core::model::Scratch;

    /// A network whose every layer has weights of useful size (a fresh DDPG init has a ±3e-3
    /// output layer, which would test little beyond the biases).
    fn trained_like(
        inputs: usize,
        width: usize,
        depth: usize,
        outputs: usize,
        activation: Activation,
        output: Output,
    ) -> Net {
        let mut rng = training_stream(width as u64 * 10 + depth as u64, "export");
        let config = NetConfig {
            inputs,
            width,
            depth,
            outputs,
            activation,
            output,
            dropout: 0.5,
        };
        let mut net = Net::new(config, &mut rng);
        for layer in &mut net.layers {
            let bound = 2.0 / (layer.inputs as f32).sqrt();
            layer
                .w
                .iter_mut()
                .chain(&mut layer.b)
                .for_each(|p| *p = uniform_in(&mut rng, -bound, bound));
        }
        net
    }

    fn norm_with_stats() -> RunningNorm {
        let mut rng = training_stream(5, "norm");
        let mut norm = RunningNorm::new(2, 5.0);
        for _ in 0..200 {
            norm.update(&[
                uniform_in(&mut rng, -6.0, 6.0),
                uniform_in(&mut rng, -1.0, 3.0),
            ]);
        }
        norm
    }

    /// 1,000 observations: in range, far out of range, and non-finite components.
    fn observations() -> Vec<[f32; 2]> {
        let mut rng = training_stream(6, "obs");
        let specials = [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            -1e30,
            0.0,
        ];
        (0..1000)
            .map(|i| match i % 10 {
                0 => [specials[i / 10 % 6], uniform_in(&mut rng, -6.0, 6.0)],
                1 => [uniform_in(&mut rng, -100.0, 100.0), specials[i / 10 % 6]],
                2 | 3 => [
                    uniform_in(&mut rng, -100.0, 100.0),
                    uniform_in(&mut rng, -100.0, 100.0),
                ],
                _ => [
                    uniform_in(&mut rng, -6.5, 6.5),
                    uniform_in(&mut rng, -6.5, 6.5),
                ],
            })
            .collect()
    }

    fn bits(v: &[f32]) -> Vec<u32> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    fn model(blob: &[u8]) -> Model<'_> {
        Model::from_blob(blob).expect("the exported blob loads")
    }

    /// The training loop's forward pass ([`act_unit`], [`act`]) against policy-core's runtime
    /// model on the exported blob: bit-equal on 1,000 observations, NaN and ±Inf included.
    fn check_actor(depth: usize, width: usize, activation: Activation) {
        let net = trained_like(2, width, depth, 2, activation, Output::Tanh);
        let norm = norm_with_stats();
        let (low, high) = ([-0.25, -1.0], [0.25, 0.5]);
        let parts = ActorParts {
            net: &net,
            norm: &norm,
            low: &low,
            high: &high,
        };
        let blob = actor_blob(&parts, "test").expect("export");
        let model = model(&blob);
        let mut scratch = Box::new(Scratch::<64>::new());
        let mut saturated = 0;
        for obs in observations() {
            let unit = act_unit(&parts, &obs);
            let mut expected = [0.0f32; 2];
            model
                .act_unit(&obs, &mut scratch, &mut expected)
                .expect("act_unit");
            assert_eq!(bits(&unit), bits(&expected), "act_unit at {obs:?}");
            model.act(&obs, &mut scratch, &mut expected).expect("act");
            assert_eq!(bits(&act(&parts, &obs)), bits(&expected), "act at {obs:?}");
            saturated += unit.iter().filter(|u| u.abs() > 0.999).count();
        }
        // The comparison covered real, unsaturated outputs.
        assert!(saturated < 1000, "{saturated} of 2000 outputs saturated");
    }

    fn check_critic(depth: usize, width: usize, activation: Activation) {
        let net = trained_like(4, width, depth, 1, activation, Output::Linear);
        let norm = norm_with_stats();
        let blob = critic_blob(&net, &norm, 2, "critic").expect("export");
        let model = model(&blob);
        let mut scratch = Box::new(Scratch::<64>::new());
        let mut rng = training_stream(7, "actions");
        for (i, obs) in observations().into_iter().enumerate() {
            let mut a = [
                uniform_in(&mut rng, -1.5, 1.5),
                uniform_in(&mut rng, -1.0, 1.0),
            ];
            if i % 50 == 0 {
                a[i / 50 % 2] = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY][i / 100 % 3];
            }
            let expected = model.q(&obs, &a, &mut scratch).expect("q");
            assert_eq!(
                q(&net, &norm, &obs, &a).to_bits(),
                expected.to_bits(),
                "q at {obs:?}, {a:?}"
            );
        }
    }

    #[test]
    fn actor_2x32_tanh_is_bit_exact() {
        check_actor(2, 32, Activation::Tanh);
    }

    /// A shape no build ever compiled: the runtime writer and model need no table.
    #[test]
    fn actor_3x40_tanh_and_relu_are_bit_exact() {
        check_actor(3, 40, Activation::Tanh);
        check_actor(3, 40, Activation::Relu);
    }

    #[test]
    fn actor_4x48_tanh_and_relu_are_bit_exact() {
        check_actor(4, 48, Activation::Tanh);
        check_actor(4, 48, Activation::Relu);
    }

    #[test]
    fn actor_3x64_and_6x64_relu_are_bit_exact() {
        check_actor(3, 64, Activation::Relu);
        check_actor(6, 64, Activation::Relu);
    }

    #[test]
    fn actor_odd_shapes_are_bit_exact() {
        check_actor(1, 7, Activation::Tanh);
        check_actor(2, 17, Activation::Relu);
    }

    #[test]
    fn critic_2x32_tanh_is_bit_exact() {
        check_critic(2, 32, Activation::Tanh);
    }

    #[test]
    fn critic_3x40_and_4x48_are_bit_exact() {
        check_critic(3, 40, Activation::Relu);
        check_critic(4, 48, Activation::Tanh);
    }

    #[test]
    fn critic_5x48_relu_is_bit_exact() {
        check_critic(5, 48, Activation::Relu);
    }

    /// The runtime writer puts the parameters exactly where the compiled types' writer did: for
    /// shapes both can write, the bytes are identical.
    /// Copies a trainer layer into a compiled layer's weights and biases.
    fn fill(w: &mut [f32], b: &mut [f32], layer: &crate::nn::net::Layer) {
        w.copy_from_slice(&layer.w);
        b.copy_from_slice(&layer.b);
    }

    #[test]
    fn runtime_writer_matches_the_compiled_writer_byte_for_byte() {
        let norm = norm_with_stats();
        let net = trained_like(2, 32, 3, 2, Activation::Relu, Output::Tanh);
        let (low, high) = ([-0.25, -1.0], [0.25, 0.5]);
        let parts = ActorParts {
            net: &net,
            norm: &norm,
            low: &low,
            high: &high,
        };
        let mut p = Box::new(policy_core::Policy::<2, 32, 2, 2>::ZERO);
        p.normalizer = norm.to_policy::<2>();
        p.bounds.low.as_mut_slice().copy_from_slice(&low);
        p.bounds.high.as_mut_slice().copy_from_slice(&high);
        fill(
            p.input.w.as_mut_slice(),
            p.input.b.as_mut_slice(),
            &net.layers[0],
        );
        for (d, l) in p.trunk.hidden.iter_mut().zip(&net.layers[1..]) {
            fill(d.w.as_mut_slice(), d.b.as_mut_slice(), l);
        }
        let out = &mut p.trunk.output;
        fill(out.w.as_mut_slice(), out.b.as_mut_slice(), &net.layers[3]);
        p.trunk.activation = Activation::Relu;
        assert_eq!(
            actor_blob(&parts, "same").expect("export"),
            p.to_blob("same").expect("blob")
        );

        let critic = trained_like(4, 32, 2, 1, Activation::Tanh, Output::Linear);
        let mut c = Box::new(policy_core::Critic::<2, 32, 1, 2>::ZERO);
        c.normalizer = norm.to_policy::<2>();
        let (obs_w, act_w) = critic.layers[0].w.split_at(2 * 32);
        c.input.w.as_mut_slice().copy_from_slice(obs_w);
        c.action_w.as_mut_slice().copy_from_slice(act_w);
        c.input
            .b
            .as_mut_slice()
            .copy_from_slice(&critic.layers[0].b);
        let hidden = &mut c.trunk.hidden[0];
        fill(
            hidden.w.as_mut_slice(),
            hidden.b.as_mut_slice(),
            &critic.layers[1],
        );
        let out = &mut c.trunk.output;
        fill(
            out.w.as_mut_slice(),
            out.b.as_mut_slice(),
            &critic.layers[2],
        );
        c.trunk.activation = Activation::Tanh;
        assert_eq!(
            critic_blob(&critic, &norm, 2, "same").expect("export"),
            c.to_blob("same").expect("blob")
        );
    }

    proptest::proptest! {
        /// Any observation at all (every f32 bit pattern, NaN and infinities included) gives
        /// a finite action inside the bounds, bit-identical to the runtime model's on the blob.
        #[test]
        fn any_observation_acts_like_the_blob_and_in_bounds(a in proptest::prelude::any::<u32>(), b in proptest::prelude::any::<u32>()) {
            let net = trained_like(2, 32, 3, 2, Activation::Relu, Output::Tanh);
            let norm = norm_with_stats();
            let (low, high) = ([-0.25, 0.0], [0.25, 2.0]);
            let parts = ActorParts { net: &net, norm: &norm, low: &low, high: &high };
            let blob = actor_blob(&parts, "p").expect("export");
            let obs = [f32::from_bits(a), f32::from_bits(b)];
            let action = act(&parts, &obs);
            let mut expected = [0.0f32; 2];
            model(&blob).act(&obs, &mut Scratch::<32>::new(), &mut expected).expect("act");
            proptest::prop_assert_eq!(bits(&action), bits(&expected));
            for ((&x, &lo), &hi) in action.iter().zip(&low).zip(&high) {
                proptest::prop_assert!(x.is_finite() && lo <= x && x <= hi);
            }
        }
    }

    #[test]
    fn same_network_same_bytes() {
        let net = trained_like(2, 48, 4, 2, Activation::Tanh, Output::Tanh);
        let norm = norm_with_stats();
        let parts = ActorParts {
            net: &net,
            norm: &norm,
            low: &[-0.25; 2],
            high: &[0.25; 2],
        };
        let first = actor_blob(&parts, "x").expect("export");
        assert_eq!(first, actor_blob(&parts, "x").expect("export"));
        let verified = policy_core::blob::verify(&first).expect("verify");
        assert_eq!(verified.header.shape.width, 48);
        assert_eq!(verified.header.shape.depth, 4);
    }

    #[test]
    fn unsupported_and_mismatched_shapes_are_errors() {
        let norm = norm_with_stats();
        let wide = trained_like(2, 1025, 1, 2, Activation::Tanh, Output::Tanh);
        let parts = ActorParts {
            net: &wide,
            norm: &norm,
            low: &[-1.0; 2],
            high: &[1.0; 2],
        };
        let err = actor_blob(&parts, "x").expect_err("width 1025 is beyond the format's limit");
        assert!(matches!(err, Error::UnsupportedShape { .. }), "{err}");
        assert!(
            err.to_string().contains("width must be in 1..=1024"),
            "{err}"
        );

        let net = trained_like(2, 32, 2, 2, Activation::Tanh, Output::Tanh);
        let parts = ActorParts {
            net: &net,
            norm: &norm,
            low: &[-1.0; 3],
            high: &[1.0; 2],
        };
        assert!(matches!(
            actor_blob(&parts, "x"),
            Err(Error::ShapeMismatch {
                expected: 2,
                found: 3,
                ..
            })
        ));

        let critic = trained_like(4, 32, 2, 1, Activation::Tanh, Output::Linear);
        assert!(matches!(
            critic_blob(&critic, &norm, 3, "x"),
            Err(Error::ShapeMismatch { .. })
        ));
        let parts = ActorParts {
            net: &critic,
            norm: &norm,
            low: &[-1.0],
            high: &[1.0],
        };
        assert!(matches!(
            actor_blob(&parts, "x"),
            Err(Error::UnsupportedShape { .. } | Error::ShapeMismatch { .. })
        ));

        let parts = ActorParts {
            net: &net,
            norm: &norm,
            low: &[-1.0; 2],
            high: &[1.0; 2],
        };
        let long = "a label that is much longer than thirty-two bytes";
        assert!(matches!(actor_blob(&parts, long), Err(Error::Blob(_))));
        let inverted = ActorParts {
            net: &net,
            norm: &norm,
            low: &[1.0; 2],
            high: &[-1.0; 2],
        };
        assert!(matches!(actor_blob(&inverted, "x"), Err(Error::Blob(_))));
        let mut broken = net.clone();
        broken.layers[1].b[0] = f32::INFINITY;
        let parts = ActorParts {
            net: &broken,
            norm: &norm,
            low: &[-1.0; 2],
            high: &[1.0; 2],
        };
        assert!(matches!(
            actor_blob(&parts, "x"),
            Err(Error::Blob(policy_core::Error::NonFiniteParameter { .. }))
        ));
    }
}

/// How a flash slot image is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ImageFormat {
    /// The raw slot record; the flasher is told the address.
    Bin,
    /// Intel HEX with the slot's address inside.
    Hex,
}

impl core::fmt::Display for ImageFormat {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            ImageFormat::Bin => "bin",
            ImageFormat::Hex => "hex",
        })
    }
}

/// Where a slot image goes: the slot's flash address and size, and the record's sequence number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlotTarget {
    /// The slot's first byte in the chip's address space.
    pub address: u32,
    /// The slot's size in bytes; a record that does not fit is refused.
    pub size: usize,
    /// The record's sequence number (one more than the running slot's makes it the newer).
    pub sequence: u32,
}

/// The flash image of a policy blob for one slot: policy-core's slot record (header with the
/// sequence number, then the blob), raw or as Intel HEX at the slot's address. The blob is
/// verified first, so an image never carries a blob the firmware would refuse as corrupt.
///
/// ```
/// use host_trainer::blob::export::{slot_image, ImageFormat, SlotTarget};
/// static BLOB: &[u8] = include_bytes!("../../../policy-core/tests/golden/actor_2x32.postcard");
/// let target = SlotTarget { address: 0x0804_0000, size: 128 * 1024, sequence: 2 };
/// let bin = slot_image(BLOB, ImageFormat::Bin, target).unwrap();
/// assert_eq!(&bin[..4], b"DCPS");
/// assert_eq!(bin.len(), 16 + BLOB.len());
/// let hex = String::from_utf8(slot_image(BLOB, ImageFormat::Hex, target).unwrap()).unwrap();
/// assert!(hex.starts_with(":020000040804EE\n:1000000044435053"));
/// assert!(slot_image(&BLOB[1..], ImageFormat::Bin, target).is_err());
/// ```
pub fn slot_image(blob: &[u8], format: ImageFormat, target: SlotTarget) -> Result<Vec<u8>, Error> {
    Model::from_blob(blob)?;
    let record = policy_core::slot::record(blob, target.sequence, target.size)?;
    check_slot_address(target.address, record.len())?;
    Ok(match format {
        ImageFormat::Bin => record,
        ImageFormat::Hex => policy_core::slot::intel_hex(&record, target.address)?.into_bytes(),
    })
}

/// The one address check of both image kinds: the slot starts at a 4-byte boundary (the
/// payload follows a 16-byte header, and the firmware reads its weights as `f32` words in place,
/// docs/blob-format.md), and the record ends inside the 32-bit address space.
fn check_slot_address(address: u32, record_len: usize) -> Result<(), Error> {
    if address % 4 != 0 {
        return Err(Error::invalid(
            "--address",
            "a slot address that is a multiple of 4 (the blob's weights are read in place as f32 words)",
            format!("{address:#x}"),
        ));
    }
    let end = u64::from(address) + record_len as u64;
    if end > 1 << 32 {
        return Err(Error::invalid(
            "--address",
            format!("room for the {record_len}-byte record below 0x1_0000_0000"),
            format!("{address:#x} (the record would end at {end:#x})"),
        ));
    }
    Ok(())
}
