//! The training loop's forward pass: the trainer's own networks acting exactly as the exported
//! blob will ([`Net::forward_one`], policy-core's arithmetic on the trainer's weights, no blob
//! needed). The tests of [`crate::blob::export`] hold these bit-equal to policy-core's
//! [`Model`](policy_core::model::Model) on the exported blob.

use super::net::Net;
use super::normalize::RunningNorm;

/// Everything needed to act like the exported policy.
#[derive(Clone, Copy, Debug)]
pub struct ActorParts<'a> {
    /// The actor (its output must be [`Output::Tanh`](super::net::Output::Tanh)).
    pub net: &'a Net,
    /// The observation statistics, frozen as they are now.
    pub norm: &'a RunningNorm,
    /// Lower action bounds.
    pub low: &'a [f32],
    /// Upper action bounds.
    pub high: &'a [f32],
}

/// The unit-box action `[-1, 1]^A` for a raw observation (the training loop's exploration
/// starts from it), bit-exact with [`Model::act_unit`](policy_core::model::Model::act_unit) of the exported blob.
///
/// # Panics
/// If `obs` does not have the normaliser's and network's input size.
///
/// ```
/// # use host_trainer::nn::{forward::{act_unit, ActorParts}, net::{Net, NetConfig, Output},
/// #     normalize::RunningNorm};
/// # let config = NetConfig { inputs: 2, width: 32, depth: 2, outputs: 2,
/// #     activation: policy_core::Activation::Tanh, output: Output::Tanh, dropout: 0.0 };
/// let net = Net::new(config, &mut firmware_sim::seed::training_stream(1, "actor"));
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

/// The greedy action for a raw observation, scaled into `[low, high]`, from the trainer's own
/// networks; bit-exact with [`Model::act`](policy_core::model::Model::act) of the exported blob.
///
/// # Panics
/// If `obs` does not have the input size, or the bounds do not have the network's output size.
///
/// ```
/// # use host_trainer::nn::{forward::{act, ActorParts}, net::{Net, NetConfig, Output},
/// #     normalize::RunningNorm};
/// # let config = NetConfig { inputs: 2, width: 32, depth: 2, outputs: 2,
/// #     activation: policy_core::Activation::Tanh, output: Output::Tanh, dropout: 0.0 };
/// let net = Net::new(config, &mut firmware_sim::seed::training_stream(1, "actor"));
/// let norm = RunningNorm::new(2, 5.0);
/// let parts = ActorParts { net: &net, norm: &norm, low: &[-0.25; 2], high: &[0.25; 2] };
/// let a = act(&parts, &[3.0, -1.0]);
/// assert!(a.iter().all(|a| a.abs() <= 0.25));
/// ```
pub fn act(parts: &ActorParts<'_>, obs: &[f32]) -> Vec<f32> {
    assert_eq!(
        parts.low.len(),
        parts.net.config.outputs,
        "forward::act: bounds size"
    );
    assert_eq!(
        parts.high.len(),
        parts.net.config.outputs,
        "forward::act: bounds size"
    );
    let unit = act_unit(parts, obs);
    unit.iter()
        .zip(parts.low.iter().zip(parts.high))
        .map(|(&u, (&lo, &hi))| policy_core::bounds::scale_value(u, lo, hi))
        .collect()
}

/// Q of a raw observation and a unit-box action with the critic `net` (inputs: observation
/// then action), bit-exact with [`Model::q`](policy_core::model::Model::q) of the exported blob.
///
/// # Panics
/// If the sizes do not fit the network.
///
/// ```
/// # use host_trainer::nn::{forward::q, net::{Net, NetConfig, Output}, normalize::RunningNorm};
/// # let config = NetConfig { inputs: 4, width: 32, depth: 2, outputs: 1,
/// #     activation: policy_core::Activation::Tanh, output: Output::Linear, dropout: 0.0 };
/// let critic = Net::new(config, &mut firmware_sim::seed::training_stream(1, "critic"));
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
