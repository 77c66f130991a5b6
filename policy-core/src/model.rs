//! The runtime: a model of any shape, run straight from a verified blob's bytes.
//!
//! [`Model::from_blob`] checks a blob once (magic, version, header, limits, length, padding,
//! CRC, then every parameter: finite, normaliser and bounds rules, action table inside the
//! bounds) and keeps a view of its payload. [`Model::act`] then reads the weights from those
//! bytes, wherever they are (a flash region, an `include_bytes!`, a `Vec`): nothing is copied to
//! RAM but the activations, which live in a caller-provided [`Scratch`] whose width is a const
//! bound. No table of compiled shapes is needed anywhere; any shape within the limits in
//! [`crate::blob`] runs.
//!
//! The arithmetic is [`crate::mlp::accumulate`]'s, operation for operation (bias first, then input
//! columns in increasing order, separate multiplies and adds), so a blob gives the same bits here
//! as in the compiled [`Policy`](crate::Policy) and in the trainer.
//!
//! ```
//! use policy_core::model::{Model, Scratch};
//! static BLOB: &[u8] = include_bytes!("../tests/golden/actor_4x48.postcard");
//! let model = Model::from_blob(BLOB).unwrap(); // verified once, at boot
//! model.expect_sizes(2, 2).unwrap(); // the firmware's observation and action sizes
//! let mut scratch = Scratch::<64>::new(); // activations: 2 x 64 floats
//! let mut action = [0.0f32; 2];
//! model.act(&[4.0, -2.5], &mut scratch, &mut action).unwrap();
//! assert!(action.iter().all(|a| a.is_finite() && a.abs() <= 0.25));
//! // The compiled type gives the same bits.
//! let compiled = policy_core::Policy::<2, 48, 3, 2>::from_blob(BLOB).unwrap();
//! assert_eq!(action, compiled.act(&[4.0, -2.5]));
//! ```

use crate::blob::{self, Encoding, Header, LayerLayout, ModelKind, Verified};
use crate::bounds::scale_value;
use crate::error::Error;
use crate::mlp::activation::activate;
use crate::mlp::{accumulate_bytes, accumulate_f16, accumulate_int8, squash};
use crate::normalizer::normalize_value;

// The integer encoding's entry points and forward pass.
mod integer;

/// Activation buffers for [`Model`]: two vectors of `W` floats, used in turn as a layer's input
/// and output. `W` must be at least the blob's [`Shape::scratch_width`](crate::Shape::scratch_width)
/// (its widest layer, observation or action vector); a narrower scratch is
/// [`Error::ScratchTooSmall`], never a panic.
///
/// The two vectors are one array of `2 W` floats, so [`Model::act`] and the other const-generic
/// methods hand it to the slice entry points ([`Model::act_in`] and so on) as it is: one forward
/// path for both.
#[derive(Clone, Debug)]
pub struct Scratch<const W: usize> {
    halves: [[f32; W]; 2],
}

impl<const W: usize> Scratch<W> {
    /// Zeroed buffers; usable in `static` initialisers.
    pub const fn new() -> Self {
        Scratch {
            halves: [[0.0; W]; 2],
        }
    }

    /// The `2 W` floats as one slice, as the slice entry points ([`Model::act_in`]) take them.
    pub fn as_mut_slice(&mut self) -> &mut [f32] {
        self.halves.as_flattened_mut()
    }
}

impl<const W: usize> Default for Scratch<W> {
    fn default() -> Self {
        Self::new()
    }
}

/// A verified blob, ready to run. Cheap to copy around: a header and a slice.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Model<'a> {
    header: Header,
    payload: &'a [u8],
    layout: Layout,
}

/// Where each part of the payload starts, in parameters (4-byte values) from its start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Layout {
    observations: usize,
    actions: usize,
    width: usize,
    hidden_layers: usize,
    inputs: usize,
    outputs: usize,
    /// Offset of the action bounds (actor, discrete): low then high.
    bounds: usize,
    /// Offset of the action table (discrete): `outputs` rows of `actions` values.
    table: usize,
    /// Offset of the first layer, in bytes (the layers' sizes depend on the encoding).
    layers: usize,
    /// The scratch width the forward pass needs (computed once, checked every call).
    scratch_width: usize,
}

