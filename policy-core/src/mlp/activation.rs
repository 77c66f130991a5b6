//! The hidden activations and the actor's output squashing: one definition each, used by the
//! runtime [`Model`](crate::model::Model), the compiled [`Trunk`](super::Trunk) and the trainer.

use serde::{Deserialize, Serialize};

/// Activation of the hidden layers. The actor's output is always squashed by tanh; the critic's
/// output is linear.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Activation {
    /// Hyperbolic tangent (`libm::tanhf`).
    Tanh,
    /// Rectified linear unit, `max(x, 0)`; NaN maps to 0.
    Relu,
}

impl Activation {
    /// Applies the activation to one value.
    ///
    /// ```
    /// use policy_core::Activation;
    /// assert_eq!(Activation::Relu.apply(-2.0), 0.0);
    /// assert_eq!(Activation::Relu.apply(1.5), 1.5);
    /// assert_eq!(Activation::Tanh.apply(0.0), 0.0);
    /// ```
    #[inline]
    pub fn apply(self, x: f32) -> f32 {
        match self {
            Activation::Tanh => libm::tanhf(x),
            Activation::Relu => {
                if x > 0.0 {
                    x
                } else {
                    0.0
                }
            }
        }
    }
}

impl core::fmt::Display for Activation {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Activation::Tanh => "tanh",
            Activation::Relu => "relu",
        })
    }
}

/// The actor's output squashing: `tanh(y)` (`libm::tanhf`), and 0 where that is not finite.
/// The one definition the compiled [`Policy`](crate::Policy), the runtime model and the trainer
/// use.
///
/// ```
/// use policy_core::mlp::squash;
/// assert_eq!(squash(0.0), 0.0);
/// assert_eq!(squash(f32::NAN), 0.0);
/// assert_eq!(squash(50.0), 1.0);
/// ```
#[inline]
pub fn squash(y: f32) -> f32 {
    let t = libm::tanhf(y);
    if t.is_finite() {
        t
    } else {
        0.0
    }
}

/// The hidden activation of a whole layer, in place; the `match` is outside the loop so each
/// case vectorises (tanh through [`crate::tanh`], bit-identical to `libm::tanhf`).
#[inline]
pub(crate) fn activate(activation: Activation, values: &mut [f32]) {
    match activation {
        Activation::Tanh => crate::tanh::tanh_in_place(values),
        Activation::Relu => values
            .iter_mut()
            .for_each(|v| *v = Activation::Relu.apply(*v)),
    }
}
