//! From trained networks to policy-core blobs, and the trainer's evaluation that the blob
//! reproduces bit for bit.
//!
//! [`act`] / [`act_unit`] / [`q`] run the trainer's own networks with policy-core's arithmetic;
//! [`actor_blob`] / [`critic_blob`] copy the same numbers into policy-core's `Policy` / `Critic`
//! and serialise them with policy-core's writer. policy-core's types have compile-time sizes, so
//! the network's runtime shape is dispatched to one of the [`SUPPORTED`] compiled shapes.

use policy_core::{Critic, Policy};

use crate::agent::Hidden;
use crate::error::Error;
use crate::net::{Net, Output};
use crate::normalize::RunningNorm;

/// The shapes with a compiled policy-core type (anything else is [`Error::UnsupportedShape`]).
pub const SUPPORTED: &str = "2 observations, 2 actions, width 32/48/64, depth 2..=6, tanh or relu";

/// Calls `$f::<S, H, L, A>(args)` for the compiled shape matching `(obs, act, width, depth)`,
/// or gives `None`. Each line is one compiled shape.
macro_rules! dispatch {
    ($f:ident $args:tt, $obs:expr, $act:expr, $width:expr, $depth:expr) => {
        dispatch!(@arms $f $args, ($obs, $act, $width, $depth);
            (2, 2, 32, 2, 1), (2, 2, 32, 3, 2), (2, 2, 32, 4, 3), (2, 2, 32, 5, 4), (2, 2, 32, 6, 5),
            (2, 2, 48, 2, 1), (2, 2, 48, 3, 2), (2, 2, 48, 4, 3), (2, 2, 48, 5, 4), (2, 2, 48, 6, 5),
            (2, 2, 64, 2, 1), (2, 2, 64, 3, 2), (2, 2, 64, 4, 3), (2, 2, 64, 5, 4), (2, 2, 64, 6, 5))
    };
    (@arms $f:ident $args:tt, $key:expr; $(($s:literal, $a:literal, $h:literal, $d:literal, $l:literal)),*) => {
        match $key {
            $( ($s, $a, $h, $d) => Some($f::<$s, $h, $l, $a> $args), )*
            _ => None,
        }
    };
}

/// Checks that policy-core has a compiled type for a network of this shape, before any network
/// is allocated: a shape like `100x100000` must be a one-line error, not a 40 GB allocation.
///
/// ```
/// use host_trainer::{agent::Hidden, export::check_supported};
/// assert!(check_supported(2, 2, Hidden { depth: 4, width: 48 }).is_ok());
/// let err = check_supported(2, 2, Hidden { depth: 100, width: 100_000 }).unwrap_err();
/// assert!(err.to_string().contains("unsupported network shape"), "{err}");
/// ```
pub fn check_supported(observations: usize, actions: usize, hidden: Hidden) -> Result<(), Error> {
    fn compiled<const S: usize, const H: usize, const L: usize, const A: usize>() {}
    dispatch!(
        compiled(),
        observations,
        actions,
        hidden.width,
        hidden.depth
    )
    .ok_or_else(|| Error::UnsupportedShape {
        shape: format!("{observations} observations, {hidden} hidden, {actions} actions"),
        supported: SUPPORTED,
    })
}

/// Everything needed to act like the exported policy.
#[derive(Clone, Copy, Debug)]
pub struct ActorParts<'a> {
    /// The actor (its output must be [`Output::Tanh`]).
    pub net: &'a Net,
    /// The observation statistics, frozen as they are now.
    pub norm: &'a RunningNorm,
    /// Lower action bounds.
    pub low: &'a [f32],
    /// Upper action bounds.
    pub high: &'a [f32],
}

/// The unit-box action `[-1, 1]^A` for a raw observation, bit-exact with
/// `policy_core::Policy::act_unit` of the exported blob.
///
/// # Panics
/// If `obs` does not have the normaliser's and network's input size.
///
/// ```
/// # use host_trainer::{export::{act_unit, ActorParts}, net::{Net, NetConfig, Output},
/// #     normalize::RunningNorm};
/// # let config = NetConfig { inputs: 2, width: 32, depth: 2, outputs: 2,
/// #     activation: policy_core::Activation::Tanh, output: Output::Tanh, dropout: 0.0 };
/// let net = Net::new(config, &mut host_trainer::seed::stream(1, "actor"));
/// let norm = RunningNorm::new(2, 5.0);
/// let parts = ActorParts { net: &net, norm: &norm, low: &[-0.25; 2], high: &[0.25; 2] };
/// let u = act_unit(&parts, &[3.0, f32::NAN]);
/// assert!(u.iter().all(|u| u.abs() <= 1.0));
/// ```
pub fn act_unit(parts: &ActorParts<'_>, obs: &[f32]) -> Vec<f32> {
    let mut z = vec![0.0; parts.norm.dim()];
    parts.norm.normalize(obs, &mut z);
    let mut unit = vec![0.0; parts.net.config.outputs];
    parts.net.forward_one(&z, &mut unit);
    unit
}

