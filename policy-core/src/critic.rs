//! The compiled critic Q(s, a), stored in the same blob format as the actor, with its sizes in
//! the type; like [`Policy`](crate::Policy), a typed front over the runtime's kernels and the one
//! load and write path.

use nalgebra::{ArrayStorage, SMatrix};

use crate::blob::{self, Compiled, ModelKind, Shape};
use crate::mlp::{accumulate, Activation, Dense, Trunk};
use crate::normalizer::Normalizer;

/// A critic `Q(s, a)` over `S` observations and `A` actions, with hidden width `H` and `L`
/// hidden-to-hidden layers (`L + 1` hidden layers in all).
///
/// The action is taken in the actor's unit box `[-1, 1]^A`, before scaling, as in training. The
/// first layer is stored as one `H × (S + A)` matrix split in two: observation columns, then
/// action columns, which is exactly the layer a trainer builds on the concatenated input.
#[derive(Clone, Debug, PartialEq)]
pub struct Critic<const S: usize, const H: usize, const L: usize, const A: usize> {
    /// Observation normaliser frozen at export (the actor's).
    pub normalizer: Normalizer<S>,
    /// First layer: observation weights and the layer's biases.
    pub input: Dense<S, H>,
    /// First layer: action weights.
    pub action_w: SMatrix<f32, H, A>,
    /// The remaining hidden layers and the single linear output.
    pub trunk: Trunk<H, L, 1>,
}

impl<const S: usize, const H: usize, const L: usize, const A: usize> Critic<S, H, L, A> {
    /// The all-zero critic: Q is 0 everywhere.
    pub const ZERO: Self = Self {
        normalizer: Normalizer::ZERO,
        input: Dense::ZERO,
        action_w: SMatrix::from_array_storage(ArrayStorage([[0.0; H]; A])),
        trunk: Trunk::ZERO,
    };

    /// Q of an observation and a unit-box action. Non-finite inputs are treated as by the
    /// normaliser (observation) or replaced by 0 (action); the result may still be large but is
    /// never NaN for finite weights.
    ///
    /// ```
    /// use policy_core::Critic;
    /// static BLOB: &[u8] = include_bytes!("../tests/golden/critic_2x32.postcard");
    /// let critic = Critic::<2, 32, 1, 2>::from_blob(BLOB).unwrap();
    /// // The action is clamped into the unit box and a NaN action component reads as 0.
    /// assert_eq!(critic.q(&[1.0, 2.0], &[5.0, f32::NAN]), critic.q(&[1.0, 2.0], &[1.0, 0.0]));
    /// ```
    #[inline]
    pub fn q(&self, obs: &[f32; S], unit_action: &[f32; A]) -> f32 {
        let z = self.normalizer.normalize(obs);
        self.q_normalized(&z.data.0[0], unit_action)
    }

    /// Q of an already normalised observation (the compare step normalises once, scores many).
    ///
    /// ```
    /// use policy_core::Critic;
    /// static BLOB: &[u8] = include_bytes!("../tests/golden/critic_2x32.postcard");
    /// let critic = Critic::<2, 32, 1, 2>::from_blob(BLOB).unwrap();
    /// let z = critic.normalizer.normalize(&[1.0, 2.0]);
    /// assert_eq!(critic.q_normalized(&z.into(), &[0.5, 0.5]), critic.q(&[1.0, 2.0], &[0.5, 0.5]));
    /// ```
    #[inline]
    pub fn q_normalized(&self, z: &[f32; S], unit_action: &[f32; A]) -> f32 {
        let mut a = [0.0; A];
        for (d, &u) in a.iter_mut().zip(unit_action) {
            *d = if u.is_finite() {
                u.clamp(-1.0, 1.0)
            } else {
                0.0
            };
        }
        let mut pre = self.input.b;
        self.input.accumulate(z, &mut pre);
        accumulate(&self.action_w, &a, &mut pre);
        self.trunk.run(pre)[0]
    }
}

blob::blob_methods!(Critic, "critic_2x32.postcard", "golden critic 2x32 relu");

impl<const S: usize, const H: usize, const L: usize, const A: usize> Compiled
    for Critic<S, H, L, A>
{
    const KIND: ModelKind = ModelKind::Critic;
    const SHAPE: Shape = Shape::compiled(S, A, H, L);

    fn activation(&self) -> Activation {
        self.trunk.activation
    }

    fn set_activation(&mut self, activation: Activation) {
        self.trunk.activation = activation;
    }

    fn params<'a>(&'a self, f: &mut dyn FnMut(&'a [f32])) {
        self.normalizer.params().into_iter().for_each(&mut *f);
        f(self.input.w.as_slice());
        f(self.action_w.as_slice());
        f(self.input.b.as_slice());
        self.trunk.params(f);
    }

    fn params_mut(&mut self, f: &mut dyn FnMut(&mut [f32])) {
        self.normalizer.params_mut().into_iter().for_each(&mut *f);
        f(self.input.w.as_mut_slice());
        f(self.action_w.as_mut_slice());
        f(self.input.b.as_mut_slice());
        self.trunk.params_mut(f);
    }
}
