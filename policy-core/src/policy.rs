//! The compiled actor: normaliser, actor network and action bounds with their sizes in the type.
//!
//! A typed front over the runtime's pieces: its layers compute through the [`crate::mlp`]
//! kernels, the normaliser and bounds through `normalize_value` and `scale_value`, and it loads
//! and writes through the one path in [`crate::blob`] (`blob_methods!`), so it gives the bits
//! the runtime [`Model`](crate::model::Model) gives on the same blob.

use nalgebra::SVector;

use crate::blob::{self, Compiled, ModelKind, Shape};
use crate::bounds::ActionBounds;
use crate::mlp::{squash, Activation, Dense, Trunk};
use crate::normalizer::Normalizer;

/// A DCP (or DDPG) actor ready to run: `act(obs) = scale(tanh(mlp(normalize(obs))))`.
///
/// Const generics fix every size: `S` observations, hidden width `H`, `L` hidden-to-hidden
/// layers (the network has `L + 1` hidden layers: the paper's 4×48 is `Policy<S, 48, 3, A>`),
/// and `A` actions. The value is about `4 * (S*H + L*H*H + H*A)` bytes, so on a chip load it
/// into a `static` slot with [`Policy::load_into`] rather than returning it by value.
#[derive(Clone, Debug, PartialEq)]
pub struct Policy<const S: usize, const H: usize, const L: usize, const A: usize> {
    /// Observation normaliser frozen at export.
    pub normalizer: Normalizer<S>,
    /// The box the actions are scaled into.
    pub bounds: ActionBounds<A>,
    /// First layer, observations to the first hidden layer.
    pub input: Dense<S, H>,
    /// The remaining hidden layers and the output layer.
    pub trunk: Trunk<H, L, A>,
}

impl<const S: usize, const H: usize, const L: usize, const A: usize> Policy<S, H, L, A> {
    /// The safe state before a blob is loaded: bounds `[0, 0]`, so every action is 0.
    pub const ZERO: Self = Self {
        normalizer: Normalizer::ZERO,
        bounds: ActionBounds::ZERO,
        input: Dense::ZERO,
        trunk: Trunk::ZERO,
    };

    /// The actor's output in the unit box `[-1, 1]^A`, before scaling. Always finite.
    ///
    /// Non-finite observation components normalise to 0 (see [`Normalizer::normalize`]); a
    /// non-finite network output (possible only if activations overflow) becomes 0.
    ///
    /// ```
    /// use policy_core::Policy;
    /// static BLOB: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
    /// let policy = Policy::<2, 32, 1, 2>::from_blob(BLOB).unwrap();
    /// let obs = [1.0, 2.0];
    /// let unit = policy.act_unit(&obs);
    /// assert!(unit.iter().all(|u| u.abs() <= 1.0));
    /// assert_eq!(policy.bounds.scale(&unit), policy.act(&obs));
    /// ```
    #[inline]
    pub fn act_unit(&self, obs: &[f32; S]) -> [f32; A] {
        let z = self.normalizer.normalize(obs);
        self.act_unit_normalized(&z)
    }

    /// [`Policy::act_unit`] on an already normalised observation.
    ///
    /// ```
    /// use policy_core::Policy;
    /// static BLOB: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
    /// let policy = Policy::<2, 32, 1, 2>::from_blob(BLOB).unwrap();
    /// let z = policy.normalizer.normalize(&[3.0, -1.0]);
    /// assert_eq!(policy.act_unit_normalized(&z), policy.act_unit(&[3.0, -1.0]));
    /// ```
    #[inline]
    pub fn act_unit_normalized(&self, z: &SVector<f32, S>) -> [f32; A] {
        let pre = self.input.affine(&z.data.0[0]);
        let out = self.trunk.run(pre);
        let mut unit = [0.0; A];
        for (u, &y) in unit.iter_mut().zip(out.iter()) {
            *u = squash(y);
        }
        unit
    }

    /// The action for an observation: finite and inside the bounds for every input, NaN and
    /// infinities included.
    ///
    /// ```
    /// use policy_core::Policy;
    /// static BLOB: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
    /// let policy = Policy::<2, 32, 1, 2>::from_blob(BLOB).unwrap();
    /// for obs in [[0.0, 0.0], [5.9, -5.9], [f32::NAN, f32::INFINITY]] {
    ///     let a = policy.act(&obs);
    ///     assert!(a.iter().all(|v| v.is_finite() && v.abs() <= 0.25));
    /// }
    /// ```
    #[inline]
    pub fn act(&self, obs: &[f32; S]) -> [f32; A] {
        self.bounds.scale(&self.act_unit(obs))
    }
}

blob::blob_methods!(Policy, "actor_2x32.postcard", "golden actor 2x32 tanh");

impl<const S: usize, const H: usize, const L: usize, const A: usize> Compiled
    for Policy<S, H, L, A>
{
    const KIND: ModelKind = ModelKind::Actor;
    const SHAPE: Shape = Shape::compiled(S, A, H, L);

    fn activation(&self) -> Activation {
        self.trunk.activation
    }

    fn set_activation(&mut self, activation: Activation) {
        self.trunk.activation = activation;
    }

    fn params<'a>(&'a self, f: &mut dyn FnMut(&'a [f32])) {
        self.normalizer.params().into_iter().for_each(&mut *f);
        self.bounds.params().into_iter().for_each(&mut *f);
        self.input.params().into_iter().for_each(&mut *f);
        self.trunk.params(f);
    }

    fn params_mut(&mut self, f: &mut dyn FnMut(&mut [f32])) {
        self.normalizer.params_mut().into_iter().for_each(&mut *f);
        self.bounds.params_mut().into_iter().for_each(&mut *f);
        self.input.params_mut().into_iter().for_each(&mut *f);
        self.trunk.params_mut(f);
    }
}