/// The action for a raw observation, scaled into `[low, high]`: the trainer's evaluation,
/// bit-exact with `policy_core::Policy::act` of the exported blob.
///
/// # Panics
/// If `obs` does not have the input size, or the bounds do not have the network's output size.
///
/// ```
/// # use host_trainer::{export::{act, ActorParts}, net::{Net, NetConfig, Output},
/// #     normalize::RunningNorm};
/// # let config = NetConfig { inputs: 2, width: 32, depth: 2, outputs: 2,
/// #     activation: policy_core::Activation::Tanh, output: Output::Tanh, dropout: 0.0 };
/// let net = Net::new(config, &mut host_trainer::seed::stream(1, "actor"));
/// let norm = RunningNorm::new(2, 5.0);
/// let parts = ActorParts { net: &net, norm: &norm, low: &[-0.25; 2], high: &[0.25; 2] };
/// let a = act(&parts, &[3.0, -1.0]);
/// assert!(a.iter().all(|a| a.abs() <= 0.25));
/// ```
pub fn act(parts: &ActorParts<'_>, obs: &[f32]) -> Vec<f32> {
    assert_eq!(
        parts.low.len(),
        parts.net.config.outputs,
        "export::act: bounds size"
    );
    assert_eq!(
        parts.high.len(),
        parts.net.config.outputs,
        "export::act: bounds size"
    );
    let unit = act_unit(parts, obs);
    unit.iter()
        .zip(parts.low.iter().zip(parts.high))
        .map(|(&u, (&lo, &hi))| scale(u, lo, hi))
        .collect()
}

/// policy-core's `ActionBounds::scale` for one dimension.
fn scale(u: f32, lo: f32, hi: f32) -> f32 {
    let u = if u.is_finite() {
        u.clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let a = lo + (u + 1.0) * 0.5 * (hi - lo);
    // `clamp` would panic on an invalid box; a valid one (all the blob accepts) takes the
    // same path as policy-core.
    if lo <= hi {
        a.clamp(lo, hi)
    } else {
        a.max(lo).min(hi)
    }
}

/// Q of a raw observation and a unit-box action with the critic `net` (inputs: observation
/// then action), bit-exact with `policy_core::Critic::q` of the exported blob.
///
/// # Panics
/// If the sizes do not fit the network.
///
/// ```
/// # use host_trainer::{export::q, net::{Net, NetConfig, Output}, normalize::RunningNorm};
/// # let config = NetConfig { inputs: 4, width: 32, depth: 2, outputs: 1,
/// #     activation: policy_core::Activation::Tanh, output: Output::Linear, dropout: 0.0 };
/// let critic = Net::new(config, &mut host_trainer::seed::stream(1, "critic"));
/// let norm = RunningNorm::new(2, 5.0);
/// // Actions are clamped into the unit box, as on the chip.
/// assert_eq!(q(&critic, &norm, &[1.0, 2.0], &[3.0, -0.5]), q(&critic, &norm, &[1.0, 2.0], &[1.0, -0.5]));
/// ```
pub fn q(net: &Net, norm: &RunningNorm, obs: &[f32], unit_action: &[f32]) -> f32 {
    let mut x = vec![0.0; norm.dim()];
    norm.normalize(obs, &mut x);
    x.extend(unit_action.iter().map(|&u| {
        if u.is_finite() {
            u.clamp(-1.0, 1.0)
        } else {
            0.0
        }
    }));
    let mut out = [0.0];
    net.forward_one(&x, &mut out);
    out[0]
}

/// The actor as blob bytes (policy-core's format), labelled `label` (at most 32 bytes).
///
/// ```
/// # use host_trainer::{export::{act, actor_blob, ActorParts}, net::{Net, NetConfig, Output},
/// #     normalize::RunningNorm};
/// # let config = NetConfig { inputs: 2, width: 48, depth: 4, outputs: 2,
/// #     activation: policy_core::Activation::Tanh, output: Output::Tanh, dropout: 0.0 };
/// let net = Net::new(config, &mut host_trainer::seed::stream(1, "actor"));
/// let norm = RunningNorm::new(2, 5.0);
/// let parts = ActorParts { net: &net, norm: &norm, low: &[-0.25; 2], high: &[0.25; 2] };
/// let blob = actor_blob(&parts, "doc").unwrap();
/// let policy = policy_core::Policy::<2, 48, 3, 2>::from_blob(&blob).unwrap();
/// assert_eq!(policy.act(&[1.0, 2.0]).to_vec(), act(&parts, &[1.0, 2.0]));
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
    let c = &net.config;
    dispatch!(
        actor_for(parts, label),
        c.inputs,
        c.outputs,
        c.width,
        c.depth
    )
    .unwrap_or_else(|| Err(unsupported(net, "actor")))
}