impl Layout {
    fn of(header: &Header) -> Layout {
        let s = &header.shape;
        let (observations, actions) = (s.observations as usize, s.actions as usize);
        let outputs = s.outputs(header.kind);
        let bounds = 2 * observations + 1;
        let (table, layers) = match header.kind {
            ModelKind::Actor => (bounds + 2 * actions, bounds + 2 * actions),
            ModelKind::Critic => (bounds, bounds),
            ModelKind::Discrete => {
                let table = bounds + 2 * actions;
                (table, table + outputs * actions)
            }
        };
        Layout {
            observations,
            actions,
            width: s.width as usize,
            hidden_layers: (s.depth as usize).saturating_sub(1),
            inputs: s.inputs(header.kind),
            outputs,
            bounds,
            table,
            layers: 4 * layers,
            scratch_width: s.scratch_width(header.kind),
        }
    }
}

impl<'a> Model<'a> {
    /// Verifies `bytes` completely and returns the model; nothing runs unless every check passed.
    ///
    /// ```
    /// use policy_core::{model::Model, Error};
    /// static BLOB: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
    /// assert!(Model::from_blob(BLOB).is_ok());
    /// let mut flipped = BLOB.to_vec();
    /// flipped[100] ^= 4;
    /// assert!(matches!(Model::from_blob(&flipped), Err(Error::ChecksumMismatch { .. })));
    /// ```
    pub fn from_blob(bytes: &'a [u8]) -> Result<Model<'a>, Error> {
        let Verified { header, payload } = blob::verify(bytes)?;
        blob::check_parameters(&header, payload)?;
        Ok(Model {
            layout: Layout::of(&header),
            header,
            payload,
        })
    }

    /// Verifies `bytes` as a policy a firmware can run: an actor or a discrete policy (not a
    /// critic) with `observations` inputs and `actions` outputs whose widest layer fits a
    /// [`Scratch`] of `scratch_width`. The example firmware's boot check, and the verification
    /// [`slot::choose`](crate::slot::choose) runs on each slot.
    ///
    /// ```
    /// use policy_core::{model::Model, Error};
    /// static ACTOR: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
    /// static CRITIC: &[u8] = include_bytes!("../tests/golden/critic_2x32.postcard");
    /// assert!(Model::for_policy(ACTOR, 2, 2, 64).is_ok());
    /// assert!(matches!(Model::for_policy(ACTOR, 2, 2, 16), Err(Error::ScratchTooSmall { .. })));
    /// assert!(matches!(Model::for_policy(ACTOR, 6, 2, 64), Err(Error::SizeMismatch { .. })));
    /// assert!(matches!(Model::for_policy(CRITIC, 2, 2, 64), Err(Error::WrongKind { .. })));
    /// ```
    pub fn for_policy(
        bytes: &'a [u8],
        observations: usize,
        actions: usize,
        scratch_width: usize,
    ) -> Result<Model<'a>, Error> {
        let model = Model::from_blob(bytes)?;
        model.check_policy_kind()?;
        model.expect_sizes(observations, actions)?;
        model.check_scratch(scratch_width)?;
        Ok(model)
    }

