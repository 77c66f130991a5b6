//! What drives the actuator: a policy booted from a blob (policy-core's runtime model, any
//! shape) or the safe state. Each plant's reference controllers (navigation's `straight` and
//! `oracle`) implement the same [`Controller`] trait in the plant's folder.

use policy_core::blob::{self, Header};
use policy_core::model::{Model, Scratch};
use policy_core::ModelKind;

use crate::Error;

/// A controller in the firmware loop: observation in, action out.
///
/// The trainer may implement it for its own networks to run them through the same loop.
pub trait Controller {
    /// A short name for reports.
    fn name(&self) -> String;
    /// Observation size it reads.
    fn observations(&self) -> usize;
    /// Action size it writes.
    fn actions(&self) -> usize;
    /// Called before every episode (controllers with memory forget it here).
    fn reset(&mut self) {}
    /// Writes the action for `obs` into `action`. Anything may come out (NaN included): the
    /// actuator model sanitises it before it reaches the plant.
    fn act(&mut self, obs: &[f32], action: &mut [f32]);
    /// Why the controller can no longer act, if it cannot: a chip in the loop that went silent,
    /// reset or garbled a frame ([`crate::hil`]). The test protocol asks after every episode;
    /// on `Some` it drops that episode and stops, and the report says why. Host controllers
    /// never fail.
    fn failure(&mut self) -> Option<Error> {
        None
    }
}

/// A controller that acts as the one it wraps and shows `note` every step: the tick since the
/// last reset (0 for an episode's first action), the observation and the action it chose. What
/// a study or a calibration records from the loop, without a controller of its own for each.
///
/// ```
/// use firmware_sim::controller::{Controller, Observed, SafeState};
/// let mut seen = Vec::new();
/// let zero = SafeState { observations: 2, actions: 1 };
/// let mut c = Observed::new(zero, |tick, obs: &[f32], _: &[f32]| {
///     seen.push((tick, obs[0]));
/// });
/// let mut a = [1.0];
/// c.act(&[4.0, 0.0], &mut a);
/// c.act(&[5.0, 0.0], &mut a);
/// c.reset();
/// c.act(&[6.0, 0.0], &mut a);
/// drop(c);
/// assert_eq!(seen, [(0, 4.0), (1, 5.0), (0, 6.0)]);
/// ```
pub struct Observed<C, F> {
    inner: C,
    note: F,
    tick: usize,
}

impl<C: core::fmt::Debug, F> core::fmt::Debug for Observed<C, F> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Observed")
            .field("inner", &self.inner)
            .field("tick", &self.tick)
            .finish_non_exhaustive()
    }
}

impl<C, F> Observed<C, F> {
    /// `inner`, with `note` called after each of its actions.
    pub fn new(inner: C, note: F) -> Self {
        Observed {
            inner,
            note,
            tick: 0,
        }
    }
}

impl<C: Controller, F: FnMut(usize, &[f32], &[f32])> Controller for Observed<C, F> {
    fn name(&self) -> String {
        self.inner.name()
    }
    fn observations(&self) -> usize {
        self.inner.observations()
    }
    fn actions(&self) -> usize {
        self.inner.actions()
    }
    fn reset(&mut self) {
        self.inner.reset();
        self.tick = 0;
    }
    fn act(&mut self, obs: &[f32], action: &mut [f32]) {
        self.inner.act(obs, action);
        (self.note)(self.tick, obs, action);
        self.tick += 1;
    }
    fn failure(&mut self) -> Option<Error> {
        self.inner.failure()
    }
}

/// The safe state a loop enters when the blob fails to load: every action is 0.
#[derive(Clone, Copy, Debug)]
pub struct SafeState {
    /// Observation size of the plant.
    pub observations: usize,
    /// Action size of the plant.
    pub actions: usize,
}

impl Controller for SafeState {
    fn name(&self) -> String {
        "safe-state".into()
    }
    fn observations(&self) -> usize {
        self.observations
    }
    fn actions(&self) -> usize {
        self.actions
    }
    fn act(&mut self, _obs: &[f32], action: &mut [f32]) {
        action.fill(0.0);
    }
}

/// Scratch width that fits every shape a blob may declare: the widest hidden layer,
/// observation vector, action vector or action table the format allows.
pub const SCRATCH_WIDTH: usize = max(
    max(blob::MAX_WIDTH, blob::MAX_OBSERVATIONS),
    max(blob::MAX_ACTIONS, blob::MAX_CHOICES),
);