/// The critic as blob bytes. `net` takes `[observation, unit action]` (`act_dim` actions last)
/// and has one linear output; `norm` is the actor's normaliser (the critic shares it).
///
/// ```
/// # use host_trainer::{export::{critic_blob, q}, net::{Net, NetConfig, Output},
/// #     normalize::RunningNorm};
/// # let config = NetConfig { inputs: 4, width: 32, depth: 2, outputs: 1,
/// #     activation: policy_core::Activation::Relu, output: Output::Linear, dropout: 0.0 };
/// let net = Net::new(config, &mut host_trainer::seed::stream(1, "critic"));
/// let norm = RunningNorm::new(2, 5.0);
/// let blob = critic_blob(&net, &norm, 2, "doc").unwrap();
/// let critic = policy_core::Critic::<2, 2, 32, 1>::from_blob(&blob).unwrap();
/// assert_eq!(critic.q(&[1.0, 2.0], &[0.5, -0.5]), q(&net, &norm, &[1.0, 2.0], &[0.5, -0.5]));
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
    let c = &net.config;
    dispatch!(
        critic_for(net, norm, label),
        norm.dim(),
        act_dim,
        c.width,
        c.depth
    )
    .unwrap_or_else(|| Err(unsupported(net, "critic")))
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
            supported: SUPPORTED,
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

fn unsupported(net: &Net, what: &str) -> Error {
    let c = &net.config;
    Error::UnsupportedShape {
        shape: format!(
            "{what} with {} inputs, {}x{} hidden, {} outputs",
            c.inputs, c.depth, c.width, c.outputs
        ),
        supported: SUPPORTED,
    }
}

/// Fills a dense layer of policy-core from a trainer layer (same column-major layout).
fn copy_dense<const I: usize, const O: usize>(
    dst: &mut policy_core::Dense<I, O>,
    w: &[f32],
    b: &[f32],
) {
    dst.w.as_mut_slice().copy_from_slice(w);
    dst.b.as_mut_slice().copy_from_slice(b);
}

/// Fills the trunk (hidden-to-hidden and output layers) from `layers[1..]`.
fn copy_trunk<const H: usize, const L: usize, const O: usize>(
    dst: &mut policy_core::Trunk<H, L, O>,
    net: &Net,
) {
    dst.activation = net.config.activation;
    for (d, s) in dst.hidden.iter_mut().zip(&net.layers[1..]) {
        copy_dense(d, &s.w, &s.b);
    }
    let out = &net.layers[L + 1];
    copy_dense(&mut dst.output, &out.w, &out.b);
}

fn actor_for<const S: usize, const H: usize, const L: usize, const A: usize>(
    parts: &ActorParts<'_>,
    label: &str,
) -> Result<Vec<u8>, Error> {
    // A 6x64 policy is ~85 KB: built on the heap, not returned by value.
    let mut p = Box::new(Policy::<S, H, L, A>::ZERO);
    p.normalizer = parts.norm.to_policy::<S>();
    p.bounds.low.as_mut_slice().copy_from_slice(parts.low);
    p.bounds.high.as_mut_slice().copy_from_slice(parts.high);
    copy_dense(&mut p.input, &parts.net.layers[0].w, &parts.net.layers[0].b);
    copy_trunk(&mut p.trunk, parts.net);
    let bytes = p.to_blob(label)?;
    // The writer does not validate; loading the bytes back applies every rule the chip applies
    // (finite parameters, low <= high, positive clip), so an exported blob always loads.
    let mut check = Box::new(Policy::<S, H, L, A>::ZERO);
    check.load_into(&bytes)?;
    Ok(bytes)
}