    /// [`Model::for_policy`] for a firmware that takes its sizes from the blob: a policy of any
    /// observation and action count up to `max_observations` and `max_actions` (the lengths of
    /// its observation and action buffers) verifies; a larger one is
    /// [`Error::SizeBeyondMaximum`]. The sizes it runs are then the blob's
    /// ([`Header::shape`]'s `observations` and `actions`).
    ///
    /// ```
    /// use policy_core::{model::Model, Error};
    /// static ACTOR: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
    /// let model = Model::for_policy_within(ACTOR, 8, 8, 64).unwrap();
    /// assert_eq!((model.header().shape.observations, model.header().shape.actions), (2, 2));
    /// assert_eq!(
    ///     Model::for_policy_within(ACTOR, 8, 1, 64),
    ///     Err(Error::SizeBeyondMaximum { what: "action size", max: 1, found: 2 })
    /// );
    /// assert!(matches!(Model::for_policy_within(ACTOR, 8, 8, 16), Err(Error::ScratchTooSmall { .. })));
    /// ```
    // Not inlined: the example firmware calls it for each slot, and one copy of the whole
    // verification is 300 to 1,000 B smaller at opt-level "s" and "z" (docs/performance.md).
    #[inline(never)]
    pub fn for_policy_within(
        bytes: &'a [u8],
        max_observations: usize,
        max_actions: usize,
        scratch_width: usize,
    ) -> Result<Model<'a>, Error> {
        let model = Model::from_blob(bytes)?;
        model.check_policy_kind()?;
        let l = &model.layout;
        for (what, max, found) in [
            ("observation size", max_observations, l.observations),
            ("action size", max_actions, l.actions),
        ] {
            if found > max {
                return Err(Error::SizeBeyondMaximum { what, max, found });
            }
        }
        model.check_scratch(scratch_width)?;
        Ok(model)
    }

    /// A policy loader's kind rule: an actor or a discrete policy, not a critic.
    fn check_policy_kind(&self) -> Result<(), Error> {
        match self.header.kind {
            ModelKind::Critic => Err(self.wrong_kind(ModelKind::Actor)),
            ModelKind::Actor | ModelKind::Discrete => Ok(()),
        }
    }

    /// A policy loader's scratch rule: the blob's widest layer fits `scratch_width`.
    fn check_scratch(&self, scratch_width: usize) -> Result<(), Error> {
        let needed = self.layout.scratch_width;
        if needed > scratch_width {
            return Err(Error::ScratchTooSmall {
                needed,
                found: scratch_width,
            });
        }
        Ok(())
    }

    /// The blob's header: kind, encoding, shape, activation, label.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// Checks that the blob fits a firmware with `observations` inputs and `actions` outputs.
    ///
    /// ```
    /// use policy_core::{model::Model, Error};
    /// static BLOB: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
    /// let model = Model::from_blob(BLOB).unwrap();
    /// assert_eq!(model.expect_sizes(2, 2), Ok(()));
    /// assert!(matches!(model.expect_sizes(3, 2), Err(Error::SizeMismatch { .. })));
    /// ```
    pub fn expect_sizes(&self, observations: usize, actions: usize) -> Result<(), Error> {
        let l = &self.layout;
        check_sizes((observations, actions), (l.observations, l.actions))
    }

    /// Every parameter, in blob order, decoded: an f16 weight as its exact f32 value, an int8
    /// weight as `scale · q` (the value the layer's arithmetic stands for; it computes
    /// `scale · Σ q x` instead), everything else as stored.
    pub fn values(&self) -> impl Iterator<Item = f32> + 'a {
        blob::values(&self.header, self.payload)
    }

    /// The action bounds of an actor or discrete policy, `(low, high)` per action dimension as
    /// the blob stores them (nothing for a critic). The same numbers as in [`Model::values`],
    /// read straight from the prefix: a firmware that checks its actions against them links a
    /// few instructions instead of the whole decoding iterator.
    ///
    /// ```
    /// use policy_core::model::Model;
    /// static BLOB: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
    /// let model = Model::from_blob(BLOB).unwrap();
    /// let bounds: Vec<(f32, f32)> = model.action_bounds().collect();
    /// assert_eq!(bounds, [(-0.25, 0.25), (-0.25, 0.25)]);
    /// ```
    pub fn action_bounds(&self) -> impl Iterator<Item = (f32, f32)> + 'a {
        let a = match self.header.kind {
            ModelKind::Critic => 0,
            ModelKind::Actor | ModelKind::Discrete => self.layout.actions,
        };
        let low = self.slice(self.layout.bounds, a);
        let high = self.slice(self.layout.bounds + a, a);
        low.iter().zip(high.iter())
    }

    /// The scratch width this blob needs: its widest layer, observation or action vector
    /// ([`Shape::scratch_width`](crate::Shape::scratch_width) for its kind). A [`Scratch<W>`]
    /// needs `W` at least this; a slice scratch ([`Model::act_in`]) twice this many floats.
    pub fn scratch_width(&self) -> usize {
        self.layout.scratch_width
    }

    /// The floats a slice scratch for [`Model::act_in`], [`Model::q_in`] and
    /// [`Model::choose_in`] must hold: `2 * scratch_width()`.
    ///
    /// ```
    /// use policy_core::model::Model;
    /// static BLOB: &[u8] = include_bytes!("../tests/golden/actor_4x48.postcard");
    /// let model = Model::from_blob(BLOB).unwrap();
    /// assert_eq!((model.scratch_width(), model.scratch_floats()), (48, 96));
    /// ```
    pub fn scratch_floats(&self) -> usize {
        2 * self.layout.scratch_width
    }

    /// The action for an observation (actor and discrete policy): finite and inside the bounds
    /// for every input, NaN and infinities included. A discrete policy returns the action-table
    /// row of the largest Q value (ties: the lowest index). [`Model::act_in`] with the scratch
    /// as a slice.
    pub fn act<const W: usize>(
        &self,
        obs: &[f32],
        scratch: &mut Scratch<W>,
        action: &mut [f32],
    ) -> Result<(), Error> {
        self.act_in(obs, scratch.as_mut_slice(), action)
    }

    /// [`Model::act`] with a caller's scratch of any length, for callers whose scratch size is
    /// known only at run time (a C firmware, a buffer shared between models): `scratch` holds
    /// two vectors of `W = scratch.len() / 2` floats (its first and second half; an odd last
    /// float is unused), and `W` must be at least [`Model::scratch_width`], else
    /// [`Error::ScratchTooSmall`] with `found` = `W`. The same bits as [`Model::act`].
    ///
    /// ```
    /// use policy_core::{model::{Model, Scratch}, Error};
    /// static BLOB: &[u8] = include_bytes!("../tests/golden/actor_4x48.postcard");
    /// let model = Model::from_blob(BLOB).unwrap();
    /// let mut scratch = vec![0.0f32; model.scratch_floats()];
    /// let mut action = [0.0f32; 2];
    /// model.act_in(&[4.0, -2.5], &mut scratch, &mut action).unwrap();
    /// let mut fixed = [0.0f32; 2];
    /// model.act(&[4.0, -2.5], &mut Scratch::<64>::new(), &mut fixed).unwrap();
    /// assert_eq!(action.map(f32::to_bits), fixed.map(f32::to_bits));
    /// assert_eq!(
    ///     model.act_in(&[4.0, -2.5], &mut [0.0; 40], &mut action),
    ///     Err(Error::ScratchTooSmall { needed: 48, found: 20 })
    /// );
    /// ```
    pub fn act_in(
        &self,
        obs: &[f32],
        scratch: &mut [f32],
        action: &mut [f32],
    ) -> Result<(), Error> {
        match self.header.kind {
            ModelKind::Actor => {
                self.act_unit_in(obs, scratch, action)?;
                self.scale_into_bounds(action);
                Ok(())
            }
            ModelKind::Discrete => {
                let row = self.choose_in(obs, scratch)?;
                self.table_row(row, action)
            }
            ModelKind::Critic => Err(self.wrong_kind(ModelKind::Actor)),
        }
    }

    /// An actor's output in the unit box `[-1, 1]^A`, before scaling; always finite.
    pub fn act_unit<const W: usize>(
        &self,
        obs: &[f32],
        scratch: &mut Scratch<W>,
        unit: &mut [f32],
    ) -> Result<(), Error> {
        self.act_unit_in(obs, scratch.as_mut_slice(), unit)
    }

    /// [`Model::act_unit`] with a slice scratch, as [`Model::act_in`] takes it.
    pub fn act_unit_in(
        &self,
        obs: &[f32],
        scratch: &mut [f32],
        unit: &mut [f32],
    ) -> Result<(), Error> {
        if self.header.kind != ModelKind::Actor {
            return Err(self.wrong_kind(ModelKind::Actor));
        }
        // The `cfg!` guard lets a build without the integer encoding drop its forward pass (no
        // such model loads there).
        if cfg!(feature = "integer") && self.header.encoding == Encoding::Integer {
            return self.act_unit_integer(obs, scratch, unit);
        }
        let (x, y) = self.split_checked(obs.len(), unit.len(), scratch)?;
        self.normalize(obs, x);
        let out = self.forward(x, y);
        for (u, &v) in unit.iter_mut().zip(out) {
            *u = squash(v);
        }
        Ok(())
    }

    /// Runs an actor (f32, f16 or int8) on one observation and shows `observe` every vector
    /// the layers read or make before their activation: `observe(0, z)` with the normalised
    /// observation, then `observe(l + 1, y)` with layer `l`'s outputs (hidden layers, then the
    /// output layer, before tanh). The same arithmetic as [`Model::act_in`]; what the integer
    /// encoding's calibration measures ([`blob::calibrate_into`]).
    ///
    /// ```
    /// use policy_core::model::Model;
    /// static BLOB: &[u8] = include_bytes!("../tests/golden/actor_4x48.postcard");
    /// let model = Model::from_blob(BLOB).unwrap();
    /// let mut seen = Vec::new();
    /// model.pre_activations_in(&[4.0, -2.5], &mut [0.0; 96], &mut |l, v| seen.push((l, v.len()))).unwrap();
    /// assert_eq!(seen, [(0, 2), (1, 48), (2, 48), (3, 48), (4, 48), (5, 2)]);
    /// ```
    pub fn pre_activations_in(
        &self,
        obs: &[f32],
        scratch: &mut [f32],
        observe: &mut dyn FnMut(usize, &[f32]),
    ) -> Result<(), Error> {
        if self.header.kind != ModelKind::Actor {
            return Err(self.wrong_kind(ModelKind::Actor));
        }
        if self.header.encoding == Encoding::Integer {
            return Err(Error::WrongEncoding {
                expected: Encoding::F32,
                found: Encoding::Integer,
            });
        }
        let (x, y) = self.split_checked(obs.len(), self.layout.actions, scratch)?;
        self.normalize(obs, x);
        observe(0, x.get(..obs.len()).unwrap_or_default());
        self.forward_with(x, y, observe);
        Ok(())
    }

    /// A critic's Q(s, a) for an observation and a unit-box action (clamped into the box; a
    /// non-finite component reads as 0). [`Model::q_in`] with the scratch as a slice.
    pub fn q<const W: usize>(
        &self,
        obs: &[f32],
        unit_action: &[f32],
        scratch: &mut Scratch<W>,
    ) -> Result<f32, Error> {
        self.q_in(obs, unit_action, scratch.as_mut_slice())
    }

    /// [`Model::q`] with a slice scratch of `2 W` floats, as [`Model::act_in`] takes it.
    ///
    /// ```
    /// use policy_core::model::{Model, Scratch};
    /// static BLOB: &[u8] = include_bytes!("../tests/golden/critic_2x32.postcard");
    /// let critic = Model::from_blob(BLOB).unwrap();
    /// let mut scratch = [0.0f32; 64];
    /// let q = critic.q_in(&[1.0, 2.0], &[0.5, -0.5], &mut scratch).unwrap();
    /// let fixed = critic.q(&[1.0, 2.0], &[0.5, -0.5], &mut Scratch::<32>::new()).unwrap();
    /// assert_eq!(q.to_bits(), fixed.to_bits());
    /// ```
    pub fn q_in(
        &self,
        obs: &[f32],
        unit_action: &[f32],
        scratch: &mut [f32],
    ) -> Result<f32, Error> {
        if self.header.kind != ModelKind::Critic {
            return Err(self.wrong_kind(ModelKind::Critic));
        }
        let (x, y) = self.split_checked(obs.len(), unit_action.len(), scratch)?;
        self.normalize(obs, x);
        let tail = x.get_mut(obs.len()..).unwrap_or_default();
        for (d, &u) in tail.iter_mut().zip(unit_action) {
            *d = if u.is_finite() {
                u.clamp(-1.0, 1.0)
            } else {
                0.0
            };
        }
        Ok(self.forward(x, y).first().copied().unwrap_or(0.0))
    }

    /// A discrete policy's choice: the index of the largest Q value (ties and NaN: the lowest
    /// index among the largest; all NaN: 0). [`Model::choose_in`] with the scratch as a slice.
    pub fn choose<const W: usize>(
        &self,
        obs: &[f32],
        scratch: &mut Scratch<W>,
    ) -> Result<usize, Error> {
        self.choose_in(obs, scratch.as_mut_slice())
    }

    /// [`Model::choose`] with a slice scratch of `2 W` floats, as [`Model::act_in`] takes it.
    ///
    /// ```
    /// use policy_core::{model::Model, Error, ModelKind};
    /// static BLOB: &[u8] = include_bytes!("../tests/golden/actor_2x32.postcard");
    /// let actor = Model::from_blob(BLOB).unwrap();
    /// let wrong = actor.choose_in(&[0.0, 0.0], &mut [0.0; 64]);
    /// assert_eq!(wrong, Err(Error::WrongKind { expected: ModelKind::Discrete, found: ModelKind::Actor }));
    /// ```
    pub fn choose_in(&self, obs: &[f32], scratch: &mut [f32]) -> Result<usize, Error> {
        if self.header.kind != ModelKind::Discrete {
            return Err(self.wrong_kind(ModelKind::Discrete));
        }
        let (x, y) = self.split_checked(obs.len(), self.layout.actions, scratch)?;
        self.normalize(obs, x);
        Ok(argmax(self.forward(x, y)))
    }

    /// A discrete policy's Q value of every action-table row, into `q` (one per row: `q.len()`
    /// must be the blob's `choices`, else [`Error::SizeMismatch`] with `what` =
    /// `"choice count"`), as computed: NaN is returned as it comes, so a port can compare the
    /// values [`Model::choose_in`] takes its argmax of. Sizes and scratch as
    /// [`Model::act_in`].
    ///
    /// ```
    /// use policy_core::model::{argmax, Model};
    /// static BLOB: &[u8] = include_bytes!("../conformance/blobs/discrete-2x8-relu-f32.blob");
    /// let policy = Model::from_blob(BLOB).unwrap();
    /// let mut scratch = vec![0.0f32; policy.scratch_floats()];
    /// let mut q = vec![0.0f32; usize::from(policy.header().shape.choices)];
    /// policy.choice_values_in(&[0.5, -1.0], &mut scratch, &mut q).unwrap();
    /// assert_eq!(argmax(&q), policy.choose_in(&[0.5, -1.0], &mut scratch).unwrap());
    /// ```
    pub fn choice_values_in(
        &self,
        obs: &[f32],
        scratch: &mut [f32],
        q: &mut [f32],
    ) -> Result<(), Error> {
        if self.header.kind != ModelKind::Discrete {
            return Err(self.wrong_kind(ModelKind::Discrete));
        }
        let (x, y) = self.split_checked(obs.len(), self.layout.actions, scratch)?;
        if q.len() != self.layout.outputs {
            return Err(Error::SizeMismatch {
                what: "choice count",
                expected: self.layout.outputs,
                found: q.len(),
            });
        }
        self.normalize(obs, x);
        for (o, &v) in q.iter_mut().zip(self.forward(x, y)) {
            *o = v;
        }
        Ok(())
    }

    /// Checks the sizes and the scratch, then splits the scratch into its two vectors of
    /// `len / 2` floats each.
    fn split_checked<'s>(
        &self,
        observations: usize,
        actions: usize,
        scratch: &'s mut [f32],
    ) -> Result<(&'s mut [f32], &'s mut [f32]), Error> {
        let width = scratch.len() / 2;
        self.check_io(observations, actions, width)?;
        let (x, rest) = scratch.split_at_mut(width);
        Ok((x, rest.get_mut(..width).unwrap_or_default()))
    }

    fn wrong_kind(&self, expected: ModelKind) -> Error {
        Error::WrongKind {
            expected,
            found: self.header.kind,
        }
    }

    fn check_io(&self, observations: usize, actions: usize, width: usize) -> Result<(), Error> {
        self.expect_sizes(observations, actions)?;
        let needed = self.layout.scratch_width;
        if width < needed {
            return Err(Error::ScratchTooSmall {
                needed,
                found: width,
            });
        }
        Ok(())
    }

    /// The parameter at `index` (0.0 past the end, which verified layouts never reach).
    fn value(&self, index: usize) -> f32 {
        self.slice(index, 1).first().unwrap_or(0.0)
    }

    /// `len` parameters from `index`, as bytes.
    fn bytes(&self, index: usize, len: usize) -> &'a [u8] {
        self.payload
            .get(4 * index..4 * (index + len))
            .unwrap_or_default()
    }

    /// `len` parameters from `index`, decoded into a small array view (used for the short
    /// vectors: normaliser and bounds rows).
    fn slice(&self, index: usize, len: usize) -> Floats<'a> {
        Floats(self.bytes(index, len))
    }

    /// `z = clip((x - mean) * inv_std)` into `z[..S]`; non-finite inputs read as the mean.
    fn normalize(&self, obs: &[f32], z: &mut [f32]) {
        let s = self.layout.observations;
        let clip = self.value(2 * s);
        let (mean, inv_std) = (self.slice(0, s), self.slice(s, s));
        for (((zi, &x), m), k) in z.iter_mut().zip(obs).zip(mean.iter()).zip(inv_std.iter()) {
            *zi = normalize_value(x, m, k, clip);
        }
    }

    /// Maps a unit-box action into the bounds, as [`ActionBounds::scale`](crate::ActionBounds::scale).
    /// Maps an actor's unit-box action (as [`Model::act_unit`] returns it) into the blob's
    /// bounds in place, as [`Model::act`] does: a non-finite component becomes the middle of
    /// its range. No effect on a critic; a discrete policy's bounds are its table's.
    pub fn scale(&self, action: &mut [f32]) {
        if self.header.kind != ModelKind::Critic {
            self.scale_into_bounds(action);
        }
    }

    /// [`Model::scale`] without the kind check, for `act`, which has already matched an actor.
    fn scale_into_bounds(&self, action: &mut [f32]) {
        let a = self.layout.actions;
        let (low, high) = (
            self.slice(self.layout.bounds, a),
            self.slice(self.layout.bounds + a, a),
        );
        for ((o, lo), hi) in action.iter_mut().zip(low.iter()).zip(high.iter()) {
            *o = scale_value(*o, lo, hi);
        }
    }

    fn table_row(&self, row: usize, action: &mut [f32]) -> Result<(), Error> {
        let a = self.layout.actions;
        let values = self.slice(self.layout.table + row * a, a);
        for (o, v) in action.iter_mut().zip(values.iter()) {
            *o = v;
        }
        Ok(())
    }

    /// Runs every layer from the input in `x[..inputs]`; returns the linear output, which lies
    /// in `x` or `y` depending on the depth.
    fn forward<'s>(&self, x: &'s mut [f32], y: &'s mut [f32]) -> &'s [f32] {
        self.forward_with(x, y, |_, _| {})
    }

    /// [`Model::forward`], showing `observe` each layer's outputs before its activation (layer
    /// `l` as `l + 1`).
    #[inline(always)]
    fn forward_with<'s>(
        &self,
        mut x: &'s mut [f32],
        mut y: &'s mut [f32],
        mut observe: impl FnMut(usize, &[f32]),
    ) -> &'s [f32] {
        let l = self.layout;
        let activation = self.header.activation;
        let mut offset = l.layers;
        let mut inputs = l.inputs;
        for k in 0..=l.hidden_layers {
            offset = self.dense(offset, inputs, l.width, x, y);
            observe(k + 1, y.get(..l.width).unwrap_or_default());
            activate(activation, y.get_mut(..l.width).unwrap_or_default());
            core::mem::swap(&mut x, &mut y);
            inputs = l.width;
        }
        self.dense(offset, inputs, l.outputs, x, y);
        observe(l.hidden_layers + 2, y.get(..l.outputs).unwrap_or_default());
        y.get(..l.outputs).unwrap_or_default()
    }

    /// `y[..outputs] = b + W x[..inputs]` for the layer at byte `at`; returns the byte offset
    /// of the next layer.
    fn dense(&self, at: usize, inputs: usize, outputs: usize, x: &[f32], y: &mut [f32]) -> usize {
        let encoding = self.header.encoding;
        let Some(l) = LayerLayout::of(encoding, inputs, outputs, at) else {
            return at; // verified layouts never overflow
        };
        let part = |from: usize, to: usize| self.payload.get(from..to).unwrap_or_default();
        let (weights, bias) = (part(l.weights, l.padding), part(l.bias, l.end));
        let (x, y) = (
            x.get(..inputs).unwrap_or_default(),
            y.get_mut(..outputs).unwrap_or_default(),
        );
        // Only the kernels of the encodings this build reads are linked: `from_blob` refused a
        // blob of any other (Error::EncodingNotCompiled), so the `cfg!`-false arms are dead code
        // the optimiser drops, and the fallback arm is never taken.
        match encoding {
            Encoding::F32 if cfg!(feature = "f32") => accumulate_bytes(weights, bias, x, y),
            Encoding::F16 if cfg!(feature = "f16") => accumulate_f16(weights, bias, x, y),
            Encoding::Int8 if cfg!(feature = "int8") => {
                accumulate_int8(part(l.scales, l.weights), weights, bias, x, y)
            }
            // The integer encoding runs its own forward pass (model/integer.rs), never this one.
            Encoding::F32 | Encoding::F16 | Encoding::Int8 | Encoding::Integer => {
                y.iter_mut().for_each(|v| *v = 0.0)
            }
        }
        l.end
    }
}