const fn max(a: usize, b: usize) -> usize {
    if a > b {
        a
    } else {
        b
    }
}

/// A policy booted from blob bytes: policy-core's runtime [`Model`] over the verified bytes,
/// whatever the shape its header names (actor or discrete policy).
///
/// The model borrows the bytes, as the chip's model borrows its flash: they are verified once, at
/// boot (CRC, header, every parameter), and every tick runs straight from them with no copy and
/// no second check. The caller keeps the bytes alive for as long as the policy runs.
pub struct BlobPolicy<'a> {
    model: Model<'a>,
    /// Activations (2 x 1024 floats, 8 KB): on the heap, as the chip keeps them in a `static`.
    scratch: Box<Scratch<SCRATCH_WIDTH>>,
}

impl core::fmt::Debug for BlobPolicy<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("BlobPolicy")
            .field("header", self.header())
            .finish_non_exhaustive()
    }
}

impl<'a> BlobPolicy<'a> {
    /// Boots from blob bytes: policy-core's [`Model::from_blob`] verifies them once (an actor or
    /// a discrete policy of any shape within the format's limits; a critic is refused).
    ///
    /// ```
    /// use firmware_sim::controller::{BlobPolicy, Controller};
    /// use policy_core::{ActionBounds, Normalizer, Policy};
    /// let mut p = Policy::<2, 48, 3, 2>::ZERO;
    /// p.normalizer = Normalizer::identity(5.0);
    /// p.bounds = ActionBounds::symmetric(0.25);
    /// p.trunk.output.b[0] = 10.0; // tanh saturates: always +0.25 on x
    /// let blob = p.to_blob("demo").unwrap();
    /// let mut c = BlobPolicy::boot(&blob).unwrap();
    /// let mut a = [0.0; 2];
    /// c.act(&[1.0, 2.0], &mut a);
    /// assert_eq!(a, [0.25, 0.0]);
    /// assert!(BlobPolicy::boot(&blob[1..]).is_err());
    /// ```
    pub fn boot(bytes: &'a [u8]) -> Result<BlobPolicy<'a>, Error> {
        BlobPolicy::from_model(Model::from_blob(bytes)?)
    }

    /// Wraps a model already verified as a policy (for example by
    /// [`Model::for_policy`](policy_core::model::Model::for_policy) when booting from flash
    /// slots); a critic is refused.
    pub fn from_model(model: Model<'a>) -> Result<BlobPolicy<'a>, Error> {
        if model.header().kind == ModelKind::Critic {
            return Err(policy_core::Error::WrongKind {
                expected: ModelKind::Actor,
                found: ModelKind::Critic,
            }
            .into());
        }
        Ok(BlobPolicy {
            model,
            scratch: Box::new(Scratch::new()),
        })
    }

    /// The blob's header (kind, shape, activation, label).
    pub fn header(&self) -> &Header {
        self.model.header()
    }

    /// The runtime model the policy runs.
    pub fn model(&self) -> &Model<'a> {
        &self.model
    }
}

impl Controller for BlobPolicy<'_> {
    fn name(&self) -> String {
        let h = self.header();
        let kind = match h.kind {
            ModelKind::Discrete => format!(" discrete x{}", h.shape.choices),
            ModelKind::Actor | ModelKind::Critic => String::new(),
        };
        // The weight encoding, where it is not the default f32.
        let encoding = match h.encoding {
            policy_core::Encoding::F32 => String::new(),
            other => format!(" {other}"),
        };
        format!(
            "blob {:?} {}x{} {}{encoding}{kind}",
            h.label.as_str(),
            h.shape.depth,
            h.shape.width,
            h.activation
        )
    }
    fn observations(&self) -> usize {
        self.header().shape.observations as usize
    }
    fn actions(&self) -> usize {
        self.header().shape.actions as usize
    }
    #[inline]
    fn act(&mut self, obs: &[f32], action: &mut [f32]) {
        // Sizes are checked at boot against the plant; a caller passing other sizes gets the
        // safe action rather than a panic.
        if self.model.act(obs, &mut self.scratch, action).is_err() {
            action.fill(0.0);
        }
    }
}
