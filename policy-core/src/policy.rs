//! The policy a chip runs: normaliser, actor network, action bounds.

use nalgebra::SVector;

use crate::blob::{self, Compiled, ModelKind, Shape};
use crate::{ActionBounds, Activation, Dense, Error, Normalizer, Trunk};

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

    /// Loads a blob into this slot. On error the slot is left exactly as it was.
    ///
    /// ```
    /// use policy_core::{Error, Policy};
    /// static BLOB: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
    /// let mut slot = Policy::<2, 32, 1, 2>::ZERO;
    /// slot.load_into(BLOB).unwrap();
    /// let mut wrong = Policy::<2, 48, 3, 2>::ZERO;
    /// assert!(matches!(wrong.load_into(BLOB), Err(Error::ShapeMismatch { .. })));
    /// assert_eq!(wrong, Policy::ZERO);
    /// ```
    pub fn load_into(&mut self, bytes: &[u8]) -> Result<(), Error> {
        blob::load_into(self, bytes)
    }

    /// Loads a blob into a new value (convenient on the host; on a chip prefer
    /// [`Policy::load_into`] into a `static`).
    ///
    /// ```
    /// use policy_core::{Error, Policy};
    /// static BLOB: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
    /// let policy = Policy::<2, 32, 1, 2>::from_blob(BLOB).unwrap();
    /// assert_eq!(policy.bounds.high[0], 0.25);
    /// let truncated = Policy::<2, 32, 1, 2>::from_blob(&BLOB[..100]);
    /// assert!(matches!(truncated, Err(Error::Truncated { needed: 4952, found: 100 })));
    /// ```
    pub fn from_blob(bytes: &[u8]) -> Result<Self, Error> {
        let mut policy = Self::ZERO;
        policy.load_into(bytes)?;
        Ok(policy)
    }

    /// Writes this policy as a blob into `out`; returns the bytes written. The label (at most
    /// 32 bytes) is free text stored in the header, e.g. task, algorithm and seed.
    ///
    /// ```
    /// use policy_core::{blob, ActionBounds, Policy};
    /// let mut policy = Policy::<2, 8, 0, 2>::ZERO;
    /// policy.bounds = ActionBounds::symmetric(0.25);
    /// let mut flash = [0u8; 512];
    /// let n = policy.write_blob("nav dcp seed 1", &mut flash).unwrap();
    /// assert_eq!(n, blob::blob_len(&policy, "nav dcp seed 1").unwrap());
    /// assert_eq!(blob::verify(&flash[..n]).unwrap().header.label.as_str(), "nav dcp seed 1");
    /// ```
    pub fn write_blob(&self, label: &str, out: &mut [u8]) -> Result<usize, Error> {
        blob::write_into(self, label, out)
    }

    /// Writes this policy as a blob into a new vector.
    ///
    /// ```
    /// use policy_core::Policy;
    /// static BLOB: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
    /// let policy = Policy::<2, 32, 1, 2>::from_blob(BLOB).unwrap();
    /// assert_eq!(policy.to_blob("golden actor 2x32 tanh").unwrap(), BLOB);
    /// ```
    #[cfg(feature = "std")]
    pub fn to_blob(&self, label: &str) -> Result<std::vec::Vec<u8>, Error> {
        blob::to_vec(self, label)
    }

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
            *u = crate::mlp::squash(y);
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