/// The index of the largest value, the rule a discrete policy chooses by: the first strictly
/// larger value wins, so ties go to the lowest index; NaN never wins; all NaN (or none): 0. The
/// trainer's greedy DQN action uses this same function.
///
/// ```
/// use policy_core::model::argmax;
/// assert_eq!(argmax(&[1.0, 3.0, 3.0, 2.0]), 1);
/// assert_eq!(argmax(&[f32::NAN, 0.5, f32::NAN]), 1);
/// assert_eq!(argmax(&[f32::NAN, f32::NAN]), 0);
/// ```
pub fn argmax(q: &[f32]) -> usize {
    let mut best: Option<(usize, f32)> = None;
    for (k, &v) in q.iter().enumerate() {
        match best {
            _ if v.is_nan() => {}
            Some((_, b)) if v <= b => {}
            _ => best = Some((k, v)),
        }
    }
    best.map_or(0, |(k, _)| k)
}

/// A run of little-endian `f32`s in the payload.
#[derive(Clone, Copy, Debug)]
struct Floats<'a>(&'a [u8]);

impl<'a> Floats<'a> {
    fn iter(self) -> impl Iterator<Item = f32> + 'a {
        blob::payload_values(self.0)
    }

    fn first(self) -> Option<f32> {
        self.iter().next()
    }
}

/// The one size check: the `(observations, actions)` a firmware or plant `expected` against the
/// sizes a controller has (`found`). [`Model::expect_sizes`] asks it for a blob; a host whose
/// controllers are not all blobs asks it directly.
///
/// ```
/// use policy_core::{model::check_sizes, Error};
/// assert_eq!(check_sizes((2, 2), (2, 2)), Ok(()));
/// let err = check_sizes((2, 2), (3, 2)).unwrap_err();
/// assert_eq!(err, Error::SizeMismatch { what: "observation size", expected: 2, found: 3 });
/// ```
pub fn check_sizes(expected: (usize, usize), found: (usize, usize)) -> Result<(), Error> {
    for (what, expected, found) in [
        ("observation size", expected.0, found.0),
        ("action size", expected.1, found.1),
    ] {
        if expected != found {
            return Err(Error::SizeMismatch {
                what,
                expected,
                found,
            });
        }
    }
    Ok(())
}