fn critic_for<const S: usize, const H: usize, const L: usize, const A: usize>(
    net: &Net,
    norm: &RunningNorm,
    label: &str,
) -> Result<Vec<u8>, Error> {
    let mut c = Box::new(Critic::<S, A, H, L>::ZERO);
    c.normalizer = norm.to_policy::<S>();
    // The first layer on [obs, action]: observation columns first, then action columns.
    let first = &net.layers[0];
    let (obs_w, act_w) = first.w.split_at(S * H);
    copy_dense(&mut c.input, obs_w, &first.b);
    c.action_w.as_mut_slice().copy_from_slice(act_w);
    copy_trunk(&mut c.trunk, net);
    let bytes = c.to_blob(label)?;
    let mut check = Box::new(Critic::<S, A, H, L>::ZERO);
    check.load_into(&bytes)?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::net::NetConfig;
    use crate::seed::{stream, uniform_in};
    use policy_core::Activation;

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
        let mut rng = stream(width as u64 * 10 + depth as u64, "export");
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
        let mut rng = stream(5, "norm");
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
        let mut rng = stream(6, "obs");
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

    fn check_actor<const H: usize, const L: usize>(activation: Activation) {
        let net = trained_like(2, H, L + 1, 2, activation, Output::Tanh);
        let norm = norm_with_stats();
        let (low, high) = ([-0.25, -1.0], [0.25, 0.5]);
        let parts = ActorParts {
            net: &net,
            norm: &norm,
            low: &low,
            high: &high,
        };
        let blob = actor_blob(&parts, "test").expect("export");
        let policy = Box::new(Policy::<2, H, L, 2>::from_blob(&blob).expect("load"));
        let mut saturated = 0;
        for obs in observations() {
            let unit = act_unit(&parts, &obs);
            assert_eq!(
                bits(&unit),
                bits(&policy.act_unit(&obs)),
                "act_unit at {obs:?}"
            );
            assert_eq!(
                bits(&act(&parts, &obs)),
                bits(&policy.act(&obs)),
                "act at {obs:?}"
            );
            saturated += unit.iter().filter(|u| u.abs() > 0.999).count();
        }
        // The comparison covered real, unsaturated outputs.
        assert!(saturated < 1000, "{saturated} of 2000 outputs saturated");
    }

    fn check_critic<const H: usize, const L: usize>(activation: Activation) {
        let net = trained_like(4, H, L + 1, 1, activation, Output::Linear);
        let norm = norm_with_stats();
        let blob = critic_blob(&net, &norm, 2, "critic").expect("export");
        let critic = Box::new(Critic::<2, 2, H, L>::from_blob(&blob).expect("load"));
        let mut rng = stream(7, "actions");
        for (i, obs) in observations().into_iter().enumerate() {
            let mut a = [
                uniform_in(&mut rng, -1.5, 1.5),
                uniform_in(&mut rng, -1.0, 1.0),
            ];
            if i % 50 == 0 {
                a[i / 50 % 2] = f32::NAN;
            }
            assert_eq!(
                q(&net, &norm, &obs, &a).to_bits(),
                critic.q(&obs, &a).to_bits(),
                "q at {obs:?}, {a:?}"
            );
        }
    }

    #[test]
    fn actor_2x32_tanh_is_bit_exact() {
        check_actor::<32, 1>(Activation::Tanh);
    }

    #[test]
    fn actor_4x48_tanh_is_bit_exact() {
        check_actor::<48, 3>(Activation::Tanh);
    }

    #[test]
    fn actor_3x64_relu_is_bit_exact() {
        check_actor::<64, 2>(Activation::Relu);
    }

    #[test]
    fn actor_6x64_relu_exports_in_debug() {
        // The largest compiled shape (~85 KB) must not overflow a test thread's stack.
        check_actor::<64, 5>(Activation::Relu);
    }

    #[test]
    fn critic_2x32_tanh_is_bit_exact() {
        check_critic::<32, 1>(Activation::Tanh);
    }

    #[test]
    fn critic_4x48_tanh_is_bit_exact() {
        check_critic::<48, 3>(Activation::Tanh);
    }

    #[test]
    fn critic_5x48_relu_is_bit_exact() {
        check_critic::<48, 4>(Activation::Relu);
    }

    proptest::proptest! {
        /// Any observation at all (every f32 bit pattern, NaN and infinities included) gives
        /// a finite action inside the bounds, bit-identical to the exported policy's.
        #[test]
        fn any_observation_acts_like_the_blob_and_in_bounds(a in proptest::prelude::any::<u32>(), b in proptest::prelude::any::<u32>()) {
            let net = trained_like(2, 32, 3, 2, Activation::Relu, Output::Tanh);
            let norm = norm_with_stats();
            let (low, high) = ([-0.25, 0.0], [0.25, 2.0]);
            let parts = ActorParts { net: &net, norm: &norm, low: &low, high: &high };
            let policy = Box::new(Policy::<2, 32, 2, 2>::from_blob(&actor_blob(&parts, "p").expect("export")).expect("load"));
            let obs = [f32::from_bits(a), f32::from_bits(b)];
            let action = act(&parts, &obs);
            proptest::prop_assert_eq!(bits(&action), bits(&policy.act(&obs)));
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
        let odd = trained_like(2, 40, 2, 2, Activation::Tanh, Output::Tanh);
        let parts = ActorParts {
            net: &odd,
            norm: &norm,
            low: &[-1.0; 2],
            high: &[1.0; 2],
        };
        let err = actor_blob(&parts, "x").expect_err("width 40 is not compiled");
        assert!(matches!(err, Error::UnsupportedShape { .. }), "{err}");
        assert!(err.to_string().contains(SUPPORTED));

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
